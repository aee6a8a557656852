"""6-D pose error on the desired frame, frame-tagged wrenches, 6-D environments, spatial compliance and impedance on the Panda."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from forcecontrol.controllers.base import Measurement, Reference
from forcecontrol.errors import DimensionError, FrameError, ParameterError, SingularityError
from forcecontrol.spatial import (
    Transform,
    Twist,
    Wrench,
    analytical_jacobian_desired,
    b_vector,
    error_rate,
    euler_xyz_T,
    euler_xyz_T_dot,
    euler_xyz_T_inv,
    euler_xyz_to_rotation,
    pose_error,
    rotation_to_euler_xyz,
    rotation_vector,
    rotvec_T,
    rotvec_to_rotation,
)

pin = pytest.importorskip("pinocchio")

from forcecontrol.controllers.redundant import NullSpacePosture, SingularityHandling, redundant_acceleration  # noqa: E402
from forcecontrol.controllers.spatial import (  # noqa: E402
    SpatialComplianceController,
    SpatialImpedanceController,
    desired_frame_error,
)
from forcecontrol.environments.spatial import ConstantWrench, SpatialSpring, Table  # noqa: E402
from forcecontrol.robots.pinocchio import PANDA_READY, panda  # noqa: E402
from forcecontrol.sim.simulation import simulate  # noqa: E402
from forcecontrol.trajectories import Setpoint  # noqa: E402

RNG = np.random.default_rng(7)


@pytest.fixture(scope="module")
def franka():
    return panda()


def _pose(robot, q):
    R, p = robot.frame_pose(q)
    return np.concatenate([p, rotation_to_euler_xyz(R)])


# ------------------------------------------------------------------ Euler angles and T


def test_euler_roundtrip_and_T_at_zero_is_identity():
    """R(φ) → φ recovers φ away from cos φ₂ = 0, and T(0) = I (Problem 3.13)."""
    for _ in range(50):
        phi = RNG.uniform([-3, -1.5, -3], [3, 1.5, 3])
        assert np.allclose(rotation_to_euler_xyz(euler_xyz_to_rotation(phi)), phi, atol=1e-10)
    assert np.array_equal(euler_xyz_T(np.zeros(3)), np.eye(3))


def test_T_maps_euler_rates_to_angular_velocity_by_finite_differences():
    """ω from S(ω) = Ṙ Rᵀ (central differences) equals T(φ) φ̇; T⁻¹ and Ṫ match too."""
    h = 1e-6
    for _ in range(10):
        phi, phid = RNG.uniform(-1.2, 1.2, 3), RNG.normal(size=3)
        dR = (euler_xyz_to_rotation(phi + h * phid) - euler_xyz_to_rotation(phi - h * phid)) / (2 * h)
        W = dR @ euler_xyz_to_rotation(phi).T
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        assert np.allclose(w, euler_xyz_T(phi) @ phid, atol=1e-7)
        assert np.allclose(euler_xyz_T_inv(phi) @ euler_xyz_T(phi), np.eye(3), atol=1e-12)
        Td = (euler_xyz_T(phi + h * phid) - euler_xyz_T(phi - h * phid)) / (2 * h)
        assert np.allclose(euler_xyz_T_dot(phi, phid), Td, atol=1e-7)


def test_rotation_vector_roundtrip_and_its_T_by_finite_differences():
    """exp/log roundtrip and ω = T(θ) θ̇ for the rotation vector (the axis-angle alternative)."""
    h = 1e-6
    for _ in range(10):
        th, thd = RNG.uniform(-1.5, 1.5, 3), RNG.normal(size=3)
        assert np.allclose(rotation_vector(rotvec_to_rotation(th)), th, atol=1e-9)
        W = (rotvec_to_rotation(th + h * thd) - rotvec_to_rotation(th - h * thd)) / (2 * h) @ rotvec_to_rotation(th).T
        assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], rotvec_T(th) @ thd, atol=1e-7)


def test_euler_extraction_at_representation_singularity_is_an_error():
    """A relative rotation with pitch 90° raises SingularityError (strict) naming the alternative."""
    R = euler_xyz_to_rotation([0.3, math.pi / 2, 0.2])
    with pytest.raises(SingularityError, match="representation singularity.*rotvec"):
        rotation_to_euler_xyz(R, strict=True)
    with pytest.raises(SingularityError, match="representation singularity"):
        pose_error(np.zeros(3), np.eye(3), np.zeros(3), R)


# ------------------------------------------------------------------ error on the desired frame (9.9)-(9.14), (9.33)


def _moving_desired(t):
    """A desired frame moving with a known analytic pose, twist and acceleration."""
    phi = np.array([0.2 + 0.3 * t, -0.1 + 0.2 * t * t, 0.4 - 0.5 * t])
    phid = np.array([0.3, 0.4 * t, -0.5])
    phidd = np.array([0.0, 0.4, 0.0])
    o = np.array([0.4 + 0.1 * t, 0.1 * math.sin(t), 0.5 + 0.05 * t * t])
    od = np.array([0.1, 0.1 * math.cos(t), 0.1 * t])
    odd = np.array([0.0, -0.1 * math.sin(t), 0.1])
    w = euler_xyz_T(phi) @ phid
    wd = euler_xyz_T_dot(phi, phid) @ phid + euler_xyz_T(phi) @ phidd
    z = np.zeros(6)
    return Reference(np.concatenate([o, phi]), np.concatenate([od, w]), np.concatenate([odd, wd]), z, z, z)


def test_error_rate_and_acceleration_bias_against_finite_differences(franka):
    """x̃̇ = −J_Ad q̇ + b (9.33, corrected b) and x̃̈ = −J_Ad q̈ + c (9.34) match differences of x̃ along a motion."""
    q0 = PANDA_READY + RNG.normal(0, 0.1, 7)
    qd0, qdd = RNG.normal(0, 0.5, 7), RNG.normal(0, 1.0, 7)
    t0, h = 0.3, 1e-4

    def err(t):
        q = q0 + qd0 * (t - t0) + 0.5 * qdd * (t - t0) ** 2
        qd = qd0 + qdd * (t - t0)
        R_e, o_e, J, Jdq, *_ = franka.spatial_terms(q, qd)
        return desired_frame_error(R_e, o_e, J.copy(), Jdq.copy(), qd, _moving_desired(t))

    e0, ep, em = err(t0), err(t0 + h), err(t0 - h)
    assert np.allclose((ep.x - em.x) / (2 * h), e0.xd, atol=1e-6)
    assert np.allclose((ep.xd - em.xd) / (2 * h), -e0.JAd @ qdd + e0.c, atol=1e-5)
    # the chapter's pieces: J_Ad (9.14) and b (9.33) give the same x̃̇
    ref = _moving_desired(t0)
    R_d = euler_xyz_to_rotation(ref.position[3:])
    R_e, o_e, J, *_ = franka.spatial_terms(q0, qd0)
    JAd = analytical_jacobian_desired(J, R_d, -e0.x[3:])
    assert np.allclose(JAd, e0.JAd, atol=1e-12)
    b = b_vector(e0.x, R_d, ref.velocity[:3], ref.velocity[3:])
    assert np.allclose(-JAd @ qd0 + b, e0.xd, atol=1e-12)
    assert np.allclose(error_rate(e0.x, R_d, J @ qd0, ref.velocity), e0.xd, atol=1e-12)
    assert np.allclose(pose_error(ref.position[:3], R_d, o_e, R_e), e0.x, atol=1e-12)


def test_rotvec_error_rate_against_finite_differences(franka):
    """With orientation='rotvec' the same x̃̇ and x̃̈ identities hold (Ṫ by a directional difference)."""
    q0, qd0, qdd = PANDA_READY.copy(), RNG.normal(0, 0.5, 7), RNG.normal(0, 1.0, 7)
    t0, h = 0.2, 1e-4

    def err(t):
        q = q0 + qd0 * (t - t0) + 0.5 * qdd * (t - t0) ** 2
        qd = qd0 + qdd * (t - t0)
        R_e, o_e, J, Jdq, *_ = franka.spatial_terms(q, qd)
        return desired_frame_error(R_e, o_e, J.copy(), Jdq.copy(), qd, _moving_desired(t), "rotvec")

    e0, ep, em = err(t0), err(t0 + h), err(t0 - h)
    assert np.allclose((ep.x - em.x) / (2 * h), e0.xd, atol=1e-6)
    assert np.allclose((ep.xd - em.xd) / (2 * h), -e0.JAd @ qdd + e0.c, atol=1e-4)


# ------------------------------------------------------------------ frames


def test_wrench_and_twist_transformations_preserve_power():
    """Changing frame (one call) keeps hᵀv, and X then X⁻¹ gives back the wrench."""
    X = Transform(euler_xyz_to_rotation([0.3, -0.2, 1.0]), [0.1, -0.4, 0.7], parent="world", child="tool")
    w = Wrench([1.0, 2.0, -3.0], [0.5, -0.1, 0.2], frame="tool", point="tool")
    v = Twist([0.2, -0.1, 0.3], [1.0, 0.4, -0.6], frame="tool", point="tool")
    w0, v0 = w.transformed(X), v.transformed(X)
    assert (w0.frame, w0.point) == ("world", "world")
    assert math.isclose(v0.power(w0), v.power(w), rel_tol=1e-12)
    back = w0.transformed(X.inverse())
    assert np.allclose(back.vector, w.vector)
    # shifting the point: moment about the new point
    s = w.rotated(X).shifted("p", [0.0, 0.0, 1.0])
    assert np.allclose(s.moment, X.rotation @ w.moment - np.cross([0, 0, 1.0], X.rotation @ w.force))


def _w(frame, point):
    return Wrench([1, 0, 0], [0, 0, 0], frame, point)


@pytest.mark.parametrize(
    ("action", "match"),
    [
        (lambda: _w("tool", "tool") + _w("world", "tool"), "different frames"),
        (lambda: _w("world", "world") - _w("world", "tool"), "different frames"),
        (lambda: _w("world", "world").transformed(Transform(np.eye(3), [0, 0, 0], "world", "tool")), "needs a wrench in 'tool'"),
        (lambda: Twist([1, 0, 0], [0, 0, 0], "a", "a") + Twist([1, 0, 0], [0, 0, 0], "b", "b"), "different frames"),
        (lambda: Twist([1, 0, 0], [0, 0, 0], "a", "a").power(Wrench([1, 0, 0], [0, 0, 0], "b", "b")), "same frame"),
        (lambda: Transform(np.eye(3), [0, 0, 0], "a", "b") @ Transform(np.eye(3), [0, 0, 0], "c", "d"), "cannot compose"),
        (lambda: Wrench([1, 0, 0], [0, 0, 0], "tool", "tool").require("world", "tool"), "must be expressed in frame 'world'"),
    ],
)
def test_mixing_frames_raises_frame_error(action, match):
    """Adding, transforming, composing or reading wrenches/twists in the wrong frame raises FrameError."""
    with pytest.raises(FrameError, match=match):
        action()


def test_transform_rejects_non_rotation():
    """A rotation that is not orthonormal is a ParameterError."""
    with pytest.raises(ParameterError, match="rotation must be a rotation matrix"):
        Transform(np.diag([1.0, 2.0, 1.0]), [0, 0, 0])


# ------------------------------------------------------------------ 6-D environments


def test_spatial_spring_rejects_non_symmetric_or_indefinite_stiffness():
    """The 6×6 stiffness must be symmetric PSD: asymmetric, indefinite and wrong-shape inputs raise."""
    K = np.eye(6)
    K[0, 3] = 1.0
    with pytest.raises(ParameterError, match="stiffness must be a symmetric positive semi-definite .*non-symmetric"):
        SpatialSpring(K, [0, 0, 0])
    with pytest.raises(ParameterError, match="stiffness must be a symmetric positive semi-definite .*eigenvalues"):
        SpatialSpring(np.diag([1, 1, 1, 1, 1, -1.0]), [0, 0, 0])
    with pytest.raises(DimensionError, match=r"\(6, 6\)"):
        SpatialSpring(np.eye(3), [0, 0, 0])


def test_spatial_spring_with_coupling_blocks_is_K_dx_in_the_rest_frame():
    """h_e = K dx for a small displacement given in the rest frame, coupling blocks included, rotated to the base."""
    A = RNG.normal(size=(6, 6))
    K = A @ A.T * 100.0
    R_r = euler_xyz_to_rotation([0.1, 0.2, -0.3])
    env = SpatialSpring(K, [0.5, 0.0, 0.3], R_r)
    d_r = np.array([1e-3, -2e-3, 5e-4, 1e-3, 2e-3, -1e-3])  # displacement in the rest frame
    o = env.rest_position + R_r @ d_r[:3]
    R_e = rotvec_to_rotation(R_r @ d_r[3:]) @ R_r
    h = env.wrench(np.concatenate([o, rotation_to_euler_xyz(R_e)]), np.zeros(6))
    X = np.zeros((6, 6))
    X[:3, :3] = X[3:, 3:] = R_r
    assert np.allclose(h, X @ K @ d_r, rtol=1e-9, atol=1e-9)


def test_table_pushes_back_along_its_normal_and_never_pulls():
    """Penetration δ gives f = k δ along +ν with zero moment; above the table nothing."""
    t = Table([0, 0, 0.1], [0, 0, 1], stiffness=1e4)
    assert np.allclose(t.wrench(np.array([0.3, 0.1, 0.098, 0, 0, 0]), np.zeros(6)), [0, 0, -20.0, 0, 0, 0])
    assert np.allclose(t.wrench(np.array([0.3, 0.1, 0.2, 0, 0, 0]), np.zeros(6)), 0)


# ------------------------------------------------------------------ controllers on the Panda


MD = np.diag([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
KP = np.diag([400.0, 400.0, 400.0, 10.0, 10.0, 10.0])
KD = np.diag(2 * 0.7 * np.sqrt(np.diag(MD) * np.diag(KP)))


def _impedance_run(robot, q0, h, duration=0.8):
    x0 = _pose(robot, q0)
    c = SpatialImpedanceController(robot, MD, KD, KP, posture=q0)
    res = simulate(robot, ConstantWrench(h), c, Setpoint(x0), q0=q0, duration=duration, substeps=1)
    R_d = euler_xyz_to_rotation(x0[3:])
    xt = np.array([pose_error(x0[:3], R_d, x[:3], euler_xyz_to_rotation(x[3:])) for x in res.x])
    h_d = np.concatenate([R_d.T @ h[:3], R_d.T @ h[3:]])
    return res.t, xt, h_d


def _second_order(t, i, h_d):
    _, y = signal.step(signal.lti([1.0], [MD[i, i], KD[i, i], KP[i, i]]), T=t)
    return h_d[i] * y


def test_panda_impedance_step_matches_second_order_response(franka):
    """(9.36): after a step of external wrench the pose error on the desired frame follows M_d s² + K_D s + K_P within 2%."""
    h = np.array([6.0, -4.0, 5.0, 0.3, -0.2, 0.25])
    t, xt, h_d = _impedance_run(franka, PANDA_READY, h)
    for i in range(6):
        y = _second_order(t, i, h_d)
        assert np.max(np.abs(xt[:, i] - y)) <= 0.02 * np.max(np.abs(y)), i


def test_orientation_compliance_is_the_same_at_two_postures(franka):
    """A moment step gives the same orientation response (on the desired frame) at two different postures."""
    h = np.array([0.0, 0.0, 0.0, 0.2, -0.15, 0.1])
    q_b = np.array([0.5, -0.3, -0.4, -1.9, 0.6, 2.1, -0.3])
    runs = [_impedance_run(franka, q, h, duration=0.6) for q in (PANDA_READY, q_b)]
    for t, xt, h_d in runs:
        for i in (3, 4, 5):
            y = _second_order(t, i, h_d)
            assert np.max(np.abs(xt[:, i] - y)) <= 0.02 * np.max(np.abs(y)), i
    # on the desired frame the moment is the same vector only if the frames coincide: compare compliance
    (t, xa, ha), (_, xb, hb) = runs
    assert np.allclose(xa[-1, 3:] / ha[3:], xb[-1, 3:] / hb[3:], rtol=0.02)


def test_impedance_with_wrench_object_in_wrong_frame_is_frame_error(franka):
    """A measured Wrench expressed in the tool frame (not the base) is refused with FrameError."""
    c = SpatialImpedanceController(franka, MD, KD, KP)
    x0 = _pose(franka, PANDA_READY)
    bad = Wrench([1, 0, 0], [0, 0, 0], frame="panda_hand_tcp", point="panda_hand_tcp")
    with pytest.raises(FrameError, match="must be expressed in frame 'world'"):
        c.step(0.0, Measurement(PANDA_READY, np.zeros(7), bad), Reference.setpoint(x0))
    good = Wrench([1, 0, 0], [0, 0, 0], frame="world", point="panda_hand_tcp")
    assert np.all(np.isfinite(c.step(0.0, Measurement(PANDA_READY, np.zeros(7), good), Reference.setpoint(x0))))


def test_desired_pose_at_representation_singularity_is_error(franka):
    """A desired frame whose relative rotation to the end-effector has pitch 90° raises SingularityError; rotvec copes."""
    R_e, o_e = franka.frame_pose(PANDA_READY)
    R_d = R_e @ euler_xyz_to_rotation([0.0, math.pi / 2, 0.0]).T
    ref = Reference.setpoint(np.concatenate([o_e, rotation_to_euler_xyz(R_d)]))
    c = SpatialImpedanceController(franka, MD, KD, KP)
    with pytest.raises(SingularityError, match="representation singularity.*rotvec"):
        c.step(0.0, Measurement(PANDA_READY, np.zeros(7), np.zeros(6)), ref)
    c2 = SpatialImpedanceController(franka, MD, KD, KP, orientation="rotvec")
    assert np.all(np.isfinite(c2.step(0.0, Measurement(PANDA_READY, np.zeros(7), np.zeros(6)), ref)))


def test_hand_built_impedance_torque(franka):
    """The controller's torque equals B y + n + Jᵀh built by hand from (9.35) with pinv and the posture term."""
    rng = np.random.default_rng(11)
    q, qd, h = PANDA_READY + rng.normal(0, 0.1, 7), rng.normal(0, 0.3, 7), rng.normal(0, 3, 6)
    x0 = _pose(franka, PANDA_READY) + np.array([0.01, -0.02, 0.01, 0.05, -0.03, 0.02])
    post = NullSpacePosture(PANDA_READY, 25.0, 10.0)
    c = SpatialImpedanceController(franka, MD, KD, KP, posture=post)
    u = c.step(0.0, Measurement(q, qd, h), Reference.setpoint(x0))
    R_e, o_e, J, Jdq, B, nv, g = franka.spatial_terms(q, qd)
    J, Jdq, B, nv = J.copy(), Jdq.copy(), B.copy(), nv.copy()
    R_d = euler_xyz_to_rotation(x0[3:])
    xt = pose_error(x0[:3], R_d, o_e, R_e)
    JAd = analytical_jacobian_desired(J, R_d, -xt[3:])
    xtd = -JAd @ qd
    # constant desired frame: c = −J̇_Ad q̇, by a finite difference of J_Ad along q̇
    eps = 1e-7
    def JAd_at(qq):
        Re, oe = franka.frame_pose(qq)
        return analytical_jacobian_desired(franka.spatial_jacobian(qq), R_d, -pose_error(x0[:3], R_d, oe, Re)[3:])
    JAd_dot_qd = (JAd_at(q + eps * qd) - JAd_at(q - eps * qd)) @ qd / (2 * eps)
    h_d = np.concatenate([R_d.T @ h[:3], R_d.T @ h[3:]])
    r = -JAd_dot_qd - np.linalg.solve(MD, h_d - KD @ xtd - KP @ xt)
    Jp = np.linalg.pinv(JAd)
    y0 = post.acceleration(q, qd)
    y = Jp @ r + (np.eye(7) - Jp @ JAd) @ y0
    assert np.allclose(u, B @ y + nv + J.T @ h, rtol=1e-6, atol=1e-6)


