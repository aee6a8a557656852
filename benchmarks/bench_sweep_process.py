"""A whole ``forcecontrol sweep`` process against the plain hand-written scalar Numba loop, in one session.

Issue 33 item 3 measures the planar sweep as a whole process (preparation, kernel, metrics and
files together), with one worker and a warm Numba cache, in arm-steps per second (one control
sample of one case), against the plain scalar loop of ``bench_plain_numba.py`` (Example 9.2's
impedance control (9.30)-(9.31) written by hand from the arm's data) run in this same process.

The sweep: Example 9.2's case 1 (impedance with force measurement, 4 s at 1 ms), the plane's
stiffness over ``logspace(3, 5, K)`` and the damping over ``linspace(300, 700, D)`` (K·D cases;
default 100 x 100 = 10⁴). Each repetition measures the plain loop, then the CLI process
(``forcecontrol sweep ... --workers 1 --no-figure``, wall time of the subprocess, so Python's
start-up and imports count too), so the ratio of each repetition is taken on a machine in the
same state; the table reports the median and the spread (min-max) of the ratios. Each ratio is
also given in CPU time (the process's user + system time against the loop's thread time), which
moves less than wall time when other work shares the cores; the target is stated in wall time.

``--breakdown`` also splits one in-process run: ``prepare_sweep`` (validate and build every
case; also per case), :func:`forcecontrol.sweep.run_block` over the same blocks (packing, kernel,
metrics, rows) and the rest of ``run_sweep`` (table, Parquet parts and the final file). The
table's head line also gives the wall time of a 4-case process: what any sweep process costs
(Python's start-up, the imports, the compiled code loaded from the cache, the files).

Each repetition runs the process twice, with each batch kernel (``FORCECONTROL_SWEEP_KERNEL``):
``scalar`` (one case at a time, :mod:`forcecontrol.sim.batch`) and ``lanes8`` (the default, 8 cases
per instruction, :mod:`forcecontrol.sim.batch_lanes`).

Run: ``python benchmarks/bench_sweep_process.py [--k 100] [--d 100] [--reps 3] [--breakdown]``;
prints a table, asserts nothing. Target (issue 33 item 3): the process at least 2x the plain loop.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_plain_numba import plain_loop  # noqa: E402  (the baseline: written from the arm's data, not the library)

import forcecontrol as fc  # noqa: E402
from forcecontrol.sim.simulation import choose_substeps  # noqa: E402

KERNELS = ("scalar", "lanes8")  # the sweep's batch kernels (FORCECONTROL_SWEEP_KERNEL): one case at a time, 8 lanes


def _steps(table) -> int:
    """Control samples actually simulated (a diverged case stops at its last sample)."""
    ok = table["status"] == "ok"
    early = np.round(table.loc[~ok, "diverged_at"] / 1e-3).astype(int)
    return int(table.loc[ok, "samples"].sum() + early.sum())


def _plain_rate(seconds: float = 2.0) -> tuple[float, float]:
    """Arm-steps/s of the plain scalar loop on Example 9.2's case (k = 1e4 N/m, 4 s at 1 ms), run for about ``seconds``.

    Not a few milliseconds: on a shared machine a 2 ms run lands either in a quiet moment or in a
    busy one (measured 5.2e6 or 1.9e6 arm-steps/s from one repetition to the next), so the baseline
    runs as long as a sweep's kernel does and averages the same conditions.
    """
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    k, Ts, N = 1e4, 1e-3, 4000
    nsub = choose_substeps(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], k), q0, Ts)
    args = (q0, np.array([1.1, 0.1]), k, 100.0, 500.0, 2500.0, N, Ts, nsub)
    plain_loop(*args)  # compile
    reps = 0
    t0, c0 = time.perf_counter(), time.thread_time()
    while time.perf_counter() - t0 < seconds:
        plain_loop(*args)
        reps += 1
    return reps * N / (time.perf_counter() - t0), reps * N / (time.thread_time() - c0)


def _children_cpu() -> float:
    """CPU time [s] (user + system) of the finished child processes so far."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _cli(k: int, d: int, out: Path, kernel: str = "lanes8") -> tuple[float, dict, float]:
    cmd = [
        "forcecontrol", "sweep", "example-9.2", "--case", "1",
        "-p", f"environment.stiffness=logspace(3,5,{k})", "-p", f"controller.damping=linspace(300,700,{d})",
        "--workers", "1", "--no-figure", "--json", "--overwrite", "--out", str(out),
    ]
    env = {**os.environ, "FORCECONTROL_SWEEP_KERNEL": kernel}
    t0, c0 = time.perf_counter(), _children_cpu()
    p = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env)
    return time.perf_counter() - t0, json.loads(p.stdout), _children_cpu() - c0


