"""A fixed-rate loop in plain Python: a rate limiter and the statistics of its timing.

:class:`RateLimiter` sleeps until each cycle's deadline (``time.perf_counter``; ``time.sleep``
for most of the wait, a short spin for the rest, because ``sleep`` alone wakes up late by about
0.1 ms on a general-purpose kernel) and records, per cycle, the deadline, the wake-up and the end
of the work. A cycle whose work ends after the next deadline is an *overrun*: the ticks it ran
over are dropped (the schedule keeps its phase, ``t_0 + k T``) rather than run in a burst to
catch up, as a real-time controller must never send a burst of stale commands.

:func:`loop_statistics` turns the three timestamp arrays into the numbers that say whether a loop
keeps its rate: wake-up lateness (the jitter against the schedule: median, p99, max), the
compute time per cycle, the overruns and the ticks dropped. It is a pure function of the
timestamps, so it is tested on synthetic ones.

When the loop misses deadlines, in order of effect:

1. Measure first: is it the compute (compute p99 close to or above the period) or the wake-up
   (lateness p99 high while compute is small)? The statistics separate the two.
2. Compute too long: keep the per-cycle work to the control law (no logging to disk, no
   plotting, no allocation-heavy code in the loop; write logs from a preallocated array after
   the run); warm up compiled code before the motors are on (the first call compiles); use the
   compiled controllers; lower the rate (500 Hz is enough for most force loops whose bandwidth
   is tens of Hz; retune with the new sample time).
3. Wake-up late: run the loop with a real-time priority (:func:`realtime_priority`:
   ``SCHED_FIFO``, optionally pinned to an idle core, memory locked; needs privileges) on a
   PREEMPT_RT kernel; disable CPU frequency scaling. Measured here (a 2-core virtual machine,
   ``python examples/own_loop.py --seconds 10``, both arms): 6–11 overruns per 10 s with ordinary
   scheduling; under ``realtime_priority``, none in 8 of 12 runs of 10 s and 1–2 in the others,
   each a wake-up 2–8 ms late or one 2.9 ms cycle (the same schedule with no work at all wakes
   up as late at times: the host's, not the loop's); keep the garbage collector out of the loop
   (:func:`frozen_heap`: ``gc.collect()`` then ``gc.freeze()`` before it — a full collection
   over the heap of NumPy, SciPy and Numba takes milliseconds and lands in whatever call
   allocates, often the sleep of ``wait``: measured here, 4–6 overruns in 10 s of the own-loop
   example, all wake-ups 0.7–3.6 ms late, and none with the heap frozen).
4. Still missing: move the 1 kHz loop into the robot's own real-time controller (libfranka's
   callback, UR's RTDE with a servo target, ros2_control) and run Python at a lower rate to
   send it set-points and gains; or let the robot's driver hold the last torque safely and treat
   an overrun as a fault (stop after N consecutive overruns).
"""

from __future__ import annotations

import gc
import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import DimensionError, ParameterError
from .scheduling import RealtimeSettings, realtime_priority

__all__ = [
    "LoopStatistics", "RateLimiter", "RealtimeSettings", "frozen_heap", "loop_statistics", "realtime_priority",
]


@contextmanager
def frozen_heap() -> Iterator[None]:
    """Keep full garbage collections out of a real-time loop: ``with frozen_heap(): <the loop>``.

    Collects once, then moves every object alive into the collector's permanent generation
    (``gc.freeze``), so the collections the loop's own allocations trigger scan only what the
    loop allocated (microseconds) instead of the whole heap (milliseconds). Unfrozen on exit.
    Reference cycles created inside the loop are still collected.
    """
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


