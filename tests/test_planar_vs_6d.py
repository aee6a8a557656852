"""Each planar law against its 6-D form (issue 13 item 8), through the public ``step`` of both.

The planar controllers run on the chapter's arm, the 6-D ones on the Panda. A signed permutation
P maps the planar task axes into the base frame (planar x → base −z, planar y → base x). For the
same errors, velocities, forces and references (mapped by P, the extra axes at rest on their
set-point), the operational-space result of each law must be the same:

* inverse-dynamics schemes: the task acceleration the torques produce,
  ``ẍ = J B⁻¹ (u − n − Jᵀ h) + J̇ q̇`` (each robot's own dynamics, so the robot cancels out);
* hybrid on a rigid plane: the acceleration and the reaction of each arm held by the constraint
  (a KKT solve written in the test);
* active compliance: the commanded wrench ``γ = (Jᵀ)⁺ (u − g)``.

Pairs: impedance (9.31) vs (9.31) in 6-D and (9.36); hybrid compliant (9.77)–(9.82) vs its
desired-frame form; hybrid rigid (9.91)/(9.93)/(9.95) vs its desired-frame form; active
compliance (8.110) vs (9.15). Each is also checked against the hand-written equation.

The reference is the other dimension's law on another robot; the comparison holds to rounding
(1e-9), so a wrong frame, sign, gain or term in either form fails it.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")

import forcecontrol as fc  # noqa: E402
from forcecontrol.controllers.base import Measurement, Reference  # noqa: E402
from forcecontrol.robots.pinocchio import panda  # noqa: E402
from forcecontrol.spatial import euler_xyz_to_rotation  # noqa: E402
from forcecontrol.task import SelectionMatrices  # noqa: E402

ARM = fc.PlanarTwoLink()
PANDA = panda()
Q2 = np.array([0.35, 1.2])
QD2 = np.array([0.4, -0.7])
QP = np.array([0.1, -0.6, 0.05, -2.2, 0.02, 1.7, 0.7])
#: planar task axes in the base frame (columns): x → −z, y → +x
P = np.array([[0.0, 1.0], [0.0, 0.0], [-1.0, 0.0]])
E_X, E_Y = np.array([1.0, 0.0]), np.array([0.0, 1.0])


def _planar_state():
    x = ARM.forward_kinematics(Q2)
    xd = ARM.jacobian(Q2) @ QD2
    return x, xd


def _panda_state(xd2):
    """The Panda at QP moving with the mapped tip velocity, no angular velocity, no self-motion."""
    J = PANDA.spatial_jacobian(QP)
    qd = np.linalg.pinv(J) @ np.concatenate([P @ xd2, np.zeros(3)])
    pose = PANDA.forward_kinematics(QP)
    return pose, qd


def _planar_acceleration(u, h):
    B, n, J = ARM.mass_matrix(Q2), ARM.nonlinear_effects(Q2, QD2), ARM.jacobian(Q2)
    return J @ np.linalg.solve(B, u - n - J.T @ h) + ARM.jdot_qdot(Q2, QD2)


def _panda_acceleration(u, h6, qd):
    B, n, J = PANDA.mass_matrix(QP), PANDA.nonlinear_effects(QP, qd), PANDA.spatial_jacobian(QP)
    return J @ np.linalg.solve(B, u - n - J.T @ h6) + PANDA.spatial_jdot_qdot(QP, qd)


Z2 = np.zeros(2)


def _pose_reference(pose, offset2, vel2, acc2, force2=Z2, rate2=Z2, accel2=Z2):
    """The Panda's reference: the planar one mapped by P, the other axes held where they are."""
    z3 = np.zeros(3)
    pos = np.concatenate([pose[:3] + P @ offset2, pose[3:]])
    return Reference(pos, np.concatenate([P @ vel2, z3]), np.concatenate([P @ acc2, z3]),
                     np.concatenate([P @ force2, z3]), np.concatenate([P @ rate2, z3]), np.concatenate([P @ accel2, z3]))


OFFSET = np.array([0.012, -0.008])  # x_d − x_e, planar
VEL_D = np.array([0.05, -0.02])
ACC_D = np.array([0.3, 0.1])
H2 = np.array([35.0, -6.0])  # the measured contact force, planar


