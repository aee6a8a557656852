"""Admittance control (9.37) on position-interface arms: equilibrium, the sampled loop's analysis, simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol.analysis.servo_loop import admittance_servo_loop
from forcecontrol.analysis.servo_loop_check import chapter_arm_case, stable_in_simulation
from forcecontrol.controllers.admittance_position import PositionAdmittanceController
from forcecontrol.environments.elastic import ElasticPlane
from forcecontrol.errors import ParameterError
from forcecontrol.robots.planar_2r import PlanarTwoLink
from forcecontrol.robots.servo import JointServo, PositionInterfaceRobot
from forcecontrol.sim.simulation import simulate
from forcecontrol.trajectories import Setpoint


def _hand_loop_radius(M, D, K, k, T, w, z, delay):
    """Second implementation: the 1-D loop along the normal written out by hand (numpy only, no python-control).

    The arm's IK is exact and every joint has the same servo, so the tip along the normal follows the
    servo's second order on the compliant frame's displacement. State [z, ż, u_{k−1..k−d}, x, ẋ].
    """
    from scipy.linalg import expm

    A = np.array([[0.0, 1.0], [-K / M, -D / M]])
    G = np.array([0.0, 1.0 / M])
    E = expm(np.block([[A * T, G[:, None] * T], [np.zeros((1, 3))]]))
    Ad, Gd = E[:2, :2], E[:2, 2]
    As = np.array([[0.0, 1.0], [-w * w, -2 * z * w]])
    Es = expm(np.block([[As * T, np.array([[0.0], [w * w]]) * T], [np.zeros((1, 3))]]))
    Phi, Gam = Es[:2, :2], Es[:2, 2]
    # f_k = k x_k (x: the tip's penetration); z_{k+1} = Ad z + Gd f; x_t,k = −z_{k+1} (penetration of the frame);
    ns = 2 + delay + 2
    Acl = np.zeros((ns, ns))
    ix = 2 + delay
    Acl[:2, :2] = Ad
    Acl[:2, ix] = Gd * k
    xt_row = np.zeros(ns)  # x_t,k as a row of the state
    xt_row[:2] = -Ad[0]
    xt_row[ix] = -Gd[0] * k
    if delay:
        Acl[2] = xt_row
        for j in range(1, delay):
            Acl[2 + j, 2 + j - 1] = 1.0
        u_row = np.zeros(ns)
        u_row[2 + delay - 1] = 1.0
    else:
        u_row = xt_row
    Acl[ix : ix + 2, ix : ix + 2] = Phi
    Acl[ix : ix + 2] += np.outer(Gam, u_row)
    return float(np.max(np.abs(np.linalg.eigvals(Acl))))


@pytest.mark.parametrize("rate, delay", [(500.0, 1), (250.0, 2), (125.0, 0)])
def test_loop_poles_match_a_hand_built_one_dimensional_loop(rate, delay):
    """python-control's loop (law + IK + delay + servo + contact) has the spectral radius of the hand-built 1-D loop."""
    c = chapter_arm_case(rate, delay=delay)
    loop = admittance_servo_loop(c["controller"], c["q0"], c["normal"])
    loop_exact_ik = type(loop)(
        inertia=loop.M, damping=loop.D, stiffness=loop.K, period=loop.T, bandwidth=loop.w, damping_ratio=loop.z,
        delay=loop.delay, lowpass=1.0, J=loop.J, ik_damping=0.0, normal=loop.nu,
    )
    for k in (500.0, 3000.0, 9000.0):
        ref = _hand_loop_radius(10.0, 200.0, 1000.0, k, 1 / rate, 44.7, 0.67, delay)
        assert loop_exact_ik.spectral_radius(k) == pytest.approx(ref, rel=1e-9, abs=1e-12)
        assert loop.spectral_radius(k) == pytest.approx(ref, rel=1e-4)  # λ = 1 mm: IK ≈ identity


