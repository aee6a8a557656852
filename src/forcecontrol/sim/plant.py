"""The chapter's arm on a built-in environment, allocation-free: terms, wrench and the RK4 plant.

One integrator for every compiled loop (the single run of :mod:`forcecontrol.sim.loop` and the
sweeps' batch of :mod:`forcecontrol.sim.batch`): :func:`rk4_sample` integrates (9.1) over one
control sample with the torque held (zero-order hold) by ``nsub`` classical RK4 steps. The
Python loop of :mod:`forcecontrol.sim.simulation` is its reference (tests: agreement to round-off).

:func:`rk4_sample` is compiled once and called by every law's loop, not inlined in each: inlining
made each loop's compile redo the whole plant (Numba copies and types an inlined function's IR at
every use). Measured on a cold cache: the three laws of Example 9.3 compile in 9.0 s instead of
13.1 s, Example 9.2's first run is unchanged (3.9 s); the scalar batch kernel runs 0.200 instead of
0.191 µs per arm-step (the call is not inlined by LLVM), the same numbers to the bit. The lanes
kernel of the sweeps (:mod:`forcecontrol.sim.batch_lanes`) has its own plant and is unaffected.
"""

from __future__ import annotations

import math

from numba import njit

from ..core.linalg import solve2_spd
from ..environments.surfaces import circle_wrench2

__all__ = ["rk4_sample", "terms2", "wrench2", "fill_terms", "OK", "NONFINITE_STATE", "RUNAWAY", "SINGULAR", "NONFINITE_TORQUE"]

#: status codes of the compiled loops.
OK, NONFINITE_STATE, RUNAWAY, SINGULAR, NONFINITE_TORQUE = 0, 1, 2, 3, 4


@njit(cache=True)
def wrench2(env_kind, p, x0, x1, v0, v1):  # pragma: no cover - compiled
    """h_e of the built-in environments for m = 2 (same arithmetic as ``environment_wrench``)."""
    if env_kind == 1:
        n0 = p[0]
        n1 = p[1]
        delta = n0 * (p[2] - x0) + n1 * (p[3] - x1)
        if delta <= 0.0:
            return 0.0, 0.0
        vn = n0 * v0 + n1 * v1
        mag = p[4] * delta - p[5] * vn
        if mag <= 0.0:
            return 0.0, 0.0
        return -mag * n0, -mag * n1
    if env_kind == 2:
        e0 = x0 - p[8]
        e1 = x1 - p[9]
        h0 = (p[0] * e0 + p[1] * e1) + (p[4] * v0 + p[5] * v1)
        h1 = (p[2] * e0 + p[3] * e1) + (p[6] * v0 + p[7] * v1)
        return h0, h1
    if env_kind == 3:  # an elastic circle [c0, c1, R, k, c] (environments.surfaces.circle_wrench2)
        return circle_wrench2(p, x0, x1, v0, v1)
    return math.nan, math.nan


@njit(cache=True, inline="always")
def terms2_scalars(K, q0, q1, w0, w1):  # pragma: no cover - compiled
    """The arm's terms at (q, q̇) as scalars: (x0, x1, xd0, xd1, J00, J01, J10, J11, Jdq0, Jdq1,
    B00, B01, B11, n0, n1, g0, g1) (the expressions of ``planar_2r._terms_into``; cos/sin(q1 + q2)
    by the angle-sum formulas). Inlined: a caller that needs only some of them pays for those only."""
    a1 = K[0]
    a2 = K[1]
    c1 = math.cos(q0)
    s1 = math.sin(q0)
    c2 = math.cos(q1)
    s2 = math.sin(q1)
    c12 = c1 * c2 - s1 * s2  # cos(q1 + q2), four trigonometric calls instead of six
    s12 = s1 * c2 + c1 * s2
    x0 = a1 * c1 + a2 * c12
    x1 = a1 * s1 + a2 * s12
    j00 = -a1 * s1 - a2 * s12
    j01 = -a2 * s12
    j10 = a1 * c1 + a2 * c12
    j11 = a2 * c12
    u12 = w0 + w1
    jdq0 = -a1 * c1 * w0 * w0 - a2 * c12 * u12 * u12
    jdq1 = -a1 * s1 * w0 * w0 - a2 * s12 * u12 * u12
    h = -K[7] * s2
    g0 = K[8] * c1 + K[9] * c12
    g1 = K[9] * c12
    return (x0, x1, j00 * w0 + j01 * w1, j10 * w0 + j11 * w1, j00, j01, j10, j11, jdq0, jdq1,
            K[2] + K[3] * c2, K[4] + K[5] * c2, K[6],
            h * w1 * w0 + h * (w0 + w1) * w1 + K[10] * w0 + g0, -h * w0 * w0 + K[11] * w1 + g1, g0, g1)


@njit(cache=True)
def terms2(K, q0, q1, w0, w1, T):  # pragma: no cover - compiled
    """Fill T = [x0, x1, xd0, xd1, J00, J01, J10, J11, Jdq0, Jdq1, B00, B01, B11, n0, n1, g0, g1]
    (:func:`terms2_scalars`)."""
    (T[0], T[1], T[2], T[3], T[4], T[5], T[6], T[7], T[8], T[9], T[10], T[11], T[12], T[13], T[14],
     T[15], T[16]) = terms2_scalars(K, q0, q1, w0, w1)


