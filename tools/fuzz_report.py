"""Run the fuzz campaign (issue 28 item 8) and print its counts: kind x outcome, then every failing input.

The generators are the package ``tests/fuzz`` (five kinds: ``scenario``, ``data``, ``urdf``, ``cli``,
``api``); the outcomes are ``success``, ``clean_error``, ``raw_traceback``, ``hang``, ``silent`` (accepted
although the input cannot mean what it says) and ``outside_write``. The same seed gives the same
inputs; a failing input is saved under ``--keep`` (its files and a ``WHAT.txt``).

Usage:
    python tools/fuzz_report.py [--kinds scenario,data,urdf,cli,api] [--count N] [--seed S] [--jobs J]
                                [--keep DIR] [--by kind|sub]
    python tools/fuzz_report.py --legacy [--seed N] [--per-scenario N] [--run N]   (the older scenario-file table
                                of tests/test_fuzz_scenarios.py)
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"


def _fuzz_module():
    spec = importlib.util.spec_from_file_location("fuzz_scenarios", TESTS / "test_fuzz_scenarios.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _legacy(args) -> int:
    fz = _fuzz_module()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        report = fz.fuzz(folder, seed=args.seed, per_scenario=args.per_scenario or fz.PER_SCENARIO,
                         run_subset=fz.RUN_SUBSET if args.run is None else args.run)
    print(fz.format_table(report))
    for scenario, kind, name, what in report["bad"]:
        print(f"BAD {name} ({scenario}, {kind}): {what}")
    return 1 if report["bad"] else 0


def _worker(job: tuple) -> list[tuple]:
    """Run the cases ``index % jobs == wid`` of each kind in a sandbox of this worker's own."""
    kinds, seed, count, wid, jobs, keep, warm = job
    if str(TESTS) not in sys.path:
        sys.path.insert(0, str(TESTS))
    import fuzz

    root = Path(tempfile.mkdtemp(prefix=f"fuzz-w{wid}-"))
    sentinel = fuzz.make_sandbox(root)
    if warm:
        fuzz.warm_up()
    rows = []
    for kind in kinds:
        cases = [c for c in fuzz.make_cases(kind, seed, count, sentinel) if c.index % jobs == wid]
        done = 0

        def progress(o, kind=kind, n=len(cases)):  # noqa: B008 - bound per kind
            nonlocal done
            done += 1
            rows.append((o.case.kind, o.case.sub, o.case.index, o.case.describe, o.outcome, o.detail))
            if o.outcome in fuzz.BAD:
                print(f"[worker {wid}] {o.case.name}: {o.outcome}: {o.detail[:200]}", file=sys.stderr, flush=True)
            if done % 25 == 0:
                print(f"[worker {wid}] {kind}: {done}/{n}", file=sys.stderr, flush=True)

        fuzz.run_cases(cases, root, keep=keep, progress=progress)
        print(f"[worker {wid}] {kind}: {len(cases)} done", file=sys.stderr, flush=True)
    import shutil

    shutil.rmtree(root, ignore_errors=True)
    return rows


def main(argv: list[str] | None = None) -> int:
    """Run the campaign and print the table; exit status 1 when any input ended in a failure outcome."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default="scenario,data,urdf,cli,api", help="comma-separated: scenario,data,urdf,cli,api")
    ap.add_argument("--count", type=int, default=100, help="inputs per kind")
    ap.add_argument("--seed", type=int, default=20261126)
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (the machine is shared: 1 or 2)")
    ap.add_argument("--keep", type=Path, help="save each failing input here")
    ap.add_argument("--by", choices=("kind", "sub"), default="kind", help="one row per kind or per kind/mutation")
    ap.add_argument("--no-warm-up", action="store_true", help="skip running each built-in scenario once first")
    ap.add_argument("--legacy", action="store_true", help="the older scenario-file fuzzer's table instead")
    ap.add_argument("--per-scenario", type=int, help="--legacy: mutated files per built-in scenario")
    ap.add_argument("--run", type=int, help="--legacy: loadable files also simulated")
    args = ap.parse_args(argv)
    if args.legacy:
        return _legacy(args)
    sys.path.insert(0, str(TESTS))
    import fuzz
    from fuzz.core import OUTCOMES, Case, Outcome

    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    unknown = [k for k in kinds if k not in fuzz.KINDS]
    if unknown or args.count < 0 or args.jobs < 1:
        ap.error(f"--kinds must be among {', '.join(fuzz.KINDS)}; --count >= 0; --jobs >= 1 (got {args.kinds!r}, "
                 f"{args.count}, {args.jobs})")
    if args.keep:
        args.keep = args.keep.resolve()
        args.keep.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(tempfile.gettempdir()) / "numba-fuzz"))
    warm = "scenario" in kinds and not args.no_warm_up
    t0 = time.perf_counter()
    jobs = [(kinds, args.seed, args.count, w, args.jobs, args.keep, warm) for w in range(args.jobs)]
    if args.jobs == 1:
        rows = _worker(jobs[0])
    else:
        import multiprocessing

        with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as ex:
            rows = [r for part in ex.map(_worker, jobs) for r in part]
    seconds = time.perf_counter() - t0
    outcomes = [Outcome(Case(k, s, i, d), o, det) for k, s, i, d, o, det in sorted(rows, key=lambda r: (r[0], r[2]))]
    print(f"fuzz campaign: seed {args.seed}, {args.count} inputs per kind ({', '.join(kinds)}), {args.jobs} job(s), "
          f"{seconds:.0f} s\n")
    print(fuzz.format_table(outcomes, by=args.by))
    bad = fuzz.failures(outcomes)
    if bad:
        print(f"\n{len(bad)} failing input(s)" + (f" (saved under {args.keep})" if args.keep else "") + ":")
    for o in bad:
        print(f"  {o.case.name}: {o.outcome}: {o.case.describe}\n      {o.detail}")
    assert set(OUTCOMES) >= {o.outcome for o in outcomes}
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
