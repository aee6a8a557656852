"""Active compliance: PD control with gravity compensation, operational (8.110) and joint (8.51)."""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def os_pd(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, ws, u):  # pragma: no cover - compiled
    """(8.110), (9.15): ``u = g(q) + Jᵀ(q) (K_P (x_d − x_e) − K_D J(q) q̇)``.

    In contact the equilibrium is (9.2)–(9.4), ``K_P (x_d − x_e) = h_A``.
    ``p = [K_P (m²), K_D (m²)]``, row-major; no state.
    """
    m = x.shape[0]
    n = q.shape[0]
    mm = m * m
    w = ws[0:m]
    for i in range(m):
        kp = 0.0
        kd = 0.0
        for j in range(m):
            kp += p[i * m + j] * (ref[j] - x[j])
            kd += p[mm + i * m + j] * xd[j]
        w[i] = kp - kd
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
    for i in range(n):
        kp = 0.0
        kd = 0.0
        for j in range(n):
            kp += p[i * n + j] * (p[2 * nn + j] - q[j])
            kd += p[nn + i * n + j] * qd[j]
        u[i] = g[i] + kp - kd
    return True
