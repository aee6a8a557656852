"""Compliance and impedance laws against torques built by hand from the chapter's equations."""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import DimensionError, MeasurementError, ParameterError, SingularityError

ARM = fc.PlanarTwoLink()
RNG = np.random.default_rng(7)


class GenericArm:
    """The same arm behind the plain RobotModel protocol, so controllers take their generic path."""

    nq = 2
    task_dim = 2

    def __getattr__(self, name):
        return getattr(ARM, name)


ROBOTS = pytest.mark.parametrize("robot", [ARM, GenericArm()], ids=["fused", "generic"])


def _random_state():
    q = np.array([0.4, -1.3]) + 0.2 * RNG.standard_normal(2)
    return q, RNG.standard_normal(2), 50 * RNG.standard_normal(2)


def _random_reference():
    return fc.Reference(*(RNG.standard_normal(2) for _ in range(6)))


@ROBOTS
def test_operational_pd_torque_is_8_110(robot):
    """u = g + Jᵀ (K_P (x_d − x) − K_D J q̇), built by hand, at 1e-12."""
    K_P = np.array([[3000.0, 200.0], [200.0, 1500.0]])
    K_D = np.array([[400.0, 10.0], [10.0, 300.0]])
    ctl = fc.OperationalSpacePD(robot, K_P, K_D)
    for _ in range(5):
        q, qd, h = _random_state()
        ref = _random_reference()
        J = ARM.jacobian(q)
        want = ARM.gravity(q) + J.T @ (K_P @ (ref.position - ARM.forward_kinematics(q)) - K_D @ J @ qd)
        got = ctl.step(0.0, fc.Measurement(q, qd, h), ref)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)


@ROBOTS
def test_joint_pd_torque_is_8_51(robot):
    """u = g + K_P (q_d − q) − K_D q̇, built by hand."""
    ctl = fc.JointSpacePD(robot, [800.0, 500.0], [80.0, 50.0], [0.5, -1.0])
    q, qd, h = _random_state()
    want = ARM.gravity(q) + np.diag([800.0, 500.0]) @ ([0.5, -1.0] - q) - np.diag([80.0, 50.0]) @ qd
    np.testing.assert_allclose(ctl.step(0.0, fc.Measurement(q, qd, h), _random_reference()), want, rtol=1e-12)


@ROBOTS
@pytest.mark.parametrize("force_measurement", [True, False])
def test_impedance_torque_is_9_30_9_31_or_9_28(robot, force_measurement):
    """u = B J⁻¹ M_d⁻¹ (M_d ẍ_d + K_D x̃̇ + K_P x̃ − M_d J̇q̇ [− h]) + n [+ Jᵀ h], by hand.

    This is (9.30)–(9.31) with the corrected first term M_d ẍ_d, or (9.28) without force.
    """
    M_d = np.array([[100.0, 5.0], [5.0, 80.0]])
    K_D = np.diag([500.0, 450.0])
    K_P = np.diag([2500.0, 2000.0])
    ctl = fc.ImpedanceController(robot, M_d, K_D, K_P, force_measurement=force_measurement)
    for _ in range(5):
        q, qd, h = _random_state()
        ref = _random_reference()
        J = ARM.jacobian(q)
        x = ARM.forward_kinematics(q)
        inner = M_d @ ref.acceleration + K_D @ (ref.velocity - J @ qd) + K_P @ (ref.position - x)
        inner = inner - M_d @ ARM.jdot_qdot(q, qd) - (h if force_measurement else 0)
        y = np.linalg.solve(J, np.linalg.solve(M_d, inner))
        want = ARM.mass_matrix(q) @ y + ARM.nonlinear_effects(q, qd) + (J.T @ h if force_measurement else 0)
        got = ctl.step(0.0, fc.Measurement(q, qd, h), ref)
        np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-8)


def test_impedance_closed_loop_is_the_linear_impedance_9_32():
    """With exact inverse dynamics the arm obeys M_d x̃̈ + K_D x̃̇ + K_P x̃ = h (9.32) at any state."""
    M_d, K_D, K_P = np.diag([100.0, 100.0]), np.diag([500.0, 500.0]), np.diag([2500.0, 2500.0])
    ctl = fc.ImpedanceController(ARM, M_d, K_D, K_P)
    q, qd, h = _random_state()
    ref = _random_reference()
    u = ctl.step(0.0, fc.Measurement(q, qd, h), ref)
    qdd = np.linalg.solve(ARM.mass_matrix(q), u - ARM.nonlinear_effects(q, qd) - ARM.jacobian(q).T @ h)
    xdd = ARM.jacobian(q) @ qdd + ARM.jdot_qdot(q, qd)
    x, xd = ARM.forward_kinematics(q), ARM.jacobian(q) @ qd
    lhs = M_d @ (ref.acceleration - xdd) + K_D @ (ref.velocity - xd) + K_P @ (ref.position - x)
    np.testing.assert_allclose(lhs, h, atol=1e-8)