def test_stability_limit_is_where_the_spectral_radius_crosses_one_and_gain_margin_agrees():
    """The bisected k_e limit puts the spectral radius at 1, and (ideal servo: loop ∝ k_e) equals k_e × gain margin."""
    c = chapter_arm_case(500.0)
    loop = admittance_servo_loop(c["controller"], c["q0"], c["normal"])
    k = loop.stability_limit(rtol=1e-7)
    assert loop.spectral_radius(0.999 * k) < 1.0 < loop.spectral_radius(1.001 * k)
    rep = loop.report(2000.0)
    assert rep.gain_margin * 2000.0 == pytest.approx(k, rel=2e-3)



def test_margins_with_slicot_equal_python_controls_own_frequency_response(monkeypatch):
    """The test install has SLICOT (extra `slycot`, in `all`), which python-control uses for a state-space loop's
    frequency response; the margins equal those of python-control's fallback (a linear solve per frequency) to 1e-9,
    on the UR5's 6-D loop and on the chapter's arm with a two-sample delay."""
    import control.statesp

    pytest.importorskip("pinocchio")
    import slycot  # noqa: F401  (a missing extra is a failure here, not a skip)

    from forcecontrol.scenarios import load_scenario
    from forcecontrol.scenarios.build import build_case

    c = chapter_arm_case(250.0, delay=2)
    loops = [(admittance_servo_loop(c["controller"], c["q0"], c["normal"]), 3000.0)]
    parts = build_case(load_scenario("ur5-admittance-servo").cases[0])
    loops.append((admittance_servo_loop(parts["controller"], parts["q0"], [0.0, 0.0, 1.0]), 3000.0))
    with_slicot = [loop.margins(k) for loop, k in loops]

    def no_slicot(self, x):  # what python-control does when SLICOT is not installed
        raise ImportError("slycot")

    monkeypatch.setattr(control.statesp.StateSpace, "slycot_laub", no_slicot)
    fallback = [loop.margins(k) for loop, k in loops]
    for got, want in zip(with_slicot, fallback):
        assert all(math.isfinite(v) for v in want[:2])
        assert got == pytest.approx(want, rel=1e-9)

def test_equilibrium_force_closed_form_in_simulation():
    """Against the plane x = 1 (k = 2000 N/m) the settled force is that of the springs in series, k K_Pt/(k + K_Pt) δ_d (9.22)."""
    c = chapter_arm_case(500.0)
    k = 2000.0
    r = simulate(c["controller"].robot, ElasticPlane([1.0, 0.0], [-1.0, 0.0], k), c["controller"], Setpoint(c["x_d"]),
                 q0=c["q0"], duration=3.0)
    expected = k * 1000.0 / (k + 1000.0) * 0.01
    assert r.wrench[-1, 0] == pytest.approx(expected, rel=1e-3)
    loop = admittance_servo_loop(c["controller"], c["q0"], c["normal"])
    assert loop.equilibrium_force(k) * 0.01 == pytest.approx(expected, rel=1e-12)


def test_dynamic_servo_equilibrium_adds_the_servo_compliance():
    """With the 'dynamic' servo (contact not compensated) the settled force has the servo's compliance J W⁻² B⁻¹ Jᵀ in series."""
    arm = PlanarTwoLink()
    servo = JointServo(nq=2, rate=500.0, bandwidth=44.7, damping=0.67, delay=1, tracking="dynamic")
    pir = PositionInterfaceRobot(arm, servo)
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    ctl = PositionAdmittanceController(pir, 10.0, 200.0, 1000.0, sample_time=5e-4)
    k = 2000.0
    r = simulate(pir, ElasticPlane([1.0, 0.0], [-1.0, 0.0], k), ctl, Setpoint([1.01, 0.0]), q0=q0, duration=3.0)
    loop = admittance_servo_loop(ctl, q0, [-1.0, 0.0])
    q_end = r.q[-1]
    J, B = arm.jacobian(q_end), arm.mass_matrix(q_end)
    c_servo = float((J @ np.linalg.solve(B, J.T))[0, 0]) / 44.7**2
    expected = k / (1 + k * (1 / 1000.0 + c_servo)) * 0.01
    assert r.wrench[-1, 0] == pytest.approx(expected, rel=5e-3)
    assert loop.equilibrium_force(k) * 0.01 == pytest.approx(expected, rel=5e-3)  # B at q* vs at the end: 0.5 %
    assert expected < k * 1000.0 / (k + 1000.0) * 0.01  # softer than the ideal servo's


