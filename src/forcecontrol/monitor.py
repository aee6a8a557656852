"""An online stability and oscillation monitor for contact: chatter, limit cycles, divergence.

The monitor watches the measured contact force (its norm, or its component along a direction)
in a sliding window and, every ``hop`` seconds, analyses the window (from 64 samples on, before
the window is full, so that a fast divergence is caught early):

* the dominant oscillation: the peak of the periodogram of the detrended force
  (``scipy.signal.periodogram``, Hann window) among frequencies with at least three periods in
  the window (slower content is a trend, e.g. a step response's rise, not an oscillation), and
  ``narrowband``, the share of that power within ±2 bins of the peak (near 1 for one sinusoid);
* the oscillation alone, band-passed around that frequency (second-order Butterworth, zero
  phase: ``scipy.signal.sosfiltfilt``): its amplitude ``A = √2 · RMS`` over the window's second
  half, and its growth rate ``σ = ln(RMS₂ / RMS₁) / (window / 2)`` [1/s] from the two halves;
* contact losses: how often the force falls below ``contact_force`` after being above it.

Flags, most severe first: ``"divergence"`` (a non-finite sample, or A above ``min_amplitude``
growing faster than ``growth_rate`` in two analyses in a row), ``"chatter"`` (at least ``chatter_losses`` contact losses
in the window with A above ``min_amplitude``: the tool bounces), ``"limit-cycle"`` (a narrowband
oscillation above ``min_amplitude`` that neither grows nor decays by more than ``growth_rate``,
in ``persistence`` consecutive analyses) and ``"ok"``. A decaying transient (the chapter's
step responses) is not flagged.

:class:`MonitoredController` runs the monitor inside the loop (the user's or the simulator's)
and switches to a safe fallback controller when it fires, logging the event.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._validate import positive_scalar
from .controllers.base import Controller, Measurement, Reference
from .errors import DimensionError, ParameterError

__all__ = ["MonitorStatus", "StabilityMonitor", "MonitoredController", "FLAGS"]

#: the monitor's verdicts, from benign to severe.
FLAGS: tuple[str, ...] = ("ok", "limit-cycle", "chatter", "divergence")


@dataclass(frozen=True)
class MonitorStatus:
    """One analysis of the window.

    Attributes:
        t: time of the last sample analysed [s].
        flag: one of :data:`FLAGS`.
        frequency: dominant frequency of the force oscillation [Hz] (NaN: window not full).
        amplitude: its amplitude, √2 · RMS of the band-passed force in the window's second half [N].
        growth_rate: σ [1/s] (> 0 growing, < 0 decaying).
        narrowband: share of the oscillation's power near the dominant frequency, in [0, 1].
        contact_losses: contact losses within the window.
    """

    t: float
    flag: str
    frequency: float
    amplitude: float
    growth_rate: float
    narrowband: float
    contact_losses: int

    @property
    def fired(self) -> bool:
        """Whether the flag is anything but ``"ok"``."""
        return self.flag != "ok"

    def as_dict(self) -> dict[str, Any]:
        """Plain values (for logs and JSON)."""
        return {
            "t": self.t, "flag": self.flag, "frequency": self.frequency, "amplitude": self.amplitude,
            "growth_rate": self.growth_rate, "narrowband": self.narrowband, "contact_losses": self.contact_losses,
        }


class StabilityMonitor:
    """Sliding-window detector of contact chatter, limit cycles and divergence from the measured force.

    Feed it one sample per control period with :meth:`update` (it returns the latest
    :class:`MonitorStatus`), or analyse a finished run with :meth:`scan`.

    Args:
        sample_time: Ts [s] of the samples fed.
        window: analysis window [s] (at least 16 samples); default 2 s, so that contact modes
            down to 1.5 Hz (three periods) are seen. Until the window is full, the samples so
            far are analysed (from 64 on), so a fast divergence is caught early.
        hop: time between analyses [s], default window / 10.
        min_amplitude: oscillations below this amplitude [N] are never flagged (sensor noise,
            small ripples); default 2 N.
        growth_rate: σ above which an oscillation is diverging, and |σ| below which a
            narrowband one is a limit cycle [1/s]; default 0.5.
        contact_force: the force norm above which the tool is in contact [N]; default 0.5 N.
        chatter_losses: contact losses per window that make chatter; default 2.
        persistence: consecutive analyses a limit cycle must last; default 3.
        direction: project the force on this direction (m,) instead of using its norm.

    Raises:
        ParameterError: a setting is not positive / the window holds fewer than 16 samples.
    """

    def __init__(
        self,
        sample_time: float,
        *,
        window: float = 2.0,
        hop: float | None = None,
        min_amplitude: float = 2.0,
        growth_rate: float = 0.5,
        contact_force: float = 0.5,
        chatter_losses: int = 2,
        persistence: int = 3,
        direction: Any = None,
    ) -> None:
        self.sample_time = positive_scalar("sample_time", sample_time)
        self.window = positive_scalar("window", window)
        self.hop = positive_scalar("hop", self.window / 10.0 if hop is None else hop)
        self.min_amplitude = positive_scalar("min_amplitude", min_amplitude)
        self.growth_rate = positive_scalar("growth_rate", growth_rate)
        self.contact_force = positive_scalar("contact_force", contact_force)
        for name, v in (("chatter_losses", chatter_losses), ("persistence", persistence)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ParameterError(f"{name} must be an integer >= 1; got {v!r}")
        self.chatter_losses = int(chatter_losses)
        self.persistence = int(persistence)
        self._n = int(round(self.window / self.sample_time))
        if self._n < 16:
            raise ParameterError(
                f"window must hold at least 16 samples of sample_time = {self.sample_time:g} s; "
                f"got window = {self.window:g} s ({self._n} samples)"
            )
        self._hop = max(1, int(round(self.hop / self.sample_time)))
        self._min = min(64, self._n)  # a partial window is analysed from 64 samples on (fast divergence)
        if direction is None:
            self.direction = None
        else:
            d = np.asarray(direction, dtype=np.float64).reshape(-1)
            if not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0.0:
                raise ParameterError(f"direction must be a finite non-zero vector; got {np.asarray(direction).tolist()}")
            self.direction = d / np.linalg.norm(d)
        self.reset()

    def reset(self) -> None:
        """Forget every sample and status."""
        self._buf: deque[float] = deque(maxlen=self._n)
        self._count = 0
        self._streak = 0
        self._growing = 0
        self.status = MonitorStatus(math.nan, "ok", math.nan, 0.0, 0.0, 0.0, 0)
        self.history: list[MonitorStatus] = []

    def _scalar(self, force: Any) -> float:
        f = np.asarray(force, dtype=np.float64).reshape(-1)
        if self.direction is not None:
            if f.shape != self.direction.shape:
                raise DimensionError(f"force must have shape {self.direction.shape} like direction; got shape {f.shape}")
            return float(f @ self.direction)
        return float(np.linalg.norm(f))

    def update(self, t: float, force: Any) -> MonitorStatus:
        """Add one sample of the measured force (m,) [N] at time t [s]; the latest status.

        A non-finite force is flagged ``"divergence"`` at once.
        """
        s = self._scalar(force)
        if not math.isfinite(s):
            self.status = MonitorStatus(float(t), "divergence", math.nan, math.inf, math.inf, 0.0, 0)
            self.history.append(self.status)
            return self.status
        self._buf.append(s)
        self._count += 1
        if len(self._buf) >= self._min and self._count % self._hop == 0:
            self.status = self._analyse(float(t), np.fromiter(self._buf, dtype=np.float64, count=len(self._buf)))
            self.history.append(self.status)
        return self.status

    def _analyse(self, t: float, s: np.ndarray) -> MonitorStatus:
        from scipy.signal import butter, detrend, periodogram, sosfiltfilt  # type: ignore[import-untyped]

        n = s.shape[0]
        fs = 1.0 / self.sample_time
        d = detrend(s, type="linear")
        freqs, power = periodogram(d, fs=fs, window="hann", detrend=False)
        # an oscillation has at least three periods in the window: slower content is a trend
        # (a step response's rise), which must not read as growth
        f_min = 3.0 * fs / n
        power = np.where(freqs >= f_min, power, 0.0)
        total = float(power.sum())
        touching = s > self.contact_force
        losses = int(np.count_nonzero(touching[:-1] & ~touching[1:]))
        if total <= 0.0:
            self._streak = 0
            return MonitorStatus(t, "ok", math.nan, 0.0, 0.0, 0.0, losses)
        i = int(np.argmax(power))
        frequency = float(freqs[i])
        narrowband = float(power[max(i - 2, 0) : i + 3].sum() / total)
        # the oscillation alone: a zero-phase band-pass around the dominant frequency
        lo, hi = max(0.5 * frequency, 0.5 * f_min), min(2.0 * frequency, 0.45 * fs)
        band = sosfiltfilt(butter(2, [lo, hi], btype="bandpass", fs=fs, output="sos"), d) if hi > lo else d
        half = n // 2
        r1 = float(np.sqrt(np.mean(band[:half] ** 2)))
        r2 = float(np.sqrt(np.mean(band[half:] ** 2)))
        amplitude = math.sqrt(2.0) * r2
        tiny = 1e-12 * max(1.0, float(np.max(np.abs(s))))
        growth = math.log(max(r2, tiny) / max(r1, tiny)) / (half * self.sample_time)
        big = amplitude > self.min_amplitude
        cycling = big and narrowband > 0.5 and abs(growth) < self.growth_rate
        self._streak = self._streak + 1 if cycling else 0
        growing = big and growth > self.growth_rate
        self._growing = self._growing + 1 if growing else 0
        if growing and self._growing >= 2:  # two analyses in a row: one abrupt start is not a trend
            flag = "divergence"
        elif losses >= self.chatter_losses and (big or float(np.ptp(s)) > 2.0 * self.min_amplitude):
            flag = "chatter"
        elif cycling and self._streak >= self.persistence:
            flag = "limit-cycle"
        else:
            flag = "ok"
        return MonitorStatus(t, flag, frequency, amplitude, growth, narrowband, losses)

    def scan(self, result: Any) -> list[MonitorStatus]:
        """Run the monitor over a finished simulation (its measured force) from a fresh state.

        Args:
            result: a :class:`~forcecontrol.simulation.SimulationResult` (or anything with
                ``t`` and ``wrench_measured``) whose sample time is this monitor's.

        Returns:
            Every analysis in time order (also kept in :attr:`history`).

        Raises:
            ParameterError: the run's sample time differs from the monitor's.
        """
        t = np.asarray(result.t, dtype=np.float64)
        if t.shape[0] > 1 and not math.isclose(float(t[1] - t[0]), self.sample_time, rel_tol=1e-6):
            raise ParameterError(
                f"the run's sample time is {float(t[1] - t[0]):.6g} s; this monitor expects "
                f"sample_time = {self.sample_time:.6g} s"
            )
        self.reset()
        for k in range(t.shape[0]):
            self.update(float(t[k]), result.wrench_measured[k])
        return list(self.history)

    def first_alarm(self) -> MonitorStatus | None:
        """The first analysis that fired since the last reset, or None."""
        return next((s for s in self.history if s.fired), None)


class MonitoredController(Controller):
    """A controller watched by a :class:`StabilityMonitor`, backed off to a safe one when it fires.

    Each step feeds the measured wrench to the monitor; while it reports ``"ok"`` the primary
    controller's torques are returned. The first time it fires (with a flag in ``react_to``),
    an event ``{"t", "event": "stability", "flag", "frequency", "amplitude", "growth_rate"}`` is
    logged and, if a ``fallback`` is given, it is reset with the current measurement and takes
    over for the rest of the run (the safe set of gains); without a fallback the primary keeps
    running (monitor only).

    Args:
        primary: the controller tuned for performance.
        monitor: the monitor (its sample time must be the controller's).
        fallback: the safe controller (same robot), or None.
        react_to: flags that trigger the fallback; default all but ``"ok"``.

    Raises:
        ParameterError: mismatched sample times or robots, unknown flags.
    """

    def __init__(self, primary: Controller, monitor: StabilityMonitor, fallback: Controller | None = None,
                 react_to: tuple[str, ...] = ("limit-cycle", "chatter", "divergence")) -> None:
        if not isinstance(primary, Controller):
            raise ParameterError(f"primary must be a Controller; got {type(primary).__name__}")
        if not isinstance(monitor, StabilityMonitor):
            raise ParameterError(f"monitor must be a StabilityMonitor; got {type(monitor).__name__}")
        super().__init__(primary.robot, primary.sample_time)
        if not math.isclose(monitor.sample_time, primary.sample_time, rel_tol=1e-9):
            raise ParameterError(
                f"monitor.sample_time must equal the controller's {primary.sample_time:g} s; got {monitor.sample_time:g} s"
            )
        if fallback is not None:
            if not isinstance(fallback, Controller):
                raise ParameterError(f"fallback must be a Controller or None; got {type(fallback).__name__}")
            if fallback.robot is not primary.robot or not math.isclose(fallback.sample_time, primary.sample_time):
                raise ParameterError("fallback must use the same robot object and sample time as primary")
        bad = [f for f in react_to if f not in FLAGS or f == "ok"]
        if bad:
            raise ParameterError(f"react_to must name flags among {list(FLAGS[1:])}; got {bad}")
        self.primary, self.monitor, self.fallback = primary, monitor, fallback
        self.react_to = tuple(react_to)
        self.uses_force = True  # type: ignore[misc]
        self.reset()

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Reset the monitor and both controllers; the primary is in charge again."""
        self.monitor.reset()
        self.primary.reset(measurement, reference)
        if self.fallback is not None:
            self.fallback.reset(measurement, reference)
        self.active = self.primary
        self._events: list[dict[str, Any]] = []

    @property
    def events(self) -> list[dict[str, Any]]:
        """The stability alarms (at most one: the first), with the inner controllers' own events."""
        inner = [e for c in (self.primary, self.fallback) if c is not None for e in getattr(c, "events", [])]
        return sorted(self._events + inner, key=lambda e: e["t"])

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """The active controller's torques, after the monitor has seen this sample's wrench."""
        status = self.monitor.update(t, measurement.wrench)
        if self.active is self.primary and status.flag in self.react_to and not self._events:
            self._events.append({"event": "stability", **status.as_dict(), "t": float(t),
                                 "reaction": "fallback" if self.fallback is not None else "none"})
            if self.fallback is not None:
                self.fallback.reset(measurement, reference)
                self.active = self.fallback
        return self.active.step(t, measurement, reference)

    def gains(self) -> dict[str, Any]:
        return {"primary": self.primary.gains(), "fallback": None if self.fallback is None else self.fallback.gains()}
