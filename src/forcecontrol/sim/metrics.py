"""The one definition of the step-response metrics: settling time, overshoot, steady state, stability.

Used by the sweeps (per case, compiled, :func:`case_metrics`), the MuJoCo comparison, the gain
design's predicted settling time and anywhere a transient is summarised (:func:`step_metrics`),
so that a "settling time" means the same thing everywhere:

* ``y_final``: the mean of y over the last ``window`` (or a given exact final value);
* the step ``s = y_final − y_0`` (y_0 the first sample);
* settling time: the first time after which ``|y − y_final| <= band · |s|`` (band 2 %), NaN if
  the signal never stays in the band;
* overshoot: ``100 · max(0, max_k sign(s) (y_k − y_final)) / |s|`` [%];
* steady-state error: ``y_final − reference``;
* stable: no divergence, and the largest ``|y − y_final|`` over the last quarter of the record is
  within ``stable_band · |s|`` or below 0.9 times that over the quarter before (still decaying);
  without a step (``s = 0``), the same test relative to the largest excursion ``max |y − y_final|``
  (a signal that never moved is stable).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from ..core.numba_cache import kernel_array

__all__ = ["case_metrics", "step_metrics", "StepMetrics"]


@njit(cache=True, inline="always")
def _largest_residual(y, yf, start, stop):  # pragma: no cover - compiled
    """max |y_k − y_final| over k in [start, stop) (0 for an empty range)."""
    r = 0.0
    for k in range(start, stop):
        v = abs(y[k] - yf)
        if v > r:
            r = v
    return r


@njit(cache=True)
def case_metrics(y, last, status, Ts, window, f_ref, settle_band, stable_band):  # pragma: no cover
    """Step-response metrics of the contact force y[0..last] (one case).

    ``y_final`` is the mean of y over the last ``window`` samples. With ``s = y_final − y_0``:
    settling time = first t_k after which ``|y − y_final| <= settle_band |s|`` (NaN if it never
    stays in the band); overshoot = ``100 max(0, max_k sign(s) (y_k − y_final)) / |s|`` [%];
    steady-state force error = ``y_final − f_ref``. Stable: no divergence, and the largest
    ``|y − y_final|`` over the last quarter of the run is within ``stable_band |s|`` or below
    0.9 times that over the quarter before (still decaying). Without a step (``s = 0``: y ends where
    it began) settling time and overshoot are NaN, and stable means y never moved or its late
    residual is within ``stable_band`` of its largest excursion (or still decaying): a tool that
    bounces to the end is not stable. Diverged cases get NaN metrics.

    Returns:
        (settling time [s], overshoot [%], steady-state error [N], stable (0/1), y_final [N]).
    """
    nan = math.nan
    if status != 0:
        return nan, nan, nan, 0.0, nan
    n = last + 1
    w = min(max(window, 1), n)
    acc = 0.0
    for k in range(n - w, n):
        acc += y[k]
    yf = acc / w
    s = yf - y[0]
    mag = abs(s)
    err = yf - f_ref
    if not math.isfinite(mag):
        return nan, nan, err, 0.0, yf
    # the late residual against the step, or without a step (y ends where it began, e.g. a tool that bounced and ends
    # in free air as it started) against the largest excursion: a bouncing limit cycle is not stable, a y that never
    # moved is
    scale = mag if mag > 0.0 else _largest_residual(y, yf, 0, n)
    qn = max(n // 4, 1)
    late = _largest_residual(y, yf, n - qn, n)
    early = _largest_residual(y, yf, max(n - 2 * qn, 0), n - qn)
    stable = 1.0 if (scale == 0.0 or late <= stable_band * scale or late < 0.9 * early) else 0.0
    if mag == 0.0:  # no step: no settling time or overshoot
        return nan, nan, err, stable, yf
    band = settle_band * mag
    k_out = -1
    for k in range(n - 1, -1, -1):
        if abs(y[k] - yf) > band:
            k_out = k
            break
    settling = nan if k_out >= n - 1 else (k_out + 1) * Ts
    sign = 1.0 if s > 0.0 else -1.0
    over = 0.0
    for k in range(n):
        v = sign * (y[k] - yf)
        if v > over:
            over = v
    over = 100.0 * over / mag
    return settling, over, err, stable, yf


@dataclass(frozen=True)
class StepMetrics:
    """Step-response metrics of one signal (see the module text for the definitions).

    Attributes:
        settling_time: [s] (NaN: never settles in the record); overshoot_percent: [%];
        steady: y_final; steady_state_error: y_final − reference; stable: bool;
        peak: the sample of largest |y|; peak_time: its time [s].
    """

    settling_time: float
    overshoot_percent: float
    steady: float
    steady_state_error: float
    stable: bool
    peak: float
    peak_time: float

    def as_dict(self) -> dict[str, Any]:
        """Plain values."""
        return dict(self.__dict__)


def step_metrics(t: Any, y: Any, *, window: float = 0.1, band: float = 0.02, reference: float = 0.0,
                 stable_band: float = 0.05, final: float | None = None) -> StepMetrics:
    """The step-response metrics of a sampled signal y(t) (uniform sampling), by :func:`case_metrics`.

    Args:
        t: sample times (N,) [s], uniform; y: the signal (N,).
        window: the final value is the mean over the last ``window`` seconds (at least one sample),
            unless ``final`` gives it exactly (e.g. from a model's steady state).
        band: settling band, relative to the step; reference: for the steady-state error;
            stable_band: see the module text.
    """
    t = np.asarray(t, dtype=np.float64)
    y = kernel_array(y)  # a column of a log (strided) would compile case_metrics a second time
    Ts = float(t[1] - t[0]) if t.shape[0] > 1 else 1.0
    if final is not None:
        # the exact final value: appended as the "last window" of one sample
        yy = np.concatenate([y, [float(final)]])
        st, ov, err, stable, yf = case_metrics(yy, yy.shape[0] - 1, 0, Ts, 1, float(reference), band, stable_band)
        if math.isfinite(st) and st > t[-1] - t[0]:
            st = math.nan
    else:
        w = max(1, int(round(window / Ts)))
        st, ov, err, stable, yf = case_metrics(y, y.shape[0] - 1, 0, Ts, w, float(reference), band, stable_band)
    i = int(np.argmax(np.abs(y)))
    return StepMetrics(float(st), float(ov), float(yf), float(err), bool(stable), float(y[i]), float(t[0] + i * Ts))
