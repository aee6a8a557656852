"""Direct force control laws (9.39)–(9.48) against torques built by hand; state, checks, warnings."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol import laws
from forcecontrol.controllers.base import pack_reference
from forcecontrol.errors import DimensionError, DriftWarning, ParameterError

ARM = fc.PlanarTwoLink()
RNG = np.random.default_rng(11)
Q0 = ARM.inverse_kinematics([1.0, 0.0], elbow="up")
M_D = np.array([[100.0, 4.0], [4.0, 90.0]])
K_D = np.diag([500.0, 450.0])
K_P = np.diag([2500.0, 2000.0])
K_F = np.array([0.00064, 0.0003])
K_I = np.array([0.0016, 0.0005])
TS = 1e-3


def _random_state():
    q = np.array([0.6, -1.5]) + 0.2 * RNG.standard_normal(2)
    return q, RNG.standard_normal(2), 30 * RNG.standard_normal(2)


def _random_reference():
    return fc.Reference(*(RNG.standard_normal(2) for _ in range(6)))


def _by_hand(q, qd, h, a):
    """u = B J⁻¹ (a − J̇ q̇) + n + Jᵀ h, the inner loop (9.30)."""
    J = ARM.jacobian(q)
    return ARM.mass_matrix(q) @ np.linalg.solve(J, a - ARM.jdot_qdot(q, qd)) + ARM.nonlinear_effects(q, qd) + J.T @ h


def _controllers():
    return {
        "inner-position": fc.InnerPositionForceController(ARM, M_D, K_D, K_P, K_F, K_I, sample_time=TS),
        "inner-velocity": fc.InnerVelocityForceController(ARM, M_D, K_D, K_P, K_F, sample_time=TS),
        "parallel": fc.ParallelForcePositionController(ARM, M_D, K_D, K_P, K_F, K_I, sample_time=TS),
    }


# ---------------------------------------------------------------------------- laws by hand


def test_inner_position_torque_is_9_30_9_39_9_43():
    """u = B J⁻¹ M_d⁻¹ (−K_D ẋ + K_P (x_F − x) − M_d J̇q̇) + n + Jᵀ h, x_F = K_F (f_d − f) + ξ, ξ ← ξ + Ts K_I (f_d − f)."""
    ctl = _controllers()["inner-position"]
    ctl.reset()
    xi = np.zeros(2)
    for k in range(4):  # one sample each: t advances (a repeated t is refused with integrators)
        q, qd, h = _random_state()
        ref = _random_reference()
        x, xd = ARM.forward_kinematics(q), ARM.jacobian(q) @ qd
        x_F = K_F * (ref.force - h) + xi
        want = _by_hand(q, qd, h, np.linalg.solve(M_D, -K_D @ xd + K_P @ (x_F - x)))
        got = ctl.step(k * TS, fc.Measurement(q, qd, h), ref)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
        xi = xi + TS * K_I * (ref.force - h)
        np.testing.assert_allclose(ctl.integral_action, xi, rtol=1e-12, atol=1e-15)


def test_inner_velocity_torque_is_9_30_9_45_9_46_with_jdot_qdot():
    """u = B J⁻¹ M_d⁻¹ (−K_D ẋ + K_P K_F (f_d − f) − M_d J̇q̇) + n + Jᵀ h (J̇q̇, not the printed J̈q̇)."""
    ctl = _controllers()["inner-velocity"]
    for _ in range(4):
        q, qd, h = _random_state()
        ref = _random_reference()
        xd = ARM.jacobian(q) @ qd
        want = _by_hand(q, qd, h, np.linalg.solve(M_D, -K_D @ xd + K_P @ (K_F * (ref.force - h))))
        np.testing.assert_allclose(ctl.step(0.0, fc.Measurement(q, qd, h), ref), want, rtol=1e-12, atol=1e-9)
    assert ctl.state.shape == (0,)


def test_parallel_torque_is_9_30_9_48():
    """u = B J⁻¹ M_d⁻¹ (−K_D ẋ + K_P (x_d − x + x_F) − M_d J̇q̇) + n + Jᵀ h with the PI x_F."""
    ctl = _controllers()["parallel"]
    ctl.reset()
    xi = np.zeros(2)
    for k in range(4):  # one sample each: t advances (a repeated t is refused with integrators)
        q, qd, h = _random_state()
        ref = _random_reference()
        x, xd = ARM.forward_kinematics(q), ARM.jacobian(q) @ qd
        x_F = K_F * (ref.force - h) + xi
        want = _by_hand(q, qd, h, np.linalg.solve(M_D, -K_D @ xd + K_P @ (ref.position - x + x_F)))
        np.testing.assert_allclose(ctl.step(k * TS, fc.Measurement(q, qd, h), ref), want, rtol=1e-12, atol=1e-9)
        xi = xi + TS * K_I * (ref.force - h)


@pytest.mark.parametrize("scheme", ["inner-position", "inner-velocity", "parallel"])
def test_compiled_law_on_the_arms_terms_equals_step(scheme):
    """The law called on the arm's terms (as the compiled loops do) gives step()'s torque and state update."""
    py, cp = _controllers()[scheme], _controllers()[scheme]
    assert py.compiled_law is not None and cp.law is type(cp).law
    py.reset()
    cp.reset()
    for k in range(3):
        q, qd, h = _random_state()
        ref = _random_reference()
        T = ARM.terms(q, qd)
        want = py.step(k * TS, fc.Measurement(q, qd, h), ref)
        got = np.empty(2)
        cp.law(k * TS, TS, q, qd, T.x, T.xd, T.J, T.Jdq, T.B, T.n, T.g, h, pack_reference(ref), cp._params,
               cp.state, np.empty(laws.workspace_size(2, 2)), got)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(cp.state, py.state, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("scheme", ["inner-position", "inner-velocity", "parallel"])
def test_python_and_compiled_engines_agree(scheme):
    """A 0.3 s contact run gives the same log with engine='python' and engine='compiled'."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4)
    ref = fc.Setpoint([1.015, 0.1], [10.0, 0.0])
    runs = [fc.simulate(ARM, env, _controllers()[scheme], ref, q0=Q0, duration=0.3, engine=e)
            for e in ("python", "compiled")]
    np.testing.assert_allclose(runs[0].wrench, runs[1].wrench, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(runs[0].q, runs[1].q, rtol=1e-10, atol=1e-12)


# ---------------------------------------------------------------------------- state


def test_inner_position_reset_puts_x_F_on_the_tip():
    """reset(measurement, reference): ξ₀ makes x_F(0) = K_F (f_d − f_e) + ξ₀ equal the tip on integral axes ("tip")."""
    ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0], integrator_start="tip")
    q = ARM.inverse_kinematics([1.0, 0.2])
    h = np.array([3.0, 0.0])
    ctl.reset(fc.Measurement(q, np.zeros(2), h), fc.Reference.setpoint([0.0, 0.0], [10.0, 0.0]))
    x_F = ctl.force_gain * (np.array([10.0, 0.0]) - h) + ctl.integral_action
    assert x_F[0] == pytest.approx(1.0, abs=1e-12)
    assert x_F[1] == 0.0  # no integral action along y: x_F,y = C_F,y (f_d − f_e) = 0, as in (9.41)


