"""6-D closed loops against the same loop in C++ on Pinocchio (issue 33 item 1), in one process session.

The case: the Panda (example-robot-data, fingers locked) at ``PANDA_READY`` under impedance on the
desired frame (:class:`~forcecontrol.controllers.spatial.SpatialImpedanceController`: XYZ Euler
error, null-space posture, variable damped least squares; M_d, K_D, K_P of ``bench_panda.py``),
the desired frame 2 cm below an elastic table (k = 5·10³ N/m, c = 50 N s/m) that touches the
tool at the start, gravity, 0.5 s at Ts = 1 ms, RK4 with 2 sub-steps (the Panda scenarios').

Implementations of that loop, timed in turns (``--repeats`` rounds; medians and spreads):

* ``library (Python engine)``: :func:`forcecontrol.sim.simulation.simulate` with
  ``engine="python"`` (what ``forcecontrol run`` does for 6-D arms today);
* ``library (compiled loop)``: :func:`forcecontrol.sim.loop_tree.run_impedance_loop`, the same
  loop as one Numba function on :mod:`forcecontrol.robots.compiled_tree`'s dynamics and the
  controller's own compiled law;
* ``simulate(engine="compiled")``: the same compiled loop through ``simulate`` (its checks, the
  contact-mode check of the log afterwards: up to 256 samples in contact);
* ``C++``: ``benchmarks/cpp/panda_impedance.cpp``, the same loop written against Pinocchio's C++
  API (computeAllTerms for the law, ABA per RK4 stage), built with ``-O3 -march=native``.

The three joint trajectories must agree (max |Δq| printed; RK4 with the same steps, so they
agree to round-off amplified by the loop, well under the integrator's own error): this is also an
independent check of the library's 6-D loop.

Build the C++ baseline (done here if the binary is missing or older than its source; it takes
a few minutes on a busy machine): ``benchmarks/cpp/build.sh`` (needs g++ and, besides the pin
wheels, Eigen's headers: ``pip install 'cmeel-eigen>=3.4.1'``). Without them the benchmark says
so on stderr and times the two library loops only.

Then the built-in scenario ``panda-admittance-contact`` (admittance (9.37)), Python engine against
the compiled loop (the C++ program has no admittance law: no C++ ratio there).

Run: ``python benchmarks/bench_6d_vs_cpp.py [--repeats 5] [--profile] [--robot ur5]`` (``--robot ur5``:
the same loop on the UR5, 6 DOF, no null-space posture) (``--profile`` adds the
table of where the Python engine's time goes: calls per sample and per-call costs).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from forcecontrol.controllers.spatial import SpatialImpedanceController
from forcecontrol.environments.spatial import Table
from forcecontrol.robots.compiled_tree import compile_tree
from forcecontrol.robots.pinocchio import PANDA_READY, panda, ur5
from forcecontrol.sim.loop_tree import run_impedance_loop
from forcecontrol.sim.simulation import simulate
from forcecontrol.spatial import rotation_to_euler_xyz
from forcecontrol.trajectories import Setpoint

HERE = Path(__file__).resolve().parent
CPP_DIR = HERE / "cpp"
BINARY = CPP_DIR / "panda_impedance"

MD = np.diag([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
KP = np.diag([400.0, 400.0, 400.0, 10.0, 10.0, 10.0])
KD = np.diag(2 * 0.7 * np.sqrt(np.diag(MD) * np.diag(KP)))
DURATION, TS, NSUB = 0.5, 1e-3, 2


UR5_Q0 = np.array([0.3, -1.2, 1.5, -1.8, -1.5, 0.4])


def case(robot_name: str = "panda"):
    """(robot, environment, controller, reference, q0) of the benchmark's loop (``"panda"`` or ``"ur5"``, no posture: 6 DOF)."""
    robot = panda() if robot_name == "panda" else ur5()
    q0 = PANDA_READY.copy() if robot_name == "panda" else UR5_Q0.copy()
    R, p = robot.frame_pose(q0)
    x_d = np.concatenate([p - np.array([0.0, 0.0, 0.02]), rotation_to_euler_xyz(R)])
    env = Table(p, (0.0, 0.0, 1.0), 5000.0, 50.0)
    ctrl = SpatialImpedanceController(robot, MD, KD, KP, posture=q0 if robot.nq > 6 else None, sample_time=TS)
    return robot, env, ctrl, Setpoint(x_d), q0


