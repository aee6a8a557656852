"""Many closed loops of the chapter's arm at once: an allocation-free compiled kernel.

The per-case loop is the sampled loop of :mod:`forcecontrol.loop` (sensor, control law,
zero-order hold, the RK4 plant :func:`forcecontrol._plant.rk4_sample`) and calls the same
compiled law (:mod:`forcecontrol.laws`), passed as a function argument: :func:`run_batch` is
specialised per law, so a block of cases shares one controller type (the sweep groups cases by
law). The results agree with ``simulate`` (compiled and Python loops) to round-off (tested).

Instead of full logs a case keeps one signal, the true contact force along a direction ``d``
(``y_k = d · h_e(t_k)``), and the metrics are computed from it at the end of the case
(:func:`case_metrics`). :func:`run_batch` runs a block of cases one after the other and releases
the GIL (``nogil``): the sweep runs one block per core from a thread pool locally, or one per
task on Dask workers, with the same compiled function, so both give identical numbers.

Output columns (``OUT_COLUMNS``): status (0 ok, 1 non-finite state, 2 runaway, 3 singular
Jacobian, 4 non-finite torque, as :mod:`forcecontrol.loop`), last sample index, peak contact
force norm [N], contact lost (0/1), settling time [s], overshoot [%], steady-state force error
[N], stable (0/1), settled force [N].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._plant import NONFINITE_STATE, NONFINITE_TORQUE, OK, RUNAWAY, SINGULAR, fill_terms, rk4_sample, terms2, wrench2
from .metrics import case_metrics  # the one definition of the step-response metrics

__all__ = ["run_batch", "run_case", "case_metrics", "OUT_COLUMNS"]

OUT_COLUMNS = (
    "status", "last_sample", "peak_force", "contact_lost", "settling_time", "overshoot",
    "steady_state_force_error", "stable", "settled_force",
)
_NOUT = len(OUT_COLUMNS)


@njit(cache=True)
def run_case(law, K, env_kind, env_p, ctrl_p, ctrl_s, refs, bias, noise, alpha,
             q0, qd0, Ts, nsub, N, max_qd, d, y):  # pragma: no cover - compiled
    """Run one closed loop of N samples with control ``law``; fill ``y[k] = d · h_e(t_k)``.

    Same loop as ``simulate`` (sensor ``raw = h_e + bias + noise_k`` low-passed with ``alpha``,
    the law, torque held over Ts, ``nsub`` RK4 steps). ``ctrl_s`` is advanced in place.

    Returns:
        (status, last sample index, peak contact force norm [N], contact lost): contact is lost
        when a sample has ``h_e = 0`` after a sample with ``h_e ≠ 0``.
    """
    n = 2
    m = 2
    x = np.empty(m)
    xd = np.empty(m)
    J = np.empty((m, n))
    Jdq = np.empty(m)
    B = np.empty((n, n))
    nv = np.empty(n)
    g = np.empty(n)
    q = np.empty(n)
    qd = np.empty(n)
    hm = np.zeros(m)
    u = np.empty(n)
    ws = np.empty(2 * m * m + 12 * m + 2 * n + 8)
    T = np.empty(17)
    W = np.empty(17)
    q_0 = q0[0]
    q_1 = q0[1]
    w_0 = qd0[0]
    w_1 = qd0[1]
    hm0 = 0.0
    hm1 = 0.0
    peak = 0.0
    touched = False
    lost = False
    for k in range(N + 1):
        terms2(K, q_0, q_1, w_0, w_1, T)
        h0, h1 = wrench2(env_kind, env_p, T[0], T[1], T[2], T[3])
        raw0 = h0 + bias[0] + noise[k, 0]
        raw1 = h1 + bias[1] + noise[k, 1]
        if k == 0:
            hm0 = raw0
            hm1 = raw1
        else:
            hm0 = hm0 + alpha * (raw0 - hm0)
            hm1 = hm1 + alpha * (raw1 - hm1)
        fill_terms(T, q_0, q_1, w_0, w_1, q, qd, x, xd, J, Jdq, B, nv, g)
        hm[0], hm[1] = hm0, hm1
        law(k * Ts, Ts, q, qd, x, xd, J, Jdq, B, nv, g, hm, refs[k], ctrl_p, ctrl_s, ws, u)
        u0 = u[0]
        u1 = u[1]
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
        ok, q_0, q_1, w_0, w_1 = rk4_sample(K, env_kind, env_p, q_0, q_1, w_0, w_1, u0, u1, T, h0, h1, Ts, nsub, W)
        if not ok:
            return NONFINITE_STATE, k, peak, lost
        if not (math.isfinite(q_0) and math.isfinite(q_1) and math.isfinite(w_0) and math.isfinite(w_1)):
            return NONFINITE_STATE, k, peak, lost
        if abs(w_0) > max_qd or abs(w_1) > max_qd:
            return RUNAWAY, k, peak, lost
    return OK, N, peak, lost


@njit(cache=True)
def _one(law, i, K, env_kind, env_p, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
         alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out):  # pragma: no cover
    s = ctrl_s[i].copy()
    y = np.empty(N[i] + 1)
    status, last, peak, lost = run_case(
        law, K[i], env_kind[i], env_p[i], ctrl_p[i], s, ref_tab[ref_id[i]], bias[i],
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
def run_batch(law, K, env_kind, env_p, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
              alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out):  # pragma: no cover
    """Run cases i = 0..C-1 with control ``law`` one after the other; row i of ``out`` gets ``OUT_COLUMNS``.

    Per-case arrays have C rows (``K`` (C, 12), ``env_p`` (C, P), ``ctrl_p`` (C, Q), ``ctrl_s``
    (C, S), ``bias`` (C, 2), ``q0``/``qd0``/``d`` (C, 2), the rest (C,)); references and noise
    come from shared tables ``ref_tab`` (R, Nmax+1, 12) and ``noise_tab`` (M, Nmax+1, 2) by index.
    """
    for i in range(K.shape[0]):
        _one(law, i, K, env_kind, env_p, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
             alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out)
