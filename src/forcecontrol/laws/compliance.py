"""Active compliance: PD control with gravity compensation, operational (8.110) and joint (8.51)."""

from __future__ import annotations

from numba import njit

from .pd import pd_action


@njit(cache=True, inline="always")
def os_pd(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, ws, u):  # pragma: no cover - compiled
    """(8.110), (9.15): ``u = g(q) + Jᵀ(q) (K_P (x_d − x_e) − K_D J(q) q̇)``.

    In contact the equilibrium is (9.2)–(9.4), ``K_P (x_d − x_e) = h_A``.
    ``p = [K_P (m²), K_D (m²)]``, row-major; no state.
    """
    m = x.shape[0]
    n = q.shape[0]
    e = ws[0:m]
    for j in range(m):
        e[j] = ref[j] - x[j]
    w = ws[m : 2 * m]
    pd_action(p, 0, e, m * m, xd, -1.0, w)
    for i in range(n):
        acc = 0.0
        for j in range(m):
            acc += J[j, i] * w[j]
        u[i] = g[i] + acc
    return True


@njit(cache=True, inline="always")
def joint_pd(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, ws, u):  # pragma: no cover - compiled
    """(8.51): ``u = g(q) + K_P (q_d − q) − K_D q̇``; in contact its equilibrium is (9.24).

    ``p = [K_P (n²), K_D (n²), q_d (n)]``, row-major; no state.
    """
    n = q.shape[0]
    nn = n * n
    e = ws[0:n]
    for j in range(n):
        e[j] = p[2 * nn + j] - q[j]
    pd_action(p, 0, e, nn, qd, -1.0, u)
    for i in range(n):
        u[i] = g[i] + u[i]
    return True
