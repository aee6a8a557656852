"""Golden results of every built-in scenario: record them, or compare a run with them.

    python tools/golden.py record [--engine auto|python|compiled|mujoco ...]
    python tools/golden.py compare

For each built-in scenario, each case and each engine, the file ``tests/golden/<scenario>.npz``
keeps the final sample and every 10th sample of the logged signals (q, qd, x, xd, wrench,
wrench_measured, torque). The tests (``tests/test_golden.py``) compare a fresh run against these
files; they were recorded on commit 31aefef, before the laws were moved (issue 12).

Re-recorded on purpose (each change explained in its commit):

* example-9.4, hybrid-rigid-plane, panda-peg-in-hole, problem-9.3, problem-9.10: the trapezoidal
  profile's sample at the start of deceleration (t = t_f − t_c) now holds the decelerating
  interval (was the cruise's zero acceleration): one sample's feed-forward torque changes by
  200–350 N m, positions by at most 1.5e-4 m, Problem 9.10's tangential speed error drops
  from 1.8e-3 to 2.2e-5 m/s.
* example-9.3, the two inner-position cases: the PI integrator starts with
  ``integrator_start = "hold"`` (the loop holds the start before the force step, which then
  acts on the whole PI as in the chapter's linear loop (9.44)); was "tip" (the step's
  proportional kick cancelled). k_x = 1e3: f(0.1 s) 0.057 -> 0.718 N (the linear model's
  0.717 N), f(2.5 s) 9.27 -> 9.58 N; k_x = 1e4: peak 10.0 -> 15.9 N.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

GOLDEN_DIR = Path(__file__).resolve().parents[1] / "tests" / "golden"
SIGNALS = ("q", "qd", "x", "xd", "wrench", "wrench_measured", "torque")
STRIDE = 10


def _key(engine: str, case: int, signal: str) -> str:
    return f"{engine}/{case}/{signal}"


def run_engine(name: str, engine: str) -> dict[str, np.ndarray]:
    """Run one scenario on one engine; return the arrays to keep (raises if the engine cannot)."""
    from forcecontrol.scenarios import run_scenario

    run = run_scenario(name, engine=engine)
    out: dict[str, np.ndarray] = {}
    for i, case in enumerate(run.cases):
        res = case.result
        for s in SIGNALS:
            a = np.asarray(getattr(res, s))
            out[_key(engine, i, s)] = np.concatenate([a[::STRIDE], a[-1:]])
    return out


def record(engines: list[str]) -> None:
    from forcecontrol.scenarios import list_scenarios

    GOLDEN_DIR.mkdir(parents=True, exist_ok=True)
    for name in list_scenarios():
        path = GOLDEN_DIR / f"{name}.npz"
        data = dict(np.load(path)) if path.exists() else {}
        for engine in engines:
            t0 = time.perf_counter()
            try:
                data.update(run_engine(name, engine))
                print(f"{name:28s} {engine:9s} {time.perf_counter() - t0:7.2f} s")
            except Exception as exc:  # an engine that refuses the scenario is simply not recorded
                print(f"{name:28s} {engine:9s} skipped: {type(exc).__name__}: {str(exc)[:90]}")
        np.savez_compressed(path, **data)


def compare(rtol: float = 1e-9) -> int:
    bad = 0
    for path in sorted(GOLDEN_DIR.glob("*.npz")):
        data = dict(np.load(path))
        engines = sorted({k.split("/")[0] for k in data})
        for engine in engines:
            got = run_engine(path.stem, engine)
            for k, want in data.items():
                if not k.startswith(engine + "/"):
                    continue
                err = np.max(np.abs(got[k] - want)) / max(1.0, np.max(np.abs(want)))
                if not err <= rtol:
                    bad += 1
                    print(f"{path.stem} {k}: relative difference {err:.3g}")
    print("golden results hold" if not bad else f"{bad} golden arrays differ")
    return 1 if bad else 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("--engine", action="append", default=None)
    sub.add_parser("compare")
    a = p.parse_args(argv)
    if a.cmd == "record":
        record(a.engine or ["python", "compiled", "mujoco"])
        return 0
    return compare()


if __name__ == "__main__":
    sys.exit(main())
