"""Print the scenario fuzzer's counts by mutation kind (the table of the hardening note).

Runs the generator of ``tests/test_fuzz_scenarios.py`` (same seed and sizes by default, so the
table is the one the test prints) and lists any file that ended in something other than success
or a library error.

Usage:
    PYTHONPATH=src python tools/fuzz_report.py [--seed N] [--per-scenario N] [--run N] [--keep DIR]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _fuzz_module():
    spec = importlib.util.spec_from_file_location("fuzz_scenarios", ROOT / "tests" / "test_fuzz_scenarios.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def main(argv: list[str] | None = None) -> int:
    """Run the fuzzer and print its table; exit status 1 when a file ended in a raw exception or a hang."""
    fz = _fuzz_module()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=fz.SEED)
    ap.add_argument("--per-scenario", type=int, default=fz.PER_SCENARIO, help="mutated files per built-in scenario")
    ap.add_argument("--run", type=int, default=fz.RUN_SUBSET, help="loadable files also simulated")
    ap.add_argument("--keep", type=Path, help="write the mutated files here (default: a temporary folder)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        report = fz.fuzz(folder, seed=args.seed, per_scenario=args.per_scenario, run_subset=args.run)
    print(f"seed {args.seed}, {args.per_scenario} files per built-in scenario, {args.run} run for "
          f"{fz.RUN_DURATION} s each, hang guard {fz.HANG_SECONDS} s per file\n")
    print(fz.format_table(report))
    for scenario, kind, name, what in report["bad"]:
        print(f"BAD {name} ({scenario}, {kind}): {what}")
    return 1 if report["bad"] else 0


if __name__ == "__main__":
    sys.exit(main())
