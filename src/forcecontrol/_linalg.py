"""Small dense linear algebra for compiled kernels.

NumPy's BLAS/LAPACK calls cost microseconds of overhead on 2x2 to 7x7 problems; these loops cost
tens of nanoseconds inside Numba. They are used by the control laws and the simulator's plant so
that one law serves both the Python path and the compiled loop.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["mv", "mtv", "solve_into", "SINGULAR_RCOND"]

#: a pivot smaller than this times the matrix's largest entry counts as singular.
SINGULAR_RCOND = 1e-10


@njit(cache=True, fastmath=False)
def mv(A: np.ndarray, x: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Return ``A @ x`` for a small dense matrix."""
    r, c = A.shape
    out = np.zeros(r)
    for i in range(r):
        s = 0.0
        for j in range(c):
            s += A[i, j] * x[j]
        out[i] = s
    return out


@njit(cache=True, fastmath=False)
def mtv(A: np.ndarray, x: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Return ``A.T @ x`` for a small dense matrix."""
    r, c = A.shape
    out = np.zeros(c)
    for j in range(c):
        s = 0.0
        for i in range(r):
            s += A[i, j] * x[i]
        out[j] = s
    return out


@njit(cache=True, fastmath=False)
def solve_into(A: np.ndarray, b: np.ndarray, out: np.ndarray) -> bool:  # pragma: no cover - compiled
    """Solve ``A x = b`` by Gaussian elimination with partial pivoting, writing ``x`` into ``out``.

    Returns:
        False when ``A`` is numerically singular (a pivot below ``SINGULAR_RCOND`` times the
        largest entry); ``out`` is then left undefined.
    """
    n = A.shape[0]
    M = A.copy()
    x = b.copy()
    scale = 0.0
    for i in range(n):
        for j in range(n):
            v = abs(M[i, j])
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
            s -= M[i, j] * out[j]
        out[i] = s / M[i, i]
    return True