@pytest.mark.parametrize("frame", ["base", "desired"])
def test_impedance_9_31_and_its_6d_forms_9_31_and_9_36_command_the_same_acceleration(frame):
    m_d, k_d, k_p = np.array([8.0, 3.0]), np.array([90.0, 40.0]), np.array([900.0, 300.0])
    if frame == "desired":  # on the desired frame the gains are the desired frame's: isotropic here
        m_d, k_d, k_p = np.full(2, 5.0), np.full(2, 60.0), np.full(2, 700.0)
    x2, xd2 = _planar_state()
    ctl2 = fc.ImpedanceController(ARM, np.diag(m_d), np.diag(k_d), np.diag(k_p))
    ref2 = Reference(x2 + OFFSET, VEL_D, ACC_D, np.zeros(2), np.zeros(2), np.zeros(2))
    a2 = _planar_acceleration(ctl2.step(0.0, Measurement(Q2, QD2, H2), ref2), H2)

    pose, qd = _panda_state(xd2)
    # base axes: x ← planar y, z ← planar x, y and the rotation with their own gains
    M6 = np.diag([m_d[1], 2.0, m_d[0], 0.3, 0.3, 0.3])
    D6 = np.diag([k_d[1], 20.0, k_d[0], 4.0, 4.0, 4.0])
    K6 = np.diag([k_p[1], 200.0, k_p[0], 30.0, 30.0, 30.0])
    if frame == "desired":
        M6[:3, :3], D6[:3, :3], K6[:3, :3] = m_d[0] * np.eye(3), k_d[0] * np.eye(3), k_p[0] * np.eye(3)
    ctl6 = fc.SpatialImpedanceController(PANDA, M6, D6, K6, frame=frame)
    h6 = np.concatenate([P @ H2, np.zeros(3)])
    a6 = _panda_acceleration(ctl6.step(0.0, Measurement(QP, qd, h6), _pose_reference(pose, OFFSET, VEL_D, ACC_D)), h6, qd)

    # the hand-written law too: ẍ = ẍ_d + M_d⁻¹ (K_D (ẋ_d − ẋ) + K_P x̃ − h)
    expected = ACC_D + (k_d * (VEL_D - xd2) + k_p * OFFSET - H2) / m_d
    np.testing.assert_allclose(a2, expected, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(P.T @ a6[:3], a2, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(a6[1], 0.0, atol=1e-8)  # base y: at rest on its set-point
    np.testing.assert_allclose(a6[3:], 0.0, atol=1e-8)  # no orientation error, rate or moment


def test_hybrid_compliant_9_77_and_its_6d_form_command_the_same_acceleration():
    """Force along planar x (λ: (9.81)–(9.82) with Ĉ), velocity along planar y (9.80) at the first
    sample (integral ∫(ν_d − ν) still 0); the 6-D form servoes the motion directions' pose error,
    here zero, with K_D = K_Pν, so the two laws ask for the same acceleration."""
    c, k_pv, k_pl, k_dl = 2e-4, 30.0, 400.0, 40.0
    x2, xd2 = _planar_state()
    sel = SelectionMatrices(E_X[:, None], E_Y[:, None])
    ctl2 = fc.HybridCompliantController(ARM, sel, c, k_pv, 1e-9, k_pl, k_dl)
    f_d, fd_rate, fd_acc = np.array([50.0, 0.0]), np.array([5.0, 0.0]), np.array([20.0, 0.0])
    ref2 = Reference(x2, VEL_D * E_Y, ACC_D * E_Y, f_d, fd_rate, fd_acc)
    h2 = np.array([35.0, 0.0])
    a2 = _planar_acceleration(ctl2.step(0.0, Measurement(Q2, QD2, h2), ref2), h2)

    pose, qd = _panda_state(xd2)
    R_d = euler_xyz_to_rotation(pose[3:])
    force_dir = np.concatenate([R_d.T @ (P @ E_X), np.zeros(3)])  # S_f in desired-frame coordinates
    ctl6 = fc.SpatialHybridController(PANDA, force_dir, c, 500.0 * np.eye(6), k_pv * np.eye(6), k_pl, k_dl)
    h6 = np.concatenate([P @ h2, np.zeros(3)])
    ref6 = _pose_reference(pose, np.zeros(2), VEL_D * E_Y, ACC_D * E_Y, f_d, fd_rate, fd_acc)
    a6 = _panda_acceleration(ctl6.step(0.0, Measurement(QP, qd, h6), ref6), h6, qd)

    # hand-written: along y ÿ = ÿ_d + K_Pν (ẏ_d − ẏ); along x ẍ = −c f_λ, λ̇ = −ẋ/c... in the
    # force's sign: the contact force grows as the tip moves into the plane (λ̇ = ẋ / c)
    lam_dot = xd2[0] / c
    f_lam = fd_acc[0] + k_dl * (fd_rate[0] - lam_dot) + k_pl * (f_d[0] - h2[0])
    expected = np.array([c * f_lam, ACC_D[1] + k_pv * (VEL_D[1] - xd2[1])])
    np.testing.assert_allclose(a2, expected, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(P.T @ a6[:3], a2, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(a6[1], 0.0, atol=1e-8)
    np.testing.assert_allclose(a6[3:], 0.0, atol=1e-8)


def test_active_compliance_8_110_and_its_6d_form_9_15_command_the_same_wrench():
    k_p, k_d = 800.0, 60.0
    x2, xd2 = _planar_state()
    ctl2 = fc.OperationalSpacePD(ARM, k_p, k_d)
    ref2 = Reference.setpoint(x2 + OFFSET)
    u2 = ctl2.step(0.0, Measurement(Q2, QD2, np.zeros(2)), ref2)
    gamma2 = np.linalg.solve(ARM.jacobian(Q2).T, u2 - ARM.gravity(Q2))

    pose, qd = _panda_state(xd2)
    K6 = np.diag([k_p] * 3 + [20.0] * 3)
    D6 = np.diag([k_d] * 3 + [2.0] * 3)
    ctl6 = fc.SpatialComplianceController(PANDA, K6, D6)
    u6 = ctl6.step(0.0, Measurement(QP, qd, np.zeros(6)), Reference.setpoint(_pose_reference(
        pose, OFFSET, np.zeros(2), np.zeros(2)).position))
    gamma6 = np.linalg.pinv(PANDA.spatial_jacobian(QP).T) @ (u6 - PANDA.gravity(QP))

    np.testing.assert_allclose(gamma2, k_p * OFFSET - k_d * xd2, rtol=1e-9)
    np.testing.assert_allclose(P.T @ gamma6[:3], gamma2, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(gamma6[[1, 3, 4, 5]], 0.0, atol=1e-8)


def _constrained(B, n, J, Jdq, s, u):
    """The arm on a rigid constraint ``sᵀ ẋ = 0`` (reaction ``s λ``): solve
    ``B q̈ + Jᵀ s λ = u − n``, ``sᵀ (J q̈ + J̇ q̇) = 0`` (Gauss's principle, written out here).
    Returns (ẍ, λ)."""
    nq = B.shape[0]
    A = np.zeros((nq + 1, nq + 1))
    A[:nq, :nq] = B
    A[:nq, nq] = J.T @ s
    A[nq, :nq] = s @ J
    sol = np.linalg.solve(A, np.concatenate([u - n, [-s @ Jdq]]))
    return J @ sol[:nq] + Jdq, sol[nq]


def test_hybrid_rigid_9_91_and_its_6d_form_give_the_same_motion_and_reaction():
    """Force/position hybrid (9.91), (9.93), (9.95) on a rigid plane (normal along planar x): both
    laws, applied to their arm held by the constraint, give ``ν̇ = α_ν`` along the plane and the
    reaction ``λ = f_λ = λ_d + K_Pλ (λ_d − λ_meas)``; the same numbers in 2-D and in 6-D."""
    k_dr, k_pr, k_pl = 30.0, 250.0, 0.5
    J2 = ARM.jacobian(Q2)
    qd2 = np.linalg.solve(J2, np.array([0.0, -0.15]))  # moving along the plane only
    x2 = ARM.forward_kinematics(Q2)
    xd2 = J2 @ qd2
    sel = SelectionMatrices(E_X[:, None], E_Y[:, None])
    ctl2 = fc.HybridRigidController(ARM, sel, motion="position", velocity_gain=k_dr, position_gain=k_pr,
                                    force_law="proportional", force_gain=k_pl)
    f_d = np.array([40.0, 0.0])
    h2 = np.array([32.0, 0.0])
    ref2 = Reference(x2 + OFFSET * E_Y, VEL_D * E_Y, ACC_D * E_Y, f_d, np.zeros(2), np.zeros(2))
    u2 = ctl2.step(0.0, Measurement(Q2, qd2, h2), ref2)
    a2, lam2 = _constrained(ARM.mass_matrix(Q2), ARM.nonlinear_effects(Q2, qd2), J2, ARM.jdot_qdot(Q2, qd2), E_X, u2)

    pose, qd = _panda_state(xd2)
    R_d = euler_xyz_to_rotation(pose[3:])
    normal = np.concatenate([P @ E_X, np.zeros(3)])  # base frame
    ctl6 = fc.SpatialHybridRigidController(
        PANDA, np.concatenate([R_d.T @ (P @ E_X), np.zeros(3)]), k_pr * np.eye(6), k_dr * np.eye(6),
        force_law="proportional", force_gain=k_pl)
    h6 = np.concatenate([P @ h2, np.zeros(3)])
    ref6 = _pose_reference(pose, OFFSET * E_Y, VEL_D * E_Y, ACC_D * E_Y, f_d)
    u6 = ctl6.step(0.0, Measurement(QP, qd, h6), ref6)
    a6, lam6 = _constrained(PANDA.mass_matrix(QP), PANDA.nonlinear_effects(QP, qd), PANDA.spatial_jacobian(QP),
                            PANDA.spatial_jdot_qdot(QP, qd), normal, u6)

    # hand-written closed loop: ÿ = ÿ_d + K_Dr (ẏ_d − ẏ) + K_Pr (y_d − y); ẍ = 0; λ = f_λ
    f_lam = f_d[0] + k_pl * (f_d[0] - h2[0])
    expected = np.array([0.0, ACC_D[1] + k_dr * (VEL_D[1] - xd2[1]) + k_pr * OFFSET[1]])
    np.testing.assert_allclose(a2, expected, rtol=1e-9, atol=1e-9)
    assert lam2 == pytest.approx(f_lam, rel=1e-9)
    np.testing.assert_allclose(P.T @ a6[:3], a2, rtol=1e-8, atol=1e-8)
    assert lam6 == pytest.approx(lam2, rel=1e-8)
    np.testing.assert_allclose(a6[[1, 3, 4, 5]], 0.0, atol=1e-8)