def test_inner_position_starts_at_rest_and_zero_start_pulls_away():
    """With the tip start, the first torque holds the arm still (a = 0); with ξ₀ = 0 it pulls it off the plane."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
    ref = fc.Setpoint([1.0, 0.0], [10.0, 0.0])
    tip = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0], integrator_start="tip")
    zero = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0], integrator_start="zero")
    r_tip = fc.simulate(ARM, env, tip, ref, q0=Q0, duration=0.2, engine="compiled")
    r_zero = fc.simulate(ARM, env, zero, ref, q0=Q0, duration=0.2, engine="compiled")
    np.testing.assert_allclose(r_tip.torque[0], ARM.gravity(Q0), rtol=1e-9)
    assert r_tip.x[-1, 0] >= 1.0  # pushes into the plane
    assert r_zero.x[-1, 0] < 0.95  # pulled away towards x_F ≈ 0


def test_parallel_reset_defaults_to_zero_and_tip_option_cancels_the_position_step():
    """Parallel: ξ₀ = 0 by default; integrator_start='tip' makes x_d + x_F(0) equal the tip."""
    meas = fc.Measurement(Q0, np.zeros(2), np.zeros(2))
    ref = fc.Reference.setpoint([1.015, 0.1], [10.0, 0.0])
    ctl = fc.ParallelForcePositionController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0])
    ctl.reset(meas, ref)
    np.testing.assert_array_equal(ctl.integral_action, 0.0)
    tip = fc.ParallelForcePositionController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0], integrator_start="tip")
    tip.reset(meas, ref)
    x_F = tip.force_gain * np.array([10.0, 0.0]) + tip.integral_action
    assert 1.015 + x_F[0] == pytest.approx(1.0, abs=1e-12)


def test_anti_windup_clamps_the_integral_action():
    """With integral_limit, |ξ − ξ₀| never exceeds the limit however long the force error persists."""
    ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0], integral_limit=0.002)
    meas = fc.Measurement(Q0, np.zeros(2), np.zeros(2))
    ref = fc.Reference.setpoint([0.0, 0.0], [1000.0, 0.0])
    ctl.reset(meas, ref)
    xi0 = ctl.integral_action
    for k in range(50):
        ctl.step(k * 1e-3, meas, ref)
    assert ctl.integral_action[0] - xi0[0] == pytest.approx(0.002, abs=1e-15)
    free = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0])
    free.reset(meas, ref)
    for k in range(50):
        free.step(k * 1e-3, meas, ref)
    assert free.integral_action[0] - xi0[0] == pytest.approx(50 * 1e-3 * 0.0016 * 1000.0, rel=1e-12)


def test_gains_report_the_parameters():
    """gains() lists the parameters by their public names (for metadata)."""
    g = _controllers()["inner-position"].gains()
    assert g["force_gain"] == K_F.tolist() and g["integral_gain"] == K_I.tolist()
    assert g["integrator_start"] == "hold"  # the default: the book's step response (issue 27)
    assert "integral_gain" not in _controllers()["inner-velocity"].gains()


# ---------------------------------------------------------------------------- free axes and drift


def test_zero_C_F_axis_behaves_as_the_chapter_says():
    """Free y axis, c_Fy = 0, tip starting at y = 0.2: inner position takes y to 0, inner velocity
    stops it (ẏ → 0, y stays), parallel takes it to y_d = 0.1 (remarks after (9.47) and (9.49))."""
    q0 = ARM.inverse_kinematics([1.0, 0.2])
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
    ref = fc.Setpoint([1.0, 0.1], [10.0, 0.0])
    kw = dict(inertia=100, damping=500, stiffness=2500)
    pos = fc.InnerPositionForceController(ARM, **kw, force_gain=[0.00064, 0], integral_gain=[0.0016, 0])
    vel = fc.InnerVelocityForceController(ARM, **kw, force_gain=[0.0024, 0])
    par = fc.ParallelForcePositionController(ARM, **kw, force_gain=[0.00064, 0], integral_gain=[0.0016, 0])
    y = {name: fc.simulate(ARM, env, c, ref, q0=q0, duration=4.0, engine="compiled").x[-1, 1]
         for name, c in (("pos", pos), ("vel", vel), ("par", par))}
    assert abs(y["pos"]) < 1e-3
    assert y["vel"] == pytest.approx(0.2, abs=1e-3)
    assert y["par"] == pytest.approx(0.1, abs=1e-3)


def test_force_reference_outside_range_of_K_warns_and_really_drifts():
    """f_d along the plane (outside R(K)) with C_F acting there: DriftWarning at reset, and y drifts.

    Along y, (9.47) with k = 0 is m ÿ + k_D ẏ = k_P k_F f_dy: a constant speed k_P k_F f_dy / k_D = 0.06 m/s.
    """
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
    ctl = fc.InnerVelocityForceController(ARM, 100, 500, 2500, [0.0024, 0.0024], environment_stiffness=env.stiffness_matrix())
    ref = fc.Setpoint([1.0, 0.0], [10.0, 5.0])
    with pytest.warns(DriftWarning, match="outside the range of the environment stiffness"):
        r = fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=1.0, engine="compiled")
    assert r.xd[-1, 1] == pytest.approx(2500 * 0.0024 * 5.0 / 500, rel=0.02)


def test_force_reference_on_a_zero_C_F_axis_warns_that_it_is_ignored():
    """f_d_y ≠ 0 while c_Fy = 0: DriftWarning that the component is ignored (even without K)."""
    ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0])
    with pytest.warns(DriftWarning, match="where C_F is zero: the scheme ignores"):
        ctl.reset(fc.Measurement(Q0, np.zeros(2), np.zeros(2)), fc.Reference.setpoint([1.0, 0.0], [10.0, 3.0]))


def test_consistent_force_reference_gives_no_warning():
    """f_d = [10, 0] on the plane x = 1 with C_F = diag(c, 0): consistent, no warning, returns True."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert fc.controllers.check_force_reference([10.0, 0.0], env.stiffness_matrix(), [True, False])
        ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0],
                                              environment_stiffness=env.stiffness_matrix())
        ctl.reset(fc.Measurement(Q0, np.zeros(2), np.zeros(2)), fc.Reference.setpoint([1.0, 0.0], [10.0, 0.0]))


