"""A realistic force/torque sensor: filter, drift, resolution, delay, zeroing and the tool's weight."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from ..core.validate import nonnegative_scalar
from ..errors import DimensionError, ParameterError
from .core import _FILTERS, ForceSensor
from .gravity import ToolGravity, _gravity_vector, planar_sensor_rotation

__all__ = ["RealisticForceSensor"]


#: longest transport delay and most zeroing readings [samples] (100 s at 1 kHz): checked before the
#: delay line or the zeroing readings are allocated (``forcecontrol.sim.limits`` lists every limit).
MAX_DELAY_SAMPLES = 100_000
MAX_ZEROING_SAMPLES = 100_000


class RealisticForceSensor(ForceSensor):
    """A wrist F/T sensor as on a real arm, with the usual corrections; runs in the Python loop.

    At sample k (t_k = k Ts), with R_S(q) the sensor orientation and h_e the true contact force
    (base frame), the chain is::

        raw_k  = R_Sᵀ (h_e − m_tool g) + b + ḃ t_k + n_k                 (sensor frame)
        qnt_k  = Δ round(raw_k / Δ)                                      (converter, Δ = resolution)
        flt_k  = filter(qnt_k)                                           (none | first-order | butterworth)
        out_k  = flt_{k−d}  (d = delay_samples; flt_0 before the first d samples)
        h_m,k  = R_S out_k + m̂_tool g − R_S b̂                           (base frame, compensated)

    ``b̂`` comes from zeroing: at start, ``zeroing_samples`` readings of the arm at rest (in free
    space: contact at start gets zeroed away, as on a real arm) are averaged and the expected
    tool reading ``−R_Sᵀ m̂ g`` is removed from the mean. The tool's sign convention is
    :class:`ToolGravity`'s (the sensor holds the tool up against gravity). ``m̂`` is ``tool_estimate.mass`` (from
    :func:`identify_tool_gravity`), zero when not given. Zeroing does not remove drift: a force
    loop regulates the measured force, so in contact the true force moves by about −ḃ t; on a
    real arm re-zero in free space between contacts.

    The first-order filter is ForceSensor's ``y_k = y_{k−1} + α (x_k − y_{k−1})``,
    ``α = 1 − exp(−2π f_c Ts)``; ``"butterworth"`` is the second-order Butterworth low-pass by the
    bilinear transform with pre-warping (``scipy.signal.butter(2, f_c, fs=1/Ts)``). Both start at rest on the first
    sample (no start-up transient).

    Args:
        noise_std, bias, cutoff, seed: as :class:`ForceSensor` (bias in the sensor frame).
        filter: ``"first-order"`` (default when a cutoff is given), ``"butterworth"`` or ``"none"``.
        drift: bias drift rate ḃ in the sensor frame [N/s], scalar or per component.
        resolution: quantisation step Δ [N], >= 0 (0 = none).
        delay_samples: transport delay d [samples], integer >= 0.
        tool: the true tool (its weight is measured); None = no tool.
        tool_estimate: the tool model used for compensation; None = no compensation.
        zeroing_samples: readings averaged at start to estimate the bias; 0 = no zeroing.
        orientation: ``q -> R_S`` (d, d); :func:`planar_sensor_rotation` when a tool is given
            on a planar arm, identity otherwise.
    """

    def __init__(
        self,
        noise_std: Any = 0.0,
        bias: Any = 0.0,
        cutoff: float | None = None,
        seed: int = 0,
        *,
        filter: str | None = None,
        drift: Any = 0.0,
        resolution: float = 0.0,
        delay_samples: int = 0,
        tool: ToolGravity | None = None,
        tool_estimate: ToolGravity | None = None,
        zeroing_samples: int = 0,
        orientation: Any = None,
    ) -> None:
        super().__init__(noise_std, bias, cutoff, seed)
        kind = ("first-order" if cutoff is not None else "none") if filter is None else filter
        if kind not in _FILTERS:
            raise ParameterError(f"filter must be one of {', '.join(repr(f) for f in _FILTERS)}; got {filter!r}")
        if kind != "none" and cutoff is None:
            raise ParameterError(f"filter {kind!r} needs a cutoff [Hz]; got cutoff=None")
        if kind == "none" and cutoff is not None:
            raise ParameterError(f"filter 'none' takes no cutoff; got cutoff={cutoff!r}")
        self.filter = kind
        self.drift = np.array(drift, dtype=np.float64)
        if self.drift.ndim > 1:
            raise DimensionError(f"drift must be a scalar or a vector; got shape {self.drift.shape}")
        if not np.all(np.isfinite(self.drift)):
            raise ParameterError(f"drift must be finite [N/s]; got {self.drift.tolist()}")
        self.resolution = nonnegative_scalar("resolution", resolution, "N")
        for name, v, cap in (("delay_samples", delay_samples, MAX_DELAY_SAMPLES),
                             ("zeroing_samples", zeroing_samples, MAX_ZEROING_SAMPLES)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0 or v > cap:  # before any buffer
                shown = repr(v) if not isinstance(v, int) or v.bit_length() <= 64 else \
                    f"an integer of about {int(v.bit_length() * 0.30103) + 1} digits"
                raise ParameterError(f"{name} must be a non-negative integer, at most {cap:,} [samples]; got {shown}")
        self.delay_samples = int(delay_samples)
        self.zeroing_samples = int(zeroing_samples)
        for name, part in (("tool", tool), ("tool_estimate", tool_estimate)):
            if part is not None and not isinstance(part, ToolGravity):
                raise ParameterError(f"{name} must be a ToolGravity or None; got {type(part).__name__}")
        self.tool = tool
        self.tool_estimate = tool_estimate
        if orientation is not None and not callable(orientation):
            raise ParameterError(f"orientation must be a callable q -> R_S or None; got {type(orientation).__name__}")
        self.orientation = orientation
        self.bias_estimate: np.ndarray | None = None
        self._k = -1
        self._last = np.zeros(0)

    @property
    def compiled_ok(self) -> bool:
        """False: this sensor is stateful and runs in the simulator's Python loop."""
        return False

    @property
    def exact(self) -> bool:
        """True when the sensor returns the true wrench unchanged."""
        return (
            super().exact and not np.any(self.drift) and self.resolution == 0.0 and self.delay_samples == 0
            and (self.tool is None or self.tool.mass == 0.0) and self.zeroing_samples == 0
            and (self.tool_estimate is None or self.tool_estimate.mass == 0.0)
        )

    def _rotation(self, q: np.ndarray | None, dim: int) -> np.ndarray:
        if self.orientation is not None:
            R = np.asarray(self.orientation(q), dtype=np.float64)
            if R.shape != (dim, dim):
                raise DimensionError(f"orientation(q) must return a ({dim}, {dim}) rotation; got shape {R.shape}")
            return R
        if self.tool is not None and dim == 2 and q is not None:
            return planar_sensor_rotation(q)
        return np.eye(dim)

    def filter_coefficients(self, sample_time: float) -> tuple[np.ndarray, np.ndarray]:
        """Digital filter (b, a), ``a[0] = 1``, of ``y_k = Σ b_i x_{k−i} − Σ_{i≥1} a_i y_{k−i}``.

        Raises:
            ParameterError: the cut-off is at or above the Nyquist frequency.
        """
        if self.filter == "none":
            return np.array([1.0]), np.array([1.0])
        alpha = self.alpha(sample_time)  # checks the Nyquist limit
        if self.filter == "first-order":
            return np.array([alpha]), np.array([1.0, alpha - 1.0])
        from scipy.signal import butter  # type: ignore[import-untyped]  # only for this filter (import cost)

        # second-order Butterworth low-pass, bilinear transform pre-warped at the cut-off
        b, a = butter(2, float(self.cutoff or 0.0), btype="low", fs=1.0 / sample_time)
        return np.asarray(b, dtype=np.float64), np.asarray(a, dtype=np.float64)

    def _quantise(self, x: np.ndarray) -> np.ndarray:
        return self.resolution * np.round(x / self.resolution) if self.resolution > 0.0 else x

    def _raw(self, t: float, h: np.ndarray, R: np.ndarray, noise: np.ndarray) -> np.ndarray:
        w = np.asarray(h, dtype=np.float64)
        if self.tool is not None:
            w = w - self.tool.mass * _gravity_vector(w.shape[0], self.tool.gravity)
        return self._quantise(R.T @ w + self._b + self._drift * t + noise)

    def start(self, n_samples: int, dim: int, sample_time: float, h0: Any, q0: Any = None) -> np.ndarray:
        """Prepare a run of ``n_samples`` samples: draw the noise, zero the sensor, reset the filter.

        Returns:
            The measurement at sample 0 (the same value ``measure(0, …)`` then returns).
        """
        bias, noise = self.sequences(n_samples + self.zeroing_samples, dim)
        try:
            self._drift = np.broadcast_to(self.drift, (dim,)).astype(np.float64)
        except ValueError as exc:
            raise DimensionError(f"drift must be a scalar or have shape ({dim},); got shape {self.drift.shape}") from exc
        self._b = bias
        self._noise = noise[self.zeroing_samples :]
        self._b_num, self._a_den = self.filter_coefficients(sample_time)
        self._dim = dim
        q0a = None if q0 is None else np.asarray(q0, dtype=np.float64)
        R0 = self._rotation(q0a, dim)
        g = _gravity_vector(dim, self.tool_estimate.gravity if self.tool_estimate else 9.81)
        self._m_hat = self.tool_estimate.mass if self.tool_estimate is not None else 0.0
        self._g = g
        if self.zeroing_samples:
            z = np.array([self._raw(0.0, h0, R0, noise[j]) for j in range(self.zeroing_samples)])
            self.bias_estimate = z.mean(axis=0) + R0.T @ (self._m_hat * g)
        else:
            self.bias_estimate = np.zeros(dim)
        self._x_hist: list[np.ndarray] = []
        self._y_hist: list[np.ndarray] = []
        self._out: deque[np.ndarray] = deque(maxlen=self.delay_samples + 1)
        self._k = -1
        return self.measure(0, 0.0, h0, q0a)

    def measure(self, k: int, t: float, h: Any, q: Any = None) -> np.ndarray:
        """The compensated measurement (base frame) at sample k; the same k twice gives the same value.

        Args:
            k: sample index (0, 1, 2, ... in order); t: its time [s].
            h: true contact force h_e (base frame), (d,) [N]; q: joint positions (for R_S).
        """
        if k == self._k:
            return self._last.copy()
        if k != self._k + 1:
            raise ParameterError(f"measure must be called for samples 0, 1, 2, ... in order; got {k} after {self._k}")
        if k >= len(self._noise):
            raise ParameterError(f"measure: sample {k} is beyond the {len(self._noise)} samples prepared by start()")
        qa = None if q is None else np.asarray(q, dtype=np.float64)
        R = self._rotation(qa, self._dim)
        x = self._raw(t, h, R, self._noise[k])
        b, a = self._b_num, self._a_den
        if k == 0:  # start at rest on the first sample
            self._x_hist = [x] * len(b)
            self._y_hist = [x] * (len(a) - 1)  # y_{k−1}, y_{k−2}, ...
        self._x_hist = [x, *self._x_hist[:-1]]
        y = sum(b[i] * self._x_hist[i] for i in range(len(b))) - sum(a[i] * self._y_hist[i - 1] for i in range(1, len(a)))
        self._y_hist = [y, *self._y_hist[:-1]]
        self._out.append(y)  # holds flt_{k−d} ... flt_k (flt_0 ... flt_k while k < d)
        out_s = self._out[0]
        hm = R @ out_s + self._m_hat * self._g - R @ self.bias_estimate
        self._k = k
        self._last = hm
        return hm.copy()

    def describe(self) -> dict[str, Any]:
        return {
            **super().describe(),
            "kind": "realistic",
            "filter": self.filter,
            "drift": self.drift.tolist(),
            "resolution": self.resolution,
            "delay_samples": self.delay_samples,
            "zeroing_samples": self.zeroing_samples,
            "tool": None if self.tool is None else self.tool.describe(),
            "tool_estimate": None if self.tool_estimate is None else self.tool_estimate.describe(),
        }