def test_dls_keeps_torques_bounded_at_a_singularity(franka):
    """At a singular posture (rank 5) the exact inverse explodes while damped least squares stays bounded."""
    q = np.array([0.0, 1e-7, 0.0, 0.0, 0.0, 0.0, 0.0])  # axes 1 and 3 aligned, arm stretched: rank 5
    R_e, o_e, J, *_ = franka.spatial_terms(q, np.zeros(7))
    assert np.linalg.svd(J, compute_uv=False)[-1] < 1e-6
    r = np.array([0.5, -0.4, 0.3, 0.2, -0.1, 0.3])
    y_exact, _ = redundant_acceleration(J.copy(), r, None, 0.05, 0.0)
    y_dls, lam2 = redundant_acceleration(J.copy(), r, None, 0.05, 0.05)
    assert lam2 > 0
    assert np.linalg.norm(y_dls) < 1e3 < np.linalg.norm(y_exact)


def test_task_met_exactly_away_from_singularities_and_posture_only_in_null_space(franka):
    """Away from singularities J y = r exactly (λ = 0), and adding a posture does not change J y."""
    R_e, o_e, J, *_ = franka.spatial_terms(PANDA_READY, np.zeros(7))
    r = RNG.normal(size=6)
    y1, lam2 = redundant_acceleration(J.copy(), r, None, 0.05, 0.05)
    y2, _ = redundant_acceleration(J.copy(), r, RNG.normal(size=7), 0.05, 0.05)
    assert lam2 == 0.0
    assert np.allclose(J @ y1, r, atol=1e-10) and np.allclose(J @ y2, r, atol=1e-10)
    assert not np.allclose(y1, y2)


