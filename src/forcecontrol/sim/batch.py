"""Many closed loops of the chapter's arm at once, in one compiled call per block of cases.

Each case runs the compiled loop of ``simulate``, :func:`forcecontrol.sim.loop.planar_loop`
(sensor, control law, zero-order hold, the RK4 plant), with the same compiled law
(:mod:`forcecontrol.laws`) passed as a function argument: :func:`run_batch` is specialised per
law, so a block of cases shares one controller type (the sweep groups cases by law). The
results are those of ``simulate`` (tested against its Python loop to round-off).

A case keeps one signal, the true contact force along a direction ``d``
(``y_k = d · h_e(t_k)``), and the metrics are computed from it at the end of the case
(:func:`case_metrics`). :func:`run_batch` runs a block of cases one after the other and releases
the GIL (``nogil``): the sweep runs one block per core from a thread pool locally, or one per
task on Dask workers, with the same compiled function, so both give identical numbers.

Output columns (``OUT_COLUMNS``): status (0 ok, 1 non-finite state, 2 runaway, 3 singular
Jacobian, 4 non-finite torque, as :mod:`forcecontrol.sim.loop`), last sample index, peak contact
force norm [N], contact lost (0/1), settling time [s], overshoot [%], steady-state force error
[N], stable (0/1), settled force [N].
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from ..core.numba_cache import build_once, kernel_identity
from .loop import planar_loop
from .metrics import case_metrics  # the one definition of the step-response metrics

__all__ = ["run_batch", "run_case", "case_metrics", "OUT_COLUMNS"]

OUT_COLUMNS = (
    "status", "last_sample", "peak_force", "contact_lost", "settling_time", "overshoot",
    "steady_state_force_error", "stable", "settled_force",
)
_NOUT = len(OUT_COLUMNS)


def kernels(law: Any) -> tuple[Any, Any]:
    """``(run_case, run_batch)`` compiled for control ``law`` (built once per law, cached on disk).

    The law's loop (:func:`forcecontrol.sim.loop.planar_loop`) is a constant of these closures, so
    they are specialised per law like the loop itself.
    """
    def build() -> tuple[Any, Any, tuple[Any, ...]]:
        k = _make_kernels(planar_loop(law, full_log=False))
        for name, fn in zip(("case", "one", "batch"), k[2]):
            # its own identity, symbol name and cache files, per kernel and law (see core.kernel_cache)
            kernel_identity(fn, f"forcecontrol:_batch.{name}:{law._uuid}")
        return k

    k = build_once(_KERNELS, law, build)  # once, even when a sweep's threads ask together
    return k[0], k[1]


def run_case(law: Any, *args: Any) -> tuple[int, int, float, bool]:
    """One case with control ``law``: ``(K, env_kind, env_p, ctrl_p, ctrl_s, refs, bias, noise, alpha, q0,
    q̇0, Ts, nsub, N, max_q̇, d, y) -> (status, last, peak, lost)`` (see :func:`kernels`)."""
    return kernels(law)[0](*args)


def run_batch(law: Any, *args: Any) -> None:
    """A block of cases with control ``law`` (see :func:`kernels`); row i of ``out`` gets ``OUT_COLUMNS``."""
    kernels(law)[1](*args)


_KERNELS: dict[Any, tuple[Any, Any, tuple[Any, ...]]] = {}
_compiled = njit(cache=True)
_compiled_nogil = njit(cache=True, nogil=True)


def _make_kernels(loop: Any) -> tuple[Any, Any, tuple[Any, ...]]:  # pragma: no cover - compiled
    @_compiled
    def case(K, env_kind, env_p, ctrl_p, ctrl_s, refs, bias, noise, alpha,
                 q0, qd0, Ts, nsub, N, max_qd, d, y):  # pragma: no cover - compiled
        """Run one closed loop of N samples with control ``law``; fill ``y[k] = d · h_e(t_k)``.

        The loop is :func:`forcecontrol.sim.loop.planar_loop` (sensor ``raw = h_e + bias + noise_k``
        low-passed with ``alpha``, the law, torque held over Ts, ``nsub`` RK4 steps), the same
        function ``simulate`` runs, built to keep only h_e (``full_log=False``); ``ctrl_s`` is
        advanced in place.

        Returns:
            (status, last sample index, peak contact force norm [N], contact lost): contact is lost
            when a sample has ``h_e = 0`` after a sample with ``h_e ≠ 0``.
        """
        Q = np.empty((1, 2))  # the loop without its full log (row 0 reused): only h_e is kept
        QD = np.empty((1, 2))
        X = np.empty((1, 2))
        XD = np.empty((1, 2))
        H = np.empty((N + 1, 2))
        HM = np.empty((1, 2))
        U = np.empty((1, 2))
        status, last = loop(
            K, env_kind, env_p, ctrl_p, ctrl_s, refs, bias, noise, alpha, q0, qd0, Ts, nsub, max_qd, Q, QD, X, XD, H, HM, U,
        )
        peak = 0.0
        touched = False
        lost = False
        for k in range(last + 1):
            h0 = H[k, 0]
            h1 = H[k, 1]
            y[k] = d[0] * h0 + d[1] * h1
            hn = math.sqrt(h0 * h0 + h1 * h1)
            if hn > peak:
                peak = hn
            if hn != 0.0:
                touched = True
            elif touched:
                lost = True
        return status, last, peak, lost


    @_compiled
    def one(i, K, env_kind, env_p, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
             alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out):  # pragma: no cover
        s = ctrl_s[i].copy()
        y = np.empty(N[i] + 1)
        status, last, peak, lost = case(
            K[i], env_kind[i], env_p[i], ctrl_p[i], s, ref_tab[ref_id[i]], bias[i],
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


    @_compiled_nogil
    def batch(K, env_kind, env_p, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
                  alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out):  # pragma: no cover
        """Run cases i = 0..C-1 with control ``law`` one after the other; row i of ``out`` gets ``OUT_COLUMNS``.

        Per-case arrays have C rows (``K`` (C, 12), ``env_p`` (C, P), ``ctrl_p`` (C, Q), ``ctrl_s``
        (C, S), ``bias`` (C, 2), ``q0``/``qd0``/``d`` (C, 2), the rest (C,)); references and noise
        come from shared tables ``ref_tab`` (R, Nmax+1, 12) and ``noise_tab`` (M, Nmax+1, 2) by index.
        """
        for i in range(K.shape[0]):
            one(i, K, env_kind, env_p, ctrl_p, ctrl_s, ref_tab, ref_id, bias, noise_tab, noise_id,
                 alpha, q0, qd0, Ts, nsub, N, max_qd, d, f_ref, window, settle_band, stable_band, out)

    return case, batch, (case, one, batch)