# ---------------------------------------------------------------------------- bad inputs

BAD = [
    (dict(force_gain=[0.1, 0.2, 0.3]), DimensionError,
     r"force_gain must be a scalar, a \(2,\) vector or a diagonal \(2, 2\) matrix .*got shape \(3,\)"),
    (dict(force_gain=np.ones((3, 3))), DimensionError, r"force_gain must be .*got shape \(3, 3\)"),
    (dict(force_gain=[[1e-3, 1e-4], [0.0, 1e-3]]), ParameterError,
     r"force_gain must be diagonal \(C_F is a diagonal matrix, \(9.41\)\)"),
    (dict(force_gain=[-1e-3, 0.0]), ParameterError,
     r"force_gain must be non-negative on every axis \[m/N\]; got \[-0.001, 0.0\]"),
    (dict(integral_gain=[0.0016, -1.0]), ParameterError, r"integral_gain must be non-negative on every axis"),
    (dict(force_gain=0.0, integral_gain=0.0), ParameterError, r"C_F must act on at least one axis"),
    (dict(stiffness=[-2500, 2500]), ParameterError,
     r"stiffness must be a symmetric positive definite \(2, 2\) matrix; got eigenvalues"),
    (dict(damping=np.ones(3)), DimensionError,
     r"damping must be a symmetric positive definite \(2, 2\) matrix; got shape \(3,\)"),
    (dict(integral_limit=-0.1), ParameterError, r"integral_limit must be positive \[m\] \(inf or 0 on an axis = no clamping"),
    (dict(integral_limit=[float("nan"), 0.1]), ParameterError, r"integral_limit must be positive \[m\]"),
    (dict(integral_limit=[float("inf"), 0.0]), ParameterError, r"not on all axes\); got \[inf, 0.0\]"),
    (dict(integral_limit=[0.1, 0.1, 0.1]), DimensionError, r"integral_limit must be a scalar or have shape \(2,\)"),
    (dict(integrator_start="middle"), ParameterError, r"integrator_start must be 'tip', 'hold' or 'zero'; got 'middle'"),
    (dict(environment_stiffness=np.ones((3, 3))), DimensionError, r"environment_stiffness must be .*got shape \(3, 3\)"),
    (dict(sample_time=0.0), ParameterError, r"sample_time must be a positive number; got 0.0"),
]


