"""Tests that a wrong implementation fails, beyond the control laws (issue 27, item 4).

Each test catches one plausible slip that the rest of the suite let through; its reference comes
from outside the code under test (a closed form, the energy balance written out by hand, NumPy's
eigenvalues, a finite-difference propagation and a Monte Carlo of the estimator, an
uninterrupted run). ``tools/mutate.py`` applies each slip and checks that these tests fail.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

import forcecontrol as fc
from forcecontrol.controllers import EnergyTank, VariableImpedanceController
from forcecontrol.controllers.base import Controller
from forcecontrol.errors import BandwidthWarning
from forcecontrol.realarm.calibration import calibrate
from forcecontrol.sim.metrics import step_metrics
from forcecontrol.supervision.safety import Safety

ARM = fc.CHAPTER_ARM
Q0 = ARM.inverse_kinematics([1.0, 0.0])
G = 9.81


class _ConstantTorque(Controller):
    """Commands the same torque at every sample (the test's own stand-in for a controller)."""

    uses_force = False

    def __init__(self, robot, torque):
        super().__init__(robot, 1e-3)
        self.torque = np.asarray(torque, dtype=np.float64)

    def step(self, t, measurement, reference):
        return self.torque.copy()


def _meas(q, qd=(0.0, 0.0)) -> fc.Measurement:
    return fc.Measurement(np.asarray(q, float), np.asarray(qd, float), np.zeros(2))


# ----------------------------------------------------------------------------- safety


def test_negative_torque_overshoot_is_clamped_and_logged():
    """Slip: the torque limit checked one-sided (u > τ_max): u₁ = −1.5 τ_max must come out −τ_max, logged once as a clamp."""
    tau_max = 400.0
    s = Safety(_ConstantTorque(ARM, [-1.5 * tau_max, 0.3 * tau_max]), max_torque=tau_max)
    ref = fc.Reference.setpoint([1.0, 0.0])
    s.reset()
    outs = [s.step(k * 1e-3, _meas(Q0), ref) for k in range(3)]
    for u in outs:
        np.testing.assert_array_equal(u, [-tau_max, 0.3 * tau_max])
    (e,) = s.events  # one episode, logged at its onset
    assert (e["t"], e["cause"], e["reaction"]) == (0.0, "torque limit", "clamp")
    assert e["value"] == pytest.approx(1.5 * tau_max) and e["limit"] == tau_max and "joint 1" in e["detail"]
    assert s.counts["torque limit"] == 3


@pytest.mark.parametrize("h", [(-80.0, 0.0), (-48.0, -64.0), (0.0, -80.0)])
def test_force_limit_acts_on_the_force_norm_in_any_direction(h):
    """Extra slip: the force limit one-sided (a signed component, not ‖h_e‖): 80 N pushing along −x or −y stops at 60 N."""
    s = Safety(_ConstantTorque(ARM, [0.0, 0.0]), max_force=60.0)
    s.reset()
    s.step(0.0, fc.Measurement(Q0, np.zeros(2), np.asarray(h)), fc.Reference.setpoint([1.0, 0.0]))
    (e,) = s.events
    assert s.stopped and (e["cause"], e["reaction"]) == ("force limit", "stop")
    assert e["value"] == pytest.approx(80.0, rel=1e-12) and e["limit"] == 60.0


# ----------------------------------------------------------------------------- sweeps


_SWEEP_SCENARIO = {
    "name": "resume-order",
    "duration": 0.1,
    "robot": {"model": "chapter-arm", "start_position": [1.0, 0.0], "elbow": "up"},
    "environment": {"type": "elastic-plane", "point": [1.0, 0.0], "normal": [-1.0, 0.0], "stiffness": 1e4},
    "controller": {"type": "inner-velocity", "inertia": 100.0, "damping": 500.0, "stiffness": 2500.0,
                   "force_gain": [0.0024, 0.0]},
    "reference": {"type": "setpoint", "position": [1.0, 0.0], "force": [10.0, 0.0]},
}


class _Interrupt(Exception):
    pass


def test_resumed_sweep_table_is_sorted_by_case_id(tmp_path):
    """Slip: a resumed sweep's parts not re-sorted by case_id: parts 2–3 and 6–7 recomputed as one block stay rows 0..7."""
    from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_sweep

    d = SweepDefinition.from_options({"environment.stiffness": [float(k) for k in np.geomspace(2e3, 5e4, 8)]})
    whole = run_sweep(prepare_sweep(_SWEEP_SCENARIO, d), tmp_path / "whole.parquet", workers=1, block_size=2)
    assert whole.table["case_id"].tolist() == list(range(8))

    out = tmp_path / "resumed.parquet"

    def stop_at_the_end(done, total):
        if done == total:
            raise _Interrupt  # every part stored, the table not yet assembled

    with pytest.raises(_Interrupt):
        run_sweep(prepare_sweep(_SWEEP_SCENARIO, d), out, workers=1, block_size=2, progress=stop_at_the_end)
    parts = out.with_name(out.name + ".parts")
    names = sorted(p.name for p in parts.glob("part-*.parquet"))
    assert names == [f"part-{lo:08d}-{lo + 1:08d}-2.parquet" for lo in (0, 2, 4, 6)]
    for lo in (2, 6):
        (parts / f"part-{lo:08d}-{lo + 1:08d}-2.parquet").unlink()
    resumed = run_sweep(prepare_sweep(_SWEEP_SCENARIO, d), out, workers=1, block_size=4)  # one block: cases 2, 3, 6, 7
    assert (resumed.resumed, resumed.ran) == (4, 4)
    assert resumed.table["case_id"].tolist() == list(range(8))
    pd.testing.assert_frame_equal(resumed.table, whole.table, check_exact=True)


def test_sweep_settling_time_uses_a_two_percent_band_by_default(tmp_path):
    """Extra slip: a sweep's default settling band 5 %: the row's settling time is NumPy's 2 % one of simulate()'s force."""
    from forcecontrol.scenarios import CaseSpec, build_case
    from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_sweep

    scn = dict(_SWEEP_SCENARIO, duration=2.0)
    prep = prepare_sweep(scn, SweepDefinition.from_options({"environment.stiffness": [1e4]}))
    (row,) = run_sweep(prep, tmp_path / "one.parquet", workers=1).table.to_dict("records")
    p = build_case(CaseSpec("one", {k: v for k, v in scn.items() if k not in ("name",)}, {}))
    res = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=2.0,
                      engine="python")
    y = res.wrench[:, 0]
    yf = y[-100:].mean()  # the sweep's final value: the mean over its last 100 samples (0.1 s)
    outside = np.flatnonzero(np.abs(y - yf) > 0.02 * abs(yf - y[0]))
    assert outside[-1] < len(y) - 1  # settled within the run
    assert row["settling_time"] == pytest.approx((outside[-1] + 1) * 1e-3, abs=1e-12)


