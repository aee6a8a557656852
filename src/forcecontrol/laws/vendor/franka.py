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
        p: ``[K_target (m), D_target (m), k_ns_target, Δτ_max, a, λ, q_ns (n)]``.
        s: state, advanced in place: ``[K (m), D (m), k_ns, τ_J_d (n)]``.
        u: (n,) the commanded torques (gravity excluded), written in place.
    """
    m = J.shape[0]
    n = J.shape[1]
    Kt = p[0:m]
    Dt = p[m : 2 * m]
    kns_t = p[2 * m]
    dtau = p[2 * m + 1]
    a = p[2 * m + 2]
    lam = p[2 * m + 3]
    q_ns = p[2 * m + 4 : 2 * m + 4 + n]
    K = s[0:m]
    D = s[m : 2 * m]
    kns = s[2 * m]
    tau_prev = s[2 * m + 1 : 2 * m + 1 + n]
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
    s[2 * m] = a * kns_t + (1.0 - a) * kns
