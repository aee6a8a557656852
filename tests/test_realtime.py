"""Loop timing: statistics on synthetic timestamps, and the rate limiter driven by a fake clock (no wall-clock asserts)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.realarm.realtime import RateLimiter, loop_statistics

T = 1e-3


def test_statistics_of_a_perfect_loop():
    """Wake-ups on the deadlines, 200 µs of work each: lateness 0, compute 200 µs, no overrun, utilisation 20 %."""
    d = np.arange(1000) * T
    st = loop_statistics(T, d, d, d + 2e-4)
    assert st.cycles == 1000 and st.overruns == 0 and st.dropped_ticks == 0
    assert st.lateness_median == 0.0 and st.lateness_max == 0.0
    assert st.compute_median == pytest.approx(2e-4) and st.utilisation == pytest.approx(0.2)


def test_statistics_percentiles_against_a_known_distribution():
    """Lateness k µs for k = 0..99 (each once): median 49.5 µs, p99 98.01 µs (linear interpolation), max 99 µs."""
    d = np.arange(100) * T
    late = np.random.default_rng(0).permutation(np.arange(100)) * 1e-6
    st = loop_statistics(T, d, d + late, d + late + 1e-4)
    assert st.lateness_median == pytest.approx(49.5e-6)
    assert st.lateness_p99 == pytest.approx(98.01e-6)
    assert st.lateness_max == pytest.approx(99e-6)
    assert st.compute_p99 == pytest.approx(1e-4)


def test_overruns_and_dropped_ticks_are_counted():
    """Cycle 3 works 2.5 ms: an overrun, next deadline 3 ticks later (2 dropped); cycle 4 ending on the tick is not one."""
    d = np.array([0, 1, 2, 3, 6, 7, 8], dtype=float) * T
    s = d.copy()
    e = s + 1e-4
    e[3] = s[3] + 2.5e-3
    e[4] = d[4] + T  # exactly on the next tick: not an overrun
    st = loop_statistics(T, d, s, e)
    assert st.overruns == 1 and st.dropped_ticks == 2


@pytest.mark.parametrize(
    "args, exc, match",
    [
        ((0.0, [0.0], [0.0], [0.0]), ParameterError, "period must be a positive number"),
        ((T, [0.0, T], [0.0], [0.0]), DimensionError, r"non-empty arrays of one length; got lengths 2, 1, 1"),
        ((T, [], [], []), DimensionError, "non-empty"),
        ((T, [0.0, T], [0.0, T], [1e-4, np.nan]), ParameterError, "ends must be finite; got NaN or inf at cycle 1"),
        ((T, [0.0, T], [0.0, 2 * T], [1e-4, T]), ParameterError, "ends must not precede wakeups; cycle 1"),
        ((T, [0.0, 0.0], [0.0, 0.0], [1e-4, 1e-4]), ParameterError, "deadlines must increase; cycle 1"),
    ],
)
def test_bad_timestamps_are_refused(args, exc, match):
    """Non-positive period, mismatched/empty arrays, NaN, ends before wake-ups, non-increasing deadlines: clear errors."""
    with pytest.raises(exc, match=match):
        loop_statistics(*args)


class FakeClock:
    """A clock that advances only when slept on or when work is simulated; sleep overshoots by a fixed amount."""

    def __init__(self, overshoot: float = 0.0) -> None:
        self.t, self.overshoot, self.sleeps = 100.0, overshoot, []

    def __call__(self) -> float:
        self.t += 1e-7  # each reading of the clock costs 0.1 µs (so spinning terminates)
        return self.t

    def sleep(self, dt: float) -> None:
        self.sleeps.append(dt)
        self.t += dt + self.overshoot

    def work(self, dt: float) -> None:
        self.t += dt


def test_rate_limiter_keeps_the_schedule_and_spins_the_last_part():
    """Fake clock, sleep overshooting 50 µs < spin 300 µs: every wake-up within 0.2 µs after its deadline, deadlines t0 + k T."""
    clk = FakeClock(overshoot=5e-5)
    lim = RateLimiter(T, cycles=50, spin=3e-4, clock=clk, sleep=clk.sleep)
    for _ in range(50):
        lim.wait()
        clk.work(2e-4)
        assert not lim.done()
    d, s, e = lim.record()
    np.testing.assert_allclose(np.diff(d), T, rtol=1e-9)
    assert np.all(s >= d) and np.all(s - d < 2e-7)
    st = lim.statistics()
    assert st.overruns == 0 and st.compute_median == pytest.approx(2e-4, abs=1e-6)
    assert all(x > 0 for x in clk.sleeps)


def test_rate_limiter_drops_missed_ticks_and_keeps_the_phase():
    """One cycle works 3.5 ms: done() reports an overrun; the next deadline is t0 + 5 T (3 ticks dropped), the phase kept."""
    clk = FakeClock()
    lim = RateLimiter(T, cycles=10, clock=clk, sleep=clk.sleep)
    works = [1e-4, 1e-4, 3.5e-3, 1e-4, 1e-4]
    flags = []
    for w in works:
        lim.wait()
        clk.work(w)
        flags.append(lim.done())
    d, _, _ = lim.record()
    assert flags == [False, False, True, False, False]
    np.testing.assert_allclose((d - d[0]) / T, [0, 1, 2, 6, 7], atol=1e-6)
    st = lim.statistics()
    assert st.overruns == 1 and st.dropped_ticks == 3


def test_rate_limiter_refuses_misuse():
    """done() before wait(), wait() twice, a zero period, a negative spin: clear errors."""
    clk = FakeClock()
    lim = RateLimiter(T, clock=clk, sleep=clk.sleep)
    with pytest.raises(ParameterError, match=r"done\(\) called without wait\(\)"):
        lim.done()
    lim.wait()
    with pytest.raises(ParameterError, match=r"wait\(\) called twice without done\(\)"):
        lim.wait()
    with pytest.raises(ParameterError, match="period must be a positive number"):
        RateLimiter(0.0)
    with pytest.raises(ParameterError, match="spin must be a non-negative number"):
        RateLimiter(T, spin=-1.0)
    with pytest.raises(ParameterError, match="cycles must be a positive integer"):
        RateLimiter(T, cycles=0)
    with pytest.raises(DimensionError, match="non-empty"):
        RateLimiter(T).statistics()


def test_own_loop_example_runs_both_arms_and_reports_statistics():
    """examples/own_loop.py on both arms for 100 cycles: one timing record per cycle (no wall time asserted)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "examples"))
    try:
        import own_loop
    finally:
        sys.path.pop(0)
    stats = own_loop.chapter_arm(100)
    st = stats["statistics"]
    assert st.cycles == 100 and st.period == own_loop.PERIOD and len(stats["compute"]) == 100
    assert st.lateness_max >= 0.0 and st.compute_median > 0.0
    pytest.importorskip("pinocchio")
    st = own_loop.panda(100)["statistics"]
    assert st.cycles == 100