# ----------------------------------------------------------------------------- metrics


def test_step_metrics_default_band_is_two_percent():
    """Slip: step_metrics' settling band 5 % instead of 2 %: y = 1 − e^(−t/τ) settles at τ ln 50 (2 %), not τ ln 20."""
    Ts, tau, y0, step = 1e-3, 0.25, 1.0, 3.0
    t = 0.5 + np.arange(int(round(20 * tau / Ts)) + 1) * Ts  # a record that starts at t = 0.5 s, from y₀ = 1
    y = y0 + step * (1.0 - np.exp(-(t - t[0]) / tau))
    # the discrete definition by NumPy: the first sample after the last one outside ±2 % of the step (time from t[0])
    first_in = np.flatnonzero(np.abs(y - (y0 + step)) > 0.02 * step)[-1] + 1
    for m in (step_metrics(t, y), step_metrics(t, y, final=y0 + step)):
        assert m.settling_time == pytest.approx(tau * math.log(50.0), abs=1.5 * Ts)
        assert m.settling_time == pytest.approx(t[first_in] - t[0], abs=1e-9)
        assert m.overshoot_percent == pytest.approx(0.0, abs=1e-6) and m.stable
        assert m.steady == pytest.approx(y0 + step, abs=1e-6) and m.peak_time == pytest.approx(t[-1], abs=1e-9)


def test_a_steady_ripple_within_the_stable_band_is_stable():
    """Extra slip: 'stable' as within the band AND decaying: a steady 1 % ripple (not decaying) inside the 5 % band is stable."""
    t = np.arange(4001) * 1e-3
    y = 1.0 - np.exp(-t / 0.1) + 0.01 * np.sin(2 * math.pi * 5.0 * t)
    assert step_metrics(t, y, final=1.0).stable
    grow = 1.0 - np.exp(-t / 0.1) + 0.01 * np.exp(t) * np.sin(2 * math.pi * 5.0 * t)  # leaves the band, growing
    assert not step_metrics(t, grow, final=1.0).stable


