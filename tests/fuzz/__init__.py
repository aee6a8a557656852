"""The library's own fuzz campaign (issue 28 item 8): seeded generators of hostile inputs of five kinds.

It lives under ``tests/`` because it is test code (it writes bags with the test helpers, it imports
the scenario mutator of ``tests/test_fuzz_scenarios.py``) and is not installed with the library;
``tests/test_fuzz_campaign.py`` runs a seeded subset in CI and ``tools/fuzz_report.py`` runs a
larger campaign (it puts ``tests/`` on ``sys.path``).
"""

from __future__ import annotations

import importlib
import time
from pathlib import Path

from .core import BAD, KINDS, OUTCOMES, Case, Outcome, classify, failures, format_table, make_sandbox

__all__ = ["BAD", "KINDS", "OUTCOMES", "Case", "Outcome", "classify", "failures", "format_table", "make_sandbox",
           "make_cases", "run_cases", "warm_up"]

_MODULES = {"scenario": "scenarios", "data": "data", "urdf": "urdf", "cli": "cli", "api": "api"}


def make_cases(kind: str, seed: int, count: int, sentinel: Path) -> list[Case]:
    """``count`` cases of one kind, the same for the same seed."""
    mod = importlib.import_module(f".{_MODULES[kind]}", __name__)
    return mod.make_cases(seed, count, sentinel)


def warm_up() -> float:
    """Run every built-in scenario once, unmutated and short, so that compiling kernels is never taken for a hang."""
    import warnings

    from forcecontrol.scenarios import list_scenarios, load_scenario, run_scenario

    t0 = time.perf_counter()
    for name in sorted(list_scenarios()):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            run_scenario(load_scenario(name).with_(duration=0.05))
    return time.perf_counter() - t0


def run_cases(cases: list[Case], root: Path, keep: Path | None = None, progress=None) -> list[Outcome]:
    """Classify every case in the sandbox ``root``; failing inputs copied under ``keep``."""
    import shutil

    out = []
    for c in cases:
        o = classify(c, root)
        out.append(o)
        if progress is not None:
            progress(o)
        d = root / "cases" / c.kind / f"{c.index:05d}"
        if keep is not None and o.outcome in BAD:
            dest = keep / c.name
            shutil.rmtree(dest, ignore_errors=True)
            shutil.copytree(d, dest, symlinks=True, ignore_dangling_symlinks=True,
                            ignore=lambda src, names: [n for n in names if not (Path(src) / n).is_file()
                                                       and not (Path(src) / n).is_dir()])
            (dest / "WHAT.txt").write_text(f"{c.describe}\n{o.outcome}: {o.detail}\n")
        shutil.rmtree(d, ignore_errors=True)
    return out