def test_compliance_6d_equilibrium_matches_9_22_and_9_23(franka):
    """(9.15) against a 6-D spring: the force and pose error at equilibrium are (9.22)–(9.23) for a small dx_{r,d}."""
    x0 = _pose(franka, PANDA_READY)
    R0 = euler_xyz_to_rotation(x0[3:])
    K_P = np.diag([1000.0, 1000.0, 1000.0, 30.0, 30.0, 30.0])
    K_D = np.diag([100.0, 100.0, 100.0, 2.0, 2.0, 2.0])
    K = np.diag([3000.0, 0.0, 2000.0, 0.0, 20.0, 0.0])  # PSD: force along x, z and moment about y (rest frame)
    # rest frame = end-effector frame at q0; desired frame moved by dx_{r,d} (small, rest-frame axes)
    dx_rd = np.array([0.004, 0.003, -0.005, 0.0, 0.02, 0.01])
    env = SpatialSpring(K, x0[:3], R0)
    o_d = x0[:3] + R0 @ dx_rd[:3]
    R_d = R0 @ rotvec_to_rotation(dx_rd[3:])
    ref = Setpoint(np.concatenate([o_d, rotation_to_euler_xyz(R_d)]))
    c = SpatialComplianceController(franka, K_P, K_D, posture=NullSpacePosture(PANDA_READY, 10.0, 5.0))
    res = simulate(franka, env, c, ref, q0=PANDA_READY, duration=3.0, substeps=1)
    h_expected = np.linalg.solve(np.eye(6) + K @ np.linalg.inv(K_P), K @ dx_rd)  # rest-frame axes
    X = np.zeros((6, 6))
    X[:3, :3] = X[3:, 3:] = R0
    h_sim = X.T @ res.wrench[-1]
    scale = np.abs(h_expected).max(axis=None)
    assert np.allclose(h_sim, h_expected, atol=0.03 * scale), (h_sim, h_expected)
    dx_ed = np.linalg.solve(K_P, h_expected)
    xt_sim = pose_error(o_d, R_d, res.x[-1, :3], euler_xyz_to_rotation(res.x[-1, 3:]))
    assert np.allclose(xt_sim, dx_ed, atol=0.03 * np.abs(dx_ed).max()), (xt_sim, dx_ed)


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"inertia": -1.0}, ParameterError, "inertia must be a symmetric positive definite"),
        ({"stiffness": np.ones((6, 6))}, ParameterError, "stiffness must be a symmetric positive definite"),
        ({"orientation": "quat"}, ParameterError, "orientation must be 'euler' or 'rotvec'"),
        ({"posture": np.zeros(3)}, ParameterError, "posture must have 7 joint values"),
    ],
)
def test_bad_controller_inputs(franka, kwargs, exc, match):
    """Bad gains, unknown orientation kind and a posture of the wrong size raise clear errors."""
    args = {"inertia": MD, "damping": KD, "stiffness": KP}
    extra = {k: v for k, v in kwargs.items() if k not in args}
    args.update({k: v for k, v in kwargs.items() if k in args})
    with pytest.raises(exc, match=match):
        SpatialImpedanceController(franka, **args, **extra)


