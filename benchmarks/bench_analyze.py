"""Time of ``forcecontrol analyze`` (issue 14, target 2: under 0.5 s of compute on every built-in scenario).

Two measurements:

* compute: ``analyze_scenario(name)`` in this process, median of ``--repeat`` calls after one warm-up
  call (which pays the imports), for every built-in scenario; its ratio to the median of
  ``numpy.linalg.eigvals`` on 1000 random 3×3 matrices, run in the same loop as a same-process
  baseline on a noisy machine;
* whole process: ``forcecontrol analyze example-9.3 --json`` as a subprocess, against
  ``python -c "import numpy"`` run in the same loop.

With ``--compare SRC`` the compute of another checkout (e.g. a worktree of an older commit) is
measured the same way in a subprocess and every stability limit is compared with this tree's
(printed: the largest relative difference).

Run: ``PYTHONPATH=src python benchmarks/bench_analyze.py [--repeat 5] [--compare ../old/src]``. Asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

PY = sys.executable

_CHILD = r"""
import json, statistics, sys, time
from forcecontrol.scenarios.report import analyze_scenario
from forcecontrol.scenarios import list_scenarios
repeat = int(sys.argv[1])
out = {}
for name in list_scenarios():
    analyze_scenario(name)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = analyze_scenario(name)
        times.append(time.perf_counter() - t0)
    limits = {f"{c['label']}/{k}": v for c in res["cases"] for k, v in c["analysis"].items()
              if k.startswith("stability_limit")}
    out[name] = {"median_s": statistics.median(times), "limits": limits}
print(json.dumps(out))
"""


def child(src: str | None, repeat: int) -> dict:
    env = os.environ.copy()
    if src:
        env["PYTHONPATH"] = src
    done = subprocess.run([PY, "-c", _CHILD, str(repeat)], capture_output=True, text=True, env=env, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def baseline(repeat: int) -> float:
    import numpy as np

    rng = np.random.default_rng(0)
    mats = rng.standard_normal((1000, 3, 3))
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for m in mats:
            np.linalg.eigvals(m)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def wall(cmd: list[str], src: str | None = None) -> float:
    env = os.environ.copy()
    if src:
        env["PYTHONPATH"] = src
    t0 = time.perf_counter()
    subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, check=True)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--compare", default=None, help="another checkout's src folder")
    args = ap.parse_args()
    src = os.environ.get("PYTHONPATH")
    base = baseline(args.repeat)
    mine = child(src, args.repeat)
    other = child(args.compare, args.repeat) if args.compare else None
    print(f"baseline: 1000 eigvals of 3x3 = {base * 1e3:.2f} ms")
    print(f"{'scenario':26s} {'compute [s]':>12s} {'/ baseline':>11s}" + (f"  {'other [s]':>10s}" if other else ""))
    for name, row in mine.items():
        line = f"{name:26s} {row['median_s']:12.4f} {row['median_s'] / base:11.1f}"
        if other and name in other:
            line += f"  {other[name]['median_s']:10.4f}"
        print(line)
    if other:
        worst = 0.0
        for name, row in mine.items():
            for key, v in row["limits"].items():
                w = other.get(name, {}).get("limits", {}).get(key)
                if v is not None and w is not None:
                    worst = max(worst, abs(v - w) / abs(w))
        print(f"largest relative difference of a stability limit vs --compare: {worst:.2e}")
    cmd = [PY, "-m", "forcecontrol", "analyze", "example-9.3", "--json"]
    floor = [PY, "-c", "import numpy"]
    wall(cmd, src)
    w, f = [], []
    for _ in range(args.repeat):
        w.append(wall(cmd, src))
        f.append(wall(floor, src))
    print(f"whole process `forcecontrol analyze example-9.3 --json`: {statistics.median(w):.2f} s "
          f"(python -c 'import numpy': {statistics.median(f):.2f} s)")


if __name__ == "__main__":
    main()
