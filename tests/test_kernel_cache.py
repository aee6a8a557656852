"""The compiled-kernel cache under concurrency (issue 27): per-law identity, locked writes, checked loads, the CLI.

References: fresh compiles (each process of the first, concurrent round compiles its law, since the cache is empty
and the saves are held until all have compiled), which the cached runs must equal bit for bit; and for the physics
the Python engine, which the compiled loop equals to round-off.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

# Each worker runs chosen cases of example-9.3 (inner position, inner velocity, parallel force
# control: three laws, one loop closure each) with the compiled engine and prints one line per
# case: label, then a hash of every log. With FC_SAVE_BARRIER set, a worker waits before saving
# its compiled loop until FC_PARTIES workers reached that point, so their saves meet (the race).
WORKER = textwrap.dedent(
    r'''
    import dataclasses, hashlib, os, sys, time
    import numpy as np
    import forcecontrol
    from numba.core import caching

    barrier, parties = os.environ.get("FC_SAVE_BARRIER"), int(os.environ.get("FC_PARTIES", "0"))
    if barrier:
        original = caching.Cache.save_overload

        def save_overload(self, sig, data):
            # the loop's compiled name comes from its identity (kernel_cache.set_identity): forcecontrol:loop:<law>
            if self._py_func.__qualname__.startswith("k_forcecontrol_loop_"):
                open(os.path.join(barrier, str(os.getpid())), "w").close()
                deadline = time.monotonic() + 300
                while len(os.listdir(barrier)) < parties and time.monotonic() < deadline:
                    time.sleep(0.0005)
            return original(self, sig, data)

        caching.Cache.save_overload = save_overload

    from forcecontrol.scenarios import load_scenario
    from forcecontrol.scenarios.core import run_scenario

    scn = load_scenario("example-9.3")
    scn = dataclasses.replace(scn, cases=tuple(scn.cases[int(i)] for i in sys.argv[1:]))
    for c in run_scenario(scn, engine="compiled").cases:
        r = c.result
        h = hashlib.sha256()
        for a in (r.t, r.q, r.qd, r.x, r.xd, r.wrench, r.wrench_measured, r.torque):
            h.update(np.ascontiguousarray(a).tobytes())
        print(f"{c.label}|{h.hexdigest()}|{float(r.wrench[-1, 0])!r}")
    '''
)
CASES = ("0", "2", "4")  # one case per law
#: rounds of the concurrent first compile: 1 (each costs 3 cold compiles, about 16 s of CPU; the barrier makes the
#: three saves meet in every round, so a round is not a chance at the race but the race itself, and
#: test_concurrent_saves_never_point_an_entry_at_another_entrys_data hammers the same lock with 160 saves);
#: FORCECONTROL_TEST_CACHE_ROUNDS=N repeats it, e.g. after a change to core/kernel_cache.py
ROUNDS = int(os.environ.get("FORCECONTROL_TEST_CACHE_ROUNDS", "1"))


def _env(cache: Path, **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("FC_SAVE_BARRIER", "FC_PARTIES")}
    return {**env, "NUMBA_CACHE_DIR": str(cache), "PYTHONHASHSEED": "0", **extra}


def _results(stdout: str) -> dict[str, tuple[str, str]]:
    rows = [line.split("|") for line in stdout.splitlines() if line.count("|") == 2]
    return {label: (digest, force) for label, digest, force in rows}


def _worker(script: Path, cache: Path, cases: tuple[str, ...], **extra: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, str(script), *cases], env=_env(cache, **extra), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True,
    )


def _finish(proc: subprocess.Popen[str]) -> dict[str, tuple[str, str]]:
    out, err = proc.communicate(timeout=900)
    assert proc.returncode == 0, err[-3000:]
    return _results(out)


def _python_engine_forces() -> dict[str, float]:
    """The final contact force f_x of WORKER's cases on the Python engine (the compiled loop equals it to round-off:
    4e-11 N of 10 N; the three laws' forces differ from each other by 6e-6 N or more)."""
    import dataclasses

    from forcecontrol.scenarios import load_scenario
    from forcecontrol.scenarios.core import run_scenario

    scn = load_scenario("example-9.3")
    scn = dataclasses.replace(scn, cases=tuple(scn.cases[int(i)] for i in CASES))
    return {c.label: float(c.result.wrench[-1, 0]) for c in run_scenario(scn, engine="python").cases}


