"""Position/velocity-interface robots: the joint servo, its presets, the differential IK, identification."""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol.analysis.servo_identify import identify_servo, identify_servo_from_file
from forcecontrol.controllers.position_interface import JointCommandPlayback
from forcecontrol.environments.elastic import LinearSpring
from forcecontrol.errors import DimensionError, MeasurementError, ParameterError
from forcecontrol.robots.ik import DifferentialIK
from forcecontrol.robots.planar_2r import PlanarTwoLink
from forcecontrol.robots.servo import JointServo, PositionInterfaceRobot
from forcecontrol.sim.simulation import simulate
from forcecontrol.trajectories import Setpoint

Q0 = np.array([0.3, 1.2])


def _step_closed_form(w: float, z: float, tau: np.ndarray) -> np.ndarray:
    """Unit step response of q̈ = ω²(1 − q) − 2ζω q̇ (underdamped), zero before the step."""
    wd = w * math.sqrt(1 - z * z)
    y = 1 - np.exp(-z * w * tau) * (np.cos(wd * tau) + z / math.sqrt(1 - z * z) * np.sin(wd * tau))
    return np.where(tau > 0, y, 0.0)


def _run_step(servo: JointServo, step: np.ndarray, t_step: float = 0.01, duration: float = 0.2, Ts: float = 2e-4,
              velocities=None):
    arm = PlanarTwoLink()
    pir = PositionInterfaceRobot(arm, servo)
    ctl = JointCommandPlayback(pir, lambda t: Q0 + (step if t >= t_step - 1e-12 else 0.0), sample_time=Ts, velocities=velocities)
    env = LinearSpring(np.zeros((2, 2)), [0.0, 0.0])
    return simulate(pir, env, ctl, Setpoint(arm.forward_kinematics(Q0)), q0=Q0, duration=duration)


def test_servo_step_matches_second_order_closed_form_with_delay():
    """A joint step through the 500 Hz servo (2 cycles delay) follows the closed-form second-order step from t_step + 2 T."""
    w, z = 40.0, 0.6
    servo = JointServo(nq=2, rate=500.0, bandwidth=w, damping=z, delay=2)
    r = _run_step(servo, np.array([0.05, -0.03]))
    cf = _step_closed_form(w, z, r.t - (0.01 + 2 * 0.002))
    ref = r.signals["servo_reference"]
    np.testing.assert_allclose((ref[:, 0] - Q0[0]) / 0.05, cf, atol=1e-9)
    np.testing.assert_allclose((ref[:, 1] - Q0[1]) / -0.03, cf, atol=1e-9)
    # the arm's joints (full dynamics, computed-torque tracking) follow the reference closely
    np.testing.assert_allclose((r.q[:, 0] - Q0[0]) / 0.05, cf, atol=2e-3)


def test_dynamic_servo_is_the_same_second_order_in_free_space():
    """The 'dynamic' realisation (PD + inverse dynamics on the arm) gives the same step response in free space."""
    w, z = 40.0, 0.6
    servo = JointServo(nq=2, rate=500.0, bandwidth=w, damping=z, delay=1, tracking="dynamic")
    r = _run_step(servo, np.array([0.05, -0.03]))
    cf = _step_closed_form(w, z, r.t - (0.01 + 0.002))
    np.testing.assert_allclose((r.q[:, 0] - Q0[0]) / 0.05, cf, atol=1e-2)


def test_velocity_limit_bounds_the_servo_reference():
    """With a joint speed limit the servo reference never moves faster than it (a large step is slew-limited)."""
    servo = JointServo(nq=2, rate=500.0, bandwidth=40.0, damping=0.7, delay=0, velocity_limit=0.5, acceleration_limit=50.0)
    with pytest.warns(UserWarning, match="limits changed the motion"):
        r = _run_step(servo, np.array([0.5, 0.0]), duration=0.5)
    ref = r.signals["servo_reference"][:, 0]
    speed = np.abs(np.diff(ref)) / 2e-4
    assert speed.max() <= 0.5 * (1 + 1e-9)
    assert speed.max() >= 0.5 * 0.99  # the limit is reached (the unlimited servo would peak at ~9 rad/s)


def test_velocity_interface_integrates_the_command():
    """A velocity interface integrates a constant joint speed command: the reference ends displaced by v · t."""
    servo = JointServo(nq=2, rate=500.0, bandwidth=60.0, damping=1.0, delay=0, interface="velocity")
    v = np.array([0.2, -0.1])
    r = _run_step(servo, np.zeros(2), duration=0.3, velocities=lambda t: v if t < 0.1 - 1e-12 else np.zeros(2))
    np.testing.assert_allclose(r.signals["servo_reference"][-1] - Q0, v * 0.1, rtol=2e-3)


