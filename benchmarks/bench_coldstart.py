"""A cold first run: ``forcecontrol run example-9.2`` with an empty kernel cache (issue 33 item 5, target <= 5 s).

Each round runs, as fresh subprocesses, interleaved so that they share the machine's load:

* ``cold``: the README's main command with ``NUMBA_CACHE_DIR`` pointed at a new empty folder
  (every kernel compiles);
* ``warm``: the same command again on that folder (every kernel loads from the cache);
* ``python -c "import numpy"``: the floor of any numerical program.

Reported: median wall time of each over ``--repeat`` rounds with its spread (min–max), the ratios
cold/warm and cold/numpy per round (median and spread), the CPU time (user + sys) of the cold
process, and the 5 s target as an absolute row (the issue states it in seconds). With
``--profile``, one more cold run records every compile Numba makes (a ``numba:compile`` event
listener, the thread's CPU time from start to end of each compile; nested compiles are listed
with their depth and counted inside their caller) and prints the top ``--top``.

``--src DIR`` (repeatable) puts a source folder on ``PYTHONPATH`` to compare checkouts in the same
loop (e.g. ``git archive <commit> src | tar -x -C /tmp/old`` then ``--src /tmp/old/src --src src``).
``--speed R`` measures the other side of the trade (what compiling less costs at run time): R
rounds, each a fresh warm process per source, in turn, timing the compiled Example 9.2 loop
(``simulate``, 20 s simulated, best of 5) and ``ImpedanceController.step`` (5000 calls, best of
3) in thread CPU time (robust to the other processes' load); reported per source: the median µs
and the median (min–max) of the per-round ratios to the first source.
Asserts nothing.

``--command 'run example-9.3 --force'`` times another command line instead (``--out DIR`` is appended).

Run: ``python benchmarks/bench_coldstart.py [--repeat 3] [--profile] [--speed 9] [--src DIR ...] [--command ARGS]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

PY = sys.executable
COMMAND = ["run", "example-9.2", "--force"]
TARGET_S = 5.0

#: the command line run in-process, with a listener that records every compile (thread CPU time).
PROFILED = r"""
import json, sys, time
from numba.core import event
records, stack = [], []

class Compiles(event.Listener):
    def on_start(self, ev):
        stack.append(time.thread_time())

    def on_end(self, ev):
        seconds = time.thread_time() - stack.pop()
        func = getattr(ev.data.get("dispatcher"), "py_func", None)
        name = f"{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', '?')}"
        records.append({"name": name, "seconds": seconds, "depth": len(stack)})

event.register("numba:compile", Compiles())
from forcecontrol.cli import main
try:
    main(sys.argv[2:])
except SystemExit:
    pass
with open(sys.argv[1], "w") as f:
    json.dump(records, f)
"""


#: one warm process: the compiled loop [µs/step] and Controller.step [µs], thread CPU, printed on one line.
SPEED = r"""
import time
import numpy as np
import forcecontrol as fc
arm = fc.CHAPTER_ARM
env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4)
q0 = arm.inverse_kinematics([1.0, 0.0])

def loop(duration):
    ctl = fc.ImpedanceController(arm, 100, 500, 2500)
    t0 = time.thread_time()
    r = fc.simulate(arm, env, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=duration)
    assert r.metadata["engine"] == "compiled"
    return (time.thread_time() - t0) / (len(r.t) - 1)

ctl = fc.ImpedanceController(arm, 100, 500, 2500)
meas = fc.Measurement(arm.inverse_kinematics([1.05, 0.05]), np.array([0.1, -0.2]), np.array([50.0, 0.0]))
ref = fc.Reference.setpoint([1.1, 0.1])

def step(n):
    t0 = time.thread_time()
    for k in range(n):
        ctl.step(k * 1e-3, meas, ref)
    return (time.thread_time() - t0) / n

loop(0.1), step(10)
print(min(loop(20.0) for _ in range(5)) * 1e6, min(step(5000) for _ in range(3)) * 1e6)
"""


def speed(srcs: list[str | None], rounds: int) -> None:
    """The compiled loop [µs/step] and Controller.step [µs] per source, a fresh warm process per source and round.

    A fresh process each time: where the machine code lands in memory (its alignment) moves a
    tight loop's speed by several per cent from one process to the next, so one long-lived
    process per source would compare placements, not sources.
    """
    res: list[list[tuple[float, float]]] = [[] for _ in srcs]
    with tempfile.TemporaryDirectory(prefix="coldstart-cache-") as cache:
        for src in srcs:  # fill the cache
            subprocess.run([PY, "-c", "import forcecontrol"], env=_env(cache, src), check=True)
        for _ in range(rounds):
            for i, src in enumerate(srcs):
                out = subprocess.run([PY, "-c", SPEED], capture_output=True, text=True, env=_env(cache, src), check=True)
                a, b = out.stdout.split()
                res[i].append((float(a), float(b)))
    print(f"\nrun time, thread CPU, a fresh warm process per source and round ({rounds} rounds; "
          "ratios to the first source per round, median (min-max)):")
    for src, r in zip(srcs, res):
        loops = [x[0] / base[0] for x, base in zip(r, res[0])]
        steps = [x[1] / base[1] for x, base in zip(r, res[0])]
        print(f"  {str(src or '(installed)'):34s} loop {statistics.median(x[0] for x in r):.3f} us/step  ratio {spread(loops, 3)}"
              f"   step {statistics.median(x[1] for x in r):.3f} us  ratio {spread(steps, 3)}")


def _env(cache: str, src: str | None) -> dict[str, str]:
    env = os.environ.copy()
    env["NUMBA_CACHE_DIR"] = cache
    if src:
        env["PYTHONPATH"] = src
    return env


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float, str]:
    """(wall [s], CPU user + sys [s], stderr) of one subprocess; wall NaN if it failed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return (wall if done.returncode == 0 else float("nan")), cpu, done.stderr