@pytest.mark.parametrize("change, error, match", BAD)
def test_bad_parameters_are_rejected_with_clear_messages(change, error, match):
    """Each bad gain raises the library error naming the parameter, what was expected and what was given."""
    kw = dict(inertia=100, damping=500, stiffness=2500, force_gain=[0.00064, 0.0], integral_gain=[0.0016, 0.0])
    kw.update(change)
    with pytest.raises(error, match=match):
        fc.InnerPositionForceController(ARM, **kw)


def test_inner_velocity_loop_has_no_integral_gain_parameter():
    """C_F = K_F in (9.46): passing integral_gain to the inner velocity loop is a TypeError (unknown keyword)."""
    with pytest.raises(TypeError, match="integral_gain"):
        fc.InnerVelocityForceController(ARM, 100, 500, 2500, 0.0024, integral_gain=0.001)  # type: ignore[call-arg]


def test_check_force_reference_rejects_wrong_shapes():
    """force_axes of the wrong length is a DimensionError naming it."""
    with pytest.raises(DimensionError, match=r"force_axes must have shape \(2,\); got shape \(3,\)"):
        fc.controllers.check_force_reference([10.0, 0.0], np.eye(2), [True, False, True])


# ---------------------------------------------------------------------------- documentation


@pytest.mark.parametrize(
    "obj, equations",
    [
        (laws.inner_position_acceleration, ["(9.39)"]),
        (laws.inner_velocity_acceleration, ["(9.45)"]),
        (laws.parallel_acceleration, ["(9.48)"]),
        (laws.force.force_reference, ["(9.41)", "(9.43)"]),
        (fc.InnerPositionForceController, ["(9.39)", "(9.41)", "(9.43)"]),
        (fc.InnerVelocityForceController, ["(9.45)", "(9.46)"]),
        (fc.ParallelForcePositionController, ["(9.48)", "(9.43)"]),
    ],
)
def test_every_law_docstring_opens_with_its_equation_numbers(obj, equations):
    """The first docstring line names the law's equation numbers (the chapter's (9.x))."""
    first = obj.__doc__.strip().splitlines()[0]
    for eq in equations:
        assert eq in first