@pytest.mark.parametrize("rate", [500.0, 250.0])
def test_predicted_stability_limit_brackets_the_simulated_one_within_5_percent(rate):
    """The full simulation settles at 0.95 and grows at 1.05 times the predicted k_e limit (two interface rates)."""
    c = chapter_arm_case(rate)
    loop = admittance_servo_loop(c["controller"], c["q0"], c["normal"])
    k = loop.stability_limit()
    args = (c["controller"], c["q0"], c["x_d"], c["rest"], c["normal"])
    assert stable_in_simulation(*args, 0.95 * k)
    assert not stable_in_simulation(*args, 1.05 * k)


def test_slower_interface_and_longer_delay_lower_the_limit():
    """The same law and servo tolerate a stiffer environment at 500 Hz than at 125 Hz, and with 1 cycle of delay than with 3."""
    k = {}
    for rate, delay in ((500.0, 1), (125.0, 1), (500.0, 3)):
        c = chapter_arm_case(rate, delay=delay)
        k[rate, delay] = admittance_servo_loop(c["controller"], c["q0"], c["normal"]).stability_limit()
    assert k[500.0, 1] > k[125.0, 1]
    assert k[500.0, 1] > k[500.0, 3]


def test_ur5_admittance_equilibrium_on_the_pose_task():
    """UR5 (pose task, 500 Hz servo): pushing 1 cm into a 3000 N/m plane along −z settles at the series-spring force."""
    from forcecontrol.robots.pinocchio import ur5

    robot = ur5()
    q0 = np.array([0.0, -1.2, 1.5, -1.9, -1.57, 0.0])
    pir = PositionInterfaceRobot(robot, JointServo.servoj(gain=2000.0, lookahead_time=0.03))
    K = [1000.0, 1000.0, 1000.0, 50.0, 50.0, 50.0]
    ctl = PositionAdmittanceController(pir, [10.0] * 3 + [0.5] * 3, [200.0] * 3 + [10.0] * 3, K, sample_time=5e-4)
    x0 = robot.forward_kinematics(q0)
    k = 3000.0
    from forcecontrol.environments.elastic import LinearSpring

    Kenv = np.zeros((6, 6))
    Kenv[2, 2] = k
    x_d = x0.copy()
    x_d[2] -= 0.01
    with pytest.warns(UserWarning, match="IK's joint or speed limits"):  # the 1 cm step at t = 0 is speed-limited
        r = simulate(pir, LinearSpring(Kenv, x0), ctl, Setpoint(x_d), q0=q0, duration=2.0)
    assert [e for e in r.events if e["event"] == "ik-limit"][0]["t"] == 0.0
    expected = -k * 1000.0 / (k + 1000.0) * 0.01
    assert r.wrench[-1, 2] == pytest.approx(expected, rel=2e-3)
    loop = admittance_servo_loop(ctl, q0, [0.0, 0.0, 1.0])
    assert loop.report(k).stable
    assert loop.equilibrium_force(k) * 0.01 == pytest.approx(-expected, rel=2e-3)


def test_velocity_interface_limit_brackets_the_simulated_one_within_5_percent():
    """A velocity interface (joint speeds integrated by the servo at its step): the predicted k_e limit brackets the
    simulation's within 5 %, and differs from the position interface's."""
    arm = PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    pir = PositionInterfaceRobot(arm, JointServo(nq=2, rate=500.0, bandwidth=44.7, damping=0.67, interface="velocity"))
    ctl = PositionAdmittanceController(pir, 10.0, 200.0, 1000.0, sample_time=5e-4)
    k = admittance_servo_loop(ctl, q0, [-1.0, 0.0]).stability_limit()
    c = chapter_arm_case(500.0)
    assert abs(k / admittance_servo_loop(c["controller"], c["q0"], c["normal"]).stability_limit() - 1.0) > 0.1
    args = (ctl, q0, np.array([1.01, 0.0]), np.array([1.0, 0.0]), np.array([-1.0, 0.0]))
    assert stable_in_simulation(*args, 0.95 * k)
    assert not stable_in_simulation(*args, 1.05 * k)


