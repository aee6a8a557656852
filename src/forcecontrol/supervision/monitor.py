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
* the envelope's growth rate over the last ``growth_window`` seconds: a least-squares line
  through ln(RMS) of the band-passed force in blocks of one period (``envelope_growth``, with its
  coefficient of determination R²);
* contact losses: how often the force falls below ``contact_force / 2`` after being above
  ``contact_force`` (the hysteresis ignores sensor noise while the force rises through it).

Flags, most severe first: ``"divergence"`` (a non-finite sample; A above ``min_amplitude``
growing faster than ``growth_rate`` in two analyses in a row; or *sustained growth*: the
envelope's fitted growth rate above ``sustained_growth`` with R² >= 0.8, over at least
``growth_periods`` periods, with the amplitude above the noise floor ``growth_floor``, in two
analyses in a row — this catches a slowly growing oscillation long before it reaches
``min_amplitude``), ``"chatter"`` (at least ``chatter_losses`` contact losses
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

from ..controllers.base import Controller, Measurement, Reference
from ..core.validate import positive_scalar
from ..errors import DimensionError, ParameterError

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
        envelope_growth: the envelope's growth rate [1/s] fitted over the last ``growth_window``
            (NaN: fewer than ``growth_periods`` periods analysed yet).
        cause: why it fired: ``"non-finite"``, ``"amplitude"`` (the amplitude path),
            ``"sustained-growth"``, or ``""``.
    """

    t: float
    flag: str
    frequency: float
    amplitude: float
    growth_rate: float
    narrowband: float
    contact_losses: int
    envelope_growth: float = math.nan
    cause: str = ""

    @property
    def fired(self) -> bool:
        """Whether the flag is anything but ``"ok"``."""
        return self.flag != "ok"

    def as_dict(self) -> dict[str, Any]:
        """Plain values (for logs and JSON)."""
        return {
            "t": self.t, "flag": self.flag, "frequency": self.frequency, "amplitude": self.amplitude,
            "growth_rate": self.growth_rate, "narrowband": self.narrowband, "contact_losses": self.contact_losses,
            "envelope_growth": self.envelope_growth, "cause": self.cause,
        }


def _contact_losses(s: np.ndarray, contact_force: float) -> int:
    """Contact losses in s: falls below contact_force / 2 after being above contact_force.

    The hysteresis keeps sensor noise around ``contact_force`` (while the force rises through it)
    from counting as losses.
    """
    state = np.where(s > contact_force, 1, np.where(s < 0.5 * contact_force, 0, -1))
    known = np.flatnonzero(state >= 0)
    if known.size < 2:
        return 0
    held = state[known]
    return int(np.count_nonzero((held[:-1] == 1) & (held[1:] == 0)))


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
        sustained_growth: σ_g [1/s] above which a steadily growing envelope (fit over
            ``growth_window``, R² >= 0.8) is a divergence even below ``min_amplitude``;
            default 0.25 (amplitude doubling in 2.8 s). Choose it below the slowest growth to
            catch and above the decay rates of the stable cases (σ_g ≈ 0 on a steady oscillation).
        growth_window: span of the envelope fit [s]; default 1.0 (at most the window).
        growth_periods: fewest oscillation periods the fit must span; default 8.
        growth_floor: noise floor [N]: an oscillation whose amplitude is below this is never a
            sustained growth; default 0.05 N. Set it above the oscillation that sensor noise
            alone excites in the closed loop (a stable loop near its limit resonates).

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
        sustained_growth: float = 0.25,
        growth_window: float = 1.0,
        growth_periods: int = 8,
        growth_floor: float = 0.05,
    ) -> None:
        self.sample_time = positive_scalar("sample_time", sample_time)
        self.window = positive_scalar("window", window)
        self.hop = positive_scalar("hop", self.window / 10.0 if hop is None else hop)
        self.min_amplitude = positive_scalar("min_amplitude", min_amplitude)
        self.growth_rate = positive_scalar("growth_rate", growth_rate)
        self.contact_force = positive_scalar("contact_force", contact_force)
        self.sustained_growth = positive_scalar("sustained_growth", sustained_growth)
        self.growth_window = min(positive_scalar("growth_window", growth_window), self.window)
        self.growth_floor = positive_scalar("growth_floor", growth_floor)
        for name, v in (("chatter_losses", chatter_losses), ("persistence", persistence), ("growth_periods", growth_periods)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ParameterError(f"{name} must be an integer >= 1; got {v!r}")
        self.chatter_losses = int(chatter_losses)
        self.persistence = int(persistence)
        self.growth_periods = int(growth_periods)
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
        self._sustained = 0
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
            self.status = MonitorStatus(float(t), "divergence", math.nan, math.inf, math.inf, 0.0, 0, math.inf, "non-finite")
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
        losses = _contact_losses(s, self.contact_force)
        if total <= 0.0:
            self._streak = self._growing = self._sustained = 0
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
        envelope, r2, last = self._envelope_fit(band, frequency)
        sustained = envelope > self.sustained_growth and r2 >= 0.8 and last > self.growth_floor
        self._sustained = self._sustained + 1 if sustained else 0
        cause = ""
        if growing and self._growing >= 2:  # two analyses in a row: one abrupt start is not a trend
            flag, cause = "divergence", "amplitude"
        elif sustained and self._sustained >= 2:
            flag, cause = "divergence", "sustained-growth"
        elif losses >= self.chatter_losses and (big or float(np.ptp(s)) > 2.0 * self.min_amplitude):
            flag = "chatter"
        elif cycling and self._streak >= self.persistence:
            flag = "limit-cycle"
        else:
            flag = "ok"
        return MonitorStatus(t, flag, frequency, amplitude, growth, narrowband, losses, envelope, cause)

    def _envelope_fit(self, band: np.ndarray, frequency: float) -> tuple[float, float, float]:
        """σ_g [1/s], R² and the last period's amplitude [N] of ln(RMS per period) over the growth window."""
        period = max(4, int(round(1.0 / (frequency * self.sample_time))))
        blocks = min(band.shape[0], int(round(self.growth_window / self.sample_time))) // period
        if blocks < max(self.growth_periods, 3):
            return math.nan, 0.0, 0.0
        seg = band[band.shape[0] - blocks * period :].reshape(blocks, period)
        rms = np.sqrt(np.mean(seg * seg, axis=1))
        if not np.all(rms > 0.0):
            return math.nan, 0.0, 0.0
        y = np.log(rms)
        tk = np.arange(blocks) * (period * self.sample_time)
        slope, icpt = np.polyfit(tk, y, 1)
        spread = float(np.var(y))
        r2 = 1.0 - float(np.var(y - (slope * tk + icpt))) / spread if spread > 0.0 else 0.0
        return float(slope), r2, math.sqrt(2.0) * float(rms[-1])

    def scan(self, result: Any) -> list[MonitorStatus]:
        """Run the monitor over a finished simulation (its measured force) from a fresh state.

        Args:
            result: a :class:`~forcecontrol.sim.simulation.SimulationResult` (or anything with
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