def test_own_loop_example_as_a_user_runs_it_reports_its_scheduling():
    """``python examples/own_loop.py``: the loops run under realtime_priority and the report says what
    the kernel granted (or refused, and why); ``--no-realtime`` says ordinary scheduling."""
    import subprocess
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "examples" / "own_loop.py"
    for flags, expect in (([], r"scheduling: (SCHED_FIFO priority 80|.*refused: )"),
                          (["--no-realtime"], r"scheduling: ordinary \(--no-realtime\)")):
        out = subprocess.run([sys.executable, str(path), "--seconds", "0.05", *flags], capture_output=True, text=True,
                             check=True).stdout
        assert re.search(expect, out), out
        assert re.search(r"chapter arm: 50 cycles at 1000 Hz", out), out


def test_a_read_only_reference_runs_the_same_compiled_step_no_new_specialisation():
    """A path's constant force is a read-only array: stepping with it after a writable one must not
    compile or load another specialisation mid-loop (that cost one 8 ms cycle at first contact)."""
    import numpy as np

    import forcecontrol as fc
    from forcecontrol import laws

    arm = fc.CHAPTER_ARM
    ctl = fc.InnerVelocityForceController(arm, 100, 5000, 2500, [0.0024, 0.0])
    q = arm.inverse_kinematics([1.0, 0.0])
    m = fc.Measurement(q, np.array([0.01, -0.02]), np.array([3.0, 0.0]))
    writable = fc.Reference.setpoint([1.0, 0.0], [10.0, 0.0])
    ctl.reset(m, writable)
    u1 = ctl.step(0, m, writable)  # an int time is fine too
    step = laws.on_arm(ctl.compiled_law)
    force = np.array([10.0, 0.0])
    force.flags.writeable = False
    read_only = fc.Reference(writable.position, writable.velocity, writable.acceleration, force,
                             writable.force_rate, writable.force_accel)
    ctl.reset(m, read_only)
    u2 = ctl.step(0.0, m, read_only)
    assert len(step.signatures) == 1
    np.testing.assert_array_equal(u1, u2)
    # a non-contiguous view takes the checked path, same torques
    wide = np.zeros((2, 2))
    wide[:, 0] = q
    ctl.reset(m, writable)
    u3 = ctl.step(0.0, fc.Measurement(wide[:, 0], m.qd, m.wrench), writable)
    np.testing.assert_allclose(u3, u1, rtol=1e-12)