def test_analysis_refuses_what_it_does_not_model():
    """The analysis names the option it does not model (velocity feed-forward); a low-pass on a velocity interface is refused."""
    arm = PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    with pytest.raises(ParameterError, match="lowpass_cutoff filters position commands"):
        JointServo(nq=2, rate=500.0, bandwidth=40.0, interface="velocity", lowpass_cutoff=100.0)
    pir = PositionInterfaceRobot(arm, JointServo(nq=2, rate=500.0, bandwidth=40.0))
    ctl = PositionAdmittanceController(pir, 10.0, 200.0, 1000.0, sample_time=5e-4, velocity_feedforward=True)
    with pytest.raises(ParameterError, match="velocity_feedforward"):
        admittance_servo_loop(ctl, q0, [-1.0, 0.0])


def test_controller_needs_a_position_interface_robot():
    """A plain torque robot is refused: the law needs the arm's servo."""
    with pytest.raises(ParameterError, match="PositionInterfaceRobot"):
        PositionAdmittanceController(PlanarTwoLink(), 10.0, 200.0, 1000.0)


def test_modes_include_the_servo_and_admittance_free_modes():
    """Out of contact along y the loop keeps the admittance's own mode (ω = √(K/M) = 10 rad/s) and the servo's (44.7 rad/s)."""
    c = chapter_arm_case(500.0)
    rep = admittance_servo_loop(c["controller"], c["q0"], c["normal"]).report(1000.0)
    wn = [w for w, _ in rep.modes]
    assert any(abs(w - 10.0) < 1e-3 for w in wn)
    assert any(abs(w - 44.7) < 1e-3 for w in wn)
    assert rep.phase_margin == math.inf  # |loop| < 1 at every frequency: no gain crossover at this k_e
    near = admittance_servo_loop(c["controller"], c["q0"], c["normal"]).report(6000.0)
    assert 0.0 < near.phase_margin < 10.0 and near.gain_margin > 1.0  # stable, little phase left near the limit


@pytest.mark.parametrize("name, limited", [("servo-admittance", False), ("ur5-admittance-servo", True)])
def test_built_in_servo_scenarios_pass_their_checks(name, limited):
    """The built-in position-interface scenarios (chapter arm at 500 Hz, UR5) settle at their closed-form forces and
    their analysis says stable/unstable as the simulation shows; the UR5's speed-limited first step is reported."""
    import warnings

    from forcecontrol.scenarios import run_scenario

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = run_scenario(name)
    said = [str(w.message) for w in caught if "IK's joint or speed limits" in str(w.message)]
    assert bool(said) == limited
    assert run.all_checks_pass, [c for case in run.cases for c in case.checks if not c["ok"]]


def test_redundant_panda_loop_has_no_marginal_null_space_pole():
    """On the 7-joint Panda the IK's null-space motion (unseen by the force) leaves no pole at z = 1: the loop is
    stable with the same limit as the chapter's arm (same servo on every joint, IK ≈ identity)."""
    from forcecontrol.robots.pinocchio import PANDA_READY, panda

    pir = PositionInterfaceRobot(panda(), JointServo(nq=7, rate=500.0, bandwidth=44.7, damping=0.67))
    ctl = PositionAdmittanceController(pir, [10.0] * 3 + [0.5] * 3, [200.0] * 3 + [10.0] * 3, [1000.0] * 3 + [50.0] * 3,
                                       sample_time=5e-4)
    loop = admittance_servo_loop(ctl, PANDA_READY, [0.0, 0.0, 1.0])
    assert loop.spectral_radius(3000.0) < 0.999
    c = chapter_arm_case(500.0)
    ref = admittance_servo_loop(c["controller"], c["q0"], c["normal"]).stability_limit()
    assert loop.stability_limit() == pytest.approx(ref, rel=1e-3)