@ROBOTS
def test_nan_measurement_is_reported_with_time_and_signal(robot):
    """A NaN in the force measurement raises MeasurementError naming the signal and the time."""
    ctl = fc.ImpedanceController(robot, 100, 500, 2500)
    q, qd, _ = _random_state()
    with pytest.raises(MeasurementError, match=r"measurement.wrench is not finite at t = 0.25 s"):
        ctl.step(0.25, fc.Measurement(q, qd, np.array([np.nan, 0.0])), _random_reference())


@ROBOTS
def test_singular_jacobian_raises_singularity_error(robot):
    """At the stretched-out singularity (q2 = 0) the inverse-dynamics law refuses with a clear error."""
    ctl = fc.ImpedanceController(robot, 100, 500, 2500)
    with pytest.raises(SingularityError, match=r"Jacobian is singular at t = 1 s"):
        ctl.step(1.0, fc.Measurement(np.array([0.3, 0.0]), np.zeros(2), np.zeros(2)), _random_reference())


@pytest.mark.parametrize(
    "build, exc, match",
    [
        (lambda: fc.ImpedanceController(ARM, np.ones((3, 3)), 500, 2500), DimensionError,
         r"inertia must be a symmetric positive definite \(2, 2\) matrix; got shape \(3, 3\)"),
        (lambda: fc.ImpedanceController(ARM, 100, [[500, 1], [0, 500]], 2500), ParameterError,
         r"damping must be a symmetric positive definite \(2, 2\) matrix; got a non-symmetric matrix"),
        (lambda: fc.ImpedanceController(ARM, 100, 500, [[1, 2], [2, 1]]), ParameterError,
         r"stiffness must be a symmetric positive definite \(2, 2\) matrix; got eigenvalues \[-1.0, 3.0\]"),
        (lambda: fc.ImpedanceController(ARM, 100, 500, -2500), ParameterError, "stiffness must be .*eigenvalues"),
        (lambda: fc.ImpedanceController(ARM, 100, 500, 2500, sample_time=0.0), ParameterError,
         "sample_time must be a positive number; got 0.0"),
        (lambda: fc.ImpedanceController(ARM, 100, 500, 2500, sample_time=-1e-3), ParameterError,
         "sample_time must be a positive number"),
        (lambda: fc.OperationalSpacePD(ARM, [1.0, 2.0, 3.0], 1.0), DimensionError, r"stiffness .*got shape \(3,\)"),
        (lambda: fc.OperationalSpacePD(ARM, 100.0, float("inf")), ParameterError, "damping must be finite"),
        (lambda: fc.JointSpacePD(ARM, 1.0, 1.0, [0.0]), DimensionError, r"joint_setpoint must have shape \(2,\)"),
        (lambda: fc.ImpedanceController(object(), 1, 1, 1), ParameterError, "robot must implement RobotModel"),
    ],
)
def test_bad_gains_raise_clear_errors(build, exc, match):
    """Non-square, non-symmetric, indefinite, negative or non-finite gains and Ts <= 0 are refused."""
    with pytest.raises(exc, match=match):
        build()


def test_controller_works_in_a_users_own_loop():
    """The same object steps in a hand-written loop (Euler plant) and holds the chapter's equilibrium."""
    ctl = fc.ImpedanceController(ARM, 100, 500, 2500)
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
    q = ARM.inverse_kinematics([1.0, 0.0])
    qd = np.zeros(2)
    ref = fc.Reference.setpoint([1.1, 0.1])
    for k in range(4000):
        T = ARM.terms(q, qd)
        h = env.wrench(T.x, T.xd)
        u = ctl.step(k * 1e-3, fc.Measurement(q, qd, h), ref)
        for _ in range(10):  # semi-implicit Euler at 0.1 ms, torque held
            T = ARM.terms(q, qd)
            qdd = np.linalg.solve(T.B, u - T.n - T.J.T @ env.wrench(T.x, T.xd))
            qd = qd + 1e-4 * qdd
            q = q + 1e-4 * qd
    assert math.isclose(env.wrench(ARM.forward_kinematics(q), np.zeros(2))[0], 71.43, rel_tol=5e-3)


def test_wrong_shapes_are_refused_before_the_compiled_law_reads_them():
    """A (1,) or (3,) wrench, or a short reference block, is a DimensionError (no out-of-bounds read)."""
    ctl = fc.ImpedanceController(ARM, 100, 500, 2500)
    q, qd, _ = _random_state()
    ref = fc.Reference.setpoint([1.1, 0.1])
    for bad in (np.array([5.0, 999.0])[:1], np.zeros(3)):
        with pytest.raises(DimensionError, match=r"measurement.wrench must have shape \(2,\); got shape"):
            ctl.step(0.0, fc.Measurement(q, qd, bad), ref)
    short = fc.Reference(np.array([1.1]), *(np.zeros(2) for _ in range(5)))
    with pytest.raises(DimensionError, match=r"reference.position must have shape \(2,\); got shape \(1,\)"):
        ctl.step(0.0, fc.Measurement(q, qd, np.zeros(2)), short)


