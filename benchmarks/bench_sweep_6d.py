"""6-D sweeps on every core (issue 33 item 2): one worker against all cores, and a 1000-case Panda Monte Carlo.

The sweep: ``panda-admittance-contact`` (Panda, admittance control (9.37) pressing into an elastic
table; every case runs in ``simulate()``, which holds the GIL) with a random environment, seeded:
the table's stiffness ``uniform(2000, 10000)`` N/m, damping ``uniform(20, 100)`` N s/m and
surface height ``environment.offset[2] = uniform(-0.005, 0.005)`` m (the scenario's table gets an
``offset = [0, 0, 0]`` to sweep), 1.5 s per case at 1 ms (2 RK4 sub-steps per sample).

1. Rate: the same ``--rate-cases`` cases with one worker (a thread of this process, as before
   worker processes) and with ``--workers`` worker processes (default: every core), alternated in
   this process, ``--reps`` times. Throughput in cases/s of the whole ``run_sweep`` (blocks, worker
   start-up, Parquet parts, table); ratio = rate(workers) / (workers x rate(one)), median and
   spread (min-max). Target: >= 0.8. Also the same ratio between the first and the last stored block,
   which leaves out the workers' start-up (fork server, imports, cached kernels: 3-5 s on a busy machine).
2. Monte Carlo: ``--cases`` cases (default 1000) on ``--workers`` worker processes, its wall time
   (the preparation of the cases apart), cases/s and arm-steps/s; and the settled forces against
   springs in series (9.22), f = k K_Pt / (k + K_Pt) (0.02 + h): the table's height h adds to the
   desired frame's 2 cm below it (a check that each case ran with its own parameters).

The kernels of both 6-D engines are warmed first (one short case each in this process: the workers
load them from the same cache). The rate comparison runs on ``--engine`` (default ``python``: the
GIL-bound case worker processes are for); the Monte Carlo on ``run_sweep``'s default (``auto``:
the compiled 6-D loop for its 3·10⁶ arm-steps; ``--mc-engine python`` for the Python engine).
The engine each case ran on is the table's ``engine`` column, printed.

Run: ``python benchmarks/bench_sweep_6d.py [--cases 1000] [--rate-cases 16] [--reps 3] [--workers N]``
(``--cases 200`` on a busy machine: the time is then also given scaled to 1000 cases, and says so).
Prints a table, asserts nothing.

Measured on the shared 2-core machine (2026-11-26/27, from a snapshot of the sources so that the
workers' cache folder matched the parent's): rate, 32 cases, python engine: one thread 2.87
cases/s, 2 processes 5.09 cases/s, ratio 0.89 (0.88-1.39), start-up apart 1.09 (1.06-1.12), load
average about 7 at the start; the same with 48 cases while the machine was busier (load 6-7): 0.46
(0.45-0.47); in the workers each case took the thread's CPU time (0.38 vs 0.36 s) but got a third of
a core (the kernel's autogroups share CPU per session). Monte Carlo, 1000 cases, compiled 6-D loop
(auto): run 46.2 s, preparation 7.5 s (load 2.3); 87.6 s and 124.9 s at load 6-7; on the Python
engine 200 cases in 40.7 s (203 s for 1000, extrapolated). Settled forces within 6.3e-6 of (9.22).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from forcecontrol.cli.overrides import apply_sets, parse_sets
from forcecontrol.scenarios import load_scenario
from forcecontrol.sweep import SweepDefinition, prepare_sweep
from forcecontrol.sweep.block import run_block
from forcecontrol.sweep.run import run_sweep

NAME = "panda-admittance-contact"
K_PT = 1000.0  # [N/m] the compliant frame's stiffness along z (the scenario's controller.stiffness[2])
DEPTH = 0.02  # [m] the desired frame below the nominal table surface (the scenario's reference.offset[2])


def monte_carlo(n: int, seed: int, duration: float = 1.5):
    """The prepared Monte Carlo of ``n`` cases (random table stiffness, damping and height)."""
    scn, _ = apply_sets(load_scenario(NAME), parse_sets(["environment.offset=[0,0,0]"]))
    d = SweepDefinition.from_options(
        ["environment.stiffness=uniform(2000,10000)", "environment.damping=uniform(20,100)",
         "environment.offset[2]=uniform(-0.005,0.005)", f"duration={duration}"],
        design="random", samples=n, seed=seed,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # BandwidthWarning of the admittance on a stiff table: reported by the scenario layer
        return prepare_sweep(scn, d)


def _run(prep, folder: Path, workers: int, processes: bool, engine: str, marks: list | None = None):
    """The result and wall time of one sweep; ``marks`` gets (time, cases done) at each stored block."""
    out = folder / f"w{workers}-{processes}-{time.perf_counter_ns()}.parquet"
    t0 = time.perf_counter()
    res = run_sweep(prep, out, workers=workers, processes=processes, engine=engine,
                    progress=None if marks is None else lambda done, total: marks.append((time.perf_counter(), done)))
    return res, time.perf_counter() - t0


def _steady(marks: list) -> float:
    """Cases/s between the first and the last stored block (the workers' start-up and the first blocks apart)."""
    stored = [(t, d) for t, d in marks if d > 0]
    (t1, d1), (t2, d2) = stored[0], stored[-1]
    return (d2 - d1) / (t2 - t1) if t2 > t1 else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=1000, help="Monte Carlo cases (0: skip)")
    ap.add_argument("--rate-cases", type=int, default=16, help="cases of the rate comparison (0: skip)")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--seed", type=int, default=33)
    ap.add_argument("--duration", type=float, default=1.5, help="[s] per case")
    ap.add_argument("--engine", default="python", help="6-D engine of the rate comparison (python, compiled, auto)")
    ap.add_argument("--mc-engine", default="auto", help="6-D engine of the Monte Carlo (auto, python, compiled)")
    a = ap.parse_args()
    W = a.workers
    print(f"{NAME}: {a.duration} s per case at 1 ms, {W} workers, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f} at the start")
    warm = monte_carlo(1, a.seed + 1, 0.01)
    t0 = time.perf_counter()
    run_block(warm.jobs, 0.02, 0.05, "python")
    run_block(warm.jobs, 0.02, 0.05, "compiled")
    print(f"warm-up (kernels compiled or loaded): {time.perf_counter() - t0:.1f} s")
    with tempfile.TemporaryDirectory(prefix="bench-sweep-6d-") as tmp:
        folder = Path(tmp)
        if a.rate_cases:
            prep = monte_carlo(a.rate_cases, a.seed)
            ones, manys, ratios, steady = [], [], [], []
            for _ in range(a.reps):
                m1: list = []
                mN: list = []
                r1, s1 = _run(prep, folder, 1, False, a.engine, m1)
                rN, sN = _run(prep, folder, W, True, a.engine, mN)
                steady.append(_steady(mN) / (W * _steady(m1)))
                assert r1.table.equals(rN.table), "the tables differ"  # bit-identical rows (NaN where NaN)
                ones.append(a.rate_cases / s1)
                manys.append(a.rate_cases / sN)
                ratios.append(manys[-1] / (W * ones[-1]))
            print(f"\nrate, {a.rate_cases} cases, {a.reps} repetitions, engine {sorted(set(r1.table['engine']))} "
                  "(tables identical in each):")
            print(f"  one worker (thread)        {statistics.median(ones):7.3f} cases/s  ({min(ones):.3f}-{max(ones):.3f})")
            print(f"  {W} worker processes        {statistics.median(manys):7.3f} cases/s  ({min(manys):.3f}-{max(manys):.3f})")
            print(f"  ratio rate({W}) / ({W} x rate(1)) = {statistics.median(ratios):.2f} "
                  f"({min(ratios):.2f}-{max(ratios):.2f}); target >= 0.8")
            print(f"  the same after the first stored block (worker start-up apart) = {statistics.median(steady):.2f} "
                  f"({min(steady):.2f}-{max(steady):.2f})")
        if a.cases:
            t0 = time.perf_counter()
            prep = monte_carlo(a.cases, a.seed)
            t_prep = time.perf_counter() - t0
            res, secs = _run(prep, folder, W, True, a.mc_engine)
            df = res.table
            steps = int(res.steps)
            print(f"\nMonte Carlo, {a.cases} cases of {a.duration} s, {W} worker processes "
                  f"(load average {os.getloadavg()[0]:.1f} at the end):")
            print(f"  prepare {t_prep:.1f} s; run {secs:.1f} s ({a.cases / secs:.2f} cases/s, {steps / secs:,.0f} arm-steps/s)")
            if a.cases != 1000:
                print(f"  scaled to 1000 cases: {secs * 1000 / a.cases:.0f} s (run), "
                      f"{(secs + t_prep) * 1000 / a.cases:.0f} s with the preparation (extrapolated, not measured)")
            k = df["environment.stiffness"].to_numpy()
            h = df["environment.offset[2]"].to_numpy()
            f = k * K_PT / (k + K_PT) * (DEPTH + h)
            rel = np.abs(np.abs(df["settled_force"].to_numpy()) - f) / f
            print(f"  status ok {int((df['status'] == 'ok').sum())}/{len(df)}, stable {int(df['stable'].sum())}, "
                  f"engine {sorted(set(df['engine']))}")
            print(f"  settled force vs springs in series (9.22): median |rel. error| {np.median(rel):.2e}, max {np.max(rel):.2e}")


if __name__ == "__main__":
    sys.exit(main())