def test_frozen_heap_freezes_for_the_loop_and_unfreezes_after():
    import gc

    from forcecontrol.realarm.realtime import frozen_heap

    assert gc.get_freeze_count() == 0
    with frozen_heap():
        assert gc.get_freeze_count() > 1000  # the library's heap, out of the collector's way
        assert gc.isenabled()
    assert gc.get_freeze_count() == 0


# --- realtime_priority: what the kernel grants, checked through the kernel's own getters --------

needs_sched = pytest.mark.skipif(not hasattr(__import__("os"), "sched_setscheduler"), reason="no POSIX scheduling API")


@pytest.mark.parametrize("priority", [0, 100, 1.5, True, "80"])
def test_realtime_priority_refuses_a_bad_priority(priority):
    from forcecontrol.realarm.realtime import realtime_priority

    with pytest.raises(ParameterError, match="priority must be an integer in 1..99"):
        with realtime_priority(priority):
            pass


@needs_sched
def test_realtime_priority_refuses_a_cpu_the_process_cannot_use():
    import os

    from forcecontrol.realarm.realtime import realtime_priority

    bad = max(os.sched_getaffinity(0)) + 1
    with pytest.raises(ParameterError, match=rf"cpu must be one of the CPUs .*got {bad}"):
        with realtime_priority(cpu=bad):
            pass


@needs_sched
def test_realtime_priority_sets_fifo_and_pins_then_restores_or_reports_the_refusal():
    """On a machine that grants it (root here), the kernel reports SCHED_FIFO at the priority and the
    pinned CPU inside the block; where it is refused, the refusal is reported and nothing changed.
    Either way the policy, priority and CPUs are back to what they were after the block."""
    import os

    from forcecontrol.realarm.realtime import realtime_priority

    policy0, prio0, cpus0 = os.sched_getscheduler(0), os.sched_getparam(0).sched_priority, os.sched_getaffinity(0)
    cpu = min(cpus0)
    with realtime_priority(7, cpu=cpu, lock_memory=False) as rt:
        if "SCHED_FIFO" in " ".join(rt.refused):
            assert os.sched_getscheduler(0) == policy0 and rt.policy != "SCHED_FIFO"
        else:
            assert os.sched_getscheduler(0) == os.SCHED_FIFO and os.sched_getparam(0).sched_priority == 7
            assert rt.policy == "SCHED_FIFO" and rt.priority == 7
        if not any("CPU" in r for r in rt.refused):
            assert os.sched_getaffinity(0) == {cpu} and rt.cpus == (cpu,)
        assert not rt.memory_locked
    assert os.sched_getscheduler(0) == policy0 and os.sched_getparam(0).sched_priority == prio0
    assert os.sched_getaffinity(0) == cpus0