def test_concurrent_first_compiles_give_the_fresh_single_process_results(tmp_path: Path) -> None:
    """Three laws compiled at once by three processes into one empty cache, saves forced to meet, then all laws
    run from that cache in one process: every log equals the fresh compiles' bit for bit, and each law's force is the
    Python engine's (ROUNDS rounds).

    Each process of the concurrent round is itself a fresh single-law compile (the cache is empty and no save happens
    before all three have compiled), so it is the bit-for-bit reference; a separate fresh process compiling the three
    laws again (about 10 s of CPU) added nothing to it. A cache entry mixed up between laws gives another law's force."""
    script = tmp_path / "worker.py"
    script.write_text(WORKER)
    physics = _python_engine_forces()
    assert len(physics) == 3
    for r in range(ROUNDS):
        cache = tmp_path / f"shared{r}"
        barrier = tmp_path / f"barrier{r}"
        barrier.mkdir()
        procs = [_worker(script, cache, (c,), FC_SAVE_BARRIER=str(barrier), FC_PARTIES=str(len(CASES))) for c in CASES]
        alone = {}
        for p in procs:
            alone.update(_finish(p))
        assert len(os.listdir(barrier)) == len(CASES)  # every process compiled, then saved: three fresh compiles
        assert sorted(alone) == sorted(physics)
        for label, (_, force) in alone.items():
            assert float(force) == pytest.approx(physics[label], rel=1e-9, abs=0.0), f"round {r}: {label}"
        warm = _finish(_worker(script, cache, CASES))
        assert warm == alone, f"round {r}: the run from the concurrently filled cache differs: {warm} != {alone}"
        verify = subprocess.run(
            [sys.executable, "-m", "forcecontrol", "cache", "--verify", "--json"], env=_env(cache), capture_output=True,
            text=True, timeout=300,
        )
        assert verify.returncode == 0, verify.stderr
        assert json.loads(verify.stdout)["problems"] == []


STRESS = textwrap.dedent(
    r'''
    import sys, time
    from forcecontrol.core.kernel_cache import _LockedFiles
    folder, me, start = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    files = _LockedFiles(folder, "k.py311.k1", "stamp", "kernel")
    while time.time() < start:
        time.sleep(0.0005)
    for i in range(40):
        files.save(((f"sig{me}-{i}",), ("cpu",), ("code", "closure")), ("machine code of", me, i))
    '''
)


def test_concurrent_saves_never_point_an_entry_at_another_entrys_data(tmp_path: Path) -> None:
    """Four processes saving 40 different entries each into one kernel's index at the same moment: every entry is
    kept and loads its own data (Numba's own IndexDataCacheFile loses entries and mixes data under this load)."""
    import time

    from forcecontrol.core.kernel_cache import _LockedFiles

    script = tmp_path / "stress.py"
    script.write_text(STRESS)
    folder = tmp_path / "cache"
    folder.mkdir()
    start = time.time() + 3.0  # all four import first, then save together
    procs = [
        subprocess.Popen([sys.executable, str(script), str(folder), str(me), repr(start)], env=_env(tmp_path / "nb"))
        for me in range(4)
    ]
    assert all(p.wait(timeout=300) == 0 for p in procs)
    files = _LockedFiles(str(folder), "k.py311.k1", "stamp", "kernel")
    for me in range(4):
        for i in range(40):
            assert files.load(((f"sig{me}-{i}",), ("cpu",), ("code", "closure"))) == ("machine code of", me, i)
    assert len(files._load_index()) == 160


