"""Mutation testing of the control laws: does a wrong law make a test fail?

    python tools/mutate_laws.py            # every mutant, prints the kill table
    python tools/mutate_laws.py --list     # the mutants only
    python tools/mutate_laws.py M3a M3b    # some of them

Each mutant is one textual change of one law's source (the chapter's equation made wrong in a
way a tired programmer could), applied alone; the fast, independent-reference tests (book
numbers, hand-built torques, closed forms: ``TESTS`` below, not the golden recordings, which
would kill anything by construction) run against it, and the file is restored afterwards (also
on Ctrl-C). A mutant is *killed* when a test fails. Each law is written once
(:mod:`forcecontrol.laws`) and every path runs it (the user's ``step``, the compiled loop, the
sweeps' batch), so one mutant per law covers every path.

Numba's cache is keyed on the package's source hash, so every mutant compiles afresh
(a few seconds) and the original sources' cache is untouched.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "forcecontrol"

#: the tests each mutant runs against (references from outside the code under test).
TESTS = [
    "tests/reference",
    "tests/test_controllers.py",
    "tests/test_force_controllers.py",
    "tests/test_hybrid.py",
    "tests/test_spatial.py",
    "tests/test_task.py",
    "tests/test_rigid.py",
    "tests/test_controller_guards.py",
    "tests/test_planar_vs_6d.py",
]


@dataclass(frozen=True)
class Mutant:
    key: str
    law: str
    file: str
    old: str
    new: str


MUTANTS = [
    Mutant("M1", "hybrid (9.82): C′ → C", "controllers/hybrid.py",
           "np.ascontiguousarray(sel.compliance(self.compliance) @ S_f)", "np.ascontiguousarray(self.compliance @ S_f)"),
    Mutant("M2", "parallel (9.48): sign of the force term", "laws/force.py",
           "d[i] = ref[i] - x[i] + d[i]", "d[i] = ref[i] - x[i] - d[i]"),
    Mutant("M3", "inner loop (9.30): J̇q̇ dropped", "laws/inner.py",
           "y[i] = a[i] - Jdq[i]", "y[i] = a[i]"),
    Mutant("M4", "impedance (9.31): M_d → I", "laws/impedance.py",
           "acc += G[i * m + j] * w[j]", "acc += (1.0 if i == j else 0.0) * w[j]"),
    Mutant("M5", "PI force loop (9.43): integrator dropped", "laws/force.py",
           "            s[i] = v\n", "            s[i] = s[i]\n"),
    Mutant("M6", "C′ (9.72): P_v and P_f swapped", "task/selection.py",
           "return (np.eye(self.dim) - self.velocity_projector) @ C", "return (np.eye(self.dim) - self.force_projector) @ C"),
    Mutant("M7a", "orientation error (9.9)-(9.11): base frame instead of desired frame", "laws/spatial.py",
           "    R_de = RdT @ R_e\n    c2 = math.hypot", "    R_de = R_e @ RdT\n    c2 = math.hypot"),
    Mutant("M7b", "orientation error (9.9)-(9.11): base frame instead of desired frame [readable copy]",
           "controllers/spatial.py",
           "    R_de = RdT @ R_e\n    phi, T, Tinv", "    R_de = R_e @ RdT\n    phi, T, Tinv"),
    Mutant("M8", "K′ (9.70) → K", "task/projections.py",
           "return S_f @ np.linalg.solve(S_f.T @ C @ S_f, S_f.T)", "return np.linalg.inv(C)"),
    Mutant("M9", "hybrid rigid (9.91): Ṡ_v ν dropped (moving constraint frame)", "laws/hybrid.py",
           "    _mv_add(S_v_dot, nu, a)\n", "\n"),
    Mutant("M10", "inner velocity loop (9.45)/(9.46): K_F dropped from x_F", "laws/force.py",
           "acc += p[oR + i * m + j] * (p[oF + j] * e[j] + xi)", "acc += p[oR + i * m + j] * (e[j] + xi)"),
    Mutant("M11", "6-D compliance (9.15): damping on J q̇ instead of J_Ad q̇", "controllers/spatial.py",
           "-err.x, JAd @ qd, JAd, Jdq", "-err.x, J @ qd, JAd, Jdq"),
    Mutant("M12", "6-D hybrid (9.77): C replaced by C⁻¹ in the force term", "controllers/spatial_hybrid.py",
           "(Q @ self.compliance).ravel()", "(Q @ np.linalg.inv(self.compliance)).ravel()"),
]


def run(mutant: Mutant, timeout: float) -> tuple[str, str, float]:
    """Apply one mutant, run the tests, restore; return (verdict, first failing test, seconds)."""
    path = SRC / mutant.file
    original = path.read_text(encoding="utf-8")
    if original.count(mutant.old) != 1:
        return "NOT APPLIED", f"pattern found {original.count(mutant.old)} times", 0.0
    t0 = time.perf_counter()
    try:
        path.write_text(original.replace(mutant.old, mutant.new), encoding="utf-8")
        cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *TESTS]
        try:
            proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return "killed (timeout)", "", time.perf_counter() - t0
        failed = next((ln.split()[1] for ln in proc.stdout.splitlines() if ln.startswith(("FAILED", "ERROR"))), "")
        verdict = "killed" if proc.returncode != 0 else "SURVIVED"
        return verdict, failed, time.perf_counter() - t0
    finally:
        path.write_text(original, encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("keys", nargs="*", help="mutants to run (default: all)")
    ap.add_argument("--list", action="store_true", help="list the mutants and exit")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per mutant")
    a = ap.parse_args(argv)
    chosen = [m for m in MUTANTS if not a.keys or m.key in a.keys]
    if a.list:
        for m in chosen:
            print(f"{m.key:4s} {m.law}  ({m.file})")
        return 0
    survivors = 0
    print("| mutant | law | file | verdict | first failing test | s |\n|---|---|---|---|---|---|")
    for m in chosen:
        verdict, test, secs = run(m, a.timeout)
        survivors += verdict != "killed" and not verdict.startswith("killed")
        print(f"| {m.key} | {m.law} | {m.file} | {verdict} | {test} | {secs:.0f} |", flush=True)
    return 1 if survivors else 0


if __name__ == "__main__":
    sys.exit(main())