@needs_sched
def test_realtime_priority_reports_or_raises_a_refused_policy_and_restores_after_an_error(monkeypatch):
    """A kernel that says EPERM (an unprivileged user): reported with the reason, or RealtimeError when
    strict; the CPU pinning granted before the error is undone."""
    import errno
    import os

    from forcecontrol.errors import RealtimeError
    from forcecontrol.realarm.realtime import realtime_priority

    def eperm(*_):
        raise PermissionError(errno.EPERM, os.strerror(errno.EPERM))

    monkeypatch.setattr(os, "sched_setscheduler", eperm)
    cpus0 = os.sched_getaffinity(0)
    with realtime_priority(50, lock_memory=False) as rt:
        assert not rt.granted and rt.policy != "SCHED_FIFO"
        assert rt.refused == ("SCHED_FIFO priority 50: Operation not permitted (needs root or CAP_SYS_NICE)",)
        assert "refused: SCHED_FIFO priority 50" in rt.summary()
    with pytest.raises(RealtimeError, match="SCHED_FIFO priority 50: Operation not permitted"):
        with realtime_priority(50, cpu=min(cpus0), lock_memory=False, strict=True):
            pytest.fail("the block must not run when strict and refused")
    assert os.sched_getaffinity(0) == cpus0


def test_realtime_priority_locks_and_unlocks_memory_through_libc(monkeypatch):
    """mlockall(MCL_CURRENT | MCL_FUTURE) on entry, munlockall on exit (a stand-in libc records the
    calls: locking the whole test process is not this test's business); a failing call is reported
    with errno's text."""
    import ctypes
    import errno
    import platform

    import forcecontrol.realarm.scheduling as rtmod

    calls = []

    class FakeLibc:
        def __init__(self, result):
            self.result = result

        def mlockall(self, flags):
            calls.append(("mlockall", flags))
            if self.result:
                ctypes.set_errno(errno.ENOMEM)
            return self.result

        def munlockall(self):
            calls.append(("munlockall",))
            return 0

    monkeypatch.setattr(platform, "system", lambda: "Linux")
    monkeypatch.setattr(platform, "machine", lambda: "x86_64")
    monkeypatch.setattr(rtmod, "_libc", lambda: FakeLibc(0))
    monkeypatch.setattr(rtmod.os, "sched_setscheduler", lambda *a: None, raising=False)
    with rtmod.realtime_priority(10) as rt:
        assert rt.memory_locked and calls == [("mlockall", 3)]
    assert calls == [("mlockall", 3), ("munlockall",)]
    calls.clear()
    monkeypatch.setattr(rtmod, "_libc", lambda: FakeLibc(-1))
    with rtmod.realtime_priority(10) as rt:
        assert not rt.memory_locked
        assert any(r.startswith("memory lock: Cannot allocate memory") for r in rt.refused)
    assert calls == [("mlockall", 3)]