def _version_folder(cache: Path) -> Path:
    out = subprocess.run(
        [sys.executable, "-m", "forcecontrol", "cache", "--json"], env=_env(cache), capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    return Path(json.loads(out.stdout)["folder"])


def test_verify_and_load_refuse_a_swapped_entry(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A data file replaced by another kernel's (two laws' entries swapped): loading it is refused with a message,
    and ``forcecontrol cache --verify`` exits 1 naming the file; before the swap it exits 0."""
    import shutil

    from forcecontrol.core.kernel_cache import _LockedFiles

    folder = _version_folder(tmp_path / "nb") / "sub"
    folder.mkdir(parents=True)
    key = (("float64",), ("cpu",), ("code", "closure"))
    a = _LockedFiles(str(folder), "loop_law_a.py311.k1", "stamp", "loop:law-a")
    b = _LockedFiles(str(folder), "loop_law_b.py311.k1", "stamp", "loop:law-b")
    a.save(key, "law a's code")
    b.save(key, "law b's code")
    ok = subprocess.run([sys.executable, "-m", "forcecontrol", "cache", "--verify"], env=_env(tmp_path / "nb"),
                        capture_output=True, text=True, timeout=300)
    assert ok.returncode == 0, ok.stderr
    assert "verified: 2 entries" in ok.stdout
    shutil.copyfile(folder / b.data_name(key), folder / a.data_name(key))
    assert a.load(key) is None
    assert "holds loop:law-b, not loop:law-a" in capsys.readouterr().err
    bad = subprocess.run([sys.executable, "-m", "forcecontrol", "cache", "--verify"], env=_env(tmp_path / "nb"),
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode == 1
    assert a.data_name(key) in bad.stderr and "holds kernel loop:law-b" in bad.stderr


def test_clear_removes_only_this_librarys_folders(tmp_path: Path) -> None:
    """``--clear`` removes every ``forcecontrol-<hash>`` folder under the cache root, says which, and nothing else."""
    root = tmp_path / "nb"
    current = _version_folder(root)
    (current / "x.nbc").write_bytes(b"12345")
    old = root / "forcecontrol-0123456789abcdef"
    old.mkdir()
    (old / "y.nbc").write_bytes(b"1")
    other = root / "someone-else"
    other.mkdir()
    out = subprocess.run([sys.executable, "-m", "forcecontrol", "cache", "--clear", "--json"], env=_env(root),
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert sorted(json.loads(out.stdout)["removed"]) == sorted([str(current), str(old)])
    assert not current.exists() and not old.exists() and other.exists()


def test_each_law_has_its_own_cache_files() -> None:
    """Two laws' loops (both variants), sweep kernels and on_arm steps have their own index files and symbol names."""
    from forcecontrol.laws import arm
    from forcecontrol.laws.force import inner_velocity, parallel
    from forcecontrol.sim.batch import kernels
    from forcecontrol.sim.loop import planar_loop

    def index(dispatcher: object) -> str:
        return dispatcher._cache._cache_file._index_path  # type: ignore[attr-defined]

    for full_log in (True, False):
        assert index(planar_loop(inner_velocity, full_log)) != index(planar_loop(parallel, full_log))
    assert index(planar_loop(parallel, True)) != index(planar_loop(parallel, False))
    assert index(kernels(inner_velocity)[1]) != index(kernels(parallel)[1])
    assert index(kernels(inner_velocity)[0]) != index(kernels(parallel)[0])
    # and their compiled symbols have names of their own (same-named closures collide: numba issue 10486)
    names = {planar_loop(inner_velocity, True).py_func.__qualname__, planar_loop(parallel, True).py_func.__qualname__,
             kernels(inner_velocity)[0].py_func.__qualname__, kernels(parallel)[0].py_func.__qualname__,
             arm.on_arm(inner_velocity).py_func.__qualname__, arm.on_arm(parallel).py_func.__qualname__}
    assert len(names) == 6 and not any("<locals>" in n for n in names)
    assert index(arm.on_arm(inner_velocity)) != index(arm.on_arm(parallel))


BATCH_WORKER = textwrap.dedent(
    r'''
    import hashlib, sys
    import numpy as np
    import forcecontrol as fc
    from forcecontrol.controllers.base import Measurement
    from forcecontrol.sim.batch import run_case

    ARM = fc.PlanarTwoLink()
    Q0 = ARM.inverse_kinematics([1.0, 0.0], elbow="up")
    MAKE = {
        "inner_position": lambda: fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0], [0.0016, 0]),
        "inner_velocity": lambda: fc.InnerVelocityForceController(ARM, 100, 500, 2500, [0.0024, 0]),
        "parallel": lambda: fc.ParallelForcePositionController(ARM, 100, 500, 2500, [0.00064, 0], [0.0016, 0]),
        "impedance": lambda: fc.ImpedanceController(ARM, 100, 500, 2500),
    }
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4, damping=20.0)
    ref = fc.LinearPath([1.0, 0.0], [1.05, 0.1], 0.5, force=[10.0, 0.0])
    N, Ts = 300, 1e-3
    sensor = fc.ForceSensor()
    bias, noise = sensor.sequences(N + 1, 2)
    for name in sys.argv[1:]:
        ctl = MAKE[name]()
        ctl.reset(Measurement(Q0, np.zeros(2), env.wrench(ARM.forward_kinematics(Q0), np.zeros(2))), ref.at(0.0))
        y = np.empty(N + 1)
        run_case(ctl.compiled_law, np.array(ARM._K), env.kind, env.packed(), np.array(ctl._params), ctl.state.copy(),
                 ref.sample(np.arange(N + 1) * Ts), bias, noise, sensor.alpha(Ts), Q0, np.zeros(2), Ts, 1, N, 50.0,
                 np.array([1.0, 0.0]), y)
        print(f"{name}|{hashlib.sha256(y.tobytes()).hexdigest()}|{y[-1]!r}")
    '''
)


def _merge(source: Path, target: Path) -> None:
    """Copy every cache file of ``source`` that ``target`` lacks (a helper both compiled keeps ``target``'s index and data)."""
    for f in sorted(source.rglob("*")):
        dest = target / f.relative_to(source)
        if f.is_dir():
            dest.mkdir(parents=True, exist_ok=True)
        elif not dest.exists():
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_bytes(f.read_bytes())


def test_laws_compiled_in_separate_processes_run_their_own_code_when_loaded_together(tmp_path: Path) -> None:
    """Each law's sweep kernel compiled alone in its own process, then all loaded in one: bit for bit those fresh runs.

    Same-named closures compiled in separate processes got the same LLVM symbol (qualified name and a
    per-process counter); a process that loaded two of them ran one law's body for the other (numba
    issue 10486: wrong forces, a crash). Each closure now has a name from its identity (fails without it).
    Each law is compiled once, in a fresh process on an empty cache of its own: that run is the fresh
    single-process reference (it holds no other closure to collide with), and its cache files are then
    merged into the shared one, so the test no longer compiles the four laws a second time in a separate
    reference process (that process proved only what each fresh single-law run proves).
    """
    script = tmp_path / "batch_worker.py"
    script.write_text(BATCH_WORKER)
    laws = ("inner_position", "inner_velocity", "parallel", "impedance")
    shared = tmp_path / "shared"
    shared.mkdir()
    reference: dict[str, tuple[str, str]] = {}
    for law in laws:  # one at a time, each in a fresh process on an empty cache: the same counters in each
        own = tmp_path / law
        reference.update(_finish(_worker(script, own, (law,))))
        _merge(own, shared)
    assert sorted(reference) == sorted(laws)
    together = _finish(_worker(script, shared, laws))
    assert together == reference


PICKLE_FIRST = textwrap.dedent(
    r'''
    import pickle, sys
    from numba.core import event
    from forcecontrol.sweep import SweepDefinition, prepare_sweep
    from forcecontrol.sweep.block import run_fast

    compiled = []

    class Compiles(event.Listener):
        def on_start(self, ev):
            func = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
            if str(getattr(func, "__module__", "")).startswith("forcecontrol"):
                compiled.append(func.__qualname__)

        def on_end(self, ev):
            pass

    event.register("numba:compile", Compiles())
    prep = prepare_sweep("example-9.2", SweepDefinition.from_options({"duration": [0.2]}))
    jobs = [j for j in prep.jobs if j.fast][:1]  # one case (impedance control) for a compiled batch kernel
    if sys.argv[1] == "pickle-first":  # what a sweep on a Dask cluster does with its cases, before any kernel is built
        pickle.dumps(jobs)
    run_fast(jobs[0].law, jobs, 0.02, 0.05, kernel="scalar")
    print("compiled:", len(compiled), sorted(set(compiled)))
    '''
)


def test_sweep_cases_pickled_before_any_kernel_is_built_find_the_cached_kernels(tmp_path: Path) -> None:
    """A process that pickles sweep cases (their law and every function it calls) before building a kernel, as a sweep
    on a Dask cluster does, then runs them through the batch kernel loads what an earlier process cached: nothing
    compiles. Before, the pickling drew random identities, which entered the kernels' cache keys: every such process
    (and each Dask worker that unpickled them) compiled again (in the suite: the lanes kernels after the Dask sweep
    journey, about 60 s of CPU)."""
    script = tmp_path / "pickle_first.py"
    script.write_text(PICKLE_FIRST)
    cache = tmp_path / "nb"
    warm = subprocess.run([sys.executable, str(script), "plain"], env=_env(cache), capture_output=True, text=True,
                          timeout=900)
    assert warm.returncode == 0, warm.stderr[-3000:]
    assert not warm.stdout.startswith("compiled: 0 "), warm.stdout  # the cache was empty: this one compiled
    again = subprocess.run([sys.executable, str(script), "pickle-first"], env=_env(cache), capture_output=True,
                           text=True, timeout=900)
    assert again.returncode == 0, again.stderr[-3000:]
    assert again.stdout.strip() == "compiled: 0 []", again.stdout


def _decorated(fn: object) -> tuple[bool, bool]:
    """(compiled with njit/jit, inlined with inline="always") from a FunctionDef's decorators."""
    import ast

    for d in fn.decorator_list:  # type: ignore[attr-defined]
        call = d if isinstance(d, ast.Call) else None
        target = call.func if call else d
        if getattr(target, "id", getattr(target, "attr", None)) in ("njit", "jit"):
            inline = any(k.arg == "inline" and isinstance(k.value, ast.Constant) and k.value.value == "always"
                         for k in (call.keywords if call else []))
            return True, inline
    return False, False


def test_no_compiled_function_calls_a_kernel_with_a_literal_flag() -> None:
    """No compiled function of the package passes True or False as such to a compiled function it does not inline:
    Numba types the constant as Literal[bool] and compiles the callee once more for each value, besides the version
    Python calls (the 6-D loop compiled tree_terms and the 6-D impedance law three times each; a variable holding
    ``bool(True)`` is a plain boolean). Read from the sources, so it holds whatever the kernel cache holds."""
    import ast

    root = Path(__file__).resolve().parents[1] / "src" / "forcecontrol"
    modules = [(p, ast.parse(p.read_text(encoding="utf-8"))) for p in sorted(root.rglob("*.py"))]
    functions = [(p, f) for p, tree in modules for f in ast.walk(tree) if isinstance(f, ast.FunctionDef)]
    assert len(functions) > 500  # the package was read
    kernels = {f.name for _, f in functions if _decorated(f) == (True, False)}
    assert {"tree_terms", "spatial_impedance_torque", "impedance_loop"} <= kernels
    literal = [
        f"{p.relative_to(root)}:{call.lineno} {f.name} calls {call.func.id}"
        for p, f in functions if _decorated(f)[0]
        for call in ast.walk(f)
        if isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id in kernels
        and any(isinstance(a, ast.Constant) and isinstance(a.value, bool)
                for a in [*call.args, *(k.value for k in call.keywords)])
    ]
    assert literal == []


LOAD_ONLY = textwrap.dedent(
    r'''
    import hashlib, sys
    import numpy as np
    from forcecontrol.scenarios import load_scenario
    from forcecontrol.scenarios.core import run_scenario

    run = run_scenario(load_scenario("example-9.2"), engine="compiled")
    h = hashlib.sha256()
    for c in run.cases:
        for a in (c.result.q, c.result.wrench, c.result.torque):
            h.update(np.ascontiguousarray(a).tobytes())
    print(h.hexdigest(), sorted(m for m in ("numba.np.arraymath", "numba.np.linalg", "numba.typed.dictimpl") if m in sys.modules))
    '''
)


def test_a_run_that_only_loads_kernels_skips_numbas_lowering_registries_and_gives_the_same_numbers(tmp_path: Path) -> None:
    """A process whose kernels are all cached loads them without importing Numba's lowering registries (Numba's
    load_overload refreshed the whole target context first: 0.25 s of CPU per command, only a compile needs it),
    and its logs equal, bit for bit, those of the process that compiled or loaded them before (the shared cache)."""
    script = tmp_path / "load_only.py"
    script.write_text(LOAD_ONLY)
    first, second = (subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=900)
                     for _ in range(2))
    assert first.returncode == 0 and second.returncode == 0, first.stderr[-2000:] + second.stderr[-2000:]
    digest, modules = second.stdout.split(" ", 1)
    assert digest == first.stdout.split(" ", 1)[0]
    assert modules.strip() == "[]", modules  # nothing compiled in the second process: no registry was imported


