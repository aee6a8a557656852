"""Mutation testing: does a wrong implementation make a test fail?

    python tools/mutate.py                      # every mutant, prints the kill table
    python tools/mutate.py --list               # the mutants only (and whether each still applies)
    python tools/mutate.py --area safety        # one area: laws, safety, sweeps, metrics, tanks, admittance, calibration
    python tools/mutate.py S1 T1                # some of them
    python tools/mutate.py --compare S1         # the mutant's older tests alone, then the slip tests alone
    python tools/mutate.py --root /tmp/wt ...   # mutate the sources of another checkout (a git worktree)

Each mutant is one textual change of one source file (a slip a tired programmer could make),
applied alone; the fast tests with independent references listed for it run against it, and the
file is restored afterwards (also on Ctrl-C). A mutant is *killed* when a test fails.

The law mutants (area ``laws``) run the law tests (book numbers, hand-built torques, closed
forms; not the golden recordings, which would kill anything by construction). The other areas'
mutants also run ``tests/test_wrong_implementations.py``, one test per slip the rest of the suite
used to let through; ``--compare`` runs a mutant's other tests and that file separately, to show
which of them catches it.

The mutated sources are those under ``--root`` (default: the checkout this file is in): the
tests run with ``PYTHONPATH=<root>/src`` and the tool refuses to start when ``forcecontrol``
would be imported from elsewhere. Others working in the same tree read the sources while a
mutant is applied, so run it on a private worktree::

    git worktree add /tmp/mut-wt HEAD && python /tmp/mut-wt/tools/mutate.py --area safety
    git worktree remove --force /tmp/mut-wt

Numba's cache is keyed on the package's source hash, so a mutant compiles afresh (tens of
seconds on a busy machine); each mutant gets a temporary cache folder, removed afterwards. A
mutant of a file with no compiled (``njit``) code cannot change a compiled function, so its
folder starts as a copy of the unmutated sources' kernels, compiled by a first *baseline* run of
those mutants' tests on the unmutated sources (which must pass, or the kills would mean nothing);
``--fresh-cache`` compiles every mutant from scratch instead.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "forcecontrol"

#: the law mutants' tests (references from outside the code under test).
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
#: one test per slip the rest of the suite let through (issue 27, item 4).
SLIPS = "tests/test_wrong_implementations.py"

_SAFETY = (SLIPS, "tests/test_safety.py")
_SWEEPS = (
    SLIPS,
    "tests/test_sweep.py::test_sweep_table_matches_per_case_python_simulations",
    "tests/test_sweep.py::test_rerun_of_a_finished_sweep_runs_nothing_and_a_different_sweep_is_refused",
    "tests/test_sweep_faults.py::test_damaged_part_is_moved_aside_and_rerun",
    "tests/test_sweep_faults.py::test_corrupt_stamp_and_corrupt_table_are_recovered",
)
_METRICS = (
    SLIPS,
    "tests/test_sweep.py::test_metrics_of_a_first_order_step_by_hand",
    "tests/test_sweep.py::test_metrics_of_a_damped_oscillation_by_hand",
    "tests/test_sweep.py::test_growing_oscillation_is_unstable_and_diverged_case_has_no_metrics",
    "tests/test_sweep.py::test_sweep_table_matches_per_case_python_simulations",
)
_TANKS = (
    SLIPS,
    "tests/test_variable_impedance.py::test_energy_tank_arithmetic",
    "tests/test_variable_impedance.py::test_tank_refuses_bad_requests",
    "tests/test_variable_impedance.py::test_energy_balance_holds_to_first_order_in_the_sample_time",
    "tests/test_variable_impedance.py::test_naive_schedule_creates_energy_and_the_tank_version_does_not",
    "tests/test_variable_impedance.py::test_built_in_scenario_naive_bounces_and_tank_keeps_contact",
    "tests/test_variable_impedance.py::test_panda_position_task_naive_grows_tank_stays_bounded",
)
_ADMITTANCE = (SLIPS, "tests/test_admittance.py")
_CALIBRATION = (SLIPS, "tests/test_calibration.py")


@dataclass(frozen=True)
class Mutant:
    key: str
    law: str  # what the slip does (the column keeps the old tool's name)
    file: str  # relative to src/forcecontrol
    old: str
    new: str
    area: str = "laws"
    tests: tuple[str, ...] = tuple(TESTS)


MUTANTS = [
    # ------------------------------------------------------------------ the control laws
    Mutant("M1", "hybrid (9.82): C′ → C", "controllers/hybrid.py",
           "np.ascontiguousarray(sel.compliance(self.compliance) @ S_f)", "np.ascontiguousarray(self.compliance @ S_f)"),
    Mutant("M2", "parallel (9.48): sign of the force term", "laws/force.py",
           "d[i] = ref[REF_X_D + i] - x[i] + d[i]", "d[i] = ref[REF_X_D + i] - x[i] - d[i]"),
    Mutant("M3", "inner loop (9.30): J̇q̇ dropped", "laws/inner.py",
           "y[i] = a[i] - Jdq[i]", "y[i] = a[i]"),
    Mutant("M4", "impedance (9.31): M_d → I", "laws/impedance.py",
           "acc += G[IMPEDANCE_M_D_INV + i * m + j] * w[j]", "acc += (1.0 if i == j else 0.0) * w[j]"),
    Mutant("M5", "PI force loop (9.43): integrator dropped", "laws/force.py",
           "            s[FORCE_STATE_XI + i] = v\n", "            s[FORCE_STATE_XI + i] = s[FORCE_STATE_XI + i]\n"),
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
           "CpS_f=Q @ self.compliance,", "CpS_f=Q @ np.linalg.inv(self.compliance),"),
    # ------------------------------------------------------------------ safety layer
    Mutant("S1", "torque limit one-sided (u > τ_max): a negative overshoot neither clamped nor logged", "supervision/safety.py",
           "over = bool((np.abs(u) > tau_max).any())", "over = bool((u > tau_max).any())", "safety", _SAFETY),
    Mutant("S2", "force limit one-sided (largest signed component instead of ‖h_e‖)", "supervision/safety.py",
           'checks.append(("force limit", math.sqrt(float(w @ w)),', 'checks.append(("force limit", float(np.max(w)),',
           "safety", _SAFETY),
    Mutant("S3", "rate limit: the clamp's bounds swapped (u_prev ∓ τ̇_max Ts)", "supervision/safety.py",
           "u = np.clip(u, u_prev - step, u_prev + step)", "u = np.clip(u, u_prev + step, u_prev - step)", "safety", _SAFETY),
    Mutant("S4", "speed limit on the joint speeds q̇ instead of the tip speed J q̇", "supervision/safety.py",
           "v = (self.robot.jacobian(q) @ np.asarray(measurement.qd, dtype=np.float64))[lin]",
           "v = np.asarray(measurement.qd, dtype=np.float64)[lin]", "safety", _SAFETY),
    Mutant("S5", "path deviation measured on every axis (S ignored)", "supervision/safety.py",
           "e = np.where(self.deviation_axes[lin], d, 0.0)", "e = d", "safety", _SAFETY),
    Mutant("S6", "safe stop's hold law: sign of the damping", "supervision/safety.py",
           "K @ (q_hold - q) - D @ qd", "K @ (q_hold - q) + D @ qd", "safety", _SAFETY),
    # ------------------------------------------------------------------ sweeps
    Mutant("W1", "resumed sweep's parts not re-sorted by case_id", "sweep/store.py",
           '    table = table.take(pc.sort_indices(table, [("case_id", "ascending")]))\n', "", "sweeps", _SWEEPS),
    Mutant("W2", "sweep's settling band 5 % instead of 2 % (from_options default)", "sweep/spec.py",
           "        settle_band: float = 0.02,\n", "        settle_band: float = 0.05,\n", "sweeps", _SWEEPS),
    Mutant("W3", "a part's case range not checked against its name", "sweep/store.py",
           "if len(ids) != n or (ids and (min(ids) != lo or max(ids) != hi)):", "if len(ids) != n:", "sweeps", _SWEEPS),
    Mutant("W4", "resume runs every case again (the stored parts not skipped)", "sweep/run.py",
           "todo = [j for j in prep.jobs if j.case_id not in done]", "todo = list(prep.jobs)", "sweeps", _SWEEPS),
    # ------------------------------------------------------------------ step-response metrics
    Mutant("X1", "step_metrics' settling band 5 % instead of 2 %", "sim/metrics.py",
           "window: float = 0.1, band: float = 0.02,", "window: float = 0.1, band: float = 0.05,", "metrics", _METRICS),
    Mutant("X2", "overshoot measured from the reference instead of the final value", "sim/metrics.py",
           "v = sign * (y[k] - yf)", "v = sign * (y[k] - f_ref)", "metrics", _METRICS),
    Mutant("X3", "the step measured from 0 instead of y_0", "sim/metrics.py",
           "s = yf - y[0]", "s = yf", "metrics", _METRICS),
    Mutant("X4", "settling time one sample early (the last sample outside the band)", "sim/metrics.py",
           "settling = nan if k_out >= n - 1 else (k_out + 1) * Ts", "settling = nan if k_out >= n - 1 else k_out * Ts",
           "metrics", _METRICS),
    Mutant("X5", "final value averaged over one sample fewer than the window", "sim/metrics.py",
           "    for k in range(n - w, n):\n        acc += y[k]", "    for k in range(n - w + 1, n):\n        acc += y[k]",
           "metrics", _METRICS),
    Mutant("X6", "stable: 'within the band AND still decaying' instead of OR", "sim/metrics.py",
           "late <= stable_band * mag or late < 0.9 * early", "late <= stable_band * mag and late < 0.9 * early",
           "metrics", _METRICS),
    # ------------------------------------------------------------------ energy tanks
    Mutant("T1", "tank filled with the new sample's damping instead of the damping that acted", "controllers/variable.py",
           "float(ed_prev @ D @ ed_prev)", "float(ed_prev @ D_new @ ed_prev)", "tanks", _TANKS),
    Mutant("T2", "tank filled with the new error rate instead of the last sample's", "controllers/variable.py",
           "float(ed_prev @ D @ ed_prev)", "float(ed @ D @ ed)", "tanks", _TANKS),
    Mutant("T3", "tank's upper bound: the deposit compared with T_max instead of the room left", "controllers/variable.py",
           "        if e > room:\n", "        if e > self.maximum:\n", "tanks", _TANKS),
    Mutant("T4", "tank pays down to 0 (T_min ignored)", "controllers/variable.py",
           "available = self.energy - self.minimum", "available = self.energy", "tanks", _TANKS),
    Mutant("T5", "σ ignored: the whole dissipation stored", "controllers/variable.py",
           "self._add(self.dissipation_fraction * energy)", "self._add(energy)", "tanks", _TANKS),
    Mutant("T6", "the stiffness moves fully although the tank granted a fraction α", "controllers/variable.py",
           "return K + alpha * dK, ", "return K_s, ", "tanks", _TANKS),
    # ------------------------------------------------------------------ admittance bandwidth check
    Mutant("A1", "bandwidth check: ω_motion from λ_max(K_P) instead of λ_min", "controllers/admittance.py",
           "np.linalg.eigvalsh(self.motion_stiffness)[0]", "np.linalg.eigvalsh(self.motion_stiffness)[-1]",
           "admittance", _ADMITTANCE),
    Mutant("A2", "bandwidth check: the expected environment stiffness left out", "controllers/admittance.py",
           "K = self.stiffness if self.environment_stiffness is None else self.stiffness + self.environment_stiffness",
           "K = self.stiffness", "admittance", _ADMITTANCE),
    Mutant("A3", "bandwidth check: ω_impedance from K_Pt without M_t⁻¹", "controllers/admittance.py",
           "np.linalg.eigvals(self._Mt_inv @ K)", "np.linalg.eigvals(K)", "admittance", _ADMITTANCE),
    Mutant("A4", "bandwidth check: ω_motion = λ_min instead of √λ_min", "controllers/admittance.py",
           "w_mot = math.sqrt(float(np.linalg.eigvalsh(self.motion_stiffness)[0]))",
           "w_mot = float(np.linalg.eigvalsh(self.motion_stiffness)[0])", "admittance", _ADMITTANCE),
    # ------------------------------------------------------------------ F/T sensor calibration
    Mutant("C1", "CoM σ: the mass term with m³ instead of m⁴", "realarm/calibration/core.py",
           "np.outer(p, p) * cov_f[0, 0] / mass**4", "np.outer(p, p) * cov_f[0, 0] / mass**3", "calibration", _CALIBRATION),
    Mutant("C2", "sign of gravity (+z / +y)", "sensors/gravity.py",
           "out[1 if dim == 2 else 2] = -g", "out[1 if dim == 2 else 2] = g", "calibration", _CALIBRATION),
    Mutant("C3", "noise variance RSS / rows instead of RSS / (rows − unknowns)", "realarm/calibration/core.py",
           "dof = A.shape[0] - A.shape[1]", "dof = A.shape[0]", "calibration", _CALIBRATION),
    Mutant("C4", "CoM σ: the first-moment term over m instead of m²", "realarm/calibration/core.py",
           "cov_c = cov_t[:d, :d] / mass**2", "cov_c = cov_t[:d, :d] / mass", "calibration", _CALIBRATION),
    Mutant("C5", "tare: the payload added to the mean reading instead of subtracted", "realarm/calibration/core.py",
           "b_f = F.mean(axis=0) - payload_f", "b_f = F.mean(axis=0) + payload_f", "calibration", _CALIBRATION),
]

AREAS = tuple(dict.fromkeys(m.area for m in MUTANTS))


def _env(root: Path, cache: str) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(root / "src"), *filter(None, [env.get("PYTHONPATH")])])
    env["NUMBA_CACHE_DIR"] = cache
    return env


def _source_hash(root: Path) -> str:
    """The package's cache key, by the package's own function (forcecontrol.core.numba_cache)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_fc_numba_cache", root / "src" / "forcecontrol" / "core" / "numba_cache.py")
    mod = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(mod)  # type: ignore[union-attr]
    return mod._source_hash(root / "src" / "forcecontrol")


