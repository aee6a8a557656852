"""ros2_controllers ``admittance_controller``: the admittance rule, its wrench filter and gravity compensation.

Read from ros-controls/ros2_controllers at commit 94e74de3 (2026-08-18, package 6.9.0, Apache-2.0):
``admittance_controller/include/admittance_controller/admittance_rule_impl.hpp``
(``calculate_admittance_rule``, ``process_wrench_measurements``, ``apply_parameters_update``),
``src/admittance_controller_parameters.yaml``; the damped inverse from
ros-controls/kinematics_interface ``kinematics_interface_kdl`` (``convert_cartesian_deltas_to_joint_deltas``)
and the filter from ros-controls/control_toolbox ``filters.hpp`` (``exponentialSmoothing``).
Written anew in the library's notation (survey of issue 30, §1); no code copied.

Sign: the project's sensor wrench is the wrench exerted *on* the robot (a hanging payload reads
``(0, 0, −m g)``), i.e. ``−h_e`` of the chapter; its wrench reference is added to the
measurement, so the loop settles where the robot exerts ``h_e = w_ref`` on the environment.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .layout import (
    ROS2_ADMITTANCE_MASS,
    ROS2_ADMITTANCE_STATE_Q_A,
    ros2_admittance_damping,
    ros2_admittance_dls_alpha,
    ros2_admittance_filter_coefficient,
    ros2_admittance_joint_damping,
    ros2_admittance_selected,
    ros2_admittance_state_qd_a,
    ros2_admittance_state_w_f,
    ros2_admittance_state_xd,
    ros2_admittance_stiffness,
)


@njit(cache=True)
def exponential_smoothing(w_in, alpha, w_f):  # pragma: no cover - compiled
    """``w_f ← α w_in + (1 − α) w_f`` per component, in place (control_toolbox ``exponentialSmoothing``).

    A first-order discrete low-pass with its pole at ``z = 1 − α``: time constant
    ``τ_f = −T / ln(1 − α)`` seconds at the controller's period T (so it changes with the rate).
    """
    for i in range(w_f.shape[0]):
        w_f[i] = alpha * w_in[i] + (1.0 - alpha) * w_f[i]


@njit(cache=True)
def gravity_compensate(w, R_w_cog, p_cog, weight):  # pragma: no cover - compiled
    """The payload's weight removed from a world-frame wrench ``w = [f; τ]`` (6,), on the robot, in place.

    ``W = (0, 0, −weight)`` (``gravity_compensation.CoG.force`` = m g, gravity along −z of the
    world frame): ``f ← f − W`` and ``τ ← τ − (R_w,cog p_cog) × W``. As in the project, the lever
    arm is ``p_cog`` rotated into the world frame with no offset between the sensor and the CoG
    frame's origins (the two frames are assumed to share an origin).
    """
    r0 = R_w_cog[0, 0] * p_cog[0] + R_w_cog[0, 1] * p_cog[1] + R_w_cog[0, 2] * p_cog[2]
    r1 = R_w_cog[1, 0] * p_cog[0] + R_w_cog[1, 1] * p_cog[1] + R_w_cog[1, 2] * p_cog[2]
    # r × W with W = (0, 0, −weight): (r1 (−weight), −r0 (−weight), 0)
    w[2] = w[2] + weight
    w[3] = w[3] - r1 * (-weight)
    w[4] = w[4] - (-r0) * (-weight)


@njit(cache=True)
def ros2_admittance_rule(dt, J, R, x, w, p, s):  # pragma: no cover - compiled
    """One cycle of ``calculate_admittance_rule``: the joint offsets ``q_a`` and rates ``q̇_a`` advanced by dt.

    With m task rows (6 in the project; fewer for the closed-form twins) and n joints:

    1. wrench filter (in the world frame, here the base): ``w_f ← α w + (1 − α) w_f``;
    2. in the control frame ``R`` (block-diagonal rotation of ``control.frame`` in the base,
       (m, m)): ``F_c = S Rᵀ w_f`` (S = ``selected_axes``: only the wrench is masked),
       ``ẍ = R M⁻¹ (F_c − D Rᵀ ẋ − K Rᵀ x)`` with ``ẋ`` the admittance velocity of the previous
       cycle (``J q̇_a``) and ``x`` the displacement of the sensor frame, *measured* pose minus
       reference pose (the spring acts on the measured pose);
       ``D = damping_ratio · 2 sqrt(mass · stiffness)`` per axis (the controller computes it);
    3. damped least squares at the sensor frame: ``q̈_a = (JᵀJ + α_k I)⁻¹ Jᵀ ẍ − c_j q̇_a``
       (``kinematics.alpha``, ``admittance.joint_damping``);
    4. semi-implicit Euler in joint space: ``q̇_a ← q̇_a + T q̈_a``, ``q_a ← q_a + T q̇_a``;
       ``ẋ ← J q̇_a`` for the next cycle.

    The command is then ``q_cmd = q_ref + q_a`` (``q̇_cmd = q̇_ref + q̇_a``).

    Args:
        dt: the controller's period T [s].
        J: (m, n) Jacobian of the sensor frame at the measured joints (base-frame twist).
        R: (m, m) rotation of the control frame in the base frame (``blockdiag(R, R)`` for m = 6).
        x: (m,) displacement measured − reference (rotation part: angle·axis) [m, rad].
        w: (m,) wrench on the robot in the base frame, gravity-compensated, plus the wrench
            reference [N, N m].
        p: ``layout.ROS2_ADMITTANCE``: ``[mass (m), damping (m), stiffness (m), selected (m; 1 or 0),
            joint_damping, filter_coefficient, dls_alpha]``.
        s: state (``layout.ROS2_ADMITTANCE_STATE``), advanced in place: ``[q_a (n), q̇_a (n), ẋ (m), w_f (m)]``.

    Returns:
        False when ``JᵀJ + α_k I`` cannot be solved (the state is then unchanged: the project
        writes the reference unchanged when a kinematics call fails).
    """
    m = J.shape[0]
    n = J.shape[1]
    o_d, o_k, o_s = ros2_admittance_damping(m), ros2_admittance_stiffness(m), ros2_admittance_selected(m)
    mass = p[ROS2_ADMITTANCE_MASS : ROS2_ADMITTANCE_MASS + m]
    damp = p[o_d : o_d + m]
    stiff = p[o_k : o_k + m]
    sel = p[o_s : o_s + m]
    c_j = p[ros2_admittance_joint_damping(m)]
    alpha = p[ros2_admittance_filter_coefficient(m)]
    dls = p[ros2_admittance_dls_alpha(m)]
    o_qd, o_xd, o_wf = ros2_admittance_state_qd_a(m, n), ros2_admittance_state_xd(m, n), ros2_admittance_state_w_f(m, n)
    qa = s[ROS2_ADMITTANCE_STATE_Q_A : ROS2_ADMITTANCE_STATE_Q_A + n]
    qda = s[o_qd : o_qd + n]
    xd = s[o_xd : o_xd + m]
    wf = s[o_wf : o_wf + m]
    wf_new = np.empty(m)
    for i in range(m):
        wf_new[i] = alpha * w[i] + (1.0 - alpha) * wf[i]
    acc_c = np.empty(m)
    for i in range(m):  # in the control frame: Rᵀ w_f, Rᵀ ẋ, Rᵀ x
        fc = 0.0
        vc = 0.0
        xc = 0.0
        for j in range(m):
            fc += R[j, i] * wf_new[j]
            vc += R[j, i] * xd[j]
            xc += R[j, i] * x[j]
        acc_c[i] = (sel[i] * fc - damp[i] * vc - stiff[i] * xc) / mass[i]
    acc = R @ acc_c
    A = J.T @ J
    for i in range(n):
        A[i, i] += dls
    rhs = J.T @ acc
    if not np.all(np.isfinite(A)) or abs(np.linalg.det(A)) < 1e-300:
        return False
    qdd = np.linalg.solve(A, rhs)
    for i in range(n):
        qdd[i] -= c_j * qda[i]
        qda[i] += dt * qdd[i]
        qa[i] += dt * qda[i]
    v = J @ qda
    for i in range(m):
        xd[i] = v[i]
        wf[i] = wf_new[i]
    return True