def test_design_keeps_the_margins_and_its_scenario_runs_for_ur5_and_panda(tmp_path):
    """`design admittance-position` finds a damping whose loop keeps 45 deg / 6 dB at k_max in simulation terms
    (stable there), and writes scenarios for the UR5 and the Panda that validate."""
    from dataclasses import replace

    from forcecontrol.analysis.servo_design import design_admittance_servo
    from forcecontrol.scenarios import load_scenario

    d = design_admittance_servo((500.0, 5000.0), inertia=10.0, stiffness=1000.0)
    assert all(c["phase_margin_deg"] >= 45.0 and c["gain_margin_db"] >= 6.0 for c in d.checks)
    c = chapter_arm_case(500.0)
    ctl = PositionAdmittanceController(c["controller"].robot, 10.0, d.gains["damping"], 1000.0, sample_time=5e-4)
    assert stable_in_simulation(ctl, c["q0"], c["x_d"], c["rest"], c["normal"], 5000.0, duration=2.0)
    for robot in ("ur5", "panda"):
        dr = replace(d, requirements={**d.requirements, "robot": robot})  # the loop does not depend on the arm
        path = tmp_path / f"{robot}.toml"
        path.write_text(dr.scenario_toml(name=robot), encoding="utf-8")
        scn = load_scenario(path)
        assert len(scn.cases) == 3


def test_mujoco_engine_runs_the_position_interface_arm():
    """With MuJoCo as the plant the chapter's arm behind its servo settles at the same closed-form force (2000 N/m)
    and bounces beyond the predicted limit (8000 N/m), as on the built-in engine."""
    pytest.importorskip("mujoco")
    from forcecontrol.scenarios import run_scenario

    run = run_scenario("servo-admittance", engine="mujoco")
    stable, beyond = run.cases
    assert stable.checks and all(c["ok"] for c in stable.checks)
    assert stable.result.metadata["engine"] == "mujoco"
    assert beyond.metrics["contact_losses"] > 0


def test_design_cli_refuses_options_the_scheme_does_not_read():
    """`design` refuses a servo option with another scheme and a sensor option with admittance-position (no silent ignore)."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    res = CliRunner().invoke(app, ["design", "impedance", "--k-min", "100", "--k-max", "1000", "--robot", "ur5"])
    assert res.exit_code != 0 and "--robot does not apply to the impedance scheme" in res.output
    res = CliRunner().invoke(app, ["design", "admittance-position", "--k-min", "100", "--k-max", "1000", "--arm-inertia", "3"])
    assert res.exit_code != 0 and "--arm-inertia does not apply" in res.output


def test_design_cli_zero_delay_is_zero_not_the_default():
    """`design admittance-position --delay 0` designs for no transport delay (the default is one cycle)."""
    import json

    from typer.testing import CliRunner

    from forcecontrol.cli import app

    args = ["design", "admittance-position", "--k-min", "1000", "--k-max", "3000", "--inertia", "10", "--stiffness", "1000",
            "--json"]
    zero = json.loads(CliRunner().invoke(app, [*args, "--delay", "0"]).output)
    one = json.loads(CliRunner().invoke(app, args).output)
    assert zero["requirements"]["delay_cycles"] == 0 and one["requirements"]["delay_cycles"] == 1


def test_dynamic_servo_stability_limit_brackets_the_simulated_one_within_5_percent():
    """With the 'dynamic' servo (contact on the joints through B⁻¹Jᵀ) the predicted k_e limit (≠ the ideal servo's)
    also brackets the simulation's within 5 %."""
    arm = PlanarTwoLink()
    pir = PositionInterfaceRobot(arm, JointServo(nq=2, rate=500.0, bandwidth=44.7, damping=0.67, delay=1, tracking="dynamic"))
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    ctl = PositionAdmittanceController(pir, 10.0, 200.0, 1000.0, sample_time=5e-4)
    loop = admittance_servo_loop(ctl, q0, [-1.0, 0.0])
    k = loop.stability_limit()
    assert k > 1.02 * admittance_servo_loop(ctl, q0, [-1.0, 0.0], tracking="ideal").stability_limit()
    args = (ctl, q0, np.array([1.01, 0.0]), np.array([1.0, 0.0]), np.array([-1.0, 0.0]))
    assert stable_in_simulation(*args, 0.95 * k)
    assert not stable_in_simulation(*args, 1.05 * k)
