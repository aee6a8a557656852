"""Controllers refuse what they do not support and honour their options, off the book's examples.

References are built by hand from the robot's separate dynamics calls (``mass_matrix``,
``nonlinear_effects``, ``jacobian``, ``jdot_qdot``) and the chapter's formulas, not from the
controller under test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.controllers.redundant import NullSpacePosture, SingularityHandling
from forcecontrol.errors import ParameterError

ARM = fc.PlanarTwoLink()

pin = pytest.importorskip("pinocchio")

from forcecontrol.robots.pinocchio import PANDA_READY, panda  # noqa: E402


@pytest.fixture(scope="module")
def panda_pose():
    return panda()


@pytest.fixture(scope="module")
def panda_position():
    return panda(task="position")


def _planar_builders(robot):
    return {
        "OperationalSpacePD": lambda: fc.OperationalSpacePD(robot, 100.0, 10.0),
        "ImpedanceController": lambda: fc.ImpedanceController(robot, 1.0, 10.0, 100.0),
        "InnerPositionForceController": lambda: fc.InnerPositionForceController(robot, 1.0, 10.0, 100.0, 1e-3, 1e-2),
        "InnerVelocityForceController": lambda: fc.InnerVelocityForceController(robot, 1.0, 10.0, 100.0, 1e-3),
        "ParallelForcePositionController": lambda: fc.ParallelForcePositionController(robot, 1.0, 10.0, 100.0, 1e-3, 1e-2),
    }


@pytest.mark.parametrize(
    "name",
    ["OperationalSpacePD", "ImpedanceController", "InnerPositionForceController", "InnerVelocityForceController",
     "ParallelForcePositionController"],
)
def test_position_task_controllers_refuse_a_pose_task_robot(panda_pose, name):
    """A planar/position law given a 6-D (task='pose') robot is refused at construction, naming the 6-D controllers."""
    with pytest.raises(ParameterError, match=rf"{name} works in a position task space .*task is 'pose'.*SpatialImpedance"):
        _planar_builders(panda_pose)[name]()


def test_impedance_on_a_redundant_arm_gives_the_requested_task_acceleration(panda_position):
    """ImpedanceController on the 7-DOF Panda (3-D position task) yields J q̈ + J̇q̇ = a of (9.31), not a 'singular Jacobian'."""
    robot = panda_position
    Md, KD, KP = np.diag([2.0, 3.0, 4.0]), np.diag([40.0, 50.0, 60.0]), np.diag([400.0, 500.0, 600.0])
    ctl = fc.ImpedanceController(robot, Md, KD, KP, posture=NullSpacePosture(PANDA_READY))
    q = PANDA_READY + 0.05 * np.arange(7) / 7
    qd = 0.1 * np.sin(np.arange(7))
    h = np.array([3.0, -2.0, 5.0])
    x_d, v_d, a_d = np.array([0.4, 0.1, 0.5]), np.array([0.01, 0.0, -0.02]), np.array([0.1, 0.2, 0.0])
    ref = fc.Reference(x_d, v_d, a_d, np.zeros(3), np.zeros(3), np.zeros(3))
    u = ctl.step(0.0, fc.Measurement(q, qd, h), ref)
    # hand-built reference from the robot's separate calls
    B, n, J, Jdq = robot.mass_matrix(q), robot.nonlinear_effects(q, qd), robot.jacobian(q), robot.jdot_qdot(q, qd)
    x, xd = robot.forward_kinematics(q), J @ qd
    a = a_d + np.linalg.solve(Md, KD @ (v_d - xd) + KP @ (x_d - x) - h)
    qdd = np.linalg.solve(B, u - n - J.T @ h)  # the arm under u and the measured contact wrench
    np.testing.assert_allclose(J @ qdd + Jdq, a, atol=1e-8 * max(1.0, np.abs(a).max()))


@pytest.mark.parametrize("kind", ["impedance", "inner-position"])
def test_singularity_handling_is_honoured_with_a_square_jacobian(kind):
    """At q2 = 1e-4 the damped least-squares torque of a configured SingularityHandling is used (hand-built), not J⁻¹."""
    sing = SingularityHandling(threshold=0.05, max_damping=0.05)
    robots = [ARM]
    q = np.array([0.3, 1e-4])
    qd = np.array([0.1, -0.2])
    h = np.array([5.0, 1.0])
    for robot in robots:
        if kind == "impedance":
            ctl = fc.ImpedanceController(robot, 100.0, 500.0, 2500.0, singularity=sing)
            exact = fc.ImpedanceController(robot, 100.0, 500.0, 2500.0)
        else:
            ctl = fc.InnerPositionForceController(robot, 100.0, 500.0, 2500.0, 1e-3, 1e-2, singularity=sing)
            exact = fc.InnerPositionForceController(robot, 100.0, 500.0, 2500.0, 1e-3, 1e-2)
        x_d = ARM.forward_kinematics(q) + np.array([0.01, 0.02])
        ref = fc.Reference.setpoint(x_d, force=np.array([10.0, 0.0]))
        meas = fc.Measurement(q, qd, h)
        for c in (ctl, exact):
            c.reset(meas, ref)
        u = ctl.step(0.0, meas, ref)
        u_exact = exact.step(0.0, meas, ref)
        # the requested acceleration is the same for both: recover it from the exact torque, a = J y + J̇q̇
        B, n, J, Jdq = ARM.mass_matrix(q), ARM.nonlinear_effects(q, qd), ARM.jacobian(q), ARM.jdot_qdot(q, qd)
        a = J @ np.linalg.solve(B, u_exact - n - J.T @ h) + Jdq
        s2 = float(np.linalg.eigvalsh(J @ J.T)[0])
        lam2 = 0.05**2 * (1.0 - s2 / 0.05**2)
        y = J.T @ np.linalg.solve(J @ J.T + lam2 * np.eye(2), a - Jdq)
        u_want = B @ y + n + J.T @ h
        np.testing.assert_allclose(u, u_want, rtol=1e-6, atol=1e-6)
        assert np.abs(u).max() < 0.05 * np.abs(u_exact).max()  # bounded where the exact inverse blows up


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda c, m, r: c.step(0.0, None, r), "measurement must be a forcecontrol Measurement"),
        (lambda c, m, r: c.step(0.0, m, None), "reference must be a forcecontrol Reference"),
        (lambda c, m, r: c.step(0.0, m, {"position": [1, 0]}), "reference must be a forcecontrol Reference"),
        (lambda c, m, r: c.step(math.nan, m, r), "t must be finite"),
        (lambda c, m, r: c.step(math.inf, m, r), "t must be finite"),
        (lambda c, m, r: c.step("0.0", m, r), "t must be a number"),
        (lambda c, m, r: c.step(None, m, r), "t must be a number"),
    ],
)
def test_step_arguments_are_checked(call, match):
    """A user-loop call with a missing or mistyped argument is a ParameterError naming it, not an AttributeError."""
    ctl = fc.ImpedanceController(ARM, 100.0, 500.0, 2500.0)
    q0 = ARM.inverse_kinematics([1.0, 0.0])
    meas = fc.Measurement(q0, np.zeros(2), np.zeros(2))
    ref = fc.Reference.setpoint([1.1, 0.1])
    with pytest.raises(ParameterError, match=match):
        call(ctl, meas, ref)
    assert np.all(np.isfinite(ctl.step(0, meas, ref)))  # an int time is fine


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: fc.ImpedanceController(ARM, "100", 500, 2500), r"inertia must be .*numbers, not text"),
        (lambda: fc.ImpedanceController(ARM, 100, ["500", "500"], 2500), r"damping must be .*numbers, not text"),
        (lambda: fc.OperationalSpacePD(ARM, True, 10), r"stiffness must be .*not text or booleans"),
        (lambda: fc.ImpedanceController(ARM, 100, 500, 2500, sample_time="0.001"), r"sample_time must be a positive number"),
        (lambda: fc.ElasticPlane([1.0, "0"], [-1.0, 0.0], 1e3), r"point must be a vector of numbers"),
    ],
)
def test_gains_given_as_text_are_refused(build, match):
    """'100' is not a gain: text and booleans are refused with the parameter named (float('100') would pass)."""
    with pytest.raises(ParameterError, match=match):
        build()


def test_redundant_spatial_controller_without_posture_damps_self_motion(panda_pose):
    """With no posture, a 7-DOF spatial impedance still damps null-space motion: it decays like e^(-D_n t), D_n = 10 1/s."""
    robot = panda_pose
    q0 = PANDA_READY
    J = robot.jacobian(q0)
    _, _, Vt = np.linalg.svd(J)
    qd0 = 0.5 * Vt[-1]  # a pure self-motion: J q̇ = 0
    R, p = robot.frame_pose(q0)
    x0 = np.concatenate([p, fc.spatial.rotation_to_euler_xyz(R)])
    MD, KP = np.diag([2.0] * 3 + [0.05] * 3), np.diag([400.0] * 3 + [10.0] * 3)
    KD = 2 * 0.7 * np.sqrt(MD * KP)
    ctl = fc.SpatialImpedanceController(robot, MD, KD, KP)
    from forcecontrol.environments.spatial import ConstantWrench

    res = fc.simulate(robot, ConstantWrench(np.zeros(6)), ctl, fc.Setpoint(x0), q0=q0, qd0=qd0, duration=0.5, engine="python")
    speed = lambda qd: float(np.linalg.norm(qd))  # noqa: E731
    assert speed(res.qd[-1]) < 0.05 * speed(qd0)  # e^(-5) = 0.0067 for a pure damping D_n = 10
    assert speed(res.qd[-1]) > 1e-6  # decays, not frozen by some other term
