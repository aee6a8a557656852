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

import ctypes
import gc
import math
import os
import platform
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._validate import nonnegative_scalar, positive_scalar
from .errors import DimensionError, ParameterError, RealtimeError

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


#: mlockall(2) flags on Linux (x86, Arm, RISC-V; PowerPC, SPARC and Alpha use other values).
_MCL_CURRENT, _MCL_FUTURE = 1, 2
_MCL_MACHINES = ("x86_64", "amd64", "i386", "i686", "aarch64", "arm64", "armv7l", "riscv64")


@dataclass(frozen=True)
class RealtimeSettings:
    """What :func:`realtime_priority` got from the operating system inside its block.

    Attributes:
        policy: ``"SCHED_FIFO"`` when granted, else the policy kept (``"SCHED_OTHER"``, ...).
        priority: the real-time priority in effect (0 under a non-real-time policy).
        cpus: the CPUs the calling thread may run on.
        memory_locked: the process's memory is locked in RAM (``mlockall``).
        refused: one line per setting asked for and not granted, with the operating system's reason.
    """

    policy: str
    priority: int
    cpus: tuple[int, ...]
    memory_locked: bool
    refused: tuple[str, ...]

    @property
    def granted(self) -> bool:
        """Every setting asked for is in effect."""
        return not self.refused

    def summary(self) -> str:
        """One line, e.g. for a loop's report."""
        got = (f"{self.policy} priority {self.priority}, CPUs {','.join(map(str, self.cpus))}, "
               f"memory {'locked' if self.memory_locked else 'not locked'}")
        return got if self.granted else f"{got}; refused: {'; '.join(self.refused)}"


def _policy_name(policy: int) -> str:
    for name in ("SCHED_OTHER", "SCHED_FIFO", "SCHED_RR", "SCHED_BATCH", "SCHED_IDLE"):
        if getattr(os, name, None) == policy:
            return name
    return f"policy {policy}"


def _locked_kb() -> int:
    """The process's locked memory [kB] (``VmLck`` of ``/proc/self/status``); 0 when unknown."""
    try:
        with open("/proc/self/status") as f:
            return next((int(line.split()[1]) for line in f if line.startswith("VmLck:")), 0)
    except (OSError, ValueError, IndexError):
        return 0


def _libc() -> Any:
    return ctypes.CDLL(None, use_errno=True)


#: the memory lock is the whole process's: the blocks holding it (any thread, nested) are
#: counted, the first locks and the last unlocks, and only when the memory was not locked
#: before the first (by the caller or a library: their lock is left as it was).
_MEMORY_LOCK = threading.Lock()
_memory_users = 0
_memory_ours = False


def _lock_memory() -> str | None:
    """Hold the process's memory locked for one more block; the OS's refusal text, or None."""
    global _memory_users, _memory_ours
    with _MEMORY_LOCK:
        if _memory_users == 0:
            before = _locked_kb()
            libc = _libc()
            if libc.mlockall(_MCL_CURRENT | _MCL_FUTURE) != 0:
                return os.strerror(ctypes.get_errno())
            _memory_ours = before == 0
        _memory_users += 1
        return None


def _unlock_memory() -> None:
    """One block less; the last unlocks the memory if the first locked it."""
    global _memory_users
    with _MEMORY_LOCK:
        _memory_users -= 1
        if _memory_users == 0 and _memory_ours:
            _libc().munlockall()


