"""Start-up time of the library and the command line, as whole-process timings (issue 14, target 3).

Each command runs as a fresh subprocess, interleaved with two baselines run in the same loop:
``python -c pass`` (the interpreter alone) and ``python -c "import numpy"`` (the floor of any
numerical library). Reported per command: the median wall time over ``--repeat`` rounds and its
ratios to both baselines (ratios survive a loaded machine better than seconds).

The Numba cache is warmed first (one untimed run of every command), so ``run`` measures a warm
cache. Targets (issue 14): ``import forcecontrol`` < 0.3 s, ``forcecontrol --help`` < 0.3 s,
``forcecontrol run example-9.2 --json`` < 1.0 s. Asserts nothing.

Run: ``PYTHONPATH=src python benchmarks/bench_startup.py [--repeat 7]`` (point ``PYTHONPATH`` at
another checkout's ``src`` to measure it the same way).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

PY = sys.executable


def commands(out: str) -> dict[str, list[str]]:
    cli = [PY, "-m", "forcecontrol"]
    return {
        "python -c pass": [PY, "-c", "pass"],
        "python -c 'import numpy'": [PY, "-c", "import numpy"],
        "import forcecontrol": [PY, "-c", "import forcecontrol"],
        "import forcecontrol; fc.simulate": [PY, "-c", "import forcecontrol as fc; fc.simulate"],
        "forcecontrol --help": [*cli, "--help"],
        "forcecontrol --version": [*cli, "--version"],
        "forcecontrol run example-9.2 --json": [*cli, "run", "example-9.2", "--json", "--force", "--out", out],
        "forcecontrol run example-9.2 --json --no-figure": [
            *cli, "run", "example-9.2", "--json", "--no-figure", "--force", "--out", out],
    }


def wall(cmd: list[str], src: str | None = None) -> float:
    """Wall time of one subprocess [s]; NaN if it fails (e.g. ``--version`` on an older tree)."""
    env = os.environ.copy()
    if src:
        env["PYTHONPATH"] = src
    t0 = time.perf_counter()
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    return time.perf_counter() - t0 if done.returncode == 0 else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7, help="rounds (each runs every command once)")
    ap.add_argument(
        "--src", action="append", default=None,
        help="a source folder to put on PYTHONPATH (repeat to compare checkouts in the same loop; default: the environment's)",
    )
    args = ap.parse_args()
    srcs = args.src or [None]
    with tempfile.TemporaryDirectory() as out:
        cmds = commands(out)
        for src in srcs:
            for cmd in cmds.values():  # warm the Numba cache and the file system cache
                wall(cmd, src)
        times: dict[tuple, list[float]] = {(src, k): [] for src in srcs for k in cmds}
        for _ in range(args.repeat):
            for name, cmd in cmds.items():
                for src in srcs:
                    times[(src, name)].append(wall(cmd, src))
    med = {k: statistics.median(v) for k, v in times.items()}
    for src in srcs:
        base, numpy_base = med[(src, "python -c pass")], med[(src, "python -c 'import numpy'")]
        print(f"\nsource: {src or os.environ.get('PYTHONPATH', '(installed)')}")
        print(f"{'command':50s} {'median [s]':>10s} {'/ pass':>8s} {'/ numpy':>8s}   (median of {args.repeat})")
        for (s_, name), m in med.items():
            if s_ == src:
                print(f"{name:50s} {m:10.3f} {m / base:8.1f} {m / numpy_base:8.2f}")


if __name__ == "__main__":
    main()