@njit(cache=True)
def _accel_terms2(T, h0, h1, u0, u1):  # pragma: no cover - compiled
    """q̈ = B⁻¹ (u − n − Jᵀ h_e) from filled terms T and the wrench; returns (ok, a0, a1)."""
    r0 = u0 - T[13] - T[4] * h0 - T[6] * h1
    r1 = u1 - T[14] - T[5] * h0 - T[7] * h1
    return solve2_spd(T[10], T[11], T[12], r0, r1)


@njit(cache=True, inline="always")
def _accel2(K, env_kind, env_p, q0, q1, w0, w1, u0, u1):  # pragma: no cover - compiled
    """q̈ = B⁻¹ (u − n − Jᵀ h_e) of the arm on the environment, on scalars; returns (ok, a0, a1)."""
    x0, x1, xd0, xd1, j00, j01, j10, j11, _, _, b00, b01, b11, n0, n1, _, _ = terms2_scalars(K, q0, q1, w0, w1)
    h0, h1 = wrench2(env_kind, env_p, x0, x1, xd0, xd1)
    return solve2_spd(b00, b01, b11, u0 - n0 - j00 * h0 - j10 * h1, u1 - n1 - j01 * h0 - j11 * h1)


@njit(cache=True)
def rk4_sample(K, env_kind, env_p, q_0, q_1, w_0, w_1, u0, u1, T, h0, h1, Ts, nsub):  # pragma: no cover
    """Integrate (9.1), ``B q̈ = u − n − Jᵀ h_e``, over one sample Ts with u held, by ``nsub`` RK4 steps.

    ``T`` holds the terms of the sample's state (and ``h0, h1`` its wrench), so the first stage
    reuses them; the other stages run on scalars and allocate nothing. Returns (ok, q0, q1, q̇0,
    q̇1); ok is False when a stage produced a non-finite acceleration.
    """
    dt = Ts / nsub
    hdt = 0.5 * dt
    sdt = dt / 6.0
    for j in range(nsub):
        if j == 0:  # the state of the sample: its terms and wrench are already in T, h
            ok, a10, a11 = _accel_terms2(T, h0, h1, u0, u1)
        else:
            ok, a10, a11 = _accel2(K, env_kind, env_p, q_0, q_1, w_0, w_1, u0, u1)
        # stages 2, 3, 4 through one call of the inlined _accel2 (Numba copies and types an inlined function at each
        # call site: one site instead of three, 0.5 s less to compile, the same speed): stage s is at q + c ṽ,
        # q̇ + c ã, with (c, ṽ, ã) = (dt/2, q̇, a1), (dt/2, v2, a2), (dt, v3, a3)
        v20 = v21 = v30 = v31 = v40 = v41 = 0.0
        a20 = a21 = a30 = a31 = a40 = a41 = 0.0
        pv0, pv1, pa0, pa1 = w_0, w_1, a10, a11
        for s in range(3):
            c = dt if s == 2 else hdt
            vs0 = w_0 + c * pa0
            vs1 = w_1 + c * pa1
            oks, as0, as1 = _accel2(K, env_kind, env_p, q_0 + c * pv0, q_1 + c * pv1, vs0, vs1, u0, u1)
            ok = ok and oks
            if s == 0:
                v20, v21, a20, a21 = vs0, vs1, as0, as1
            elif s == 1:
                v30, v31, a30, a31 = vs0, vs1, as0, as1
            else:
                v40, v41, a40, a41 = vs0, vs1, as0, as1
            pv0, pv1, pa0, pa1 = vs0, vs1, as0, as1
        if not ok:
            return False, q_0, q_1, w_0, w_1
        q_0 += sdt * (w_0 + 2.0 * v20 + 2.0 * v30 + v40)
        q_1 += sdt * (w_1 + 2.0 * v21 + 2.0 * v31 + v41)
        w_0 += sdt * (a10 + 2.0 * a20 + 2.0 * a30 + a40)
        w_1 += sdt * (a11 + 2.0 * a21 + 2.0 * a31 + a41)
    return True, q_0, q_1, w_0, w_1


@njit(cache=True, inline="always")
def fill_terms(T, q_0, q_1, w_0, w_1, q, qd, x, xd, J, Jdq, B, nv, g):  # pragma: no cover - compiled
    """Copy the scalar terms T of :func:`terms2` into the arrays a control law reads."""
    q[0], q[1], qd[0], qd[1] = q_0, q_1, w_0, w_1
    x[0], x[1], xd[0], xd[1] = T[0], T[1], T[2], T[3]
    J[0, 0], J[0, 1], J[1, 0], J[1, 1] = T[4], T[5], T[6], T[7]
    Jdq[0], Jdq[1] = T[8], T[9]
    B[0, 0], B[0, 1], B[1, 0], B[1, 1] = T[10], T[11], T[11], T[12]
    nv[0], nv[1], g[0], g[1] = T[13], T[14], T[15], T[16]
