"""Variable impedance with an energy tank (issue 18, part 1).

References from outside the controller's own bookkeeping: the energy of the closed loop is
recomputed from the simulator's logs of the full nonlinear arm (tip position and velocity, the
plane's elastic energy) and must balance the tank's energy to first order in the sample time;
the tank's arithmetic is checked against hand-computed values.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.controllers import DirectionalStiffness, EnergyTank, SinusoidalStiffness, VariableImpedanceController
from forcecontrol.errors import ParameterError

K_ENV = 1e4
M_D, K_D = 100.0, 200.0
X_D = np.array([1.02, 0.0])


@pytest.fixture(scope="module")
def arm():
    return fc.PlanarTwoLink()


def _run(arm, tank, sample_time=1e-3, duration=1.0, schedule=None):
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], K_ENV)
    ctl = VariableImpedanceController(arm, M_D, K_D, 1000.0, stiffness_schedule=schedule or DirectionalStiffness(1e3, 1e4),
                                      tank=tank, sample_time=sample_time)
    return fc.simulate(arm, env, ctl, fc.Setpoint(X_D), q0=q0, duration=duration, engine="python")


def _energies(res):
    """Storage of (9.32) with the applied stiffness, the plane's elastic energy, the damper's dissipation."""
    xt, xtd = X_D - res.x, -res.xd
    K = res.signals["stiffness"].reshape(-1, 2, 2)
    H = 0.5 * M_D * np.einsum("ij,ij->i", xtd, xtd) + 0.5 * np.einsum("ij,ijk,ik->i", xt, K, xt)
    V = 0.5 * K_ENV * np.maximum(res.x[:, 0] - 1.0, 0.0) ** 2
    Ts = res.t[1] - res.t[0]
    dissipated = np.concatenate([[0.0], np.cumsum(K_D * np.einsum("ij,ij->i", xtd, xtd))[:-1] * Ts])
    return H, V, dissipated


def test_energy_balance_holds_to_first_order_in_the_sample_time(arm):
    """σ = 1, no cap: H + V_env + T is conserved by the continuous loop; the sampled loop drifts O(Ts)."""
    drifts = {}
    for Ts in (1e-3, 5e-4):
        tank = EnergyTank(0.5, minimum=0.0, maximum=math.inf, dissipation_fraction=1.0)
        res = _run(arm, tank, sample_time=Ts)
        H, V, dissipated = _energies(res)
        E = H + V + res.signals["tank_energy"]
        drifts[Ts] = float(np.max(np.abs(E - E[0])))
        assert drifts[Ts] < 0.02 * dissipated[-1], (Ts, drifts[Ts], dissipated[-1])
        assert np.min(res.signals["stiffness_scale"]) < 0.9  # the tank did refuse part of the schedule
    assert 1.6 < drifts[1e-3] / drifts[5e-4] < 2.5  # first order: halving Ts halves the error


def test_naive_schedule_creates_energy_and_the_tank_version_does_not(arm):
    """Without a tank H + V grows far above its start (energy created by ½ x̃ᵀ K̇ x̃); with it H + V + T never does."""
    naive = _run(arm, None, duration=2.0)
    H, V, _ = _energies(naive)
    assert np.all(np.isnan(naive.signals["tank_energy"]))
    assert (H + V).max() > 5.0 * (H + V)[0]
    tank = EnergyTank(0.05, minimum=0.01, maximum=0.1, dissipation_fraction=0.5)
    passive = _run(arm, tank, duration=2.0)
    H, V, _ = _energies(passive)
    E = H + V + passive.signals["tank_energy"]
    assert E.max() <= E[0] * 1.02
    assert np.all(passive.signals["tank_energy"] >= 0.01 - 1e-12)


def test_a_tank_storing_all_the_dissipation_keeps_the_sampled_loop_passive_over_a_long_contact(arm):
    """σ = 1, the default tank, 6 s of the directional schedule on the plane: H + V_env + T never rises above its start
    (the sampled loop loses less than the damper's Ts x̃̇ᵀ K_D x̃̇; crediting that made it grow by about 0.08 J in 6 s,
    the peak force rising, at a rate that halves with Ts: unbounded over a run)."""
    res = _run(arm, EnergyTank(), duration=6.0)
    H, V, _ = _energies(res)
    E = H + V + res.signals["tank_energy"]
    assert E.max() <= E[0] + 1e-9, (E[0], E.max())
    assert np.min(res.signals["stiffness_scale"]) < 0.9  # the tank did refuse part of the schedule


def test_the_admittance_tank_storing_all_the_dissipation_keeps_the_virtual_frame_passive():
    """The Panda's compliant frame (9.37) with σ = 1: H_t + T never exceeds H_t0 + T0 plus the energy its held input
    brought, Σ h_kᵀ (z̃_{k+1} − z̃_k), both recomputed here from the frame's states (the damper's estimate alone let it
    exceed that by 1.2e-4 J in 1 s)."""
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers import VariableAdmittanceController
    from forcecontrol.scenarios.core import build_case

    parts = build_case(fc.scenario("panda-admittance-contact").cases[0])
    M = np.diag([4.0] * 3 + [0.1] * 3)

    def directional(t, z, zd):
        k = 3000.0 if float(z[:3] @ zd[:3]) < 0.0 else 300.0
        return np.diag([k, k, k, 20.0, 20.0, 20.0])

    ctl = VariableAdmittanceController(
        parts["robot"], [4.0] * 3 + [0.1] * 3, [40.0] * 3 + [2.83] * 3, [1000.0] * 3 + [20.0] * 3,
        stiffness_schedule=directional, tank=EnergyTank(0.02, minimum=0.0, maximum=math.inf, dissipation_fraction=1.0),
        motion_stiffness=14400.0, motion_damping=240.0,
    )
    seen = []
    own = ctl.compliant_reference

    def compliant_reference(reference, h_d):  # the frame's state, input and stiffness at each sample
        seen.append((ctl.state.copy(), np.array(h_d, dtype=np.float64), ctl.stiffness.copy()))
        return own(reference, h_d)

    ctl.compliant_reference = compliant_reference
    r = fc.simulate(parts["robot"], parts["environment"], ctl, parts["reference"], q0=parts["q0"], duration=1.0,
                    substeps=2)
    z, h, K = (np.array([s[i] for s in seen]) for i in range(3))
    H = 0.5 * np.einsum("ni,ij,nj->n", z[:, 6:], M, z[:, 6:]) + 0.5 * np.einsum("ni,nij,nj->n", z[:, :6], K, z[:, :6])
    port = np.concatenate([[0.0], np.cumsum(np.einsum("ni,ni->n", h[:-1], z[1:, :6] - z[:-1, :6]))])
    T = r.signals["tank_energy"][: H.shape[0]]
    excess = H + T - (H[0] + T[0] + port)
    assert excess.max() <= 1e-9, excess.max()
    assert np.min(r.signals["stiffness_scale"]) < 0.9


def test_built_in_scenario_naive_bounces_and_tank_keeps_contact():
    """The built-in 'variable-stiffness' scenario: its own checks pass (the naive case bounces, the tank case does not)."""
    out = fc.scenario("variable-stiffness").run()
    assert out.all_checks_pass
    naive, tank = out.cases
    f_naive = np.linalg.norm(naive.result.wrench, axis=1)
    t = naive.result.t
    assert f_naive[t >= 3.0].max() > 3.0 * f_naive[t < 1.0].max()  # growing
    f_tank = np.linalg.norm(tank.result.wrench, axis=1)
    assert f_tank[t >= 3.0].max() < f_tank[t < 1.0].max()  # decaying
    assert "tank_energy" in tank.result.columns()


def test_energy_tank_arithmetic():
    tank = EnergyTank(1.0, minimum=0.2, maximum=2.0, dissipation_fraction=0.5)
    tank.fill(1.0)
    assert tank.energy == pytest.approx(1.5)
    assert tank.pay(0.5) == 1.0 and tank.energy == pytest.approx(1.0)
    assert tank.pay(1.6) == pytest.approx(0.8 / 1.6) and tank.energy == pytest.approx(0.2)
    assert tank.pay(-5.0) == 1.0 and tank.energy == pytest.approx(2.0) and tank.dropped == pytest.approx(3.2)
    tank.reset()
    assert tank.energy == 1.0 and tank.dropped == 0.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"initial": 30.0}, "initial must lie in"),
        ({"maximum": 0.0}, "maximum must be >"),
        ({"dissipation_fraction": 1.5}, "dissipation_fraction must be in"),
        ({"minimum": -1.0}, "minimum"),
    ],
)
def test_energy_tank_refuses_bad_settings(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        EnergyTank(**{"initial": 1.0, **kwargs})


def test_tank_refuses_bad_requests():
    tank = EnergyTank(1.0)
    with pytest.raises(ParameterError, match="energy to fill must be a finite number >= 0"):
        tank.fill(-1.0)
    for bad in (math.inf, math.nan, np.array([1.0, 2.0]), "1"):  # inf made T NaN with σ = 0 (0 · inf)
        with pytest.raises(ParameterError, match="energy to fill must be a finite number"):
            EnergyTank(1.0, dissipation_fraction=0.0).fill(bad)
    for bad in ("abc", None, 10**400, math.nan):
        with pytest.raises(ParameterError, match="maximum"):
            EnergyTank(1.0, maximum=bad)
    assert EnergyTank(1.0, maximum=math.inf).maximum == math.inf
    with pytest.raises(ParameterError, match="finite"):
        tank.pay(math.nan)


def test_schedules_are_checked(arm):
    with pytest.raises(ParameterError, match="stiffness_schedule must be a callable"):
        VariableImpedanceController(arm, M_D, K_D, 1000.0, stiffness_schedule=5.0)
    bad = VariableImpedanceController(arm, M_D, K_D, 1000.0, stiffness_schedule=lambda t, e, de: -1.0)
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    meas = fc.Measurement(q0, np.zeros(2), np.zeros(2))
    with pytest.raises(ParameterError, match=r"at t = 0.25 s, the stiffness schedule returned an invalid gain"):
        bad.step(0.25, meas, fc.Reference.setpoint(X_D))
    with pytest.raises(ParameterError, match="amplitude must be <= mean"):
        SinusoidalStiffness(100.0, 200.0, 1.0)
    with pytest.raises(ParameterError, match="high must be >= low"):
        DirectionalStiffness(10.0, 1.0)


def test_constant_schedule_equals_the_impedance_controller(arm):
    """With no schedule the law is (9.30)-(9.31) exactly: same torques as ImpedanceController."""
    q = arm.inverse_kinematics([1.01, 0.05], elbow="up")
    meas = fc.Measurement(q, np.array([0.3, -0.2]), np.array([12.0, 1.0]))
    ref = fc.Reference.setpoint(X_D)
    a = VariableImpedanceController(arm, M_D, K_D, 2500.0, tank=EnergyTank(1.0)).step(0.0, meas, ref)
    b = fc.ImpedanceController(arm, M_D, K_D, 2500.0, True).step(0.0, meas, ref)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)


def test_panda_position_task_naive_grows_tank_stays_bounded():
    """The same law on the 7-DOF Panda (position task, null-space posture) pressing a plane k = 10⁴ N/m."""
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers import NullSpacePosture
    from forcecontrol.robots.pinocchio import panda

    robot = panda(task="position")
    q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785])
    x0 = robot.terms(q0, np.zeros(7)).x
    env = fc.ElasticPlane(x0, [0.0, 0.0, 1.0], 1e4)
    peaks = {}
    for name, tank in (("naive", None), ("tank", EnergyTank(0.05, minimum=0.01, maximum=0.1, dissipation_fraction=0.5))):
        ctl = VariableImpedanceController(robot, 5.0, 20.0, 200.0, stiffness_schedule=DirectionalStiffness(200.0, 2000.0),
                                          tank=tank, posture=NullSpacePosture(q0))
        res = fc.simulate(robot, env, ctl, fc.Setpoint(x0 - [0.0, 0.0, 0.02]), q0=q0, duration=1.5)
        f = np.linalg.norm(res.wrench, axis=1)
        peaks[name] = (f[res.t < 0.5].max(), f[res.t >= 1.0].max())
    assert peaks["naive"][1] > 3.0 * peaks["naive"][0]
    assert peaks["tank"][1] <= peaks["tank"][0] * 1.05
    assert peaks["tank"][1] < 0.1 * peaks["naive"][1]


def test_panda_admittance_naive_schedule_chatters_and_the_tank_keeps_contact():
    """Admittance control (9.37) on the Panda pressing the table: a directional schedule of the compliant
    frame's stiffness keeps it bouncing (contact lost every cycle); paid from a tank, the contact is kept."""
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers import VariableAdmittanceController
    from forcecontrol.scenarios.core import build_case

    parts = build_case(fc.scenario("panda-admittance-contact").cases[0])

    def directional(t, z, zd):
        k = 3000.0 if float(z[:3] @ zd[:3]) < 0.0 else 300.0
        return np.diag([k, k, k, 20.0, 20.0, 20.0])

    runs = {}
    for name, tank in (("naive", None), ("tank", EnergyTank(0.02, minimum=0.005, maximum=0.05, dissipation_fraction=0.5))):
        ctl = VariableAdmittanceController(
            parts["robot"], [4.0] * 3 + [0.1] * 3, [40.0] * 3 + [2.83] * 3, [1000.0] * 3 + [20.0] * 3,
            stiffness_schedule=directional, tank=tank, motion_stiffness=14400.0, motion_damping=240.0,
        )
        runs[name] = fc.simulate(parts["robot"], parts["environment"], ctl, parts["reference"], q0=parts["q0"],
                                 duration=2.0, substeps=2)
    late = {k: np.abs(r.wrench[r.t >= 1.0, 2]) for k, r in runs.items()}
    assert late["naive"].min() == 0.0 and late["naive"].max() > 50.0  # still bouncing after 1 s
    assert late["tank"].min() > 1.0 and late["tank"].max() < 0.2 * late["naive"].max()
    tank_energy = runs["tank"].signals["tank_energy"]
    assert np.all(tank_energy >= 0.005 - 1e-12) and np.all(tank_energy <= 0.05 + 1e-12)


