"""Rigid environments: constrained dynamics (9.87)–(9.88), drift, unilateral contact, and hybrid control on them (9.91)–(9.95)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol import CHAPTER_ARM, LinearPath, OperationalSpacePD, Setpoint, simulate
from forcecontrol.controllers.hybrid import HybridRigidController
from forcecontrol.environments.rigid import (
    CircleConstraint,
    JointConstraint,
    PlaneConstraint,
    RigidEnvironment,
)
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.task import inclined_plane
from forcecontrol.trajectories import ReferenceSignal

R2 = 1.0 / math.sqrt(2.0)
P0 = np.array([1.0, 0.0])
LAMBDA_D = -50.0


@pytest.fixture(scope="module")
def plane_env():
    """The π/4 plane of Example 9.4, rigid and unilateral."""
    return RigidEnvironment(PlaneConstraint.inclined(math.pi / 4, P0), unilateral=True)


@pytest.fixture(scope="module")
def hybrid_run(plane_env):
    """Hybrid force/velocity control on the rigid plane: 50 N into it while sliding 0.2√2 m along it (integral force law)."""
    task = inclined_plane()
    sel = task.selection("base")
    ref = LinearPath(P0, P0 + 0.2 * np.array([1.0, 1.0]), 1.0, force=sel.wrench([LAMBDA_D]))
    ctrl = HybridRigidController(
        CHAPTER_ARM, task, velocity_gain=100.0, velocity_integral_gain=2500.0,
        force_law="integral", force_integral_gain=100.0,
    )
    res = simulate(CHAPTER_ARM, plane_env, ctrl, ref, q0=CHAPTER_ARM.inverse_kinematics(P0), duration=2.5)
    return res, sel


def test_rigid_hybrid_run_keeps_constraint_and_reaches_force(hybrid_run, plane_env):
    """Hybrid control (9.91) with (9.94) on the rigid plane: |φ| < 1e-6 m throughout and λ within 1 % of −50 N from 0.5 s on."""
    res, sel = hybrid_run
    phi = np.array([plane_env.violation(CHAPTER_ARM, q)[0] for q in res.q])
    assert np.abs(phi).max() < 1e-6
    lam = (res.wrench @ sel.force_pinv.T).ravel()
    late = res.t >= 0.5
    assert np.all(np.abs(lam[late] - LAMBDA_D) < 0.01 * abs(LAMBDA_D))
    assert lam[-1] == pytest.approx(LAMBDA_D, rel=1e-6)


def test_first_reaction_is_that_of_an_arm_at_rest(hybrid_run):
    """At t = 0 the arm rests on the plane under gravity compensation: the reaction is ~0, not a falling arm's."""
    res, sel = hybrid_run
    lam0 = float((res.wrench[0] @ sel.force_pinv.T).ravel()[0])
    assert abs(lam0) < 1e-6 * abs(LAMBDA_D)
    lam = (res.wrench @ sel.force_pinv.T).ravel()
    assert np.all(lam[:20] <= 1e-6)  # pushes into the plane from the start, never a spurious pull


def test_reciprocity_along_rigid_run(hybrid_run):
    """Reciprocity (9.57): h_eᵀ v_e = 0 along the run (|h_eᵀ v_e| below 1e-6 of |h_e| |v_e|)."""
    res, _ = hybrid_run
    work = np.abs(np.einsum("ij,ij->i", res.wrench, res.xd))
    scale = np.linalg.norm(res.wrench, axis=1) * np.linalg.norm(res.xd, axis=1)
    moving = scale > 1e-3
    assert moving.sum() > 500
    assert np.all(work[moving] <= 1e-6 * scale[moving])


def test_rigid_velocity_tracks_along_plane(hybrid_run):
    """ν̇ = α_ν on the constraint: the tangential speed follows the trapezoidal profile within 1 % of the cruise speed."""
    res, sel = hybrid_run
    nu = (res.xd @ sel.velocity_pinv.T).ravel()
    nu_d = (res.reference_block("velocity") @ sel.velocity_pinv.T).ravel()
    during = res.t <= 1.0
    assert np.abs(nu - nu_d)[during].max() < 0.01 * (0.2 * math.sqrt(2) / 0.8)