def build(force: bool = False) -> Path | None:
    """The C++ binary, built if missing or older than its source; None (and why, on stderr) when it cannot be."""
    src = CPP_DIR / "panda_impedance.cpp"
    newest = max(src.stat().st_mtime, (CPP_DIR / "build.sh").stat().st_mtime)
    if not force and BINARY.exists() and BINARY.stat().st_mtime >= newest:
        return BINARY
    print("building the C++ baseline (benchmarks/cpp/build.sh; a few minutes) ...", file=sys.stderr)
    try:
        proc = subprocess.run(["bash", str(CPP_DIR / "build.sh"), sys.executable, str(BINARY)], capture_output=True, text=True)
    except OSError as exc:
        print(f"C++ baseline skipped: cannot run build.sh ({exc})", file=sys.stderr)
        return None
    if proc.returncode != 0 or not BINARY.exists():
        tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        print(f"C++ baseline skipped: the build failed ({tail})", file=sys.stderr)
        return None
    return BINARY


def write_params(path: Path, robot, env, ctrl, ref, q0, repeats: int) -> None:
    """The C++ program's input: the model the library loaded (per joint), then the loop's parameters."""
    tree = compile_tree(robot)
    rows: list[str] = [str(tree.n)]
    F = np.diag(tree.friction)
    for i in range(tree.n):
        vals = [*tree.axis[i], *tree.Rp[i].ravel(), *tree.pp[i], tree.mass[i], *tree.com[i], *tree.Ic[i].ravel(),
                tree.armature[i], F[i]]
        rows.append(f"{int(tree.kind[i])} " + " ".join(repr(float(v)) for v in vals))
    rows.append(f"{tree.fj + 1} " + " ".join(repr(float(v)) for v in [*tree.Rf.ravel(), *tree.pf, *tree.gravity]))
    post, k_n, d_n, has = ctrl._post
    s = ctrl.singularity
    x_d = ref.at(0.0).position
    vals = [*q0, *x_d, *ctrl._Md_inv.ravel(), *ctrl.damping.ravel(), *ctrl.stiffness.ravel(), *post, k_n, d_n, float(has),
            s.threshold, s.max_damping, *env.point, *env.normal, env.stiffness, env.damping, DURATION, TS]
    rows.append(" ".join(repr(float(v)) for v in vals) + f" {NSUB} {repeats}")
    path.write_text("\n".join(rows) + "\n")


def run_cpp(binary: Path, robot, env, ctrl, ref, q0, repeats: int) -> tuple[list[float], np.ndarray]:
    """([median, min] µs/step over the program's own repeats, its trajectory q)."""
    with tempfile.TemporaryDirectory() as d:
        params, traj = Path(d) / "params.txt", Path(d) / "q.txt"
        write_params(params, robot, env, ctrl, ref, q0, repeats)
        proc = subprocess.run([str(binary), str(params), str(traj)], capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"the C++ baseline failed (exit {proc.returncode}): {proc.stderr.strip()}")
        out = proc.stdout
        med, best = (float(v) for v in out.split()[1:3])
        return [med, best], np.loadtxt(traj)


def profile_python_engine(robot, env, ctrl, ref, q0, duration: float = 0.2) -> None:
    """Where the Python engine's time goes: calls per sample and cost per call of the hot functions."""
    N = int(round(duration / TS)) + 1
    pr = cProfile.Profile()
    pr.enable()
    t0 = time.perf_counter()
    simulate(robot, env, ctrl, ref, q0=q0, duration=duration, substeps=NSUB, engine="python")
    wall = time.perf_counter() - t0
    pr.disable()
    st = pstats.Stats(pr)
    print(f"\nprofile of the Python engine, {N} samples, {NSUB} RK4 sub-steps ({wall / N * 1e6:.0f} us/step under the profiler)")
    print(f"{'function':<58} {'calls/sample':>12} {'own us/call':>11} {'own us/sample':>13}")
    rows = []
    for (file, _line, fn), (_cc, nc, tt, _ct, _callers) in st.stats.items():  # type: ignore[attr-defined]
        rows.append((tt, nc, f"{Path(file).name}:{fn}" if "built-in" not in file and file != "~" else fn))
    rows.sort(reverse=True)
    for tt, nc, name in rows[:22]:
        print(f"{name[:58]:<58} {nc / N:12.1f} {tt / nc * 1e6:11.2f} {tt / N * 1e6:13.1f}")