@dataclass(frozen=True)
class LoopStatistics:
    """Timing of a fixed-rate loop (all times in seconds).

    Attributes:
        period: the loop period T.
        cycles: number of cycles run.
        lateness_median, lateness_p99, lateness_max: wake-up time minus deadline (jitter).
        compute_median, compute_p99, compute_max: end of the work minus wake-up.
        overruns: cycles whose work ended after the next deadline.
        dropped_ticks: deadlines skipped because of overruns.
        utilisation: median compute / period.
    """

    period: float
    cycles: int
    lateness_median: float
    lateness_p99: float
    lateness_max: float
    compute_median: float
    compute_p99: float
    compute_max: float
    overruns: int
    dropped_ticks: int
    utilisation: float

    def summary(self) -> str:
        """One line in microseconds, e.g. for a report."""
        us = 1e6
        return (
            f"{self.cycles} cycles at {1.0 / self.period:.0f} Hz: lateness median {us * self.lateness_median:.0f} µs, "
            f"p99 {us * self.lateness_p99:.0f} µs, max {us * self.lateness_max:.0f} µs; compute median "
            f"{us * self.compute_median:.0f} µs, p99 {us * self.compute_p99:.0f} µs, max {us * self.compute_max:.0f} µs; "
            f"overruns {self.overruns} ({self.dropped_ticks} ticks dropped); utilisation {100 * self.utilisation:.0f} %"
        )

    def as_dict(self) -> dict[str, Any]:
        """Plain data for JSON."""
        return dict(self.__dict__)


def loop_statistics(period: float, deadlines: Any, wakeups: Any, ends: Any) -> LoopStatistics:
    """Statistics of a fixed-rate loop from its per-cycle timestamps.

    Cycle k has deadline d_k, wakes up at s_k >= d_k (ideally) and ends its work at e_k. It is an
    overrun when e_k > d_k + T (it ran into the next tick); the ticks dropped after it are the
    multiples of T skipped until the next deadline d_{k+1} (``round((d_{k+1} − d_k)/T) − 1``).

    Args:
        period: T [s], > 0.
        deadlines, wakeups, ends: (n,) timestamps [s] on one clock, n >= 1.

    Returns:
        A :class:`LoopStatistics`.

    Raises:
        ParameterError: period not positive, timestamps not finite, an end before its wake-up,
            deadlines not increasing. DimensionError: arrays of different lengths or empty.
    """
    T = positive_scalar("period", period)
    d, s, e = (np.asarray(v, dtype=np.float64).reshape(-1) for v in (deadlines, wakeups, ends))
    if not (d.shape == s.shape == e.shape) or d.size == 0:
        raise DimensionError(
            f"deadlines, wakeups and ends must be non-empty arrays of one length; got lengths {d.size}, {s.size}, {e.size}"
        )
    for name, a in (("deadlines", d), ("wakeups", s), ("ends", e)):
        if not np.all(np.isfinite(a)):
            raise ParameterError(f"{name} must be finite; got NaN or inf at cycle {int(np.flatnonzero(~np.isfinite(a))[0])}")
    if np.any(e < s):
        raise ParameterError(f"ends must not precede wakeups; cycle {int(np.flatnonzero(e < s)[0])} ends before it starts")
    if np.any(np.diff(d) <= 0):
        raise ParameterError(f"deadlines must increase; cycle {int(np.flatnonzero(np.diff(d) <= 0)[0]) + 1} does not")
    late, comp = s - d, e - s
    over = e > d + T
    gaps = np.rint(np.diff(d) / T).astype(np.int64) - 1
    return LoopStatistics(
        period=T, cycles=int(d.size),
        lateness_median=float(np.median(late)), lateness_p99=float(np.percentile(late, 99)), lateness_max=float(late.max()),
        compute_median=float(np.median(comp)), compute_p99=float(np.percentile(comp, 99)), compute_max=float(comp.max()),
        overruns=int(over.sum()), dropped_ticks=int(np.maximum(gaps, 0).sum()),
        utilisation=float(np.median(comp)) / T,
    )