def compiles(root: Path, mutant: Mutant) -> bool:
    """Whether the mutated file holds compiled code (then the mutant's kernels are compiled afresh)."""
    return "njit" in (root / "src" / "forcecontrol" / mutant.file).read_text(encoding="utf-8")


def baseline(root: Path, tests: list[str], cache: str, timeout: float) -> tuple[str, str, float]:
    """The tests on the unmutated sources (they must pass), compiling the kernels into ``cache``."""
    t0 = time.perf_counter()
    verdict, failed = _pytest(root, tests, _env(root, cache), timeout)
    return ("passed" if verdict == "SURVIVED" else verdict), failed, time.perf_counter() - t0


def check_root(root: Path) -> str:
    """Where ``forcecontrol`` is imported from with the tool's environment; SystemExit when not under root."""
    cache = tempfile.mkdtemp(prefix="fc-mutate-check-")
    try:
        proc = subprocess.run([sys.executable, "-c", "import forcecontrol; print(forcecontrol.__file__)"], cwd=root,
                              env=_env(root, cache), capture_output=True, text=True)
    finally:
        shutil.rmtree(cache, ignore_errors=True)
    where = proc.stdout.strip()
    if proc.returncode != 0 or not Path(where).resolve().is_relative_to((root / "src").resolve()):
        raise SystemExit(f"--root {root}: forcecontrol is imported from {where or proc.stderr.strip()!r}, "
                         f"not from {root / 'src'}; the mutants would not be tested")
    return where