@pytest.mark.skipif(__import__("platform").system() != "Linux", reason="mlockall and /proc are Linux's")
def test_realtime_priority_memory_lock_as_the_kernel_reports_it():
    """In a fresh process (locking the test process's heap is not this test's business): the
    kernel's VmLck is the whole process inside the block when the lock is granted, and 0 after."""
    import subprocess
    import sys

    code = (
        "from forcecontrol.realarm.realtime import realtime_priority\n"
        "def vmlck():\n"
        "    return int(next(l.split()[1] for l in open('/proc/self/status') if l.startswith('VmLck')))\n"
        "with realtime_priority(5) as rt:\n"
        "    inside = vmlck()\n"
        "    with realtime_priority(6) as inner:\n"
        "        pass\n"
        "    nested = (inner.memory_locked, vmlck())\n"
        "print(rt.memory_locked, inside, vmlck(), any(r.startswith('memory lock') for r in rt.refused), *nested)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    locked, inside, after, refused = out[0] == "True", int(out[1]), int(out[2]), out[3] == "True"
    inner_locked, after_inner = out[4] == "True", int(out[5])
    assert locked != refused
    assert after == 0
    assert (inside > 10_000) if locked else (inside == 0)  # kB: NumPy alone maps tens of MB
    if locked:  # a nested block finds the memory locked and leaves it locked for the outer one
        assert inner_locked and after_inner > 10_000


@pytest.mark.skipif(__import__("platform").system() != "Linux", reason="mlockall and /proc are Linux's")
def test_realtime_priority_memory_lock_is_held_while_any_thread_holds_it_and_a_callers_lock_is_kept():
    """In a fresh process: thread A enters, thread B enters, A leaves: the memory stays locked for B,
    and is unlocked when B leaves. A page the caller locked before any block stays locked after."""
    import subprocess
    import sys

    code = (
        "import ctypes, threading\n"
        "from forcecontrol.realarm.realtime import realtime_priority\n"
        "def vmlck():\n"
        "    return int(next(l.split()[1] for l in open('/proc/self/status') if l.startswith('VmLck')))\n"
        "out, granted = [], []\n"
        "a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()\n"
        "def A():\n"
        "    with realtime_priority(5) as rt:\n"
        "        granted.append(rt.memory_locked); a_in.set(); b_in.wait()\n"
        "    a_out.set()\n"
        "def B():\n"
        "    a_in.wait()\n"
        "    with realtime_priority(5) as rt:\n"
        "        granted.append(rt.memory_locked); b_in.set(); a_out.wait(); out.append(vmlck())\n"
        "    out.append(vmlck())\n"
        "ts = [threading.Thread(target=A), threading.Thread(target=B)]\n"
        "[t.start() for t in ts]; [t.join() for t in ts]\n"
        "libc = ctypes.CDLL(None, use_errno=True)\n"
        "page = ctypes.create_string_buffer(4096)\n"
        "mine = libc.mlock(page, 4096) == 0\n"
        "before = vmlck()\n"
        "with realtime_priority(5):\n"
        "    pass\n"
        "print(all(granted), out[0], out[1], mine, before, vmlck())\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    granted, while_b, after_b, mine, before, after = res.stdout.split()
    if granted == "True":
        assert int(while_b) > 10_000 and int(after_b) == 0  # kB
    if mine == "True" and granted == "True":
        assert int(before) > 0 and int(after) >= int(before)


@needs_sched
def test_realtime_priority_restores_every_setting_even_when_one_restore_fails(monkeypatch):
    """The CPUs cannot be given back (the kernel says EINVAL): the policy and priority are still
    restored, and RealtimeError says what failed; an error of the block itself takes precedence."""
    import errno
    import os

    from forcecontrol.errors import RealtimeError
    from forcecontrol.realarm.realtime import realtime_priority

    policy0, cpus0 = os.sched_getscheduler(0), os.sched_getaffinity(0)
    real = os.sched_setaffinity
    calls = []

    def flaky(pid, cpus):
        calls.append(set(cpus))
        if len(calls) % 2 == 0:  # every give-back fails
            raise OSError(errno.EINVAL, os.strerror(errno.EINVAL))
        real(pid, cpus)

    monkeypatch.setattr(os, "sched_setaffinity", flaky)
    try:
        with pytest.raises(RealtimeError, match="restoring the scheduling .* failed: .*Invalid argument"):
            with realtime_priority(9, cpu=min(cpus0), lock_memory=False):
                pass
        assert os.sched_getscheduler(0) == policy0
        with pytest.raises(KeyError, match="the block's own"):
            with realtime_priority(9, cpu=min(cpus0), lock_memory=False):
                raise KeyError("the block's own")
        assert os.sched_getscheduler(0) == policy0
    finally:
        real(0, cpus0)