class RateLimiter:
    """Sleep until each cycle's deadline; record the timing of every cycle.

    Usage::

        limiter = RateLimiter(1e-3, cycles=2000)
        for k in range(2000):
            limiter.wait()          # returns at deadline t_0 + j T (j >= k when ticks were dropped)
            ...read, control, write...
            limiter.done()          # end of the work; schedules the next deadline
        print(limiter.statistics().summary())

    The first :meth:`wait` sets t_0 to the current time. After :meth:`done`, the next deadline is
    the next multiple of T after the previous one; when the work ended past it (an overrun), the
    next deadline is the first multiple of T still ahead (missed ticks are dropped, the phase kept).

    Args:
        period: T [s], > 0.
        cycles: capacity of the timing record (cycles beyond it are run but not recorded).
        spin: the last part of each wait spent spinning instead of sleeping [s], >= 0.
        clock: a monotonic clock in seconds (``time.perf_counter``); replaceable for tests.
        sleep: a sleep function in seconds (``time.sleep``); replaceable for tests.

    Raises:
        ParameterError: period not positive, spin negative, cycles not a positive integer.
    """

    def __init__(self, period: float, *, cycles: int = 100_000, spin: float = 3e-4,
                 clock: Callable[[], float] = time.perf_counter, sleep: Callable[[float], Any] = time.sleep) -> None:
        self.period = positive_scalar("period", period)
        self.spin = nonnegative_scalar("spin", spin)
        if isinstance(cycles, bool) or not isinstance(cycles, (int, np.integer)) or cycles < 1:
            raise ParameterError(f"cycles must be a positive integer; got {cycles!r}")
        self._clock, self._sleep = clock, sleep
        self._d = np.empty(int(cycles))
        self._s = np.empty(int(cycles))
        self._e = np.empty(int(cycles))
        self.reset()

    def reset(self) -> None:
        """Forget the schedule and the record; the next :meth:`wait` starts a new schedule."""
        self.count = 0
        self._t0: float | None = None
        self._tick = 0
        self._woke: float | None = None

    @property
    def deadline(self) -> float:
        """The current cycle's deadline [s] on the clock (NaN before the first wait)."""
        return math.nan if self._t0 is None else self._t0 + self._tick * self.period

    def wait(self) -> float:
        """Sleep until the current deadline; return the lateness (wake-up − deadline) [s].

        Raises:
            ParameterError: called twice without :meth:`done` in between.
        """
        if self._woke is not None:
            raise ParameterError("wait() called twice without done(): call done() at the end of each cycle's work")
        now = self._clock()
        if self._t0 is None:
            self._t0 = now
        target = self.deadline
        while (left := target - now) > self.spin:
            self._sleep(left - self.spin)
            now = self._clock()
        while now < target:
            now = self._clock()
        self._woke = now
        return now - target

    def done(self) -> bool:
        """Mark the end of the cycle's work; schedule the next deadline. Returns True on an overrun.

        Raises:
            ParameterError: called without a preceding :meth:`wait`.
        """
        if self._woke is None:
            raise ParameterError("done() called without wait(): call wait() at the start of each cycle")
        end = self._clock()
        deadline = self.deadline
        if self.count < len(self._d):
            self._d[self.count], self._s[self.count], self._e[self.count] = deadline, self._woke, end
        self.count += 1
        self._woke = None
        next_tick = self._tick + 1
        overrun = end > deadline + self.period
        if overrun:  # drop the ticks already past, keep the phase
            t0 = self._t0 if self._t0 is not None else end
            next_tick = max(next_tick, math.floor((end - t0) / self.period) + 1)
        self._tick = next_tick
        return overrun

    def record(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(deadlines, wakeups, ends) of the recorded cycles [s]."""
        n = min(self.count, len(self._d))
        return self._d[:n].copy(), self._s[:n].copy(), self._e[:n].copy()

    def statistics(self) -> LoopStatistics:
        """:func:`loop_statistics` of the recorded cycles.

        Raises:
            DimensionError: no cycle recorded yet.
        """
        return loop_statistics(self.period, *self.record())