def test_the_compiled_engine_refusal_names_what_it_cannot_compile(arm):
    """engine='compiled' with a scheduled controller: refused naming the controller's missing compiled law (the message
    listed the arm, the plane and the controller, all built-in, without saying which one was the reason)."""
    ctl = VariableImpedanceController(arm, M_D, K_D, 1000.0, stiffness_schedule=DirectionalStiffness(1e3, 1e4))
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], K_ENV)
    with pytest.raises(ParameterError, match="the controller VariableImpedanceController has no compiled law") as err:
        fc.simulate(arm, env, ctl, fc.Setpoint(X_D), q0=arm.inverse_kinematics([1.0, 0.0], elbow="up"), duration=0.01,
                    engine="compiled")
    assert "robot is" not in str(err.value) and "environment ElasticPlane" not in str(err.value)


@pytest.mark.parametrize(("change", "message"), [
    ({"controller.tank_minimum": 0.2}, r"tank_maximum must be > tank_minimum = 0\.2 J"),
    ({"controller.stiffness_high": 500.0}, r"stiffness_high must be >= stiffness_low = 1000"),
    ({"controller.tank_initial": -1.0}, r"tank_initial must be a non-negative number"),
])
def test_scenario_errors_name_the_scenario_keys(change, message):
    """A bad variable-impedance key is refused naming the scenario's keys (it named the Python arguments: 'maximum must
    be > minimum', when the user had changed tank_minimum)."""
    from forcecontrol.errors import ForceControlError

    with pytest.raises(ForceControlError, match=message):
        scn = fc.scenario("variable-stiffness").with_(change)
        for case in scn.cases:
            fc.scenarios.build_case(case)