def _breakdown(k: int, d: int, tmp: Path) -> None:
    from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_block, run_sweep
    from forcecontrol.sweep.run import _blocks

    defn = SweepDefinition.from_options(
        {"environment.stiffness": f"logspace(3, 5, {k})", "controller.damping": f"linspace(300, 700, {d})"}, cases=["1"],
    )
    t0 = time.perf_counter()
    prep = prepare_sweep("example-9.2", defn)
    t_prep = time.perf_counter() - t0
    blocks = _blocks(prep.jobs, 1, None)
    for kernel in ("scalar", "lanes8"):
        os.environ["FORCECONTROL_SWEEP_KERNEL"] = kernel
        t0 = time.perf_counter()
        steps = 0
        for b in blocks:
            steps += sum(r["_steps"] for r in run_block(b, 0.02, 0.05))
        t_block = time.perf_counter() - t0
        t0 = time.perf_counter()
        run_sweep(prep, tmp / f"in-process-{kernel}.parquet", workers=1)
        t_sweep = time.perf_counter() - t0
        total = t_prep + t_sweep
        print(f"\nin-process breakdown, kernel {kernel} ({prep.n_cases} cases, {steps:,} arm-steps, {len(blocks)} blocks):")
        print(f"  prepare_sweep per case: {1e6 * t_prep / prep.n_cases:.1f} us")
        for what, t in (("prepare_sweep (validate, build every case)", t_prep),
                        ("run_block over the blocks (pack, kernel, metrics, rows)", t_block),
                        ("rest of run_sweep (table, Parquet parts, final file)", t_sweep - t_block),
                        ("prepare_sweep + run_sweep", total)):
            print(f"  {what:<58} {t:>7.2f} s {100 * t / total:>5.1f} %")
        print(f"  kernel-side rate (run_block): {steps / t_block:.3g} arm-steps/s; whole: {steps / total:.3g}")
    os.environ.pop("FORCECONTROL_SWEEP_KERNEL", None)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--k", type=int, default=100, help="stiffness values")
    ap.add_argument("--d", type=int, default=100, help="damping values")
    ap.add_argument("--reps", type=int, default=3, help="repetitions (plain loop then process, each)")
    ap.add_argument("--breakdown", action="store_true", help="also split one in-process run into its parts")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="fc-bench-process-"))
    try:
        for kernel in KERNELS:  # a warm cache: the kernels compile (if at all) here, not in the timings
            _cli(2, 2, tmp / f"warm-{kernel}.parquet", kernel)
        # what a process costs whatever its size (start-up, imports, the compiled code loaded from the cache,
        # the files): a 4-case sweep, the median of 3
        fixed = statistics.median(_cli(2, 2, tmp / f"fixed-{i}.parquet")[0] for i in range(3))
        import pandas as pd

        plains: list[float] = []
        procs: dict[str, list[float]] = {k: [] for k in KERNELS}
        ratios: dict[str, list[float]] = {k: [] for k in KERNELS}
        cpu_ratios: dict[str, list[float]] = {k: [] for k in KERNELS}
        for rep in range(args.reps):
            plain, plain_cpu = _plain_rate()
            plains.append(plain)
            for kernel in KERNELS:
                out = tmp / f"sweep-{kernel}-{rep}.parquet"  # a new file each time: the same file would resume, not run
                dt, js, cpu = _cli(args.k, args.d, out, kernel)
                steps = _steps(pd.read_parquet(out))
                procs[kernel].append(steps / dt)
                ratios[kernel].append(steps / dt / plain)
                cpu_ratios[kernel].append(steps / cpu / plain_cpu)
                print(f"plain loop {plain:.3g} arm-steps/s; process ({kernel}) {js['cases']} cases, {steps:,} arm-steps in "
                      f"{dt:.2f} s (sweep's own 'seconds' {js['seconds']:.2f}): {steps / dt:.3g} arm-steps/s; "
                      f"ratio {steps / dt / plain:.2f}x; in CPU time {steps / cpu / plain_cpu:.2f}x")
        print(f"\ncores: {os.cpu_count()}, repetitions: {args.reps}; a 4-case process (fixed cost) takes {fixed:.2f} s")
        print(f"plain scalar loop           : median {statistics.median(plains):.3g} arm-steps/s "
              f"(min {min(plains):.3g}, max {max(plains):.3g})")
        for kernel in KERNELS:
            v, r, c = procs[kernel], ratios[kernel], cpu_ratios[kernel]
            print(f"whole sweep process {kernel:<8}: median {statistics.median(v):.3g} arm-steps/s (min {min(v):.3g}, "
                  f"max {max(v):.3g}); / plain: median {statistics.median(r):.2f}x (min {min(r):.2f}, max {max(r):.2f}); "
                  f"in CPU time (the process's user + system, the loop's thread): median {statistics.median(c):.2f}x "
                  f"(min {min(c):.2f}, max {max(c):.2f})")
        r = ratios["lanes8"]
        print(f"target (lanes8 process >= 2.00x the plain loop): {'met' if statistics.median(r) >= 2.0 else 'NOT met'}")
        if args.breakdown:
            _breakdown(args.k, args.d, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