def scenario_rows(repeats: int, duration: float = 0.5) -> dict[str, float]:
    """The built-in scenario panda-admittance-contact: Python engine vs the compiled loop (no C++ port of admittance)."""
    from forcecontrol.scenarios import build_case, load_scenario

    parts = build_case(load_scenario("panda-admittance-contact").cases[0])
    robot, env, ctrl, ref, q0, nsub = (parts[k] for k in ("robot", "environment", "controller", "reference", "q0", "substeps"))
    N = int(round(duration / ctrl.sample_time)) + 1
    py = lambda: simulate(robot, env, ctrl, ref, q0=q0, duration=duration, substeps=nsub, engine="python")  # noqa: E731
    comp = lambda: run_impedance_loop(robot, env, ctrl, ref, q0, duration, nsub)  # noqa: E731
    res, out = py(), comp()
    t_py, t_c = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        py()
        t_py.append((time.perf_counter() - t0) / N * 1e6)
        t0 = time.perf_counter()
        comp()
        t_c.append((time.perf_counter() - t0) / N * 1e6)
    ratios = [p / c for p, c in zip(t_py, t_c)]
    print(f"\npanda-admittance-contact ({duration} s, RK4 x {nsub}): Python engine {statistics.median(t_py):.1f} us/step "
          f"({min(t_py):.1f}-{max(t_py):.1f}), compiled loop {statistics.median(t_c):.1f} ({min(t_c):.1f}-{max(t_c):.1f}); "
          f"speed-up {statistics.median(ratios):.1f}x ({min(ratios):.1f}-{max(ratios):.1f}); "
          f"max |dq| {np.max(np.abs(out['q'] - res.q)):.1e} rad")
    return {"scenario_python_us": statistics.median(t_py), "scenario_compiled_us": statistics.median(t_c)}


def main(repeats: int = 5, profile: bool = False, robot_name: str = "panda") -> dict[str, float]:
    robot, env, ctrl, ref, q0 = case(robot_name)
    N = int(round(DURATION / TS)) + 1
    py = lambda: simulate(robot, env, ctrl, ref, q0=q0, duration=DURATION, substeps=NSUB, engine="python")  # noqa: E731
    comp = lambda: run_impedance_loop(robot, env, ctrl, ref, q0, DURATION, NSUB)  # noqa: E731
    sim_c = lambda: simulate(robot, env, ctrl, ref, q0=q0, duration=DURATION, substeps=NSUB, engine="compiled")  # noqa: E731
    res_py, res_c, res_sc = py(), comp(), sim_c()  # warm: compiles the law and the loop (cached on disk afterwards)
    if res_c["status"] != 0:
        raise RuntimeError(f"the compiled loop stopped with status {res_c['status']} at row {res_c['last_row']}")
    binary = build()
    t_py, t_c, t_sc, t_cpp, t_cpp_best = [], [], [], [], []
    q_cpp = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        py()
        t_py.append((time.perf_counter() - t0) / N * 1e6)
        t0 = time.perf_counter()
        comp()
        t_c.append((time.perf_counter() - t0) / N * 1e6)
        t0 = time.perf_counter()
        sim_c()
        t_sc.append((time.perf_counter() - t0) / N * 1e6)
        if binary is not None:
            (med, best), q_cpp = run_cpp(binary, robot, env, ctrl, ref, q0, 3)
            t_cpp.append(med)
            t_cpp_best.append(best)

    def line(name, ts):
        print(f"{name:<34} {statistics.median(ts):9.1f} us/step  (min {min(ts):.1f}, max {max(ts):.1f})")

    print(f"{robot_name} impedance on an elastic table, {DURATION} s at {TS * 1e3:g} ms, RK4 x {NSUB}; {repeats} rounds")
    line("library, Python engine", t_py)
    line("library, compiled loop", t_c)
    line("simulate(engine='compiled')", t_sc)
    out = {"python_us": statistics.median(t_py), "compiled_us": statistics.median(t_c),
           "simulate_compiled_us": statistics.median(t_sc)}
    fz = res_py.wrench[-1, 2]
    print(f"max |q_compiled - q_python| = {np.max(np.abs(res_c['q'] - res_py.q)):.2e} rad   f_z(end) = {fz:.4f} N"
          f"   (simulate compiled: {np.max(np.abs(res_sc.q - res_py.q)):.2e})")
    if t_cpp:
        line("C++ on Pinocchio", t_cpp)
        assert q_cpp is not None
        d_cpp = float(np.max(np.abs(q_cpp - res_py.q)))
        print(f"max |q_C++ - q_python|      = {d_cpp:.2e} rad")
        ratios_c = [c / k for c, k in zip(t_c, t_cpp)]
        ratios_py = [p / k for p, k in zip(t_py, t_cpp)]
        rc, rp = ratios_c, ratios_py
        print(f"ratio compiled loop / C++ = {statistics.median(rc):.2f} (per round: {min(rc):.2f}-{max(rc):.2f}); target <= 1.5")
        print(f"ratio Python engine / C++ = {statistics.median(rp):.1f} (per round: {min(rp):.1f}-{max(rp):.1f})")
        out.update(cpp_us=statistics.median(t_cpp), ratio_compiled_cpp=statistics.median(ratios_c),
                   ratio_python_cpp=statistics.median(ratios_py), dq_cpp=d_cpp)
    else:
        print("C++ baseline skipped (see stderr): no ratio against C++", file=sys.stderr)
    if robot_name == "panda":
        out.update(scenario_rows(repeats))
    if profile:
        profile_python_engine(robot, env, ctrl, ref, q0)
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--robot", choices=("panda", "ur5"), default="panda")
    a = ap.parse_args()
    main(a.repeats, a.profile, a.robot)
