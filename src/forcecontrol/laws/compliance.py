"""Active compliance: PD control with gravity compensation, operational (8.110) and joint (8.51)."""

from __future__ import annotations

from numba import njit

from .layout import JOINT_PD_K_P, OS_PD_K_P, REF_X_D, joint_pd_K_D, joint_pd_q_d, os_pd_K_D
from .pd import pd_action


@njit(cache=True, inline="always")
def os_pd(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, ws, u):  # pragma: no cover - compiled
    """(8.110), (9.15): ``u = g(q) + Jᵀ(q) (K_P (x_d − x_e) − K_D J(q) q̇)``.

    In contact the equilibrium is (9.2)–(9.4), ``K_P (x_d − x_e) = h_A``.
    ``p``: :data:`~forcecontrol.laws.layout.OS_PD`; ``ref``: x_d of
    :data:`~forcecontrol.laws.layout.REFERENCE`; no state.
    """
    m = x.shape[0]
    n = q.shape[0]
    e = ws[0:m]
    for j in range(m):
        e[j] = ref[REF_X_D + j] - x[j]
    w = ws[m : 2 * m]
    pd_action(p, OS_PD_K_P, e, os_pd_K_D(m), xd, -1.0, w)
    for i in range(n):
        acc = 0.0
        for j in range(m):
            acc += J[j, i] * w[j]
        u[i] = g[i] + acc
    return True


@njit(cache=True, inline="always")
def joint_pd(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, ws, u):  # pragma: no cover - compiled
    """(8.51): ``u = g(q) + K_P (q_d − q) − K_D q̇``; in contact its equilibrium is (9.24).

    ``p``: :data:`~forcecontrol.laws.layout.JOINT_PD` (in the number of joints n); no state.
    """
    n = q.shape[0]
    e = ws[0:n]
    for j in range(n):
        e[j] = p[joint_pd_q_d(n) + j] - q[j]
    pd_action(p, JOINT_PD_K_P, e, joint_pd_K_D(n), qd, -1.0, u)
    for i in range(n):
        u[i] = g[i] + u[i]
    return True
