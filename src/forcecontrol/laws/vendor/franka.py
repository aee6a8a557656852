"""franka_ros ``cartesian_impedance_example_controller``: Cartesian impedance on the torque interface.

Read from frankaemika/franka_ros (ROS 1) at c11f000c (2024-03-28, Apache-2.0):
``franka_example_controllers/src/cartesian_impedance_example_controller.cpp`` (``update``,
``saturateTorqueRate``), ``include/franka_example_controllers/pseudo_inversion.h`` (damped SVD
pseudo-inverse, λ = 0.2) and ``cfg/compliance_param.cfg`` (the parameters' defaults and ranges).
franka_ros2 at 40cf08b6 has no Cartesian impedance example. Written anew in the library's
notation (survey of issue 30, §3); no code copied.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .layout import (
    FRANKA_K,
    FRANKA_STATE_K,
    franka_D,
    franka_delta_tau_max,
    franka_filter,
    franka_k_ns,
    franka_pinv_damping,
    franka_q_ns,
    franka_state_D,
    franka_state_k_ns,
    franka_state_tau_J_d,
)


@njit(cache=True)
def franka_impedance_torque(J, e, qd, q, coriolis, p, s, u):  # pragma: no cover - compiled
    """One 1-ms cycle: ``u = τ_J_d + clamp(τ_d − τ_J_d, ±Δτ_max)``, then the gains filtered towards their targets.

    ::

        τ_task = Jᵀ (−K e − D J q̇)                      (e = [p − p_d; e_o], base frame)
        τ_ns   = (I − Jᵀ J^{T+}) (k_ns (q_ns − q) − 2 sqrt(k_ns) q̇)
        τ_d    = τ_task + τ_ns + C(q, q̇) q̇               (the robot adds gravity itself)

    with ``J^{T+} = (J Jᵀ + λ² I)⁻¹ J`` (the damped SVD pseudo-inverse ``σ/(σ² + λ²)`` of Jᵀ,
    written in closed form), ``τ_J_d`` the previous cycle's commanded torque and the damping
    ``D = 2 sqrt(K)`` per axis ("damping ratio 1", i.e. critical for a *unit* apparent mass).
    After the command, K, D and k_ns move towards their targets: ``y ← a y_target + (1 − a) y``
    (a = ``filter_params_`` = 0.005 per cycle; the pose target is filtered the same way by the
    caller). The controller starts with K = D = 0 (a soft start).

    Args:
        J: (m, n) zero Jacobian of the end effector; e: (m,) the pose error (position minus
            desired; orientation ``−R vec(quat⁻¹ ⊗ quat_d)``); qd, q: (n,); coriolis: (n,) C q̇.
        p: ``layout.FRANKA``: ``[K_target (m), D_target (m), k_ns_target, Δτ_max, a, λ, q_ns (n)]``.
        s: state (``layout.FRANKA_STATE``), advanced in place: ``[K (m), D (m), k_ns, τ_J_d (n)]``.
        u: (n,) the commanded torques (gravity excluded), written in place.
    """
    m = J.shape[0]
    n = J.shape[1]
    o_D, o_q, o_sD, o_tau = franka_D(m, n), franka_q_ns(m, n), franka_state_D(m, n), franka_state_tau_J_d(m, n)
    Kt = p[FRANKA_K : FRANKA_K + m]
    Dt = p[o_D : o_D + m]
    kns_t = p[franka_k_ns(m, n)]
    dtau = p[franka_delta_tau_max(m, n)]
    a = p[franka_filter(m, n)]
    lam = p[franka_pinv_damping(m, n)]
    q_ns = p[o_q : o_q + n]
    K = s[FRANKA_STATE_K : FRANKA_STATE_K + m]
    D = s[o_sD : o_sD + m]
    o_kns = franka_state_k_ns(m, n)
    kns = s[o_kns]
    tau_prev = s[o_tau : o_tau + n]
    v = J @ qd
    w = np.empty(m)
    for i in range(m):
        w[i] = -K[i] * e[i] - D[i] * v[i]
    tau = J.T @ w
    A = J @ J.T
    for i in range(m):
        A[i, i] += lam * lam
    JTp = np.linalg.solve(A, J)  # (m, n): J^{T+}
    N = np.eye(n) - J.T @ JTp
    y = np.empty(n)
    d_ns = 2.0 * np.sqrt(kns)
    for i in range(n):
        y[i] = kns * (q_ns[i] - q[i]) - d_ns * qd[i]
    tau = tau + N @ y
    for i in range(n):
        d = tau[i] + coriolis[i] - tau_prev[i]
        if d > dtau:
            d = dtau
        elif d < -dtau:
            d = -dtau
        u[i] = tau_prev[i] + d
        tau_prev[i] = u[i]
    for i in range(m):
        K[i] = a * Kt[i] + (1.0 - a) * K[i]
        D[i] = a * Dt[i] + (1.0 - a) * D[i]
    s[o_kns] = a * kns_t + (1.0 - a) * kns
