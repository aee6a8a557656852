"""The chapter's two-link arm in closed form against its data, finite differences and physics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import forcecontrol as fc
from forcecontrol.errors import DimensionError, ParameterError, WorkspaceError

angles = st.floats(-math.pi, math.pi, allow_nan=False)
speeds = st.floats(-3.0, 3.0, allow_nan=False)
state = st.tuples(angles, angles, speeds, speeds).map(lambda v: (np.array(v[:2]), np.array(v[2:])))

ARM = fc.PlanarTwoLink()


def test_mass_matrix_matches_the_reference_numbers():
    """B(q) equals b11 = 200.01 + 50 c2, b12 = 23.5 + 25 c2, b22 = 122.5 of two-link-arm.md."""
    for q2 in (-2.0, 0.0, 0.7, math.pi):
        c2 = math.cos(q2)
        B = ARM.mass_matrix([0.3, q2])
        np.testing.assert_allclose(B, [[200.01 + 50 * c2, 23.5 + 25 * c2], [23.5 + 25 * c2, 122.5]], rtol=0, atol=1e-12)


def test_gravity_matches_the_reference_numbers():
    """g1 = 9.81 (80 c1 + 25 c12), g2 = 9.81 · 25 c12."""
    q = np.array([0.4, -1.1])
    c1, c12 = math.cos(q[0]), math.cos(q.sum())
    np.testing.assert_allclose(ARM.gravity(q), [9.81 * (80 * c1 + 25 * c12), 9.81 * 25 * c12], atol=1e-12)


def test_friction_is_diag_100():
    """F = K_r F_m K_r = diag(100, 100) N m s/rad."""
    np.testing.assert_array_equal(ARM.friction_matrix(), np.diag([100.0, 100.0]))


@settings(max_examples=60, deadline=None)
@given(state)
def test_mass_matrix_is_symmetric_positive_definite(s):
    """B(q) is symmetric positive definite for all q."""
    B = ARM.mass_matrix(s[0])
    np.testing.assert_allclose(B, B.T, atol=0)
    assert np.linalg.eigvalsh(B).min() > 0


@settings(max_examples=60, deadline=None)
@given(state)
def test_bdot_minus_2c_is_skew_symmetric(s):
    """Ḃ − 2C is skew-symmetric (Ḃ by central differences along q̇)."""
    q, qd = s
    eps = 1e-6
    Bdot = (ARM.mass_matrix(q + eps * qd) - ARM.mass_matrix(q - eps * qd)) / (2 * eps)
    N = Bdot - 2 * ARM.coriolis_matrix(q, qd)
    np.testing.assert_allclose(N + N.T, 0, atol=1e-6)


@settings(max_examples=60, deadline=None)
@given(state)
def test_gravity_is_the_gradient_of_the_potential(s):
    """g(q) = ∂U/∂q (central differences)."""
    q = s[0]
    eps = 1e-6
    fd = [(ARM.potential_energy(q + eps * e) - ARM.potential_energy(q - eps * e)) / (2 * eps) for e in np.eye(2)]
    np.testing.assert_allclose(ARM.gravity(q), fd, atol=1e-5)


@settings(max_examples=60, deadline=None)
@given(state)
def test_jacobian_matches_finite_differences(s):
    """J(q) = ∂p/∂q (central differences of the forward kinematics)."""
    q = s[0]
    eps = 1e-7
    fd = np.column_stack(
        [(ARM.forward_kinematics(q + eps * e) - ARM.forward_kinematics(q - eps * e)) / (2 * eps) for e in np.eye(2)]
    )
    np.testing.assert_allclose(ARM.jacobian(q), fd, atol=1e-7)


@settings(max_examples=60, deadline=None)
@given(state)
def test_jdot_qdot_matches_finite_differences(s):
    """J̇q̇ = d/dt(J(q(t))) q̇ along q(t) = q + t q̇ (central differences)."""
    q, qd = s
    eps = 1e-6
    fd = (ARM.jacobian(q + eps * qd) - ARM.jacobian(q - eps * qd)) / (2 * eps) @ qd
    np.testing.assert_allclose(ARM.jdot_qdot(q, qd), fd, atol=1e-6)


@settings(max_examples=60, deadline=None)
@given(state)
def test_nonlinear_effects_are_c_qdot_plus_f_qdot_plus_g(s):
    """n(q, q̇) = C q̇ + F q̇ + g (8.56), assembled from the separate terms."""
    q, qd = s
    want = ARM.coriolis_matrix(q, qd) @ qd + ARM.friction_matrix() @ qd + ARM.gravity(q)
    np.testing.assert_allclose(ARM.nonlinear_effects(q, qd), want, atol=1e-10)


def test_inverse_kinematics_gives_the_chapter_start_posture(q_contact):
    """IK of [1, 0] elbow up is [π/3, −2π/3] (two-link-arm.md)."""
    np.testing.assert_allclose(ARM.inverse_kinematics([1.0, 0.0], elbow="up"), q_contact, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.floats(0.1, 1.95), st.floats(-math.pi, math.pi), st.sampled_from(["up", "down"]))
def test_inverse_kinematics_round_trips(r, phi, elbow):
    """FK(IK(p)) = p for reachable p, and the elbow choice sets the sign of q2."""
    p = np.array([r * math.cos(phi), r * math.sin(phi)])
    q = ARM.inverse_kinematics(p, elbow=elbow)
    np.testing.assert_allclose(ARM.forward_kinematics(q), p, atol=1e-9)
    assert (q[1] <= 1e-12) if elbow == "up" else (q[1] >= -1e-12)


def test_energy_is_conserved_without_friction_and_gravity():
    """Free motion with F = 0, g = 0 conserves ½ q̇ᵀ B q̇ (plant integration check)."""
    arm = fc.PlanarTwoLink(fc.PlanarTwoLinkParameters(F1=0.0, F2=0.0, gravity=0.0))

    class Zero(fc.Controller):
        uses_force = False

        def step(self, t, measurement, reference):
            return np.zeros(2)

    env = fc.LinearSpring(np.zeros((2, 2)), [0.0, 0.0])
    res = fc.simulate(arm, env, Zero(arm), fc.Setpoint([0.0, 0.0]), q0=[0.3, 1.0], qd0=[1.5, -2.0], duration=2.0)
    E = [0.5 * qd @ arm.mass_matrix(q) @ qd for q, qd in zip(res.q, res.qd)]
    assert np.ptp(E) / E[0] < 1e-8


def test_gravity_work_is_accounted_for():
    """Without friction, kinetic plus potential energy is conserved under gravity."""
    arm = fc.PlanarTwoLink(fc.PlanarTwoLinkParameters(F1=0.0, F2=0.0))

    class Zero(fc.Controller):
        uses_force = False

        def step(self, t, measurement, reference):
            return np.zeros(2)

    env = fc.LinearSpring(np.zeros((2, 2)), [0.0, 0.0])
    res = fc.simulate(arm, env, Zero(arm), fc.Setpoint([0.0, 0.0]), q0=[0.3, 1.0], duration=2.0, substeps=4)
    E = [0.5 * qd @ arm.mass_matrix(q) @ qd + arm.potential_energy(q) for q, qd in zip(res.q, res.qd)]
    assert np.ptp(E) < 1e-6 * max(abs(e) for e in E)


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: ARM.inverse_kinematics([3.0, 0.0]), WorkspaceError, r"outside the workspace.*\[0, 2\] m"),
        (lambda: ARM.inverse_kinematics([1.0, 0.0], elbow="left"), WorkspaceError, "elbow must be 'up' or 'down'"),
        (lambda: ARM.mass_matrix([1.0, 2.0, 3.0]), DimensionError, r"q must have shape \(2,\); got shape \(3,\)"),
        (lambda: fc.PlanarTwoLinkParameters(a1=-1.0), ParameterError, "a1 must be a positive number"),
        (lambda: fc.PlanarTwoLinkParameters(F1=float("nan")), ParameterError, "F1 must be a non-negative number"),
    ],
)
def test_bad_inputs_raise_clear_errors(call, exc, match):
    """Bad arm inputs raise the library's errors naming parameter, expectation and value."""
    with pytest.raises(exc, match=match):
        call()


def test_the_python_closed_forms_equal_the_compiled_terms_to_the_bit():
    """x, J, J̇q̇, B, g, n and (x, ẋ), written in plain Python for single calls, equal the compiled terms() and the compiled
    loops' _pose_twist bit for bit on 20,000 random states (the Python and compiled engines start from the same numbers)."""
    from forcecontrol.robots.planar_2r import _pose_twist, _terms

    rng = np.random.default_rng(11)
    for _ in range(20_000):
        q, qd = rng.uniform(-7.0, 7.0, 2), rng.normal(scale=5.0, size=2)
        x, xd, J, Jdq, B, nv, g = _terms(q, qd, ARM._K)
        pose_twist = np.concatenate(ARM.pose_twist(q, qd))
        for got, want in ((ARM.forward_kinematics(q), x), (ARM.jacobian(q), J), (ARM.jdot_qdot(q, qd), Jdq),
                          (ARM.mass_matrix(q), B), (ARM.gravity(q), g), (ARM.nonlinear_effects(q, qd), nv),
                          (pose_twist, np.array(_pose_twist(q, qd, ARM._K))), (pose_twist, np.concatenate([x, xd]))):
            assert np.array_equal(got, want), (q, qd, got, want)