def test_reaction_matches_chapter_formula(plane_env):
    """λ of the simulator equals (9.87), λ = B_f (S_fᵀ B_e⁻¹ (γ_e − n_e)), on the constraint with a tangential velocity."""
    q = CHAPTER_ARM.inverse_kinematics([1.1, 0.1])
    T0 = CHAPTER_ARM.terms(q, np.zeros(2))
    qd = np.linalg.solve(T0.J, 0.3 * np.array([R2, R2]))  # v_e along the plane: S_fᵀ v_e = 0
    u = np.array([150.0, -80.0])
    T = CHAPTER_ARM.terms(q, qd)
    S_f = np.array([[-R2], [R2]])
    Jinv = np.linalg.inv(T.J)
    B_e = Jinv.T @ T.B @ Jinv
    n_e = Jinv.T @ T.n - B_e @ T.Jdq
    gamma = Jinv.T @ u
    B_f = np.linalg.inv(S_f.T @ np.linalg.solve(B_e, S_f))
    lam = B_f @ (S_f.T @ np.linalg.solve(B_e, gamma - n_e))
    env = RigidEnvironment(PlaneConstraint.inclined(math.pi / 4, P0))  # bilateral: λ of either sign
    np.testing.assert_allclose(env.reaction(CHAPTER_ARM, q, qd, u), lam, rtol=1e-9)
    # (9.88): B_e v̇_e = P (γ_e − n_e), P = I − S_f B_f S_fᵀ B_e⁻¹ a projection with P S_f = O
    P = np.eye(2) - S_f @ B_f @ S_f.T @ np.linalg.inv(B_e)
    np.testing.assert_allclose(P @ P, P, atol=1e-12)
    np.testing.assert_allclose(P @ S_f, 0.0, atol=1e-12)
    qdd, h = env.acceleration(CHAPTER_ARM, q, qd, u)
    vdot = T.J @ qdd + T.Jdq
    np.testing.assert_allclose(B_e @ vdot, P @ (gamma - n_e), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(h, S_f @ lam, rtol=1e-9)


def test_unilateral_contact_lets_go_instead_of_pulling():
    """A torque pulling the tip off the plane gives λ = 0 on a unilateral plane (free motion) but λ > 0 on a bilateral one."""
    q = CHAPTER_ARM.inverse_kinematics(P0)
    J = CHAPTER_ARM.jacobian(q)
    u = CHAPTER_ARM.gravity(q) + J.T @ (200.0 * np.array([-R2, R2]))  # 200 N out of the plane
    uni = RigidEnvironment(PlaneConstraint.inclined(math.pi / 4, P0), unilateral=True)
    bi = RigidEnvironment(PlaneConstraint.inclined(math.pi / 4, P0))
    assert uni.reaction(CHAPTER_ARM, q, np.zeros(2), u)[0] == 0.0
    assert bi.reaction(CHAPTER_ARM, q, np.zeros(2), u)[0] > 0.0
    qdd, h = uni.acceleration(CHAPTER_ARM, q, np.zeros(2), u)
    np.testing.assert_allclose(qdd, np.linalg.solve(CHAPTER_ARM.mass_matrix(q), u - CHAPTER_ARM.gravity(q)), rtol=1e-12)
    np.testing.assert_array_equal(h, 0.0)
    # pushing into it: the unilateral plane pushes back like the bilateral one
    u_in = CHAPTER_ARM.gravity(q) - J.T @ (200.0 * np.array([-R2, R2]))
    assert uni.reaction(CHAPTER_ARM, q, np.zeros(2), u_in)[0] == pytest.approx(bi.reaction(CHAPTER_ARM, q, np.zeros(2), u_in)[0])


def test_unilateral_arm_leaves_the_plane_in_simulation():
    """In closed loop, a set-point away from the unilateral plane makes the tip leave it with zero contact force."""
    env = RigidEnvironment(PlaneConstraint.inclined(math.pi / 4, P0), unilateral=True)
    ctrl = OperationalSpacePD(CHAPTER_ARM, 2500.0, 500.0)
    res = simulate(CHAPTER_ARM, env, ctrl, Setpoint([0.9, 0.1]), q0=CHAPTER_ARM.inverse_kinematics(P0), duration=0.5)
    phi = np.array([env.violation(CHAPTER_ARM, q)[0] for q in res.q])
    assert phi[-1] > 0.05
    assert np.all(phi > -1e-6)
    np.testing.assert_array_equal(res.wrench[-100:], 0.0)


def test_bilateral_crank_keeps_circle():
    """A bilateral circular constraint (a crank handle) holds the tip on the circle within 1e-6 m while a controller drags it."""
    env = RigidEnvironment(CircleConstraint([1.0, 0.5], 0.3))
    q0 = CHAPTER_ARM.inverse_kinematics([1.3, 0.5])
    ctrl = OperationalSpacePD(CHAPTER_ARM, 2500.0, 500.0)
    res = simulate(CHAPTER_ARM, env, ctrl, Setpoint([1.0, 1.0]), q0=q0, duration=1.0)
    phi = np.array([env.violation(CHAPTER_ARM, q)[0] for q in res.q])
    assert np.abs(phi).max() < 1e-6
    # the tip turned the crank, and the reaction is radial: h_eᵀ v_e = 0 (9.57)
    assert np.linalg.norm(res.x[-1] - [1.3, 0.5]) > 0.1
    work = np.abs(np.einsum("ij,ij->i", res.wrench, res.xd))
    assert work.max() < 1e-6 * max(1.0, np.abs(res.wrench).max())


def test_joint_constraint_matches_operational_one():
    """A joint-space constraint with a finite-difference J̇_φ q̇ reproduces the operational plane constraint's reaction."""
    plane = PlaneConstraint.inclined(math.pi / 4, P0)
    joint = JointConstraint(
        lambda q: plane.psi(CHAPTER_ARM.forward_kinematics(q)),
        lambda q: plane.gradient(CHAPTER_ARM.forward_kinematics(q)) @ CHAPTER_ARM.jacobian(q),
        size=1,
    )
    q = CHAPTER_ARM.inverse_kinematics([1.1, 0.1])
    qd = np.array([0.4, -0.7])
    u = np.array([100.0, 20.0])
    a = RigidEnvironment(plane).solve(CHAPTER_ARM, q, qd, u)
    b = RigidEnvironment(joint, dim=2).solve(CHAPTER_ARM, q, qd, u)
    np.testing.assert_allclose(b[1], a[1], rtol=1e-6)
    np.testing.assert_allclose(b[0], a[0], rtol=1e-6)


def test_position_mode_reaches_position_on_plane(plane_env):
    """Hybrid force/position control (9.95) with (9.93): the tangential coordinate r reaches r_d and λ reaches λ_d."""
    task = inclined_plane()
    sel = task.selection("base")
    end = P0 + 0.2 * np.array([1.0, 1.0])
    ref = LinearPath(P0, end, 1.0, force=sel.wrench([LAMBDA_D]))
    ctrl = HybridRigidController(
        CHAPTER_ARM, task, motion="position", velocity_gain=100.0, position_gain=2500.0,
        force_law="proportional", force_gain=0.5,
    )
    res = simulate(CHAPTER_ARM, plane_env, ctrl, ref, q0=CHAPTER_ARM.inverse_kinematics(P0), duration=2.0)
    np.testing.assert_allclose(res.x[-1], end, atol=1e-6)
    assert (sel.force_pinv @ res.wrench[-1])[0] == pytest.approx(LAMBDA_D, rel=1e-6)


def test_proportional_force_law_sampled_limit():
    """The reaction is read one sample late: (9.93) gives λ_{k+1} = (1 + K_Pλ) λ_d − K_Pλ λ_k; K_Pλ = 0.5 converges, 1 not."""
    env = RigidEnvironment(PlaneConstraint.inclined(math.pi / 4, P0))  # bilateral: the oscillation is not clipped
    task = inclined_plane()
    sel = task.selection("base")
    out = {}
    for kp in (0.5, 1.0):
        ctrl = HybridRigidController(CHAPTER_ARM, task, velocity_gain=100.0, velocity_integral_gain=2500.0,
                                     force_law="proportional", force_gain=kp)
        res = simulate(CHAPTER_ARM, env, ctrl, Setpoint(P0, force=sel.wrench([LAMBDA_D])),
                       q0=CHAPTER_ARM.inverse_kinematics(P0), duration=0.2)
        out[kp] = (res.wrench[-20:] @ sel.force_pinv.T).ravel()
    assert np.abs(out[0.5] - LAMBDA_D).max() < 1e-6
    assert np.abs(out[1.0] - LAMBDA_D).max() > 10.0


# --------------------------------------------------------------------------- bad inputs


def test_rigid_environment_has_no_pose_only_wrench(plane_env):
    """wrench(x, ẋ) is meaningless for a rigid environment and says what to call instead."""
    with pytest.raises(ParameterError, match=r"reaction depends on the joint torques.*use sampled_wrench"):
        plane_env.wrench(np.zeros(2), np.zeros(2))


def test_bad_rigid_inputs_raise():
    """Constraint type, missing dimension, zero normal and a bad stabilisation frequency are refused by name."""
    with pytest.raises(ParameterError, match=r"constraint must be a HolonomicConstraint; got str"):
        RigidEnvironment("plane")  # type: ignore[arg-type]
    with pytest.raises(DimensionError, match=r"dim must be given for a joint-space constraint"):
        RigidEnvironment(JointConstraint(lambda q: q[:1], lambda q: np.eye(2)[:1], size=1))
    with pytest.raises(ParameterError, match=r"normal must be a non-zero vector; got \[0.0, 0.0\]"):
        PlaneConstraint([1.0, 0.0], [0.0, 0.0])
    with pytest.raises(ParameterError, match=r"stabilisation_frequency must be a positive number; got -1"):
        RigidEnvironment(PlaneConstraint(P0, [0.0, 1.0]), stabilisation_frequency=-1)
    with pytest.raises(ParameterError, match=r"size must be a positive integer; got 0"):
        JointConstraint(lambda q: q, lambda q: np.eye(2), size=0)


class CircleReference(ReferenceSignal):
    """The handle of a crank turning at a constant rate: tip position, velocity and acceleration on the circle."""

    dim = 2

    def __init__(self, center, radius, rate):
        self.center, self.radius, self.rate = np.asarray(center, dtype=float), float(radius), float(rate)

    def sample(self, times):
        th = self.rate * np.asarray(times, dtype=float)
        r, w = self.radius, self.rate
        out = np.zeros((len(th), 12))
        out[:, 0:2] = self.center + r * np.column_stack([np.cos(th), np.sin(th)])
        out[:, 2:4] = r * w * np.column_stack([-np.sin(th), np.cos(th)])
        out[:, 4:6] = -r * w * w * np.column_stack([np.cos(th), np.sin(th)])
        return out


def test_crank_hybrid_control_with_moving_selection():
    """Turning a crank: with S_f, S_v, Ṡ_v from the geometry, (9.91) keeps λ = f_λ = 0 instead of ≈ 28 N centripetal."""
    center, radius, rate = np.array([1.0, 0.5]), 0.3, 1.0
    crank = CircleConstraint(center, radius)
    env = RigidEnvironment(crank)
    ctrl = HybridRigidController(CHAPTER_ARM, crank, velocity_gain=100.0, velocity_integral_gain=2500.0,
                                 force_law="feedforward")
    q0 = CHAPTER_ARM.inverse_kinematics(center + [radius, 0.0])
    res = simulate(CHAPTER_ARM, env, ctrl, CircleReference(center, radius, rate), q0=q0, duration=2.0)
    sels = [crank.selection(x, xd) for x, xd in zip(res.x, res.xd)]
    lam = np.array([S_f[:, 0] @ h for (S_f, _, _), h in zip(sels, res.wrench)])
    nu = np.array([S_v[:, 0] @ xd for (_, S_v, _), xd in zip(sels, res.xd)])
    nu_d = np.array([S_v[:, 0] @ v for (_, S_v, _), v in zip(sels, res.reference_block("velocity"))])
    phi = np.array([env.violation(CHAPTER_ARM, q)[0] for q in res.q])
    assert np.abs(phi).max() < 1e-6
    late = res.t >= 0.3
    assert np.abs(lam[late]).max() < 1.0
    assert np.abs(nu - nu_d)[late].max() < 0.01 * radius * rate
    angle = math.atan2(res.x[-1, 1] - center[1], res.x[-1, 0] - center[0])
    assert angle == pytest.approx(rate * 2.0, abs=1e-3)
    # the reaction the Ṡ_v ν term removes: B_f S_fᵀ Ṡ_v ν at the last state (λ of (9.90) with α_ν = 0)
    T = CHAPTER_ARM.terms(res.q[-1], res.qd[-1])
    S_f, S_v, S_v_dot = crank.selection(T.x, T.xd)
    Jinv = np.linalg.inv(T.J)
    B_e = Jinv.T @ T.B @ Jinv
    B_f = 1.0 / (S_f.T @ np.linalg.solve(B_e, S_f))
    assert abs((B_f * (S_f.T @ S_v_dot) * (S_v.T @ T.xd)).item()) > 20.0


def test_moving_selection_needs_velocity_motion_and_planar_constraint():
    """A constraint-given selection refuses position control (ψ unknown) and constraints that are not one planar equation."""
    crank = CircleConstraint([1.0, 0.5], 0.3)
    with pytest.raises(ParameterError, match=r"motion must be 'velocity' with a moving contact geometry.*got 'position'"):
        HybridRigidController(CHAPTER_ARM, crank, motion="position", velocity_gain=1.0, position_gain=1.0)
    with pytest.raises(DimensionError, match=r"one constraint on a 2-dimensional operational space; got dim 3"):
        HybridRigidController(CHAPTER_ARM, CircleConstraint([1.0, 0.5, 0.0], 0.3), velocity_gain=1.0,
                              velocity_integral_gain=1.0, force_integral_gain=1.0)


@pytest.mark.parametrize("unilateral", [True, False])
@pytest.mark.parametrize("which", ["plane", "circle"])
def test_the_planar_scalar_solve_equals_the_general_one(which, unilateral, monkeypatch):
    """One operational constraint on the 2-joint arm is solved on scalars (RigidEnvironment._solve_planar_one): q̈, λ
    and h_e equal the general path's (arrays, LAPACK) to round-off on 300 random states, in contact and released,
    pushing and (unilateral) pulling."""
    from forcecontrol.environments.rigid import CircleConstraint, PlaneConstraint, RigidEnvironment

    arm = CHAPTER_ARM
    c = PlaneConstraint.inclined(math.pi / 4, [1.0, 0.0]) if which == "plane" else CircleConstraint([1.2, 0.1], 0.25)
    env = RigidEnvironment(c, unilateral=unilateral)
    rng = np.random.default_rng(5)
    fast, general = [], []
    for _ in range(300):
        q = arm.inverse_kinematics([1.0, 0.0]) + rng.normal(0.0, 0.05, 2)
        qd, u = rng.normal(0.0, 1.0, 2), rng.normal(0.0, 200.0, 2)
        assert env._planar_one
        fast.append(env.solve(arm, q, qd, u)[:3])
        with monkeypatch.context() as m:
            m.setattr(RigidEnvironment, "_planar_one", property(lambda self: False))
            general.append(env.solve(arm, q, qd, u)[:3])
    for i, what in enumerate(("q̈", "λ", "h_e")):
        a = np.array([f[i] for f in fast])
        b = np.array([g[i] for g in general])
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-9 * np.abs(b).max(), err_msg=what)
    lam = np.array([g[1][0] for g in general])
    assert (lam != 0.0).sum() > 50 and (lam > 0.0).any() != unilateral  # both signs when bilateral; released ones
    if unilateral:
        assert (lam == 0.0).sum() > 20
