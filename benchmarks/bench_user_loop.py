"""The controller in a user's own fixed-rate 1 kHz loop: per-cycle compute time and jitter.

Runs ``examples/own_loop.py``'s loop (read state and wrench from the interface, step the
controller stack Safety(ContactSupervisor(impedance, inner velocity loop)), write torques) for
``--cycles`` cycles against the stand-in arm, and reports:

* the per-cycle compute time (read state and wrench + reference + control law + safety checks;
  the stand-in's plant integration in ``write_torque`` is excluded; its ``read_wrench`` runs the
  contact model and the sensor model, which a real driver replaces by a bus read) as
  percentiles and a histogram, and the control step alone (reference + controller);
* the wake-up lateness (jitter) against the 1 ms schedule, as percentiles and a histogram;
* overruns (a cycle ending after the next tick);
* the cost of each layer alone in a tight loop (no sleeping), to see where the time goes;
* the baseline: the same schedule with no work at all, whose late wake-ups are the OS's (on a
  general-purpose kernel an overrun can come from there alone; in a virtual machine, from the host:
  the steal time the kernel counted during the loop is printed).

The loops run under :func:`forcecontrol.realarm.realtime.realtime_priority` (SCHED_FIFO 80, memory locked)
when the kernel grants it, as the example does; ``--no-realtime`` measures ordinary scheduling.

Wall-clock numbers depend on the machine and its load (a shared machine shows long tails):
the script asserts nothing. Run: ``python benchmarks/bench_user_loop.py [--cycles 10000] [--no-realtime]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "examples"))

import own_loop  # noqa: E402

import forcecontrol as fc  # noqa: E402
from forcecontrol.sensors import RealisticForceSensor  # noqa: E402
from forcecontrol.supervision.safety import Safety  # noqa: E402
from forcecontrol.supervision.transitions import ContactSupervisor  # noqa: E402

EDGES_US = [0, 25, 50, 100, 200, 300, 500, 1000, 2000, 5000, np.inf]


def histogram(values_us: np.ndarray, title: str) -> None:
    """A text histogram over fixed bins [µs]."""
    counts, _ = np.histogram(values_us, bins=EDGES_US)
    n = len(values_us)
    print(f"\n{title} (n = {n})")
    for lo, hi, c in zip(EDGES_US[:-1], EDGES_US[1:], counts):
        label = f"{lo:>5g}–{hi:<5g} µs" if np.isfinite(hi) else f"   >= {lo:<5g} µs"
        print(f"  {label}  {c:6d}  {100 * c / n:6.2f} %  {'#' * int(round(50 * c / n))}")


def percentiles(name: str, values_us: np.ndarray) -> dict[str, float]:
    p = {f"p{q}": float(np.percentile(values_us, q)) for q in (50, 90, 99, 99.9)}
    p["max"] = float(values_us.max())
    print(f"{name:34s} " + "  ".join(f"{k} {v:8.1f}" for k, v in p.items()) + "  [µs]")
    return p


def layer_costs(n: int = 5000) -> dict[str, float]:
    """Mean µs per call of each layer alone (tight loop, no sleeping)."""
    arm = fc.CHAPTER_ARM
    q = arm.inverse_kinematics([1.0005, 0.0])
    meas = fc.Measurement(q, np.array([0.01, -0.02]), np.array([5.0, 0.0]))
    path = fc.LinearPath([0.95, 0.0], [1.05, 0.0], 0.6, accel_time=0.1, force=[10.0, 0.0])
    ref = path.at(0.3)
    force = fc.InnerVelocityForceController(arm, 100, 5000, 2500, [0.0024, 0.0])
    motion = fc.ImpedanceController(arm, 100, 2000, 10000)
    sup = ContactSupervisor(motion, force, [1.0, 0.0])
    safe = Safety(ContactSupervisor(fc.ImpedanceController(arm, 100, 2000, 10000),
                                    fc.InnerVelocityForceController(arm, 100, 5000, 2500, [0.0024, 0.0]), [1.0, 0.0]),
                  max_torque=3000.0, max_torque_rate=2e5, max_force=80.0, max_speed=0.5)
    sensor = RealisticForceSensor(noise_std=0.5, cutoff=100.0, resolution=0.02, delay_samples=1)
    sensor.start(n + 10, 2, 1e-3, np.zeros(2), q)
    cases = {
        "InnerVelocityForceController.step": lambda k: force.step(k * 1e-3, meas, ref),
        "ContactSupervisor.step": lambda k: sup.step(k * 1e-3, meas, ref),
        "Safety(ContactSupervisor).step": lambda k: safe.step(k * 1e-3, meas, ref),
        "LinearPath.at": lambda k: path.at(k * 1e-3),
        "RealisticForceSensor.measure": lambda k: sensor.measure(k + 1, k * 1e-3, meas.wrench, q),
    }
    out = {}
    for name, fn in cases.items():
        fn(0)
        t0 = time.perf_counter()
        for k in range(1, n + 1):
            fn(k)
        out[name] = 1e6 * (time.perf_counter() - t0) / n
    return out


def main(cycles: int = 5000, realtime: bool = True) -> dict[str, object]:
    import contextlib

    from forcecontrol.realarm.realtime import realtime_priority

    with realtime_priority(80) if realtime else contextlib.nullcontext() as rt:
        print(f"scheduling: {rt.summary() if rt else 'ordinary (--no-realtime)'}")
        return _measure(cycles)


def _measure(cycles: int) -> dict[str, object]:
    robot = own_loop.StandInArm(fc.CHAPTER_ARM.inverse_kinematics([0.95, 0.0]), samples=cycles + 1)
    controller = own_loop.make_controller()
    reference = fc.LinearPath([0.95, 0.0], [1.05, 0.0], 0.6, accel_time=0.1, force=[10.0, 0.0])
    steal0 = steal_ms()
    stats = own_loop.run(robot, controller, reference, cycles)
    stolen = steal_ms() - steal0
    c, ctl, lat = 1e6 * stats["compute"], 1e6 * stats["control"], 1e6 * stats["lateness"]
    print(f"1 kHz loop, {cycles} cycles, Safety(ContactSupervisor(impedance, inner velocity)), stand-in arm")
    out: dict[str, object] = {
        "compute_us": percentiles("compute per cycle (read+control)", c),
        "control_us": percentiles("control step (reference+controller)", ctl),
        "lateness_us": percentiles("wake-up lateness (jitter)", lat),
        "overruns": int(stats["overrun"].sum()),
    }
    print(f"overruns (cycle ended after the next tick): {out['overruns']} of {cycles}")
    if stolen == stolen:
        print(f"time the hypervisor took from this machine's CPUs during the loop (steal, /proc/stat): {stolen:.0f} ms")
    out["steal_ms"] = stolen
    histogram(c, "compute time per cycle")
    histogram(lat, "wake-up lateness against the 1 ms schedule")
    costs = layer_costs()
    print("\nlayer costs alone (tight loop, mean per call)")
    for k, v in costs.items():
        print(f"  {k:36s} {v:8.1f} µs")
    out["layers_us"] = costs
    bare = bare_loop(cycles)
    print(f"\nbaseline, the same RateLimiter loop doing no work ({cycles} cycles, heap frozen): "
          f"wake-ups more than 0.5 ms late: {bare['late_over_500us']}, max lateness {bare['max_late_us']:.0f} µs "
          "(what the OS alone adds on this machine)")
    out["bare_loop"] = bare
    return out


def steal_ms() -> float:
    """CPU time the hypervisor has taken from this (virtual) machine since boot, all CPUs [ms]
    (``steal`` of ``/proc/stat``, in 10 ms ticks); NaN where there is no such file."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()
        return 10.0 * float(fields[8])
    except (OSError, IndexError, ValueError):
        return float("nan")


def bare_loop(cycles: int) -> dict[str, float]:
    """The OS's share: the same 1 kHz schedule with no work in the cycle."""
    from forcecontrol.realarm.realtime import RateLimiter, frozen_heap

    late = np.empty(cycles)
    limiter = RateLimiter(1e-3, cycles=cycles)
    with frozen_heap():
        for k in range(cycles):
            late[k] = limiter.wait()
            limiter.done()
    return {"late_over_500us": int(np.sum(late > 5e-4)), "max_late_us": float(1e6 * late.max())}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=5000)
    ap.add_argument("--no-realtime", dest="realtime", action="store_false", help="ordinary scheduling")
    args = ap.parse_args()
    main(args.cycles, args.realtime)
