"""Drift of a calibrated force/torque sensor: is the unloaded reading still the calibrated bias?"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...core.validate import positive_scalar
from ...errors import DimensionError, MeasurementError, ParameterError
from .core import CalibrationResult

__all__ = ["DriftCheck", "DriftDetector"]


@dataclass(frozen=True)
class DriftCheck:
    """One step of :class:`DriftDetector`.

    Attributes:
        drifted: True when a component of the moving-average residual exceeds its threshold.
        ready: False during warm-up (noise being measured, or the window not yet full).
        offset: moving-average residual (measured − model), forces then moments, (d + nt,) or (d,).
        threshold: the per-component threshold, same shape.
        ratio: max |offset| / threshold (>1 means drift).
        component: index of the worst component.
    """

    drifted: bool
    ready: bool
    offset: np.ndarray
    threshold: np.ndarray
    ratio: float
    component: int


class DriftDetector:
    """Online free-space check of the sensor against its calibration: flags a bias change.

    Each free-space reading gives a residual ``r = reading − model(R)`` (forces, then moments).
    Its moving average over ``window`` samples is compared per component with
    ``k_sigma · sqrt(σ_n²/window + σ_model²(R))``: σ_n the per-sample noise (given, or measured on
    the first ``window`` readings as their residuals' standard deviation, which an offset does not
    change), σ_model the uncertainty of the model's prediction at R (:meth:`CalibrationResult.prediction_std`).
    For white noise the false-alarm rate per component and sample is about 2 Φ(−k_sigma) (6e-5
    for k_sigma = 4, but successive averages are correlated, so alarms come in bursts). Filtered
    (coloured) noise averages down more slowly than 1/√window: pass a larger ``noise_std`` or
    ``k_sigma``. Call it only when the arm is in free space (no contact) and moving slowly (the
    model is static).

    Args:
        result: the calibration.
        window: moving-average length [samples], >= 2.
        k_sigma: threshold in standard deviations, > 0.
        noise_std: per-sample noise σ_n, scalar or per component (d + nt,) ((d,) without
            moments); None = measured during warm-up.
        floor: smallest threshold (avoids a zero threshold with noise-free data) [N or N m].

    Raises:
        ParameterError: bad window, k_sigma, floor; noise_std negative. DimensionError: noise_std shape.
    """

    def __init__(self, result: CalibrationResult, *, window: int = 200, k_sigma: float = 5.0,
                 noise_std: Any = None, floor: float = 1e-9) -> None:
        if not isinstance(result, CalibrationResult):
            raise ParameterError(f"result must be a CalibrationResult; got {type(result).__name__}")
        if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 2:
            raise ParameterError(f"window must be an integer >= 2 [samples]; got {window!r}")
        self.result = result
        self.window = int(window)
        self.k_sigma = positive_scalar("k_sigma", k_sigma)
        self.floor = positive_scalar("floor", floor)
        self.n = result.dim + ((1 if result.dim == 2 else 3) if result.has_torques else 0)
        self._given: np.ndarray | None = None
        if noise_std is not None:
            s = np.array(noise_std, dtype=np.float64)
            if s.ndim > 1 or (s.ndim == 1 and s.shape != (self.n,)):
                raise DimensionError(f"noise_std must be a scalar or have shape ({self.n},); got shape {s.shape}")
            if not np.all(np.isfinite(s)) or np.any(s < 0):
                raise ParameterError(f"noise_std must be finite and >= 0; got {s.tolist()}")
            self._given = np.broadcast_to(s, (self.n,)).copy()
        self.reset()

    def reset(self) -> None:
        """Forget the readings (and the measured noise, when it was measured: it is measured again)."""
        self._buf: deque[np.ndarray] = deque(maxlen=self.window)
        self._sum = np.zeros(self.n)
        self._warm: list[np.ndarray] = []
        self.noise_std: np.ndarray | None = None if self._given is None else self._given.copy()
        self.count = 0

    def residual(self, R: Any, force: Any, torque: Any = None) -> np.ndarray:
        """reading − model(R), forces then moments, (d + nt,) or (d,)."""
        f, t = self.result.compensate(R, force, torque if self.result.has_torques else None)
        if self.result.has_torques and t is None:
            raise ParameterError("torque is required: the calibration identified the moments; got None")
        r = np.concatenate([np.ravel(f), np.ravel(t)]) if t is not None else np.ravel(f)
        if r.shape != (self.n,):
            raise DimensionError(f"one reading expected (R (d, d), force (d,)); got a residual of shape {r.shape}")
        if not np.all(np.isfinite(r)):
            raise MeasurementError(f"the reading must be finite; got force {np.ravel(force).tolist()}")
        return r

    def update(self, R: Any, force: Any, torque: Any = None) -> DriftCheck:
        """Add one free-space reading at orientation R and check for drift.

        Args:
            R: sensor orientation (d, d).
            force: force reading in S (d,) [N].
            torque: moment reading in S (nt,) [N m]; required when the calibration has moments.

        Returns:
            A :class:`DriftCheck`.

        Raises:
            DimensionError, MeasurementError, ParameterError: as :meth:`residual`.
        """
        r = self.residual(R, force, torque)
        self.count += 1
        if self.noise_std is None:
            self._warm.append(r)
            if len(self._warm) >= self.window:
                self.noise_std = np.std(np.array(self._warm), axis=0, ddof=1)
                self._warm = []
        if len(self._buf) == self.window:
            self._sum -= self._buf[0]
        self._buf.append(r)
        self._sum += r
        offset = self._sum / len(self._buf)
        sf, st = self.result.prediction_std(R)
        model = np.concatenate([sf, st]) if st is not None else sf
        noise = self.noise_std if self.noise_std is not None else np.zeros(self.n)
        thr = np.maximum(self.k_sigma * np.sqrt(noise**2 / self.window + model**2), self.floor)
        ready = self.noise_std is not None and len(self._buf) == self.window
        ratios = np.abs(offset) / thr
        i = int(np.argmax(ratios))
        return DriftCheck(drifted=bool(ready and ratios[i] > 1.0), ready=ready, offset=offset, threshold=thr,
                          ratio=float(ratios[i]), component=i)
