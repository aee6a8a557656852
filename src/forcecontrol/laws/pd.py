"""The proportional-derivative action every law of the chapter is built on."""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def pd_action(G, o_P, e, o_D, v, sign_D, out):  # pragma: no cover - compiled
    """``out = K_P e + sign_D K_D v``, K_P and K_D the row-major (m, m) blocks of G at offsets o_P and o_D.

    The stiffness and damping terms of (8.110), (8.51), (9.28)/(9.31), (9.35), (9.39), (9.45) and
    (9.48) (``sign_D = −1`` with v a velocity, ``+1`` with v an error rate).
    """
    m = out.shape[0]
    for i in range(m):
        kp = 0.0
        kd = 0.0
        for j in range(m):
            kp += G[o_P + i * m + j] * e[j]
            kd += G[o_D + i * m + j] * v[j]
        out[i] = kp + sign_D * kd