def test_planar_robot_is_refused_by_6d_controllers():
    """A robot whose task space is not the 6-D pose is refused with a message naming what is needed."""
    from forcecontrol.robots import CHAPTER_ARM

    with pytest.raises(ParameterError, match="task='pose'"):
        SpatialImpedanceController(CHAPTER_ARM, 1.0, 1.0, 1.0)


def test_singularity_settings_are_checked():
    """A non-positive DLS threshold is a ParameterError."""
    with pytest.raises(ParameterError, match="threshold must be a positive number"):
        SingularityHandling(threshold=0.0)


def test_compiled_law_equals_the_readable_functions(franka):
    """The one-call compiled XYZ-Euler law gives the same torque as the readable Python path (moving frame, posture, DLS)."""
    rng = np.random.default_rng(5)
    c = SpatialImpedanceController(franka, MD, KD, KP, posture=PANDA_READY)
    for q in (PANDA_READY + rng.normal(0, 0.2, 7), np.array([0.0, 0.02, 0.0, -0.1, 0.0, 0.1, 0.0])):
        qd, h = rng.normal(0, 0.5, 7), rng.normal(0, 3, 6)
        m = Measurement(q, qd, h)
        ref = _moving_desired(0.3)
        c.compiled = True
        u1 = c.step(0.0, m, ref)
        lam_c = c.last_damping
        c.compiled = False
        u2 = c.step(0.0, m, ref)
        assert np.allclose(u1, u2, rtol=1e-10, atol=1e-9)
        assert lam_c == pytest.approx(c.last_damping, abs=1e-12)


def test_hybrid_presses_20_newtons_on_a_table_while_tracing_a_line(franka):
    """6-D hybrid (9.77)–(9.84): λ follows λ̈ + K_Dλ λ̇ + K_Pλ (λ − λ_d) = 0 within 3%, then holds 20 N along a line."""
    from forcecontrol.controllers.spatial_hybrid import SpatialHybridController
    from forcecontrol.trajectories import LinearPath

    R, p = franka.frame_pose(PANDA_READY)
    x0 = np.concatenate([p, rotation_to_euler_xyz(R)])
    k = 1e4
    table = Table(p, [0, 0, 1], stiffness=k)
    x1 = x0 + np.array([0.1, 0.1, 0, 0, 0, 0])
    ref = LinearPath(x0, x1, duration=0.6, start_time=0.5, force=[0, 0, -20.0, 0, 0, 0])
    # the hand's z axis points down, into the table: force along the desired frame's z
    c = SpatialHybridController(franka, [0, 0, 1, 0, 0, 0], 1 / k, 400.0, 40.0, 400.0, 40.0, posture=PANDA_READY)
    res = simulate(franka, table, c, ref, q0=PANDA_READY, duration=1.3, substeps=2)
    lam = -res.wrench[:, 2]
    t = res.t
    w = 20.0  # K_Pλ = 400, K_Dλ = 40: critically damped, ω = 20 rad/s
    expected = 20.0 * (1 - (1 + w * t) * np.exp(-w * t))
    early = t <= 0.5
    assert np.max(np.abs(lam[early] - expected[early])) <= 0.03 * 20.0
    late = t >= 0.5
    assert np.max(np.abs(lam[late] - 20.0)) <= 0.01 * 20.0
    xy_err = res.x[:, :2] - res.reference_block("position")[:, :2]
    assert np.max(np.abs(xy_err)) < 1e-3
    assert np.allclose(res.x[-1, :2], x1[:2], atol=1e-4)