# Two processes started at one instant on an empty cache, running the same law: each prints the package functions it
# compiled (outermost compiles) and a hash of its logs.
SAME_LAW = textwrap.dedent(
    r'''
    import hashlib, json, sys, time
    import numpy as np
    from numba.core import event

    compiled, depth = [], [0]

    class Census(event.Listener):
        def on_start(self, ev):
            depth[0] += 1

        def on_end(self, ev):
            depth[0] -= 1
            f = getattr(ev.data.get("dispatcher"), "py_func", None)
            if depth[0] == 0 and f is not None and f.__module__.startswith("forcecontrol"):
                compiled.append(f"{f.__module__}.{f.__qualname__}")

    event.register("numba:compile", Census())
    from forcecontrol.scenarios import load_scenario, run_scenario

    scn = load_scenario("example-9.2").with_(duration=0.2)
    start = float(sys.argv[1])
    late = time.time() > start  # still importing when the other process began: the test would prove nothing
    while time.time() < start:  # both processes have imported everything: their first compiles start together
        time.sleep(0.001)
    h = hashlib.sha256()
    for c in run_scenario(scn, engine="compiled").cases:
        for a in (c.result.q, c.result.qd, c.result.wrench, c.result.torque):
            h.update(np.ascontiguousarray(a).tobytes())
    print(json.dumps({"compiled": compiled, "hash": h.hexdigest(), "late": late}))
    '''
)


