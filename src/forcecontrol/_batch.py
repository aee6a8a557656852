"""Many closed loops of the chapter's arm at once: an allocation-free compiled kernel.

The per-case loop is the sampled loop of :mod:`forcecontrol.simulation` (sensor, controller,
zero-order hold, RK4 plant), written with scalars for the two-link arm (m = n = 2) so that a step
allocates nothing: about 0.2 µs per control step with one RK4 substep instead of the few µs of
the general compiled loop. The control laws of the built-in controllers (kinds 1-6: operational
and joint PD (8.110)/(8.51), impedance (9.28)/(9.31), inner position loop (9.39)+(9.43), inner
velocity loop (9.45)+(9.46), parallel (9.48)+(9.43)) are written out here in the same order of
operations as the law functions, so that the results agree with ``simulate(engine="python")``
to round-off (tested). Other controllers are not handled here (the sweep runs them case by case
through :func:`forcecontrol.simulation.simulate`).

Instead of full logs a case keeps one signal, the true contact force along a direction ``d``
(``y_k = d · h_e(t_k)``), and the metrics are computed from it at the end of the case
(:func:`case_metrics`). :func:`run_batch` runs a block of cases one after the other and releases
the GIL (``nogil``): the sweep runs one block per core from a thread pool locally, or one per
task on Dask workers, with the same compiled function, so both give identical numbers.

Output columns (``OUT_COLUMNS``): status (0 ok, 1 non-finite state, 2 runaway, 3 singular
Jacobian, 4 non-finite torque, as :mod:`forcecontrol._kernels`), last sample index, peak
contact force norm [N], contact lost (0/1), settling time [s], overshoot [%], steady-state force
error [N], stable (0/1), settled force [N].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._linalg import SINGULAR_RCOND
from .metrics import case_metrics  # the one definition of the step-response metrics

__all__ = ["run_batch", "run_case", "case_metrics", "OUT_COLUMNS", "FAST_KINDS"]

#: controller kinds with an allocation-free law here (others use the general dispatcher).
FAST_KINDS = frozenset({1, 2, 3, 4, 5, 6})

OUT_COLUMNS = (
    "status", "last_sample", "peak_force", "contact_lost", "settling_time", "overshoot",
    "steady_state_force_error", "stable", "settled_force",
)
_NOUT = len(OUT_COLUMNS)

OK, NONFINITE_STATE, RUNAWAY, SINGULAR, NONFINITE_TORQUE = 0, 1, 2, 3, 4


# --------------------------------------------------------------------------- 2x2 helpers


@njit(cache=True)
def _solve2(a00, a01, a10, a11, b0, b1):  # pragma: no cover - compiled
    """``A x = b`` for 2x2 A, the same arithmetic as :func:`forcecontrol._linalg.solve_into`.

    Returns (ok, x0, x1); ok is False when A is numerically singular.
    """
    scale = abs(a00)
    if abs(a01) > scale:
        scale = abs(a01)
    if abs(a10) > scale:
        scale = abs(a10)
    if abs(a11) > scale:
        scale = abs(a11)
    if scale == 0.0 or not math.isfinite(scale):
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
    x0 = (b0 - a01 * x1) / a00
    return True, x0, x1


@njit(cache=True)
def _wrench2(env_kind, p, x0, x1, v0, v1):  # pragma: no cover - compiled
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
    return math.nan, math.nan


@njit(cache=True)
def _terms2(K, q0, q1, w0, w1, T):  # pragma: no cover - compiled
    """Fill T = [x0, x1, xd0, xd1, J00, J01, J10, J11, Jdq0, Jdq1, B00, B01, B11, n0, n1, g0, g1]
    (the expressions of ``planar_2r._terms_into``; cos/sin(q1 + q2) by the angle-sum formulas)."""
    a1 = K[0]
    a2 = K[1]
    c1 = math.cos(q0)
    s1 = math.sin(q0)
    c2 = math.cos(q1)
    s2 = math.sin(q1)
    c12 = c1 * c2 - s1 * s2  # cos(q1 + q2), four trigonometric calls instead of six
    s12 = s1 * c2 + c1 * s2
    T[0] = a1 * c1 + a2 * c12
    T[1] = a1 * s1 + a2 * s12
    T[4] = -a1 * s1 - a2 * s12
    T[5] = -a2 * s12
    T[6] = a1 * c1 + a2 * c12
    T[7] = a2 * c12
    T[2] = T[4] * w0 + T[5] * w1
    T[3] = T[6] * w0 + T[7] * w1
    u1 = w0
    u12 = w0 + w1
    T[8] = -a1 * c1 * u1 * u1 - a2 * c12 * u12 * u12
    T[9] = -a1 * s1 * u1 * u1 - a2 * s12 * u12 * u12
    T[10] = K[2] + K[3] * c2
    T[11] = K[4] + K[5] * c2
    T[12] = K[6]
    h = -K[7] * s2
    T[15] = K[8] * c1 + K[9] * c12
    T[16] = K[9] * c12
    T[13] = h * w1 * w0 + h * (w0 + w1) * w1 + K[10] * w0 + T[15]
    T[14] = -h * w0 * w0 + K[11] * w1 + T[16]


@njit(cache=True)
def _accel_terms2(T, h0, h1, u0, u1):  # pragma: no cover - compiled
    """q̈ = B⁻¹ (u − n − Jᵀ h_e) from filled terms T and the wrench; returns (ok, a0, a1)."""
    r0 = u0 - T[13] - T[4] * h0 - T[6] * h1
    r1 = u1 - T[14] - T[5] * h0 - T[7] * h1
    return _solve2(T[10], T[11], T[11], T[12], r0, r1)


@njit(cache=True)
def _accel2(K, env_kind, env_p, q0, q1, w0, w1, u0, u1, T):  # pragma: no cover - compiled
    """q̈ = B⁻¹ (u − n − Jᵀ h_e) of the arm on the environment; returns (ok, a0, a1)."""
    _terms2(K, q0, q1, w0, w1, T)
    h0, h1 = _wrench2(env_kind, env_p, T[0], T[1], T[2], T[3])
    return _accel_terms2(T, h0, h1, u0, u1)


@njit(cache=True)
def _inverse_dynamics2(T, a0, a1, h0, h1, compensate):  # pragma: no cover - compiled
    """(9.30) ``u = B J⁻¹ (a − J̇q̇) + n [+ Jᵀ h]``, as ``inverse_dynamics_torque``; NaN if J singular."""
    ok, y0, y1 = _solve2(T[4], T[5], T[6], T[7], a0 - T[8], a1 - T[9])
    if not ok:
        return math.nan, math.nan
    u0 = T[13] + T[10] * y0 + T[11] * y1
    u1 = T[14] + T[11] * y0 + T[12] * y1
    if compensate:
        u0 += T[4] * h0 + T[6] * h1
        u1 += T[5] * h0 + T[7] * h1
    return u0, u1


@njit(cache=True)
def _mv2(p, o, v0, v1):  # pragma: no cover - compiled
    """(M v) for the row-major 2x2 matrix stored at p[o:o+4]."""
    return p[o] * v0 + p[o + 1] * v1, p[o + 2] * v0 + p[o + 3] * v1


@njit(cache=True)
def _control2(kind, Ts, q0, q1, w0, w1, T, h0, h1, ref, p, s):  # pragma: no cover - compiled
    """Torques of the built-in controller ``kind`` (1-6) with packed parameters and state.

    The packed layouts are those of the adapters in ``controllers/*.py``; ``s`` (the PI state
    ``[ξ, ξ₀]``) is advanced in place like the adapters do.
    """
    x0 = T[0]
    x1 = T[1]
    v0 = T[2]
    v1 = T[3]
    if kind == 4 or kind == 5 or kind == 6:
        # p = [M_d⁻¹ (4), K_D (4), K_P (4), K_F (2), K_I (2), limit (2)], s = [ξ (2), ξ₀ (2)]
        fd0 = ref[6]
        fd1 = ref[7]
        e0 = fd0 - h0
        e1 = fd1 - h1
        if kind == 5:
            xF0 = p[12] * e0 + 0.0
            xF1 = p[13] * e1 + 0.0
        else:
            xF0 = p[12] * e0 + s[0]
            xF1 = p[13] * e1 + s[1]
            for i in range(2):
                v = s[i] + Ts * p[14 + i] * (ref[6 + i] - (h0 if i == 0 else h1))
                lim = p[16 + i]
                if lim > 0.0:
                    lo = s[2 + i] - lim
                    hi = s[2 + i] + lim
                    if v < lo:
                        v = lo
                    elif v > hi:
                        v = hi
                s[i] = v
        if kind == 4:
            d0 = xF0 - x0
            d1 = xF1 - x1
        elif kind == 5:
            d0 = xF0
            d1 = xF1
        else:
            d0 = ref[0] - x0 + xF0
            d1 = ref[1] - x1 + xF1
        k0, k1 = _mv2(p, 8, d0, d1)
        c0, c1 = _mv2(p, 4, v0, v1)
        a0, a1 = _mv2(p, 0, k0 - c0, k1 - c1)
        return _inverse_dynamics2(T, a0, a1, h0, h1, True)
    if kind == 3:
        # p = [M_d⁻¹ (4), K_D (4), K_P (4), use_force]
        use_force = p[12] != 0.0
        c0, c1 = _mv2(p, 4, ref[2] - v0, ref[3] - v1)
        k0, k1 = _mv2(p, 8, ref[0] - x0, ref[1] - x1)
        w0 = c0 + k0
        w1 = c1 + k1
        if use_force:
            w0 = w0 - h0
            w1 = w1 - h1
        m0, m1 = _mv2(p, 0, w0, w1)
        return _inverse_dynamics2(T, ref[4] + m0, ref[5] + m1, h0, h1, use_force)
    if kind == 1:
        # p = [K_P (4), K_D (4)]: u = g + Jᵀ (K_P (x_d − x) − K_D ẋ)
        k0, k1 = _mv2(p, 0, ref[0] - x0, ref[1] - x1)
        c0, c1 = _mv2(p, 4, v0, v1)
        f0 = k0 - c0
        f1 = k1 - c1
        return T[15] + (T[4] * f0 + T[6] * f1), T[16] + (T[5] * f0 + T[7] * f1)
    # kind == 2, p = [K_P (4), K_D (4), q_d (2)]: u = g + K_P (q_d − q) − K_D q̇
    k0, k1 = _mv2(p, 0, p[8] - q0, p[9] - q1)
    c0, c1 = _mv2(p, 4, w0, w1)
    return T[15] + k0 - c0, T[16] + k1 - c1


# --------------------------------------------------------------------------- one case


@njit(cache=True)
def run_case(K, env_kind, env_p, ctrl_kind, ctrl_p, ctrl_s, refs, bias, noise, alpha,
             q0, qd0, Ts, nsub, N, max_qd, d, y):  # pragma: no cover - compiled
    """Run one closed loop of N samples; fill ``y[k] = d · h_e(t_k)``.

    Same loop as ``simulate`` (sensor ``raw = h_e + bias + noise_k`` low-passed with ``alpha``,
    controller, torque held over Ts, ``nsub`` RK4 steps). ``ctrl_s`` is advanced in place.

    Returns:
        (status, last sample index, peak contact force norm [N], contact lost): contact is lost
        when a sample has ``h_e = 0`` after a sample with ``h_e ≠ 0``.
    """
    T = np.empty(17)
    U = np.empty(17)
    q_0 = q0[0]
    q_1 = q0[1]
    w_0 = qd0[0]
    w_1 = qd0[1]
    hm0 = 0.0
    hm1 = 0.0
    dt = Ts / nsub
    hdt = 0.5 * dt
    sdt = dt / 6.0
    peak = 0.0
    touched = False
    lost = False
    for k in range(N + 1):
        _terms2(K, q_0, q_1, w_0, w_1, T)
        h0, h1 = _wrench2(env_kind, env_p, T[0], T[1], T[2], T[3])
        raw0 = h0 + bias[0] + noise[k, 0]
        raw1 = h1 + bias[1] + noise[k, 1]
        if k == 0:
            hm0 = raw0
            hm1 = raw1
        else:
            hm0 = hm0 + alpha * (raw0 - hm0)
            hm1 = hm1 + alpha * (raw1 - hm1)
        u0, u1 = _control2(ctrl_kind, Ts, q_0, q_1, w_0, w_1, T, hm0, hm1, refs[k], ctrl_p, ctrl_s)
        y[k] = d[0] * h0 + d[1] * h1
        hn = math.sqrt(h0 * h0 + h1 * h1)
        if hn > peak:
            peak = hn
        if hn != 0.0:
            touched = True
        elif touched:
            lost = True
        if not (math.isfinite(u0) and math.isfinite(u1)):
            det = T[4] * T[7] - T[5] * T[6]
            if abs(det) < 1e-9:
                return SINGULAR, k, peak, lost
            return NONFINITE_TORQUE, k, peak, lost
        if k == N:
            break
        for j in range(nsub):
            if j == 0:  # the state of the sample: its terms and wrench are already in T, h
                ok1, a10, a11 = _accel_terms2(T, h0, h1, u0, u1)
            else:
                ok1, a10, a11 = _accel2(K, env_kind, env_p, q_0, q_1, w_0, w_1, u0, u1, U)
            v20 = w_0 + hdt * a10
            v21 = w_1 + hdt * a11
            ok2, a20, a21 = _accel2(K, env_kind, env_p, q_0 + hdt * w_0, q_1 + hdt * w_1, v20, v21, u0, u1, U)
            v30 = w_0 + hdt * a20
            v31 = w_1 + hdt * a21
            ok3, a30, a31 = _accel2(K, env_kind, env_p, q_0 + hdt * v20, q_1 + hdt * v21, v30, v31, u0, u1, U)
            v40 = w_0 + dt * a30
            v41 = w_1 + dt * a31
            ok4, a40, a41 = _accel2(K, env_kind, env_p, q_0 + dt * v30, q_1 + dt * v31, v40, v41, u0, u1, U)
            if not (ok1 and ok2 and ok3 and ok4):
                return NONFINITE_STATE, k, peak, lost
            q_0 += sdt * (w_0 + 2.0 * v20 + 2.0 * v30 + v40)
            q_1 += sdt * (w_1 + 2.0 * v21 + 2.0 * v31 + v41)
            w_0 += sdt * (a10 + 2.0 * a20 + 2.0 * a30 + a40)
            w_1 += sdt * (a11 + 2.0 * a21 + 2.0 * a31 + a41)
        if not (math.isfinite(q_0) and math.isfinite(q_1) and math.isfinite(w_0) and math.isfinite(w_1)):
            return NONFINITE_STATE, k, peak, lost
        if abs(w_0) > max_qd or abs(w_1) > max_qd:
            return RUNAWAY, k, peak, lost
    return OK, N, peak, lost


@njit(cache=True)
def _one(i, K, env_kind, env_p, ctrl_kind, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
         alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out):  # pragma: no cover
    s = ctrl_s[i].copy()
    y = np.empty(N[i] + 1)
    status, last, peak, lost = run_case(
        K[i], env_kind[i], env_p[i], ctrl_kind[i], ctrl_p[i], s, ref_tab[ref_id[i]], bias[i],
        noise_tab[noise_id[i]], alpha[i], q0[i], qd0[i], Ts[i], nsub[i], N[i], max_qd[i], d[i], y,
    )
    st, ov, err, stable, yf = case_metrics(y, last, status, Ts[i], window[i], f_ref[i], settle_band, stable_band)
    out[i, 0] = status
    out[i, 1] = last
    out[i, 2] = peak
    out[i, 3] = 1.0 if lost else 0.0
    out[i, 4] = st
    out[i, 5] = ov
    out[i, 6] = err
    out[i, 7] = stable
    out[i, 8] = yf


@njit(cache=True, nogil=True)
def run_batch(K, env_kind, env_p, ctrl_kind, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
              alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out):  # pragma: no cover
    """Run cases i = 0..C-1 one after the other; row i of ``out`` gets ``OUT_COLUMNS``.

    Per-case arrays have C rows (``K`` (C, 12), ``env_p`` (C, P), ``ctrl_p`` (C, Q), ``ctrl_s``
    (C, S), ``bias`` (C, 2), ``q0``/``qd0``/``d`` (C, 2), the rest (C,)); references and noise
    come from shared tables ``ref_tab`` (R, Nmax+1, 12) and ``noise_tab`` (M, Nmax+1, 2) by index.
    """
    for i in range(K.shape[0]):
        _one(i, K, env_kind, env_p, ctrl_kind, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
             alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out)