def _step_state(franka, seed):
    rng = np.random.default_rng(seed)
    q = PANDA_READY + rng.normal(0, 0.1, 7)
    qd = rng.normal(0, 0.3, 7)
    h = rng.normal(0, 5.0, 6)
    return q, qd, h, Measurement(q, qd, h)


def test_compliance_6d_step_is_9_15_written_out(franka):
    """SpatialComplianceController.step (the planar law (8.110) on the desired frame) equals
    g + J_Adᵀ (K_P x̃ − K_D J_Ad q̇) (9.15), written out here, with full (coupled) gains and a moving
    frame, plus the redundant arm's null-space damping torque."""
    from forcecontrol.controllers.spatial import SpatialComplianceController

    A = RNG.normal(0, 1, (6, 6))
    K_P = A @ A.T + 300.0 * np.eye(6)
    K_D = 0.1 * K_P + 5.0 * np.eye(6)
    c = SpatialComplianceController(franka, K_P, K_D)
    q, qd, _h, meas = _step_state(franka, 3)
    ref = _moving_desired(0.4)
    u = c.step(0.4, meas, ref)
    R_e, o_e, J, Jdq, _B, _nv, g = franka.spatial_terms(q, qd)
    R_d = euler_xyz_to_rotation(ref.position[3:])
    xt = pose_error(ref.position[:3], R_d, o_e, R_e)
    JAd = analytical_jacobian_desired(J, R_d, -xt[3:])
    # the redundant arm's default null-space damping, projected out of the task directions
    tau0 = _B @ c.posture.acceleration(q, qd)
    tau0 = tau0 - JAd.T @ np.linalg.lstsq(JAd.T, tau0, rcond=None)[0]
    np.testing.assert_allclose(u, g + JAd.T @ (K_P @ xt - K_D @ (JAd @ qd)) + tau0, rtol=1e-10, atol=1e-9)


def test_hybrid_6d_step_requests_the_hybrid_acceleration(franka):
    """SpatialHybridController.step (the planar hybrid law on the desired frame) makes the arm accelerate
    so that J_Ad q̈ = c − x̃̈* with x̃̈* = P_v (−K_D x̃̇ − K_P x̃) − S_f C f_λ and
    f_λ = λ̈_d + K_Dλ (λ̇_d − λ̇) + K_Pλ (λ_d − λ), λ̇ = C⁻¹ S_fᵀ J_Ad q̇ (the tip relative to the environment; along
    S_f, c of the desired frame at rest) (written out here; gains diagonal in the desired frame, two force directions,
    a moving desired frame and force references)."""
    from forcecontrol.controllers.spatial_hybrid import SpatialHybridController

    S_f = np.zeros((6, 2))
    S_f[2, 0] = S_f[3, 1] = 1.0
    C = np.diag([2e-4, 5e-3])
    K_P, K_D = np.diag([400.0, 300.0, 200.0, 100.0, 90.0, 80.0]), np.diag([40.0, 35.0, 30.0, 20.0, 19.0, 18.0])
    K_Pl, K_Dl = np.diag([400.0, 250.0]), np.diag([40.0, 30.0])
    c = SpatialHybridController(franka, S_f, C, K_P, K_D, K_Pl, K_Dl)
    q, qd, h, meas = _step_state(franka, 5)
    base = _moving_desired(0.3)
    fd, fdr, fdd = np.array([1.0, -2.0, -15.0, 0.5, 0.2, 0.1]), RNG.normal(0, 3, 6), RNG.normal(0, 3, 6)
    ref = Reference(base.position, base.velocity, base.acceleration, fd, fdr, fdd)
    u = c.step(0.3, meas, ref)
    R_e, o_e, J, Jdq, B, nv, _g = franka.spatial_terms(q, qd)
    qdd = np.linalg.solve(B, u - nv - J.T @ h)  # the arm's response to u with the contact wrench h
    err = desired_frame_error(R_e, o_e, J, Jdq, qd, ref)
    X = np.zeros((6, 6))
    X[:3, :3] = X[3:, 3:] = err.R_d.T
    lam, lam_d, lam_d_dot, lam_d_ddot = (S_f.T @ (X @ w) for w in (h, fd, fdr, fdd))
    lam_dot = np.linalg.solve(C, S_f.T @ (err.JAd @ qd))
    f_lam = lam_d_ddot + K_Dl @ (lam_d_dot - lam_dot) + K_Pl @ (lam_d - lam)
    P_v = np.eye(6) - S_f @ S_f.T
    xdd_star = P_v @ (-K_D @ err.xd - K_P @ err.x) - S_f @ (C @ f_lam)
    rest = desired_frame_error(R_e, o_e, J, Jdq, qd, Reference(ref.position, *[np.zeros(6)] * 5))
    np.testing.assert_allclose(err.JAd @ qdd, P_v @ err.c + S_f @ (S_f.T @ rest.c) - xdd_star, rtol=1e-7, atol=1e-6)


def _euler_pose(robot, q):
    """[o_e; XYZ Euler angles of R_e] from scipy's Rotation (independent of the library's conversions)."""
    from scipy.spatial.transform import Rotation

    R, p = robot.frame_pose(q)
    return np.concatenate([p, Rotation.from_matrix(R).as_euler("XYZ")])


def test_base_frame_impedance_step_gives_the_9_31_acceleration(franka):
    """frame='base': the arm accelerates so that ẍ_e = ẍ_d + M_d⁻¹ (K_D (ẋ_d − ẋ_e) + K_P (x_d − x_e) − h_A)
    in x_e = [o_e; φ_e] (9.31), h_A = T_Aᵀ h_e; ẋ_e and ẍ_e by finite differences of scipy's Euler angles
    along the motion the torque produces; x_d and its derivatives from the analytic moving reference."""
    M_d = np.diag([2.0, 2.5, 3.0, 0.2, 0.25, 0.3])
    K_D = np.diag([80.0, 90.0, 100.0, 6.0, 7.0, 8.0])
    K_P = np.diag([900.0, 1000.0, 1100.0, 40.0, 50.0, 60.0])
    c = SpatialImpedanceController(franka, M_d, K_D, K_P, frame="base")
    q, qd, h, meas = _step_state(franka, 11)
    t0 = 0.3
    ref = _moving_desired(t0)
    u = c.step(t0, meas, ref)
    _R, _o, J, _Jdq, B, nv, _g = franka.spatial_terms(q, qd)
    qdd = np.linalg.solve(B, u - nv - J.T @ h)
    step = 1e-4
    xs = [_euler_pose(franka, q + qd * s + 0.5 * qdd * s * s) for s in (-step, 0.0, step)]
    x_e, xd_e, xdd_e = xs[1], (xs[2] - xs[0]) / (2 * step), (xs[2] - 2 * xs[1] + xs[0]) / step**2
    phi, phid, phidd = (np.array([0.2 + 0.3 * t0, -0.1 + 0.2 * t0 * t0, 0.4 - 0.5 * t0]), np.array([0.3, 0.4 * t0, -0.5]),
                        np.array([0.0, 0.4, 0.0]))  # the orientation of _moving_desired and its derivatives
    x_d = np.concatenate([ref.position[:3], phi])
    xd_d = np.concatenate([ref.velocity[:3], phid])
    xdd_d = np.concatenate([ref.acceleration[:3], phidd])
    h_A = np.concatenate([h[:3], euler_xyz_T(x_e[3:]).T @ h[3:]])
    want = xdd_d + np.linalg.solve(M_d, K_D @ (xd_d - xd_e) + K_P @ (x_d - x_e) - h_A)
    np.testing.assert_allclose(xdd_e, want, rtol=1e-4, atol=2e-3 * np.abs(want).max())