def _pytest(root: Path, tests: list[str], env: dict[str, str], timeout: float) -> tuple[str, str]:
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests]
    try:
        proc = subprocess.run(cmd, cwd=root, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return "killed (timeout)", ""
    failed = next((ln.split()[1] for ln in proc.stdout.splitlines() if ln.startswith(("FAILED", "ERROR"))), "")
    if proc.returncode == 0:
        return "SURVIVED", ""
    if proc.returncode in (1, 2) and failed:
        return "killed", failed
    # no test ran to a verdict (a collection error, pytest itself failed): not a kill
    last = (proc.stdout + proc.stderr).strip().splitlines()
    return f"ERROR (pytest exit {proc.returncode})", last[-1] if last else ""


def run(mutant: Mutant, timeout: float, root: Path = ROOT, compare: bool = False,
        warm: Path | None = None) -> list[tuple[str, str, float]]:
    """Apply one mutant, run its tests (or, with ``compare``, its other tests then the slip tests), restore.

    ``warm``: a cache folder of the unmutated sources' kernels to start from (a mutant of a file
    without compiled code only). Returns one (verdict, first failing test, seconds) per pytest run.
    """
    path = root / "src" / "forcecontrol" / mutant.file
    original = path.read_text(encoding="utf-8")
    if original.count(mutant.old) != 1:
        return [("NOT APPLIED", f"pattern found {original.count(mutant.old)} times", 0.0)]
    if compare:
        others = [t for t in mutant.tests if t != SLIPS]
        plan = [others, [SLIPS]] if SLIPS in mutant.tests else [others]
    else:
        plan = [list(mutant.tests)]
    cache = tempfile.mkdtemp(prefix=f"fc-mutant-{mutant.key}-numba-")
    out = []
    try:
        path.write_text(original.replace(mutant.old, mutant.new), encoding="utf-8")
        if warm is not None and warm.is_dir():
            shutil.copytree(warm, Path(cache) / f"forcecontrol-{_source_hash(root)}")
        for tests in plan:
            t0 = time.perf_counter()
            verdict, failed = _pytest(root, tests, _env(root, cache), timeout)
            out.append((verdict, failed, time.perf_counter() - t0))
        return out
    finally:
        path.write_text(original, encoding="utf-8")
        shutil.rmtree(cache, ignore_errors=True)


def main(argv: list[str] | None = None, default_area: str | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("keys", nargs="*", help="mutants to run (default: all, or those of --area)")
    ap.add_argument("--area", action="append", choices=AREAS, help="only this area's mutants (repeatable)")
    ap.add_argument("--list", action="store_true", help="list the mutants and exit")
    ap.add_argument("--compare", action="store_true",
                    help=f"run a mutant's other tests and {SLIPS} separately (two columns)")
    ap.add_argument("--root", type=Path, default=ROOT, help="the checkout whose sources are mutated (default: %(default)s)")
    ap.add_argument("--fresh-cache", action="store_true",
                    help="compile every mutant from scratch (no baseline run, no copied kernels)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per pytest run")
    a = ap.parse_args(argv)
    root = a.root.resolve()
    areas = a.area or ([default_area] if default_area and not a.keys else None)
    chosen = [m for m in MUTANTS if (not a.keys or m.key in a.keys) and (not areas or m.area in areas)]
    unknown = sorted(set(a.keys) - {m.key for m in MUTANTS})
    if unknown:
        ap.error(f"unknown mutant(s) {unknown}; see --list")
    if a.list:
        for m in chosen:
            n = (root / "src" / "forcecontrol" / m.file).read_text(encoding="utf-8").count(m.old)
            state = "" if n == 1 else f"   [NOT APPLICABLE: pattern found {n} times]"
            print(f"{m.key:4s} {m.area:11s} {m.law}  ({m.file}){state}")
        return 0
    print(f"forcecontrol imported from {check_root(root)}", file=sys.stderr)
    base = Path(tempfile.mkdtemp(prefix="fc-mutate-base-numba-"))
    try:
        return _table(chosen, root, a, base)
    finally:
        shutil.rmtree(base, ignore_errors=True)


def _table(chosen: list[Mutant], root: Path, a: argparse.Namespace, base: Path) -> int:
    warmable = [] if a.fresh_cache else [m for m in chosen if not compiles(root, m)]
    warm = None
    if warmable:
        tests = list(dict.fromkeys(t for m in warmable for t in m.tests))
        verdict, failed, secs = baseline(root, tests, str(base), a.timeout)
        print(f"baseline (unmutated sources, the tests of {len(warmable)} mutants): {verdict} {failed} in {secs:.0f} s",
              file=sys.stderr, flush=True)
        if verdict != "passed":
            print("the unmutated sources fail their tests: no mutant can be judged", file=sys.stderr)
            return 2
        warm = base / f"forcecontrol-{_source_hash(root)}"
    survivors = 0
    if a.compare:
        print("| mutant | area | slip | file | other tests | first failing | slip tests | first failing | s |\n"
              "|---|---|---|---|---|---|---|---|---|")
    else:
        print("| mutant | area | slip | file | verdict | first failing test | s |\n|---|---|---|---|---|---|---|")
    for m in chosen:
        res = run(m, a.timeout, root, a.compare, None if m not in warmable else warm)
        killed = any(v.startswith("killed") for v, _, _ in res)
        survivors += not killed
        secs = sum(s for _, _, s in res)
        cells = " | ".join(f"{v} | {f}" for v, f, _ in res)
        if a.compare and len(res) == 1:
            cells += " | | "
        print(f"| {m.key} | {m.area} | {m.law} | {m.file} | {cells} | {secs:.0f} |", flush=True)
    return 1 if survivors else 0


if __name__ == "__main__":
    sys.exit(main())