# ----------------------------------------------------------------------------- energy tank


def test_tank_is_filled_with_the_damping_that_acted():
    """Slip: the tank filled with the new sample's damping: T_k = T₀ + Ts Σ x̃̇ᵀ K_D x̃̇ over past samples, each with its own K_D."""
    Ts, T0 = 1e-3, 0.5
    D_of = {0: 200.0, 1: 200.0, 2: 3000.0, 3: 50.0}  # K_D asked at sample k (scalar · I)

    def damping(t, e, ed):
        return D_of[int(round(t / Ts))]

    tank = EnergyTank(T0, minimum=0.0, maximum=math.inf, dissipation_fraction=1.0)
    ctl = VariableImpedanceController(ARM, 100.0, 200.0, 1000.0, damping_schedule=damping, tank=tank, sample_time=Ts)
    x0 = ARM.forward_kinematics(Q0)
    # speeds falling sample to sample: the loop's own loss, ½ M_d (|x̃̇_{k-1}|² − |x̃̇_k|²) with no port energy (x̃ held),
    # is above the damper's share, so the cap on the deposit (what the loop really lost) does not bind here
    v = {0: np.array([0.5, -0.3]), 1: np.array([0.2, 0.4]), 2: np.array([-0.3, 0.1]), 3: np.array([0.1, 0.1])}
    expected, T = [], T0
    for k in range(4):
        # q̇ = 0: the error rate x̃̇ = ẋ_d − J q̇ is the reference velocity itself
        ref = fc.Reference(x0, v[k], np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2))
        ctl.step(k * Ts, _meas(Q0), ref)
        if k > 0:  # the damper acted over the last sample with the error rate and the K_D of that sample
            T += Ts * D_of[k - 1] * float(v[k - 1] @ v[k - 1])
        expected.append(T)
    np.testing.assert_allclose(ctl.signals()["tank_energy"], expected, rtol=1e-12, atol=0.0)


def test_tank_is_never_credited_more_than_the_loop_lost():
    """Slip: the damper's Ts x̃̇ᵀ K_D x̃̇ credited whatever the loop did. Speeds rising with x̃ held: the loop's storage
    grew with no energy at its port, so it lost nothing and the tank gets nothing; falling: it gets the loss when that
    is below the damper's share (x̃̇ from 0.3 to 0.29 m/s with M_d = 100 kg: 0.295 J lost, 0.3 J the damper's at
    K_D = 3333 N s/m)."""
    Ts, T0 = 1e-3, 0.5
    x0 = ARM.forward_kinematics(Q0)
    for speeds, damping, deposit in (((0.1, 0.2, 0.3), 200.0, 0.0), ((0.3, 0.29), 1e4 / 3.0, 0.5 * 100.0 * (0.09 - 0.0841))):
        tank = EnergyTank(T0, minimum=0.0, maximum=math.inf, dissipation_fraction=1.0)
        ctl = VariableImpedanceController(ARM, 100.0, damping, 1000.0, tank=tank, sample_time=Ts)
        for k, sp in enumerate(speeds):
            ctl.step(k * Ts, _meas(Q0), fc.Reference(x0, np.array([sp, 0.0]), np.zeros(2), np.zeros(2), np.zeros(2),
                                                      np.zeros(2)))
        assert damping * Ts * speeds[-2] ** 2 > deposit  # the damper's share would have been more
        assert ctl.signals()["tank_energy"][-1] == pytest.approx(T0 + deposit, rel=1e-12, abs=1e-15)


def test_tank_never_holds_more_than_its_maximum():
    """Extra slip: the cap compared with the deposit, not the room left: 1 + 0.75 + 0.75 J in a 2 J tank keeps 2 J, drops 0.5."""
    tank = EnergyTank(1.0, minimum=0.0, maximum=2.0, dissipation_fraction=1.0)
    tank.fill(0.75)
    assert (tank.energy, tank.dropped) == (pytest.approx(1.75), 0.0)
    tank.fill(0.75)  # each deposit is below T_max, the sum is not
    assert tank.energy == pytest.approx(2.0) and tank.dropped == pytest.approx(0.5)
    assert tank.pay(-0.75) == 1.0 and tank.energy == pytest.approx(2.0) and tank.dropped == pytest.approx(1.25)