def test_two_processes_missing_the_same_kernel_compile_it_once(tmp_path: Path) -> None:
    """Started together on an empty cache, two processes running one law: one compiles every kernel, the other waits for
    each and loads it (it compiles nothing), and both give the same logs to the bit. Without the compile lock both
    compiled the law's loop (core/kernel_cache.py's _CompileLock)."""
    import time

    script = tmp_path / "same_law.py"
    script.write_text(SAME_LAW)
    cache = tmp_path / "cache"
    start = time.time() + 8.0  # after both have started Python and imported the package, on a loaded machine too
    procs = [subprocess.Popen([sys.executable, str(script), repr(start)], env=_env(cache), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outs = []
    for p in procs:
        out, err = p.communicate(timeout=900)
        assert p.returncode == 0, err[-3000:]
        outs.append({**json.loads(out.strip().splitlines()[-1]), "stderr": err})
    assert not any(o["late"] for o in outs), "a process was still importing at the start: raise the start's margin"
    waiter, compiler = sorted(outs, key=lambda o: len(o["compiled"]))
    assert waiter["compiled"] == [] and any("k_forcecontrol_loop_" in n for n in compiler["compiled"]), outs
    assert outs[0]["hash"] == outs[1]["hash"]
    # the process that waited said so, once; the one that compiled had nothing to wait for
    assert waiter["stderr"].count("waiting for another process that is compiling the same kernels") == 1, waiter["stderr"]
    assert "waiting for another process" not in compiler["stderr"]


def test_a_compile_that_fails_lets_the_next_process_compile_at_once(tmp_path: Path, monkeypatch) -> None:
    """A kernel whose compile raises (a type it cannot take) releases its compile lock: another process (here, another
    open file of the lock, which flock treats alike) takes it at once, not after the wait's limit."""
    import fcntl

    import numba

    from forcecontrol.core.kernel_cache import KernelCache, set_identity

    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "cache"))  # this test's kernel in a cache of its own

    @numba.njit(cache=True)
    def double(x):
        return x * 2.0

    set_identity(double, f"test:failing-compile:{tmp_path.name}")
    cache = double._cache
    assert isinstance(cache, KernelCache)
    with pytest.raises(numba.core.errors.TypingError):
        double("a string")
    assert not cache._compile_lock.held and cache._compile_lock.path.startswith(str(tmp_path))
    fd = os.open(cache._compile_lock.path, os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # BlockingIOError while the failed compile still held it
    finally:
        os.close(fd)
    assert double(2.0) == 4.0  # and this process compiles it once asked a type it takes


def test_a_process_stuck_in_a_compile_is_waited_for_a_bounded_time(tmp_path: Path, monkeypatch, capfd) -> None:
    """While another process holds a kernel's compile lock past COMPILE_WAIT, this one compiles it anyway and says so."""
    import fcntl

    import numba

    import forcecontrol.core.kernel_cache as kc

    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "cache"))

    @numba.njit(cache=True)
    def triple(x):
        return x * 3.0

    kc.set_identity(triple, f"test:stuck-compile:{tmp_path.name}")
    lock = triple._cache._compile_lock
    os.makedirs(os.path.dirname(lock.path), exist_ok=True)
    monkeypatch.setattr(kc, "COMPILE_WAIT", 0.3)
    fd = os.open(lock.path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # "another process" compiling it, never finishing
        assert triple(2.0) == 6.0
    finally:
        os.close(fd)
    err = capfd.readouterr().err
    assert "waiting for another process" in err and "has been compiling" in err and "compiling it here too" in err, err
    assert not lock.held and lock.path.startswith(str(tmp_path))