@contextmanager
def realtime_priority(priority: int = 80, *, cpu: int | None = None, lock_memory: bool = True,
                      strict: bool = False) -> Iterator[RealtimeSettings]:
    """Run the block as a real-time thread: ``with realtime_priority() as rt: <the 1 kHz loop>``.

    What a fixed-rate control loop on Linux asks of the kernel (as ros2_control's and libfranka's
    loops do): the ``SCHED_FIFO`` policy at ``priority`` for the calling thread (it preempts every
    ordinary process, so a wake-up is no longer queued behind them), optionally pinned to one CPU,
    and the process's memory locked in RAM (``mlockall(MCL_CURRENT | MCL_FUTURE)``: no page fault
    to disk inside the loop). Everything is restored on exit: policy, priority, CPUs, and the
    memory unlocked when the last block holding it (in any thread; blocks nest) ends, unless
    some of it was locked before the first (that lock is the caller's, and is left).

    Each setting needs a privilege (root, ``CAP_SYS_NICE`` / ``CAP_IPC_LOCK``, or the
    ``rtprio`` / ``memlock`` limits of ``/etc/security/limits.conf``). One that is refused is
    reported in the yielded :class:`RealtimeSettings` (``refused``) and the block runs without it,
    or, with ``strict=True``, :class:`~forcecontrol.errors.RealtimeError` is raised before the
    block runs. Keep the block's loop sleeping most of each period: the kernel's real-time
    throttling (``/proc/sys/kernel/sched_rt_runtime_us``, 95 % by default) is the only thing
    that stops a ``SCHED_FIFO`` thread that never sleeps from starving its CPU.

    A priority does not make a general-purpose kernel real-time: a PREEMPT_RT kernel bounds the
    remaining latencies, and under a virtual machine the host can still take the CPU away (the
    loop's statistics show it as late wake-ups with no work to blame).

    Args:
        priority: ``SCHED_FIFO`` priority, an integer in 1..99 (ros2_control uses 50, libfranka 80).
        cpu: pin the calling thread to this CPU (one the process may run on); ``None`` keeps the CPUs.
        lock_memory: lock the process's memory in RAM for the block.
        strict: raise instead of running with a setting refused.

    Yields:
        The :class:`RealtimeSettings` in effect.

    Raises:
        ParameterError: priority not an integer in 1..99, cpu not one of the process's CPUs.
        RealtimeError: ``strict=True`` and a setting was refused (or the platform has no such setting).
    """
    if isinstance(priority, bool) or not isinstance(priority, (int, np.integer)) or not 1 <= priority <= 99:
        raise ParameterError(f"priority must be an integer in 1..99 (SCHED_FIFO); got {priority!r}")
    has_sched = all(hasattr(os, f) for f in ("sched_setscheduler", "sched_getscheduler", "sched_getaffinity"))
    allowed = tuple(sorted(os.sched_getaffinity(0))) if has_sched else ()
    if cpu is not None and (isinstance(cpu, bool) or not isinstance(cpu, (int, np.integer)) or
                            (has_sched and int(cpu) not in allowed)):
        raise ParameterError(f"cpu must be one of the CPUs this process may run on {list(allowed)}; got {cpu!r}")
    refused: list[str] = []
    restore: list[Callable[[], Any]] = []
    try:
        if not has_sched:
            refused.append(f"SCHED_FIFO and CPU pinning: not available on {platform.system()}")
        else:
            old_policy, old_param = os.sched_getscheduler(0), os.sched_getparam(0)
            try:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(int(priority)))
                restore.append(lambda: os.sched_setscheduler(0, old_policy, old_param))
            except OSError as exc:
                refused.append(f"SCHED_FIFO priority {priority}: {exc.strerror or exc} (needs root or CAP_SYS_NICE)")
            if cpu is not None:
                old_cpus = set(allowed)
                try:
                    os.sched_setaffinity(0, {int(cpu)})
                    restore.append(lambda: os.sched_setaffinity(0, old_cpus))
                except OSError as exc:
                    refused.append(f"pinning to CPU {cpu}: {exc.strerror or exc}")
        locked = False
        if lock_memory:
            if platform.system() != "Linux" or platform.machine().lower() not in _MCL_MACHINES:
                refused.append(f"memory lock: not available on {platform.system()} {platform.machine()}")
            else:
                err = _lock_memory()
                if err is None:
                    locked = True
                    restore.append(_unlock_memory)
                else:
                    refused.append(f"memory lock: {err} (needs root, CAP_IPC_LOCK or a larger memlock limit)")
        if strict and refused:
            raise RealtimeError("real-time settings refused: " + "; ".join(refused))
        if has_sched:
            policy = os.sched_getscheduler(0)
            settings = RealtimeSettings(_policy_name(policy), int(os.sched_getparam(0).sched_priority),
                                        tuple(sorted(os.sched_getaffinity(0))), locked, tuple(refused))
        else:
            settings = RealtimeSettings("unknown", 0, (), locked, tuple(refused))
        yield settings
    finally:
        failed = []
        for undo in reversed(restore):  # each one, even when another fails
            try:
                undo()
            except OSError as exc:
                failed.append(str(exc))
        if failed and sys.exc_info()[0] is None:  # the block's own error, if any, is the one to see
            raise RealtimeError("restoring the scheduling after the real-time block failed: " + "; ".join(failed))


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
