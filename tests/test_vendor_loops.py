"""Stability limits of the ros2 admittance and UR force-mode loops (analysis.vendor_loops): closed forms and simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol.analysis.vendor_loops import Ros2AdmittanceLoop, UrForceModeLoop, stability_limit

W, Z = math.sqrt(2000.0), 0.03 * math.sqrt(2000.0) / 2.0  # servoj gain 2000, lookahead 0.03 s (inferred mapping)


def test_ur_limit_with_an_ideal_servo_is_the_jury_bound():
    """Servo reaching the command within the cycle: v ← (1 − d) v − T G s k x, x ← x + T v is stable iff
    k < (4 − 2d)/(T² G s) (Jury on z² − (2 − d − T²Gsk) z + (1 − d))."""
    T, G, s, d = 0.002, 0.05, 0.5, 0.025
    loop = UrForceModeLoop(gain=G, gain_scaling=s, damping_force_mode=d, rate=1 / T, bandwidth=1e5, damping=1.0, delay=0)
    assert stability_limit(loop) == pytest.approx((4 - 2 * d) / (T * T * G * s), rel=1e-3)


def test_ros2_limit_with_an_ideal_servo_matches_the_survey_recurrence():
    """Ideal servo: the limit equals the largest k_e at which the survey's recurrence (§1.2, on [F, v, p]) has all
    its eigenvalues inside the unit circle (bisected on that matrix, written independently)."""
    T, M, zeta, K, c_j, alpha = 0.002, 5.5, 2.828427, 214.1, 5.0, 0.05
    D = zeta * 2 * math.sqrt(M * K)

    def stable(k_e: float) -> bool:
        A = np.zeros((3, 3))
        A[0] = [1 - alpha, 0, -alpha * k_e]
        A[1] = T / M * A[0] + np.array([0, 1 - T * D / M - T * c_j, -T * K / M])
        A[2] = T * A[1] + np.array([0, 0, 1.0])
        return bool(np.max(np.abs(np.linalg.eigvals(A))) < 1)

    lo, hi = 1.0, 1e9
    while hi - lo > 1e-5 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    loop = Ros2AdmittanceLoop(mass=M, damping_ratio=zeta, stiffness=K, rate=1 / T, bandwidth=1e5, damping=1.0, delay=0,
                              joint_damping=c_j, filter_coefficient=alpha)
    assert stability_limit(loop) == pytest.approx(lo, rel=1e-3)


pytest.importorskip("pinocchio")


def _run(kind: str, rate: float, k_e: float, duration: float) -> np.ndarray:
    from forcecontrol.controllers.vendor import Ros2AdmittanceController, UrForceModeController
    from forcecontrol.environments.spatial import Table
    from forcecontrol.robots.pinocchio import ur5
    from forcecontrol.robots.servo import JointServo, PositionInterfaceRobot
    from forcecontrol.sim.simulation import simulate
    from forcecontrol.trajectories.profiles import Setpoint

    q0 = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
    arm = ur5()
    robot = PositionInterfaceRobot(arm, JointServo.servoj(nq=6, gain=2000.0, lookahead_time=0.03, rate=rate))
    _, p = arm.frame_pose(q0)
    Ts = (1 / rate) / math.ceil((1 / rate) / 5e-4 - 1e-9)
    x0 = arm.forward_kinematics(q0)
    if kind == "ros2":  # the documented example's gains; z: mass 7.7, stiffness 214.3
        ctl = Ros2AdmittanceController(robot, mass=[5.5, 6.6, 7.7, 8.8, 9.9, 10.1], damping_ratio=2.828427,
                                       stiffness=[214.1, 214.2, 214.3, 214.4, 214.5, 214.6], filter_coefficient=0.05,
                                       kinematics_alpha=0.0005, sample_time=Ts)
        ref = Setpoint(x0, [0, 0, -10.0, 0, 0, 0])
    else:
        ctl = UrForceModeController(robot, selection_vector=[0, 0, 1, 0, 0, 0], wrench=[0, 0, -10.0, 0, 0, 0],
                                    limits=[0.1, 0.1, 0.5, 0.785, 0.785, 0.785], damping=0.025, gain_scaling=0.5, gain=0.05,
                                    sample_time=Ts)
        ref = Setpoint(x0)
    return np.asarray(simulate(robot, Table(p, stiffness=k_e), ctl, ref, q0=q0, duration=duration).wrench)[:, 2]


@pytest.mark.parametrize("kind, rate", [("ros2", 250.0), ("ros2", 500.0), ("ur", 250.0), ("ur", 500.0)])
def test_predicted_limit_brackets_the_simulated_one_within_5_percent(kind, rate):
    """On the UR5 through servoj: at 0.95 × the predicted k_e limit the contact holds and the force's oscillation
    decays; at 1.05 × the tool bounces (contact lost again and again)."""
    loop = (Ros2AdmittanceLoop(mass=7.7, damping_ratio=2.828427, stiffness=214.3, rate=rate, bandwidth=W, damping=Z,
                               filter_coefficient=0.05, kinematics_alpha=0.0005) if kind == "ros2"
            else UrForceModeLoop(gain=0.05, gain_scaling=0.5, damping_force_mode=0.025, rate=rate, bandwidth=W, damping=Z))
    limit = stability_limit(loop)
    duration = 3.0 if kind == "ros2" else 2.0
    below, above = _run(kind, rate, 0.95 * limit, duration), _run(kind, rate, 1.05 * limit, duration)
    n = len(below)
    assert not np.any(below[n // 2 :] > -1e-9) and np.std(below[3 * n // 4 :]) < np.std(below[n // 2 : 3 * n // 4])
    assert np.any(above[n // 2 :] > -1e-9)
