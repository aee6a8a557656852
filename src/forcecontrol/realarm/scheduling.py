"""Asking the operating system for a real-time loop: ``SCHED_FIFO``, a pinned CPU, locked memory.

:func:`realtime_priority` (re-exported by :mod:`forcecontrol.realarm.realtime`, where the loop's other
tools are) runs a block as a real-time thread and restores everything after it; what the kernel
refused is reported in :class:`RealtimeSettings`, or raised with ``strict=True``.
"""

from __future__ import annotations

import ctypes
import os
import platform
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError, RealtimeError

__all__ = ["RealtimeSettings", "realtime_priority"]


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