def test_command_lowpass_gain_is_libfranka_value():
    """The Franka preset's command low-pass has libfranka's a = T/(T + 1/(2π·100 Hz)) = 0.386 at 1 kHz."""
    s = JointServo.preset("franka-joint-position")
    assert s.lowpass_gain() == pytest.approx(1e-3 / (1e-3 + 1 / (2 * math.pi * 100)), rel=1e-12)
    assert s.lowpass_gain() == pytest.approx(0.386, abs=1e-3)


def test_presets_rates_and_servoj_mapping():
    """The presets carry the documented rates; servoj(gain, lookahead) maps to ω = √gain, ζ = T_la √gain / 2."""
    assert JointServo.preset("ur-e-series").rate == 500.0
    assert JointServo.preset("kuka-rsi").period == pytest.approx(0.004)
    assert JointServo.preset("franka-joint-position").rate == 1000.0
    s = JointServo.servoj(gain=2000.0, lookahead_time=0.03)
    assert s.bandwidth[0] == pytest.approx(math.sqrt(2000.0))
    assert s.damping[0] == pytest.approx(0.03 * math.sqrt(2000.0) / 2)
    assert "INFERRED" in JointServo.preset("ur-e-series").source


@pytest.mark.parametrize(
    "kwargs, err, match",
    [
        ({"rate": -1.0}, ParameterError, "rate"),
        ({"bandwidth": [1.0, 2.0, 3.0]}, DimensionError, "bandwidth must be a number or have shape"),
        ({"delay": 1.5}, ParameterError, "delay must be a whole number"),
        ({"interface": "torque"}, ParameterError, "interface must be"),
        ({"tracking": "magic"}, ParameterError, "tracking must be"),
        ({"velocity_limit": -1.0}, ParameterError, "velocity_limit must be positive"),
    ],
)
def test_servo_refuses_bad_parameters(kwargs, err, match):
    """Bad servo parameters are refused with the parameter named."""
    base = {"nq": 2, "rate": 500.0, "bandwidth": 40.0}
    base.update(kwargs)
    with pytest.raises(err, match=match):
        JointServo(**base)


def test_interface_period_must_be_a_multiple_of_the_sample_time():
    """A sample time that does not divide the interface period is refused, naming both."""
    pir = PositionInterfaceRobot(PlanarTwoLink(), JointServo(nq=2, rate=500.0, bandwidth=40.0))
    with pytest.raises(ParameterError, match="whole multiple of the sample time"):
        JointCommandPlayback(pir, lambda t: Q0, sample_time=3e-4)


def test_unknown_preset_lists_the_presets():
    """An unknown preset name is refused with the valid names."""
    with pytest.raises(ParameterError, match="franka-joint-position"):
        JointServo.preset("abb-egm")


def test_ik_converges_to_the_closed_form_inverse_kinematics():
    """Iterated damped least squares reaches the chapter arm's closed-form IK solution."""
    arm = PlanarTwoLink()
    ik = DifferentialIK(arm, 0.002, damping=1e-6, iterations=20)
    target = np.array([1.2, 0.4])
    q = ik.solve(arm.inverse_kinematics([1.0, 0.0], elbow="up"), target).q
    np.testing.assert_allclose(q, arm.inverse_kinematics(target, elbow="up"), atol=1e-9)


def test_ik_step_is_first_order_exact_against_finite_differences():
    """One IK step of a small displacement moves the tip by that displacement to second order (J from the arm)."""
    arm = PlanarTwoLink()
    ik = DifferentialIK(arm, 0.002, damping=0.0)
    q0 = arm.inverse_kinematics([1.0, 0.2], elbow="up")
    for eps in (1e-3, 1e-4):
        dx = eps * np.array([0.6, -0.8])
        q1 = ik.solve(q0, arm.forward_kinematics(q0) + dx).q
        err = np.linalg.norm(arm.forward_kinematics(q1) - arm.forward_kinematics(q0) - dx)
        assert err < 5 * eps**2


def test_ik_speed_limit_scales_the_step_and_keeps_its_direction():
    """With a joint speed limit the step is scaled to v_max T on the fastest joint, direction unchanged."""
    arm = PlanarTwoLink()
    free = DifferentialIK(arm, 0.002, damping=0.0)
    lim = DifferentialIK(arm, 0.002, damping=0.0, velocity_limit=1.0)
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    target = np.array([1.2, 0.3])
    d_free = free.solve(q0, target).q - q0
    d_lim = lim.solve(q0, target).q - q0
    assert np.max(np.abs(d_lim)) == pytest.approx(0.002, rel=1e-12)
    np.testing.assert_allclose(d_lim / np.linalg.norm(d_lim), d_free / np.linalg.norm(d_free), atol=1e-12)
    assert lim.last_limited