def test_base_frame_impedance_settles_at_the_9_32_equilibrium(franka):
    """frame='base' against a 6-D spring: at rest K_P (x_d − x_e) = h_A = T_Aᵀ h_e (the equilibrium of (9.32))."""
    x0 = _euler_pose(franka, PANDA_READY)
    R0 = euler_xyz_to_rotation(x0[3:])
    K = np.diag([3000.0, 2000.0, 2500.0, 30.0, 20.0, 25.0])
    env = SpatialSpring(K, x0[:3], R0)
    x_d = x0 + np.array([0.01, -0.008, 0.006, 0.05, -0.04, 0.03])
    K_P = np.diag([1000.0, 1000.0, 1000.0, 40.0, 40.0, 40.0])
    c = SpatialImpedanceController(franka, np.diag([2, 2, 2, 0.1, 0.1, 0.1]), np.diag([120, 120, 120, 4, 4, 4.0]), K_P,
                                   frame="base", posture=NullSpacePosture(PANDA_READY, 10.0, 5.0))
    res = simulate(franka, env, c, Setpoint(x_d), q0=PANDA_READY, duration=3.0, substeps=1)
    x_e = _euler_pose(franka, res.q[-1])
    h = res.wrench[-1]
    h_A = np.concatenate([h[:3], euler_xyz_T(x_e[3:]).T @ h[3:]])
    x_t = x_d - x_e
    x_t[3:] = np.angle(np.exp(1j * x_t[3:]))  # angles differ by 2π across ±π (the hand points down: φ₁ ≈ π)
    np.testing.assert_allclose(K_P @ x_t, h_A, atol=0.01 * np.abs(h_A).max())
    assert np.abs(res.qd[-1]).max() < 1e-3


def test_base_frame_impedance_refuses_a_rotation_vector_error(franka):
    with pytest.raises(ParameterError, match="frame='base' is the chapter's"):
        SpatialImpedanceController(franka, 1.0, 10.0, 100.0, frame="base", orientation="rotvec")
    with pytest.raises(ParameterError, match="frame must be 'desired'"):
        SpatialImpedanceController(franka, 1.0, 10.0, 100.0, frame="tool")


def test_rigid_hybrid_6d_step_is_9_91_written_out(franka):
    """SpatialHybridRigidController.step (the planar rigid law on the desired frame): with the commanded
    wrench h_c = blockdiag(R_d, R_d) S_f λ_d (feedforward law (9.92)) the arm's acceleration gives
    J_Ad q̈ = c + S_v (K_Dr S_vᵀ x̃̇ + K_Pr S_vᵀ x̃), K_r = S_vᵀ K S_v (9.95), c along S_f that of the desired frame
    at rest (the environment holds the pose there) — written out here."""
    from forcecontrol.controllers import SpatialHybridRigidController

    S_f = np.zeros((6, 2))
    S_f[2, 0] = S_f[4, 1] = 1.0
    K_P, K_D = np.diag([400.0, 300.0, 200.0, 100.0, 90.0, 80.0]), np.diag([40.0, 35.0, 30.0, 20.0, 19.0, 18.0])
    c = SpatialHybridRigidController(franka, S_f, K_P, K_D)
    q, qd, h, meas = _step_state(franka, 9)
    base = _moving_desired(0.2)
    fd = np.array([1.0, -2.0, -15.0, 0.5, 0.7, 0.1])
    ref = Reference(base.position, base.velocity, base.acceleration, fd, np.zeros(6), np.zeros(6))
    u = c.step(0.2, meas, ref)
    R_e, o_e, J, Jdq, B, nv, _g = franka.spatial_terms(q, qd)
    err = desired_frame_error(R_e, o_e, J, Jdq, qd, ref)
    X = np.zeros((6, 6))
    X[:3, :3] = X[3:, 3:] = err.R_d
    h_c = X @ (S_f @ (S_f.T @ (X.T @ fd)))
    S_v = np.eye(6)[:, [0, 1, 3, 5]]
    a = S_v @ ((S_v.T @ K_D @ S_v) @ (S_v.T @ err.xd) + (S_v.T @ K_P @ S_v) @ (S_v.T @ err.x))
    qdd = np.linalg.solve(B, u - nv - J.T @ h_c)
    rest = desired_frame_error(R_e, o_e, J, Jdq, qd, Reference(ref.position, *[np.zeros(6)] * 5))
    c_f = err.c + S_f @ (S_f.T @ (rest.c - err.c))
    np.testing.assert_allclose(err.JAd @ qdd, c_f + a, rtol=1e-7, atol=1e-6)


def test_rigid_hybrid_6d_presses_20_newtons_on_a_rigid_table_while_tracing_a_line(franka):
    """(9.91)-(9.95) in 6-D on a rigid table (constrained dynamics): λ = λ_d = 20 N (9.93) within 1 % after
    the first 50 ms, the line tracked within 0.1 mm in x, y, the constraint kept within 1e-9 m."""
    from forcecontrol.controllers import SpatialHybridRigidController
    from forcecontrol.environments.rigid import PlaneConstraint, RigidEnvironment
    from forcecontrol.trajectories import LinearPath

    R, p = franka.frame_pose(PANDA_READY)
    x0 = np.concatenate([p, rotation_to_euler_xyz(R)])
    table = RigidEnvironment(PlaneConstraint(np.concatenate([p, np.zeros(3)]), [0, 0, 1, 0, 0, 0]), unilateral=True)
    c = SpatialHybridRigidController(franka, [0, 0, 1, 0, 0, 0], 400.0, 40.0, force_law="integral",
                                     force_integral_gain=50.0, posture=PANDA_READY)
    x1 = x0 + np.array([0.1, 0.1, 0, 0, 0, 0])
    ref = LinearPath(x0, x1, duration=0.6, start_time=0.2, force=[0, 0, -20.0, 0, 0, 0])
    res = simulate(franka, table, c, ref, q0=PANDA_READY, duration=1.0, substeps=2)
    late = res.t >= 0.05
    np.testing.assert_allclose(res.wrench[late, 2], -20.0, atol=0.2)
    np.testing.assert_allclose(res.wrench[:, [0, 1, 3, 4, 5]], 0.0, atol=1e-9)
    assert np.max(np.abs(res.x[:, :2] - res.reference_block("position")[:, :2])) < 1e-4
    assert np.allclose(res.x[-1, :2], x1[:2], atol=1e-5)
    assert max(abs(float(table.violation(franka, q)[0])) for q in res.q[::50]) < 1e-9


