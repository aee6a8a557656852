"""The inverse-dynamics inner loop (9.30), shared by every inverse-dynamics scheme."""

from __future__ import annotations

import math

from numba import njit

from .._linalg import solve_in_place


@njit(cache=True, inline="always")
def inverse_dynamics(B, nv, J, Jdq, a, hc, compensate, ws, u):  # pragma: no cover - compiled
    """(9.30): ``u = B(q) y + n(q, q̇) [+ Jᵀ(q) h_c]`` with ``y = J⁻¹(q) (a − J̇ q̇)``.

    The operational-space acceleration ``a`` is what each scheme chooses: impedance (9.28)/(9.31),
    inner position loop (9.39), inner velocity loop (9.45), parallel (9.48), hybrid (9.77)/(9.91).
    ``h_c`` is the measured wrench h_e (it cancels the contact force, (9.30)) or, on a rigid
    environment, the commanded ``S_f f_λ`` of (9.91).

    Args:
        B: inertia matrix (n, n); nv: ``C q̇ + F q̇ + g`` (n,); J: the Jacobian, square (m, m);
            Jdq: ``J̇ q̇`` (m,); a: the requested acceleration (m,); hc: the wrench to compensate (m,).
        compensate: add ``Jᵀ h_c``.
        ws: scratch of at least m² + m floats.
        u: the torques (n,), written.

    Returns:
        False (and u = NaN) when J is numerically singular.
    """
    m = a.shape[0]
    n = B.shape[0]
    y = ws[0:m]
    for i in range(m):
        y[i] = a[i] - Jdq[i]
    if not solve_in_place(J, y, ws[m : m + m * m]):
        for i in range(n):
            u[i] = math.nan
        return False
    for i in range(n):
        acc = nv[i]
        for j in range(n):
            acc += B[i, j] * y[j]
        u[i] = acc
    if compensate:
        for i in range(n):
            acc = 0.0
            for j in range(m):
                acc += J[j, i] * hc[j]
            u[i] += acc
    return True