def test_ik_pose_task_matches_finite_differences_on_ur5():
    """On the UR5 (pose task) a small pose displacement (translation + rotation vector) is reached to second order."""
    from forcecontrol.robots.pinocchio import ur5
    from forcecontrol.spatial.closed_form import rotation_to_euler_xyz, rotation_vector, rotvec_to_rotation

    robot = ur5()
    q0 = np.array([0.0, -1.2, 1.5, -1.9, -1.57, 0.0])
    ik = DifferentialIK(robot, 0.002, damping=0.0)
    R0, o0 = robot.frame_pose(q0)
    eps = 1e-4
    dth = eps * np.array([0.3, -0.5, 0.2])
    do = eps * np.array([1.0, 0.5, -0.7])
    R_t = rotvec_to_rotation(dth) @ R0
    q1 = ik.solve(q0, np.concatenate([o0 + do, rotation_to_euler_xyz(R_t)])).q
    R1, o1 = robot.frame_pose(q1)
    assert np.linalg.norm(o1 - o0 - do) < 10 * eps**2
    assert np.linalg.norm(rotation_vector(R_t @ R1.T)) < 10 * eps**2


def _synthetic_recording(tmp_path, w, z, delay):
    servo = JointServo(nq=2, rate=500.0, bandwidth=w, damping=z, delay=delay)
    step = np.array([0.04, -0.06])
    r = _run_step(servo, step, t_step=0.02, duration=0.4)
    N = 10  # steps per interface cycle (2 ms / 0.2 ms)
    rows = slice(0, None, N)
    t = r.t[rows]
    target = Q0 + np.where(t[:, None] >= 0.02 - 1e-12, step, 0.0)
    import pandas as pd

    df = pd.DataFrame({"t": t})
    for i in range(2):
        df[f"q{i + 1}"] = r.q[rows, i]
        df[f"qd{i + 1}"] = r.qd[rows, i]
        df[f"target_q_{i}"] = target[:, i]
    path = tmp_path / "step.csv"
    df.to_csv(path, index=False)
    return path


def test_identification_recovers_servo_from_its_own_recording(tmp_path):
    """A step recording made by the model (ω = 45 rad/s, ζ = 0.65, delay 2 cycles) gives ω, ζ within 2 %, the delay exactly."""
    path = _synthetic_recording(tmp_path, 45.0, 0.65, 2)
    fit = identify_servo_from_file(path, max_delay=3)
    np.testing.assert_allclose(fit.bandwidth, 45.0, rtol=0.02)
    np.testing.assert_allclose(fit.damping, 0.65, rtol=0.02)
    assert fit.delay.tolist() == [2, 2]
    assert fit.period == pytest.approx(0.002)


def test_identification_refuses_missing_targets_and_flat_steps(tmp_path):
    """A file without target columns and a recording without a step are refused with what is missing."""
    import pandas as pd

    t = np.arange(20) * 0.002
    df = pd.DataFrame({"t": t, "q1": 0.0, "qd1": 0.0})
    p = tmp_path / "nosteps.csv"
    df.to_csv(p, index=False)
    with pytest.raises(ParameterError, match="target_q1"):
        identify_servo_from_file(p)
    with pytest.raises(MeasurementError, match="step response is needed"):
        identify_servo(t, np.zeros(20), np.zeros(20))


def test_a_biting_limit_is_logged_as_an_event_and_warned():
    """When the speed limit changes the servo's motion the run says so: a warning and a 'servo-limit' event with its time."""
    servo = JointServo(nq=2, rate=500.0, bandwidth=40.0, damping=0.7, delay=0, velocity_limit=0.5)
    with pytest.warns(UserWarning, match="speed/acceleration/jerk limits changed the motion of joint"):
        r = _run_step(servo, np.array([0.5, 0.0]), duration=0.3)
    ev = [e for e in r.events if e["event"] == "servo-limit"]
    assert ev and 0.01 <= ev[0]["t"] < 0.05


def test_no_limit_event_when_the_limits_do_not_bite():
    """A small step inside the limits logs no event."""
    servo = JointServo(nq=2, rate=500.0, bandwidth=40.0, damping=0.7, delay=0, velocity_limit=5.0)
    r = _run_step(servo, np.array([0.01, 0.0]), duration=0.1)
    assert not [e for e in r.events if e["event"] == "servo-limit"]
