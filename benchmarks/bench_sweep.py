"""Throughput of sweeps over the chapter's arm: arm-steps per second, single-case loop against batched.

The sweep: Example 9.3's three direct force control schemes (inner position, inner velocity,
parallel; 1 ms control, 10 s per case), the environment stiffness over ``logspace(3, 5, K)`` and
the force sensor's noise seed over ``range(0, S)`` (0.2 N noise), so 3·K·S cases. An arm-step is
one control sample of one case (the plant is integrated by ``substeps`` RK4 steps within it).

Measured in this process, on the same cases:

* for orientation, the plain Python/NumPy reference loop, ``simulate(engine="python")``;
* single-case loop: ``simulate(engine="compiled")`` called case after case from Python (the
  path a user's own loop takes), on the first cases of the sweep;
* batched kernel, one thread: :func:`forcecontrol.sweep.run_block` on blocks of cases;
* the sweep: :func:`forcecontrol.sweep.run_sweep` on all cores (thread per core, the kernel
  releases the GIL), Parquet parts written as blocks end, final table assembled;
  ``prepare_sweep`` (validation and build of every case) reported separately;
* optionally the same sweep on a Dask ``LocalCluster`` (``--local-cluster``; its workers are
  warmed first: import and compiled kernel) or a running scheduler (``--scheduler tcp://...``).

Run: ``python benchmarks/bench_sweep.py [--k 20] [--seeds 10] [--local-cluster]``; prints a table,
asserts nothing. The acceptance target is at least 2·10⁶ arm-steps per second for the sweep on a
2-core machine; the machine is shared, so rates drift (up to 1.5x) between runs.
"""

from __future__ import annotations

import argparse
import copy
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

import forcecontrol as fc
from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_block, run_sweep


def _steps(table) -> int:
    """Control samples actually simulated (a diverged case stops early)."""
    ok = table["status"] == "ok"
    early = np.round(table.loc[~ok, "diverged_at"] / 1e-3).astype(int)
    return int(table.loc[ok, "samples"].sum() + early.sum())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--k", type=int, default=20, help="environment stiffness values per scheme")
    ap.add_argument("--seeds", type=int, default=10, help="noise seeds per stiffness")
    ap.add_argument("--single", type=int, default=12, help="cases for the single-case loop")
    ap.add_argument("--local-cluster", action="store_true", help="also run on a dask LocalCluster (2 workers)")
    ap.add_argument("--scheduler", default=None, help="also run on this Dask scheduler")
    ap.add_argument("--scaling", action="store_true",
                    help="only compare a sweep of about 100 cases with one of about 5,000 (prepare + run, arm-steps/s)")
    args = ap.parse_args()
    if args.scaling:
        scaling()
        return

    d = SweepDefinition.from_options(
        {
            "environment.stiffness": f"logspace(3, 5, {args.k})",
            "sensor.seed": f"range(0, {args.seeds})",
            "sensor.noise_std": [0.2],
        },
        cases=["1", "3", "5"],  # the three schemes of Example 9.3 (k_x = 1e4 rows; k is swept)
    )
    prepare_sweep("example-9.3", SweepDefinition.from_options({"sensor.seed": "range(0, 3)"}, cases=["1", "3", "5"]))
    t0 = time.perf_counter()  # (after a small sweep: the process's one-time imports are not counted)
    prep = prepare_sweep("example-9.3", d)
    t_prep = time.perf_counter() - t0
    n = prep.n_cases
    samples = prep.jobs[0].N
    print(f"sweep: example-9.3, 3 schemes x {args.k} stiffnesses x {args.seeds} seeds = {n} cases of {samples} "
          f"samples (1 ms), cores: {os.cpu_count()}")
    print(f"prepare_sweep (validate and build every case): {t_prep:.2f} s ({1e3 * t_prep / n:.2f} ms per case)")

    # warm the compiled code (a cold Numba cache compiles here, not in the timings)
    run_block(prep.jobs[:1], 0.02, 0.05)
    from forcecontrol.scenarios import CaseSpec, build_case

    def single_case(job) -> int:
        cfg = {c["label"]: c["config"] for c in prep.metadata["cases"]}[job.label]
        cfg = copy.deepcopy(cfg)
        cfg["environment"]["stiffness"] = job.values["environment.stiffness"]
        cfg.setdefault("sensor", {}).update(seed=job.values["sensor.seed"], noise_std=0.2)
        p = build_case(CaseSpec(job.label, cfg, {}))
        try:
            r = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"],
                            duration=p["duration"], sensor=p["sensor"], engine="compiled")
            return len(r.t) - 1
        except fc.SimulationDivergedError as e:
            return e.step

    single_case(prep.jobs[0])
    rows = []
    picks = prep.jobs[:: max(1, n // args.single)][: args.single]
    t0 = time.perf_counter()
    steps = sum(single_case(j) for j in picks)
    dt = time.perf_counter() - t0
    rows.append(("single-case loop: simulate(engine='compiled') per case", len(picks), steps, dt))

    job = prep.jobs[0]
    cfg = copy.deepcopy({c["label"]: c["config"] for c in prep.metadata["cases"]}[job.label])
    p = build_case(CaseSpec(job.label, cfg, {}))
    fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=0.01,
                engine="python")  # warm its compiled helpers
    t0 = time.perf_counter()
    r = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=0.5,
                    engine="python")
    rows.insert(0, ("for orientation: simulate(engine='python'), one case, 0.5 s", 1, len(r.t) - 1,
                    time.perf_counter() - t0))

    block = prep.jobs[: max(1, min(n, 60))]
    t0 = time.perf_counter()
    out = run_block(block, 0.02, 0.05)
    dt = time.perf_counter() - t0
    st = sum(r["samples"] if r["status"] == "ok" else int(round(r["diverged_at"] / 1e-3)) for r in out)
    rows.append(("batched kernel, one thread (run_block)", len(block), st, dt))

    tmp = Path(tempfile.mkdtemp(prefix="fc-bench-sweep-"))
    try:
        res = run_sweep(prep, tmp / "local.parquet")
        rows.append((f"sweep, local, {os.cpu_count()} threads (run_sweep, Parquet parts)", n, _steps(res.table), res.seconds))
        if args.local_cluster:
            from dask.distributed import Client, LocalCluster

            with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
                with Client(cluster) as client:  # workers import forcecontrol and load the kernel first
                    client.run(run_block, prep.jobs[:1], 0.02, 0.05)
                r2 = run_sweep(prep, tmp / "cluster.parquet", scheduler=cluster.scheduler_address)
                same = r2.table.equals(res.table)
                rows.append((f"sweep, dask LocalCluster 2x1 (identical table: {same})", n, _steps(r2.table), r2.seconds))
        if args.scheduler:
            r3 = run_sweep(prep, tmp / "remote.parquet", scheduler=args.scheduler)
            rows.append((f"sweep, dask {args.scheduler} (identical: {r3.table.equals(res.table)})", n,
                         _steps(r3.table), r3.seconds))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    print()
    print(f"{'what':<66} {'cases':>6} {'arm-steps':>11} {'seconds':>8} {'µs/step':>8} {'arm-steps/s':>12}")
    for what, cases, st, dt in rows:
        print(f"{what:<66} {cases:>6} {st:>11,} {dt:>8.2f} {1e6 * dt / st:>8.3f} {st / dt:>12.3g}")
    base = rows[1][2] / rows[1][3]
    sweep_rate = rows[3][2] / rows[3][3]
    print(f"\nsweep / single-case loop: {sweep_rate / base:.1f}x; target 2e6 arm-steps/s: "
          f"{'met' if sweep_rate >= 2e6 else 'NOT met'} ({sweep_rate:.3g})")
    print(f"with prepare_sweep included: {rows[3][2] / (rows[3][3] + t_prep):.3g} arm-steps/s")