class _TurningStiffness:
    """A stiffness of fixed eigenvalues (1e4 and 1e3 N/m) whose axes turn at 5 rad/s: its trace never changes."""

    def __call__(self, t, x_tilde, x_tilde_dot):
        c, s = math.cos(5.0 * t), math.sin(5.0 * t)
        R = np.array([[c, -s], [s, c]])
        return R @ np.diag([1e4, 1e3]) @ R.T


def test_a_turning_schedule_that_the_tank_refuses_shows_in_stiffness_refused_not_in_the_trace_ratio(arm):
    """A schedule that turns K (constant trace) with a nearly empty tank: stiffness_scale stays 1 while the applied K
    differs from the scheduled one; stiffness_refused is ‖K_s − K‖_F / ‖K_s‖_F recomputed from the logged applied K and
    the schedule (outside the controller's bookkeeping), and is 0 to round-off without a tank."""
    schedule = _TurningStiffness()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], K_ENV)

    def run(tank):  # starts at the schedule's K(0): only its turning is asked afterwards
        ctl = VariableImpedanceController(arm, M_D, K_D, schedule(0.0, None, None), stiffness_schedule=schedule,
                                          tank=tank, sample_time=1e-3)
        return fc.simulate(arm, env, ctl, fc.Setpoint(X_D), q0=q0, duration=0.4, engine="python")

    res = run(EnergyTank(1e-6, minimum=0.0, maximum=1e-6, dissipation_fraction=0.0))  # pays for (almost) nothing
    scale, refused = res.signals["stiffness_scale"], res.signals["stiffness_refused"]
    K = res.signals["stiffness"].reshape(-1, 2, 2)
    K_s = np.array([schedule(t, None, None) for t in res.t])
    want = np.linalg.norm(K_s - K, axis=(1, 2)) / np.linalg.norm(K_s, axis=(1, 2))
    assert refused == pytest.approx(want, abs=1e-12)
    assert np.max(refused) > 0.5 and np.min(scale) > 0.99  # refused in direction, never in size
    free = run(None)
    assert np.all(np.isnan(free.signals["tank_energy"]))  # no tank: the schedule is applied as asked
    assert np.max(free.signals["stiffness_refused"]) < 1e-12
