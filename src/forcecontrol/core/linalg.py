"""Small dense linear algebra for compiled kernels.

NumPy's BLAS/LAPACK calls cost microseconds of overhead on 2x2 to 7x7 problems; these loops cost
tens of nanoseconds inside Numba. They are used by the control laws and the simulator's plant so
that one law serves both the Python path and the compiled loop.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["mv", "mv_into", "solve2", "solve2_spd", "solve_into", "solve_in_place", "SINGULAR_RCOND"]

#: a pivot smaller than this times the matrix's largest entry counts as singular.
SINGULAR_RCOND = 1e-10


@njit(cache=True, fastmath=False, inline="always")
def mv_into(A: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out = A @ x`` without allocating (``out`` must not alias ``x``)."""
    r, c = A.shape
    for i in range(r):
        s = 0.0
        for j in range(c):
            s += A[i, j] * x[j]
        out[i] = s


@njit(cache=True, fastmath=False)
def mv(A: np.ndarray, x: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Return ``A @ x`` for a small dense matrix (a new array; see :func:`mv_into`)."""
    out = np.zeros(A.shape[0])
    mv_into(A, x, out)
    return out


@njit(cache=True, fastmath=False, inline="always")
def solve2(a00, a01, a10, a11, b0, b1):  # pragma: no cover - compiled
    """``A x = b`` for a 2×2 A on scalars: :func:`solve_in_place`'s pivoting and arithmetic for n = 2.

    Returns (ok, x0, x1); ok is False when A is numerically singular.
    """
    scale = max(abs(a00), abs(a01), abs(a10), abs(a11))
    if scale == 0.0 or not np.isfinite(scale):
        return False, 0.0, 0.0
    big = abs(a00)
    if abs(a10) > big:
        big = abs(a10)
        a00, a01, a10, a11 = a10, a11, a00, a01
        b0, b1 = b1, b0
    if big <= SINGULAR_RCOND * scale:
        return False, 0.0, 0.0
    f = a10 / a00
    if f != 0.0:
        a11 -= f * a01
        b1 -= f * b0
    if abs(a11) <= SINGULAR_RCOND * scale:
        return False, 0.0, 0.0
    x1 = b1 / a11
    return True, (b0 - a01 * x1) / a00, x1


@njit(cache=True, inline="always")
def solve2_spd(a00, a01, a11, b0, b1):  # pragma: no cover - compiled
    """``A x = b`` for a symmetric positive definite 2×2 ``A = [[a00, a01], [a01, a11]]`` (an arm's
    inertia), by its inverse: ``1/det`` depends on A only, so b (in the plant: the torques and the
    contact wrench, known last) meets one multiplication and no division, where :func:`solve2`'s
    pivoting puts two divisions in a row. Returns (ok, x0, x1); ok is False when A is not
    numerically positive definite."""
    scale = max(abs(a00), abs(a01), abs(a11))
    det = a00 * a11 - a01 * a01
    if not (det > SINGULAR_RCOND * scale * scale and np.isfinite(det)):
        return False, 0.0, 0.0
    inv = 1.0 / det
    return True, (a11 * b0 - a01 * b1) * inv, (a00 * b1 - a01 * b0) * inv


@njit(cache=True, fastmath=False, inline="always")
def solve_in_place(A: np.ndarray, x: np.ndarray, scratch: np.ndarray) -> bool:  # pragma: no cover - compiled
    """Solve ``A y = x`` by Gaussian elimination with partial pivoting, overwriting ``x`` with y.

    ``scratch`` holds at least n² floats (A is copied into it); nothing is allocated.

    Returns:
        False when ``A`` is numerically singular (a pivot below ``SINGULAR_RCOND`` times the
        largest entry); ``x`` is then left undefined.
    """
    n = A.shape[0]
    if n == 2:  # the chapter's arm: the same elimination on scalars (no scratch, ~4x faster)
        ok, x[0], x[1] = solve2(A[0, 0], A[0, 1], A[1, 0], A[1, 1], x[0], x[1])
        return ok
    M = scratch[: n * n].reshape((n, n))
    scale = 0.0
    for i in range(n):
        for j in range(n):
            v = A[i, j]
            M[i, j] = v
            v = abs(v)
            if v > scale:
                scale = v
    if scale == 0.0 or not np.isfinite(scale):
        return False
    for k in range(n):
        p = k
        big = abs(M[k, k])
        for i in range(k + 1, n):
            v = abs(M[i, k])
            if v > big:
                big = v
                p = i
        if big <= SINGULAR_RCOND * scale:
            return False
        if p != k:
            for j in range(n):
                tmp = M[k, j]
                M[k, j] = M[p, j]
                M[p, j] = tmp
            tmp = x[k]
            x[k] = x[p]
            x[p] = tmp
        for i in range(k + 1, n):
            f = M[i, k] / M[k, k]
            if f != 0.0:
                for j in range(k, n):
                    M[i, j] -= f * M[k, j]
                x[i] -= f * x[k]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for j in range(i + 1, n):
            s -= M[i, j] * x[j]
        x[i] = s / M[i, i]
    return True


@njit(cache=True, fastmath=False)
def solve_into(A: np.ndarray, b: np.ndarray, out: np.ndarray) -> bool:  # pragma: no cover - compiled
    """Solve ``A x = b`` writing ``x`` into ``out`` (:func:`solve_in_place` on a copy of b).

    Returns:
        False when ``A`` is numerically singular; ``out`` is then left undefined.
    """
    n = A.shape[0]
    for i in range(n):
        out[i] = b[i]
    return solve_in_place(A, out, np.empty(n * n))