def scaling() -> None:
    """Throughput of a small sweep against a large one (issue target: within 2x), preparation included.

    The same definition as :func:`main` (Example 9.3's three schemes, stiffness x seeds), 96 and
    5,010 cases of 10 s; ``prepare_sweep`` + ``run_sweep`` on all cores, timed together. The
    small one runs first (with the process's one-time imports) and again last; the ratio uses
    the last.
    """
    rates = {}
    # the small sweep twice: its first run also pays one-time imports (pandas, pyarrow: ~0.3 s)
    for k, seeds in ((4, 8), (167, 10), (4, 8)):
        d = SweepDefinition.from_options(
            {"environment.stiffness": f"logspace(3, 5, {k})", "sensor.seed": f"range(0, {seeds})", "sensor.noise_std": [0.2]},
            cases=["1", "3", "5"],
        )
        warm = prepare_sweep("example-9.3", d).jobs
        run_block([next(j for j in warm if j.law is law) for law in {j.law for j in warm}], 0.02, 0.05)  # each law's kernel
        tmp = Path(tempfile.mkdtemp(prefix="fc-bench-scaling-"))
        try:
            t0 = time.perf_counter()
            prep = prepare_sweep("example-9.3", d)
            t_prep = time.perf_counter() - t0
            res = run_sweep(prep, tmp / "s.parquet")
            dt = time.perf_counter() - t0
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        steps = _steps(res.table)
        rates[prep.n_cases] = steps / dt
        print(f"{prep.n_cases:>6} cases: prepare {t_prep:.2f} s ({1e6 * t_prep / prep.n_cases:.0f} µs/case), "
              f"prepare + run {dt:.2f} s, {steps / dt:.3g} arm-steps/s")
    small, large = sorted(rates)
    print(f"large / small sweep throughput: {rates[large] / rates[small]:.2f}x (target <= 2)")


if __name__ == "__main__":
    main()