def test_rigid_table_reaction_on_a_redundant_arm_is_g_transpose_lambda(franka):
    """An operational constraint on the 7-joint arm: h_e = Gᵀ λ (9.52)-(9.53 with J_φ = G J; J is not square)
    and Jᵀ h_e equals the joint reaction J_φᵀ λ."""
    from forcecontrol.environments.rigid import PlaneConstraint, RigidEnvironment

    R, p = franka.frame_pose(PANDA_READY)
    table = RigidEnvironment(PlaneConstraint(np.concatenate([p, np.zeros(3)]), [0, 0, 1, 0, 0, 0]))
    u = RNG.normal(0, 5.0, 7)
    qdd, lam, h, T = table.solve(franka, PANDA_READY, np.zeros(7), u)
    np.testing.assert_allclose(h, [0, 0, lam[0], 0, 0, 0], atol=1e-12)
    _phi, Jphi, _ = table.constraint.terms(franka, PANDA_READY, np.zeros(7), T)
    np.testing.assert_allclose(T.J.T @ h, Jphi.T @ lam, atol=1e-9)


def test_hybrid_rejects_bad_force_directions(franka):
    """Force directions that are not (6, k) or are linearly dependent raise ParameterError."""
    from forcecontrol.controllers.spatial_hybrid import SpatialHybridController

    with pytest.raises(ParameterError, match=r"force_directions must be a \(6, k\) matrix"):
        SpatialHybridController(franka, np.ones((3, 1)), 1e-4, 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ParameterError, match="linearly independent"):
        SpatialHybridController(franka, np.array([[1, 2], [0, 0], [0, 0], [0, 0], [0, 0], [0, 0.0]]), 1e-4, 1.0, 1.0, 1.0, 1.0)


@pytest.mark.parametrize("name", ["panda-table-line", "panda-peg-in-hole", "panda-admittance-contact"])
def test_panda_scenarios_run_by_name_and_meet_their_expected_values(name):
    """The Panda scenarios (hybrid line on a table, peg-in-hole with Table 9.2, admittance contact) pass their checks."""
    from forcecontrol.scenarios import run_scenario

    run = run_scenario(name)
    assert run.all_checks_pass, [c.checks for c in run.cases]


def test_peg_follows_the_hole_axis_with_zero_lateral_wrench():
    """Peg-in-hole: the tip ends on the hole's (offset, tilted) axis 3 cm deep with lateral forces and tilting moments near 0."""
    from forcecontrol.scenarios import run_scenario

    res = run_scenario("panda-peg-in-hole").cases[0].result
    d = res.x[-1, :3] - res.x[0, :3]
    assert d[0] == pytest.approx(0.002, abs=2e-5)  # the hole's axis is 2 mm along x
    assert d[1] == pytest.approx(-0.03 * math.tan(math.radians(-1.0)), abs=2e-5)  # tilted 1° about x
    assert d[2] == pytest.approx(-0.03, abs=1e-4)
    assert np.all(np.abs(res.wrench[-1, [0, 1]]) < 0.01) and np.all(np.abs(res.wrench[-1, [3, 4]]) < 1e-3)


def test_closed_loop_at_a_wrist_singularity_dls_bounds_torques():
    """UR5 at a wrist singularity pushed along the lost direction: DLS keeps torques small, the exact inverse does not."""
    from forcecontrol.errors import SimulationDivergedError
    from forcecontrol.robots.pinocchio import ur5

    robot = ur5()
    q0 = np.array([0.0, -1.2, 1.5, -1.9, 0.002, 0.3])  # wrist 1 and 3 nearly aligned
    U, S, _ = np.linalg.svd(robot.spatial_jacobian(q0))
    assert S[-1] < 1e-3
    x0 = _pose(robot, q0)
    h = 0.5 * U[:, -1]  # a wrench along the direction the arm cannot move in
    peaks = []
    for sing in (SingularityHandling(0.05, 0.05), SingularityHandling(0.05, 0.0)):
        c = SpatialImpedanceController(robot, MD, KD, KP, singularity=sing)
        try:
            res = simulate(robot, ConstantWrench(h), c, Setpoint(x0), q0=q0, duration=0.5, substeps=1)
        except SimulationDivergedError as exc:  # the exact inverse may run away
            res = exc.partial
        g = np.array([robot.gravity(q) for q in res.q])
        peaks.append((float(np.nanmax(np.abs(res.torque - g))), float(np.nanmax(np.abs(res.qd)))))
    (u_dls, v_dls), (u_exact, v_exact) = peaks
    assert u_dls < 20.0 and v_dls < 1.0
    assert u_exact > 10 * u_dls and v_exact > 10 * v_dls


def test_ur5_impedance_step_matches_second_order_response():
    """A 6-DOF arm (square J, no null space): the step of external wrench follows (9.36) within 2%."""
    from forcecontrol.robots.pinocchio import ur5

    robot = ur5()
    q0 = np.array([0.3, -1.2, 1.5, -1.9, -1.4, 0.3])
    t, xt, h_d = _impedance_run(robot, q0, np.array([4.0, -3.0, 5.0, 0.2, -0.1, 0.15]), duration=0.6)
    for i in range(6):
        y = _second_order(t, i, h_d)
        assert np.max(np.abs(xt[:, i] - y)) <= 0.02 * np.max(np.abs(y)), i


_angles = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3)
_vec = st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3)


@settings(max_examples=60, deadline=None)
@given(_angles, _vec, _vec, _vec, _vec, _vec)
def test_frame_change_preserves_power_for_any_pose(phi, t, f, m, v, w):
    """For any transform, hᵀv computed in the child frame equals the one in the parent frame (property)."""
    X = Transform(euler_xyz_to_rotation(phi), t, parent="world", child="tool")
    h, tw = Wrench(f, m, "tool", "tool"), Twist(v, w, "tool", "tool")
    assert math.isclose(tw.transformed(X).power(h.transformed(X)), tw.power(h), rel_tol=1e-9, abs_tol=1e-9)


@settings(max_examples=60, deadline=None)
@given(_angles)
def test_euler_T_determinant_is_cos_phi2(phi):
    """det T(φ) = cos φ₂ for XYZ angles: the representation singularity is exactly at cos φ₂ = 0 (property)."""
    assert math.isclose(np.linalg.det(euler_xyz_T(phi)), math.cos(phi[1]), abs_tol=1e-12)


# ----------------------------------------------------------------------------- against scipy's Rotation

from scipy.spatial.transform import Rotation  # noqa: E402

from forcecontrol.spatial import closed_form  # noqa: E402


def _random_rotations(n: int, seed: int) -> np.ndarray:
    return Rotation.random(n, random_state=seed).as_matrix()