# ----------------------------------------------------------------------------- admittance


def test_admittance_bandwidth_uses_the_smallest_motion_stiffness_eigenvalue():
    """Slip: ω_motion from λ_max(K_P): a K_P with one slow direction (NumPy's λ_min) must warn and report √λ_min."""
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers.admittance import AdmittanceController
    from forcecontrol.robots.pinocchio import panda

    Mt = np.diag([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
    Kpt = np.diag([300.0, 300.0, 300.0, 8.0, 8.0, 8.0])
    Kdt = np.diag(2 * 0.8 * np.sqrt(np.diag(Mt) * np.diag(Kpt)))
    Q = Rotation.from_rotvec([0.3, -0.5, 0.2]).as_matrix()
    Qb = np.block([[Q, np.zeros((3, 3))], [np.zeros((3, 3)), np.eye(3)]])
    Kp = Qb @ np.diag([2500.0, 2500.0, 36.0, 2500.0, 2500.0, 2500.0]) @ Qb.T
    Kp = 0.5 * (Kp + Kp.T)
    w_mot = math.sqrt(float(np.linalg.eigvalsh(Kp).min()))  # 6 rad/s: the slow direction
    w_imp = math.sqrt(float(np.linalg.eigvals(np.linalg.inv(Mt) @ Kpt).real.max()))  # √160
    assert w_mot / w_imp < 3.0 < math.sqrt(float(np.linalg.eigvalsh(Kp).max())) / w_imp  # λ_max would pass
    with pytest.warns(BandwidthWarning, match=r"motion loop \(ω = 6 rad/s\)"):
        c = AdmittanceController(panda(), Mt, Kdt, Kpt, motion_stiffness=Kp, motion_damping=100.0)
    assert c.bandwidths["motion"] == pytest.approx(w_mot, rel=1e-9)
    assert c.bandwidths["ratio"] == pytest.approx(w_mot / w_imp, rel=1e-9)


# ----------------------------------------------------------------------------- calibration

LIGHT = {"mass": 0.15, "com": np.array([0.05, -0.04, 0.12]), "force_bias": np.array([0.3, -0.2, 0.6]),
         "torque_bias": np.array([0.01, -0.02, 0.005])}


def _readings(true, Rs, rng, sf, st):
    """f_S = −m R_Sᵀ g + b_f, τ_S = −c × (m R_Sᵀ g) + b_τ (the sensor holds the tool up), with white noise."""
    g = np.array([0.0, 0.0, -G])
    w = true["mass"] * np.einsum("kji,j->ki", Rs, g)
    F = -w + true["force_bias"] + sf * rng.standard_normal(w.shape)
    T = -np.cross(true["com"], w) + true["torque_bias"] + st * rng.standard_normal(w.shape)
    return F, T


def test_com_uncertainty_of_a_light_tool():
    """Slip: the CoM σ's mass term with m³ instead of m⁴: σ_c of a 0.15 kg tool against finite differences and Monte Carlo."""
    Rs = Rotation.random(12, random_state=5).as_matrix()
    sf, st = 0.2, 0.002
    r = calibrate(Rs, *_readings(LIGHT, Rs, np.random.default_rng(0), sf, st))
    # delta method by central differences of c = p / m, with p and m from independent problems
    m, p = r.mass, np.asarray(r.first_moment)
    theta, h = np.concatenate([p, [m]]), 1e-6
    J = np.empty((3, 4))
    for i in range(4):
        dp, dm = np.zeros(4), np.zeros(4)
        dp[i], dm[i] = h, -h
        J[:, i] = ((theta + dp)[:3] / (theta + dp)[3] - (theta + dm)[:3] / (theta + dm)[3]) / (2 * h)
    cov = np.zeros((4, 4))
    cov[:3, :3] = r.torque_covariance[:3, :3]
    cov[3, 3] = r.force_covariance[0, 0]
    np.testing.assert_allclose(r.com_std, np.sqrt(np.diag(J @ cov @ J.T)), rtol=1e-6)
    # the estimator's own scatter over many noise draws
    runs = [calibrate(Rs, *_readings(LIGHT, Rs, np.random.default_rng(s), sf, st)) for s in range(1, 801)]
    coms = np.array([x.com for x in runs])
    np.testing.assert_allclose(coms.std(axis=0, ddof=1), np.mean([x.com_std for x in runs], axis=0), rtol=0.12)
