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
loop (e.g. ``git worktree add /tmp/old <commit>`` then ``--src /tmp/old/src --src src``).
Asserts nothing.

Run: ``python benchmarks/bench_coldstart.py [--repeat 3] [--profile] [--src DIR ...]``.
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
    cli = [PY, "-m", "forcecontrol", *COMMAND, "--out", out]
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


def spread(values: list[float]) -> str:
    return f"{statistics.median(values):7.2f}  ({min(values):.2f}-{max(values):.2f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="rounds (each: a cold, a warm and a numpy run per source)")
    ap.add_argument("--profile", action="store_true", help="also list the compiles of one cold run per source")
    ap.add_argument("--top", type=int, default=10, help="compiles listed by --profile")
    ap.add_argument("--src", action="append", default=None, help="a source folder for PYTHONPATH (repeat to compare)")
    args = ap.parse_args()
    srcs = args.src or [None]
    rows: dict[str | None, list[dict[str, float]]] = {s: [] for s in srcs}
    with tempfile.TemporaryDirectory() as out:
        for _ in range(args.repeat):
            for src in srcs:
                rows[src].append(one_round(src, out))
        profiles = {src: profile(src, out) for src in srcs} if args.profile else {}
    print(f"load average at the end: {os.getloadavg()[0]:.1f} (2 cores)")
    for src in srcs:
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