def test_euler_xyz_is_scipys_intrinsic_xyz():
    """The chapter's XYZ angles are SciPy's intrinsic "XYZ" (R = R_x R_y R_z), not the extrinsic "xyz"."""
    phi = np.array([0.3, -0.4, 1.2])
    Rx = Rotation.from_euler("x", phi[0]).as_matrix()
    Ry = Rotation.from_euler("y", phi[1]).as_matrix()
    Rz = Rotation.from_euler("z", phi[2]).as_matrix()
    np.testing.assert_allclose(euler_xyz_to_rotation(phi), Rx @ Ry @ Rz, atol=1e-15)
    assert not np.allclose(euler_xyz_to_rotation(phi), Rotation.from_euler("xyz", phi).as_matrix())


@pytest.mark.parametrize("impl", [closed_form, __import__("forcecontrol.spatial", fromlist=["x"])], ids=["closed_form", "public"])
def test_conversions_agree_with_scipy_on_random_rotations(impl):
    """Matrix <-> XYZ angles and matrix <-> rotation vector agree with scipy's Rotation on 2000 random rotations."""
    Rs = _random_rotations(2000, seed=1)
    ref_phi = Rotation.from_matrix(Rs).as_euler("XYZ")
    ref_vec = Rotation.from_matrix(Rs).as_rotvec()
    for R, phi, vec in zip(Rs, ref_phi, ref_vec):
        np.testing.assert_allclose(impl.rotation_to_euler_xyz(R), phi, atol=1e-10)
        np.testing.assert_allclose(impl.euler_xyz_to_rotation(phi), R, atol=1e-12)
        np.testing.assert_allclose(impl.rotation_vector(R), vec, atol=1e-9)
        np.testing.assert_allclose(impl.rotvec_to_rotation(vec), R, atol=1e-12)


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-7, 1e-5, 0.5, math.pi / 2, math.pi - 1e-5, math.pi - 1e-8, math.pi])
def test_rotation_vector_near_zero_and_pi_matches_scipy(angle):
    """The closed-form rotation vector matches scipy's at the delicate angles 0 and π (random axes)."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        R = Rotation.from_rotvec(angle * axis).as_matrix()
        got, ref = closed_form.rotation_vector(R), Rotation.from_matrix(R).as_rotvec()
        if abs(angle - math.pi) < 1e-4:  # at π the axis sign is arbitrary: compare the rotation
            np.testing.assert_allclose(Rotation.from_rotvec(got).as_matrix(), R, atol=1e-7)
            assert abs(np.linalg.norm(got) - np.linalg.norm(ref)) < 1e-7
        else:
            np.testing.assert_allclose(got, ref, atol=1e-9)


def test_euler_singular_branch_is_a_valid_decomposition():
    """At cos φ₂ < EULER_SINGULARITY_TOL both forms return φ₃ = 0 and angles that rebuild R (scipy's convention there)."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        phi = np.array([rng.uniform(-3, 3), rng.choice([-1, 1]) * (math.pi / 2 - rng.uniform(0, 5e-4)), rng.uniform(-3, 3)])
        R = Rotation.from_euler("XYZ", phi).as_matrix()
        for impl in (closed_form, __import__("forcecontrol.spatial", fromlist=["x"])):
            got = impl.rotation_to_euler_xyz(R)
            assert got[2] == 0.0
            np.testing.assert_allclose(Rotation.from_euler("XYZ", got).as_matrix(), R, atol=2e-3)
            with pytest.raises(SingularityError):
                impl.rotation_to_euler_xyz(R, strict=True)


def test_compiled_rotation_of_the_spatial_kernel_matches_scipy():
    """The @njit R(φ) used inside the compiled 6-D law equals scipy's intrinsic XYZ rotation on random angles."""
    from forcecontrol.laws.spatial import _R_xyz as R_xyz

    rng = np.random.default_rng(11)
    phis = rng.uniform(-math.pi, math.pi, size=(500, 3))
    phis[:, 1] /= 2
    ref = Rotation.from_euler("XYZ", phis).as_matrix()
    for phi, R in zip(phis, ref):
        np.testing.assert_allclose(R_xyz(phi), R, atol=1e-12)


def test_rate_map_T_against_scipy_finite_differences():
    """ω = T(φ) φ̇ (3.64): the angular velocity of scipy's R(φ(t)) by finite differences equals T(φ) φ̇."""
    rng = np.random.default_rng(5)
    for _ in range(100):
        phi, phid = rng.uniform(-1.2, 1.2, 3), rng.normal(size=3)
        h = 1e-6
        Rp = Rotation.from_euler("XYZ", phi + h * phid).as_matrix()
        Rm = Rotation.from_euler("XYZ", phi - h * phid).as_matrix()
        R = Rotation.from_euler("XYZ", phi).as_matrix()
        W = (Rp - Rm) / (2 * h) @ R.T
        omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
        np.testing.assert_allclose(euler_xyz_T(phi) @ phid, omega, atol=1e-7)
        th = Rotation.from_euler("XYZ", phi).as_rotvec()
        Rp = Rotation.from_rotvec(th + h * phid).as_matrix()
        Rm = Rotation.from_rotvec(th - h * phid).as_matrix()
        W = (Rp - Rm) / (2 * h) @ Rotation.from_rotvec(th).as_matrix().T
        np.testing.assert_allclose(rotvec_T(th) @ phid, [W[2, 1], W[0, 2], W[1, 0]], atol=1e-7)


def test_spatial_package_keeps_its_public_names():
    """Every name of the former spatial.py is importable from forcecontrol.spatial; each module is under 450 lines."""
    from pathlib import Path

    import forcecontrol.spatial as sp

    assert set(sp.__all__) - set(dir(sp)) == set()
    assert {"Transform", "Wrench", "Twist", "pose_error", "rotation_vector", "EULER_SINGULARITY_TOL"} <= set(sp.__all__)
    for f in Path(sp.__file__).parent.glob("*.py"):
        assert len(f.read_text().splitlines()) < 450, f


RIGID_TABLE_LINE = """
name = "panda-rigid-table-line"
duration = 1.0
sample_time = 0.001
substeps = 2
[robot]
model = "panda"
q0 = [0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398]
[environment]
type = "rigid-table"
[controller]
type = "spatial-hybrid-rigid"
force_directions = [[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]
stiffness = 400.0
damping = 40.0
force_law = "integral"
force_integral_gain = 50.0
[reference]
type = "pose-line"
end_offset = [0.1, 0.1, 0.0]
duration = 0.6
start_time = 0.2
force = [0.0, 0.0, -20.0, 0.0, 0.0, 0.0]
"""


def test_rigid_hybrid_6d_runs_from_a_scenario_file(tmp_path):
    """[environment] rigid-table with [controller] spatial-hybrid-rigid: the scenario runs and holds 20 N."""
    from forcecontrol.scenarios import load_scenario

    path = tmp_path / "rigid.toml"
    path.write_text(RIGID_TABLE_LINE)
    res = load_scenario(path).run().cases[0].result
    np.testing.assert_allclose(res.wrench[res.t >= 0.05, 2], -20.0, atol=0.2)
    assert np.allclose(res.x[-1, :2] - res.x[0, :2], [0.1, 0.1], atol=1e-5)