def test_nan_reference_is_named_not_reported_as_a_singularity():
    """A NaN force reference raises ParameterError naming reference.force, not a 'singular Jacobian'."""
    ctl = fc.ImpedanceController(ARM, 100, 500, 2500)
    q, qd, h = _random_state()
    ref = fc.Reference.setpoint([1.1, 0.1], force=[np.nan, 0.0])
    with pytest.raises(ParameterError, match=r"reference.force is not finite at t = 0.5 s"):
        ctl.step(0.5, fc.Measurement(q, qd, h), ref)


def test_a_nan_sample_does_not_corrupt_the_integrator():
    """A NaN wrench is refused before the PI integrator moves; the next finite sample works normally."""
    ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, force_gain=[0.00064, 0.0], integral_gain=[0.0016, 0.0])
    q = ARM.inverse_kinematics([1.0, 0.0])
    ref = fc.Reference.setpoint([1.0, 0.0], force=[10.0, 0.0])
    ctl.reset(fc.Measurement(q, np.zeros(2), np.zeros(2)), ref)
    before = ctl.state.copy()
    with pytest.raises(MeasurementError, match=r"measurement.wrench is not finite at t = 0.001 s"):
        ctl.step(0.001, fc.Measurement(q, np.zeros(2), np.array([np.nan, 0.0])), ref)
    np.testing.assert_array_equal(ctl.state, before)
    assert np.all(np.isfinite(ctl.step(0.002, fc.Measurement(q, np.zeros(2), np.zeros(2)), ref)))
    with pytest.raises(MeasurementError, match="measurement.wrench is not finite"):
        ctl.reset(fc.Measurement(q, np.zeros(2), np.array([np.inf, 0.0])), ref)
    ctl.reset(fc.Measurement(q, np.zeros(2), np.zeros(2)), ref)
    before = ctl.state.copy()
    with pytest.raises(ParameterError, match=r"reference.force is not finite at t = 0.003 s"):
        ctl.step(0.003, fc.Measurement(q, np.zeros(2), np.zeros(2)), fc.Reference.setpoint([1.0, 0.0], [np.nan, 0.0]))
    np.testing.assert_array_equal(ctl.state, before)  # a NaN reference leaves the integrator as it was


@pytest.mark.parametrize("odd", ["list", "int", "float32", "view", "column"])
def test_signals_of_another_type_give_the_same_torques_and_switch_the_controller_to_checking(odd):
    """The one-call path does not check the signals' types until Numba's dispatcher has refused one
    call: lists, integer, float32, strided or 2-D signals give the torques the float64 vectors
    give (the checked path), and the controller then checks before each call. Reference: a
    twin controller always fed float64 vectors."""
    ctl, twin = (fc.InnerPositionForceController(ARM, 100, 5000, 2500, 0.0024, 0.01) for _ in range(2))
    q = ARM.inverse_kinematics([1.0005, 0.05])
    ref = fc.Reference.setpoint([1.01, 0.1], [10.0, 0.0])
    wrench = np.array([5.0, 0.0])
    convert = {
        "list": lambda v: v.tolist(), "int": lambda v: np.rint(v).astype(np.int64), "float32": lambda v: v.astype(np.float32),
        "view": lambda v: np.repeat(v, 2)[::2], "column": lambda v: v.reshape(2, 1),
    }[odd]
    first = fc.Measurement(q, np.zeros(2), wrench)
    np.testing.assert_array_equal(ctl.step(0.0, first, ref), twin.step(0.0, first, ref))
    assert "_check_signals" not in ctl.__dict__  # float64 vectors: never checked in Python
    for k in range(1, 4):
        w = convert(wrench)
        if odd == "column":
            with pytest.raises(DimensionError, match=r"measurement.wrench must have shape \(2,\); got shape \(2, 1\)"):
                ctl.step(k * 1e-3, fc.Measurement(q, np.zeros(2), w), ref)
            continue
        want = twin.step(k * 1e-3, fc.Measurement(q, np.zeros(2), np.asarray(w, dtype=np.float64).copy()), ref)
        np.testing.assert_allclose(ctl.step(k * 1e-3, fc.Measurement(q, np.zeros(2), w), ref), want, rtol=1e-12)
        np.testing.assert_allclose(ctl.state, twin.state, rtol=1e-12)
    assert ctl.__dict__.get("_check_signals") is True
    np.testing.assert_allclose(ctl.step(0.005, first, ref), twin.step(0.005, first, ref), rtol=1e-12)