def test_anti_windup_can_clamp_one_axis_alone():
    """integral_limit = [0.002, inf]: x is clamped around ξ₀ while y integrates freely (9.43)."""
    ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.00064], [0.0016, 0.0016],
                                          integral_limit=[0.002, np.inf])
    q = ARM.inverse_kinematics([1.0, 0.0])
    ref = fc.Reference.setpoint([1.0, 0.0], force=[10.0, 10.0])
    meas = fc.Measurement(q, np.zeros(2), np.zeros(2))
    ctl.reset(meas, ref)
    xi0 = ctl.state[:2].copy()
    for k in range(2000):  # 2 s of a 10 N error on both axes
        ctl.step(k * 1e-3, meas, ref)
    assert abs(ctl.state[0] - xi0[0]) == pytest.approx(0.002, abs=1e-15)
    assert ctl.state[1] - xi0[1] == pytest.approx(2.0 * 0.0016 * 10.0, rel=1e-9)


def test_force_reference_check_refuses_nan_and_names_the_force_on_a_shape_mismatch():
    """check_force_reference: NaN f_d is an error, and a wrong-length f_d is blamed on the force."""
    from forcecontrol.controllers.force import check_force_reference

    with pytest.raises(ParameterError, match=r"force must be finite \[N\]; got \[nan, 0.0\]"):
        check_force_reference([np.nan, 0.0], np.diag([1e3, 0.0]), [True, False])
    msg = r"force must have shape \(2,\) like environment_stiffness \(2, 2\); got shape \(1,\)"
    with pytest.raises(DimensionError, match=msg):
        check_force_reference([10.0], np.diag([1e3, 0.0]), [True, False])


@pytest.mark.parametrize("scheme", ["inner-velocity", "inner-position", "parallel"])
def test_direct_force_control_on_a_redundant_arm(scheme):
    """A 7-joint Panda (3-D position task, 3×7 J) presses 10 N on a plane with the chapter's schemes.

    The inner loop goes through damped least squares with a null-space posture; the force settles
    to f_d with x_e from (9.44). Along the free axes (zero C_F) each scheme does what the chapter
    says: the inner velocity loop stops the tip where it is, the inner position loop takes it to
    x = 0 (remark after (9.47)), the parallel scheme to x_d (9.49).
    """
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers.redundant import NullSpacePosture
    from forcecontrol.robots.pinocchio import panda

    robot = panda(task="position")
    q0 = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])
    x0 = robot.forward_kinematics(q0)
    k_env, f_d = 5e3, np.array([0.0, 0.0, -10.0])  # pushing down on the plane z = z0
    plane = fc.ElasticPlane(x0, [0.0, 0.0, 1.0], k_env)
    motion = dict(inertia=10.0, damping=200.0, stiffness=1000.0)
    posture = NullSpacePosture(q0, stiffness=25.0, damping=10.0)
    pi = dict(force_gain=[0.0, 0.0, 2e-5], integral_gain=[0.0, 0.0, 4e-4], posture=posture)
    x_d = x0 + np.array([0.05, -0.03, 0.0])
    if scheme == "inner-velocity":  # ω_n = sqrt(k_P k_F k / m_d) = 10 rad/s, ζ = 1
        ctl = fc.InnerVelocityForceController(robot, **motion, force_gain=[0.0, 0.0, 2e-4], posture=posture)
        free_xy = x0[:2]
    elif scheme == "inner-position":
        ctl = fc.InnerPositionForceController(robot, **motion, **pi)
        free_xy = np.zeros(2)
    else:
        ctl = fc.ParallelForcePositionController(robot, **motion, **pi)
        free_xy = x_d[:2]
    r = fc.simulate(robot, plane, ctl, fc.Setpoint(x_d, force=f_d), q0=q0, duration=4.0)
    assert r.settled("wrench")[2] == pytest.approx(-10.0, rel=5e-3)
    assert r.settled("x")[2] == pytest.approx(x0[2] - 10.0 / k_env, abs=5e-5)  # (9.44)
    np.testing.assert_allclose(r.settled("x")[:2], free_xy, atol=1e-3)


def test_bad_posture_and_singularity_options_are_refused():
    """posture and singularity must be the library's types, and the posture must have one entry per joint."""
    from forcecontrol.controllers.redundant import NullSpacePosture

    gains = dict(inertia=100, damping=500, stiffness=2500, force_gain=[0.0024, 0.0])
    with pytest.raises(ParameterError, match="posture must be a NullSpacePosture or None; got list"):
        fc.InnerVelocityForceController(ARM, **gains, posture=[0.1, 0.2])
    with pytest.raises(ParameterError, match="singularity must be a SingularityHandling or None; got float"):
        fc.InnerVelocityForceController(ARM, **gains, singularity=0.05)
    with pytest.raises(DimensionError, match=r"posture.posture must have shape \(2,\); got shape \(3,\)"):
        fc.InnerVelocityForceController(ARM, **gains, posture=NullSpacePosture([0.0, 0.0, 0.0]))