def one_round(src: str | None, out: str) -> dict[str, float]:
    """cold, warm (same cache) and the numpy floor, as fresh processes."""
    cli = [PY, "-m", "forcecontrol", *COMMAND, "--out", out]  # COMMAND: --command, else the README's
    with tempfile.TemporaryDirectory(prefix="coldstart-cache-") as cache:
        env = _env(cache, src)
        cold, cold_cpu, err = timed(cli, env)
        warm, _, _ = timed(cli, env)
        numpy_floor, _, _ = timed([PY, "-c", "import numpy"], env)
    notices = sum(line.startswith("forcecontrol: compiling kernels") for line in err.splitlines())
    return {"cold": cold, "cold_cpu": cold_cpu, "warm": warm, "numpy": numpy_floor, "notices": notices}


def profile(src: str | None, out: str) -> list[dict[str, float]]:
    """Every compile of one cold run: [{name, seconds (thread CPU), depth}]."""
    with tempfile.TemporaryDirectory(prefix="coldstart-cache-") as cache:
        rec = os.path.join(cache, "compiles.json")
        subprocess.run([PY, "-c", PROFILED, rec, *COMMAND, "--out", out], stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, env=_env(os.path.join(cache, "numba"), src), check=True)
        with open(rec) as f:
            return json.load(f)


def spread(values: list[float], digits: int = 2) -> str:
    return f"{statistics.median(values):7.{digits}f}  ({min(values):.{digits}f}-{max(values):.{digits}f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="rounds (each: a cold, a warm and a numpy run per source)")
    ap.add_argument("--profile", action="store_true", help="also list the compiles of one cold run per source")
    ap.add_argument("--top", type=int, default=10, help="compiles listed by --profile")
    ap.add_argument("--speed", type=int, default=0, metavar="R", help="also R interleaved rounds of run-time speed per source")
    ap.add_argument("--src", action="append", default=None, help="a source folder for PYTHONPATH (repeat to compare)")
    ap.add_argument("--command", default=None, metavar="ARGS",
                    help="another forcecontrol command line to time cold and warm (default: 'run example-9.2 --force'; "
                         "e.g. 'run example-9.3 --force')")
    args = ap.parse_args()
    if args.command:
        COMMAND[:] = args.command.split()
    srcs = args.src or [None]
    rows: dict[str | None, list[dict[str, float]]] = {s: [] for s in srcs}
    if args.speed:
        speed(srcs, args.speed)
    with tempfile.TemporaryDirectory() as out:
        for _ in range(args.repeat):
            for src in srcs:
                rows[src].append(one_round(src, out))
        profiles = {src: profile(src, out) for src in srcs} if args.profile else {}
    print(f"load average at the end: {os.getloadavg()[0]:.1f} (2 cores)")
    for src in srcs if args.repeat > 0 else ():
        r = rows[src]
        print(f"\nsource: {src or '(installed)'}   command: forcecontrol {' '.join(COMMAND)} --out DIR   "
              f"(median (min-max) of {args.repeat})")
        print(f"{'quantity':38s} {'value':>7s}")
        print(f"{'cold run, empty cache [s]':38s} {spread([x['cold'] for x in r])}")
        print(f"{'cold run, CPU user+sys [s]':38s} {spread([x['cold_cpu'] for x in r])}")
        print(f"{'warm run [s]':38s} {spread([x['warm'] for x in r])}")
        print(f"{'python -c import numpy [s]':38s} {spread([x['numpy'] for x in r])}")
        print(f"{'cold / warm':38s} {spread([x['cold'] / x['warm'] for x in r])}")
        print(f"{'cold / numpy':38s} {spread([x['cold'] / x['numpy'] for x in r])}")
        print(f"{'target: cold <= 5 s':38s} {'met' if statistics.median(x['cold'] for x in r) <= TARGET_S else 'NOT met'}")
        print(f"{'compile notices on stderr (cold)':38s} {sorted({int(x['notices']) for x in r})}")
        if src in profiles:
            recs = profiles[src]
            top = sum(x["seconds"] for x in recs if x["depth"] == 0)
            print(f"\n{len(recs)} compiles, {top:.2f} s thread CPU at depth 0 (callees counted in their callers):")
            for x in sorted(recs, key=lambda x: -x["seconds"])[: args.top]:
                print(f"  {x['seconds']:6.3f} s  depth {x['depth']}  {x['name']}")


if __name__ == "__main__":
    main()
