"""Sweeps survive damage: corrupt or truncated parts, a corrupt stamp or table, a second sweep on the same output.

Each resumed table is compared with an uninterrupted run of the same sweep (the reference).
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import textwrap
import time
import warnings

import pytest

from forcecontrol.sweep.run import prepare_sweep, run_sweep
from forcecontrol.sweep.spec import SweepDefinition, SweepError, SweepWarning
from forcecontrol.sweep.store import stamp_text, with_checksum

pytest.importorskip("pyarrow")

PARAMS = ["environment.stiffness=linspace(1000,5000,6)", "controller.damping=400,600"]


def _prep():
    return prepare_sweep("example-9.2", SweepDefinition.from_options(PARAMS))


@pytest.fixture(scope="module")
def fault_table():
    """Rows (fault -> outcome) gathered by the tests; printed as a Markdown table at the end (pytest -s shows it)."""
    rows: list[tuple[str, str]] = []
    yield rows
    if rows:
        print("\n\n| fault | outcome |\n|---|---|")
        for fault, outcome in rows:
            print(f"| {fault} | {outcome} |")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted run of the sweep."""
    return run_sweep(_prep(), tmp_path_factory.mktemp("ref") / "t.parquet", block_size=4).table


def _parts_of_a_killed_run(tmp_path):
    """Run the sweep, then recreate its parts folder as a killed run would leave it (parts, no table)."""
    out = tmp_path / "t.parquet"
    prep = _prep()
    run_sweep(prep, out, block_size=4)
    parts = out.with_name(out.name + ".parts")
    parts.mkdir()
    (parts / "sweep.json").write_text(stamp_text(prep.metadata))  # as the library writes it (with its checksum)
    import pyarrow.parquet as pq

    table = pq.read_table(out)
    for lo in range(0, prep.n_cases, 4):
        block = table.slice(lo, 4)
        ids = block.column("case_id").to_pylist()
        pq.write_table(with_checksum(block, prep.sweep_id), parts / f"part-{min(ids):08d}-{max(ids):08d}-{len(ids)}.parquet")
    out.unlink()
    return out, parts, prep


def _same(a, b):
    cols = ["case_id", "case", "settled_force", "settling_time", "overshoot", "stable"]
    assert a[cols].equals(b[cols])


@pytest.mark.parametrize("damage", ["truncate", "garbage", "empty", "other-sweep-name"])
def test_damaged_part_is_moved_aside_and_rerun(tmp_path, reference, damage, fault_table):
    """A truncated, garbage, empty or misnamed part: warned, moved aside, its cases re-run; the table equals the reference."""
    out, parts, prep = _parts_of_a_killed_run(tmp_path)
    victim = sorted(parts.glob("part-*.parquet"))[1]
    data = victim.read_bytes()
    if damage == "truncate":
        victim.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        victim.write_bytes(os.urandom(len(data)))
    elif damage == "empty":
        victim.write_bytes(b"")
    else:  # a part whose name promises other cases than it holds
        victim.rename(victim.with_name("part-00000100-00000103-4.parquet"))
    with pytest.warns(SweepWarning, match="moved to .*corrupt"):
        res = run_sweep(prep, out, block_size=4)
    assert res.ran == 4 and res.resumed == prep.n_cases - 4
    _same(res.table, reference)
    fault_table.append((f"part 2 of 6 {damage}", f"warned, moved aside, its 4 cases re-run; table = reference ({prep.n_cases})"))


def test_corrupt_stamp_and_corrupt_table_are_recovered(tmp_path, reference, fault_table):
    """A corrupt sweep.json (parts verified one by one) and a truncated final table (rebuilt): warned, same table."""
    out, parts, prep = _parts_of_a_killed_run(tmp_path)
    (parts / "sweep.json").write_text("{not json")
    with pytest.warns(SweepWarning, match="sweep.json is unreadable"):
        res = run_sweep(prep, out, block_size=4)
    assert res.ran == 0
    _same(res.table, reference)
    out.write_bytes(out.read_bytes()[:100])
    fault_table.append(("sweep.json corrupt", "warned, parts verified one by one, nothing re-run; table = reference"))
    with pytest.warns(SweepWarning, match="t.parquet is unreadable"):
        res = run_sweep(prep, out, block_size=4)
    _same(res.table, reference)
    fault_table.append(("final table truncated to 100 bytes", "warned, moved aside, rebuilt; table = reference"))


def test_second_sweep_on_the_same_output_is_refused(tmp_path, reference, fault_table):
    """A live process holding the lock: a second sweep refuses (naming the process); a dead owner's lock is taken over."""
    out = tmp_path / "t.parquet"
    lock = out.with_name(out.name + ".lock")
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        lock.write_text(str(sleeper.pid))
        with pytest.raises(SweepError, match=rf"another sweep \(process {sleeper.pid}\) is writing"):
            run_sweep(_prep(), out, block_size=4)
    finally:
        sleeper.kill()
        sleeper.wait()
    with pytest.warns(SweepWarning, match="stale lock"):
        res = run_sweep(_prep(), out, block_size=4)
    _same(res.table, reference)
    assert not lock.exists()
    fault_table.append(("lock held by a live process", "SweepError naming the process"))
    fault_table.append(("lock left by a dead process", "warned (stale lock), taken over; table = reference"))


def test_sweep_reads_scenario_files_like_run(tmp_path):
    """A UTF-16 scenario given to a sweep: the same ScenarioError as `run` (the sweep reads files with the loader's reader)."""
    from forcecontrol.errors import ScenarioError
    from forcecontrol.scenarios import scenario_source
    from forcecontrol.sweep.run import load_sweep_scenario

    p = tmp_path / "utf16.toml"
    p.write_bytes(scenario_source("example-9.2").read_text(encoding="utf-8").encode("utf-16"))
    with pytest.raises(ScenarioError, match="not UTF-8 text"):
        load_sweep_scenario(p)


# ----------------------------------------------------------------------------- kill -9 at random points, two sweeps at once

#: a sweep file of 60 cases of 60 s each (inner velocity loop): a few seconds in one process.
SLOW_SWEEP = """
name = "kill-random"
duration = 60.0
[robot]
start_position = [1.0, 0.0]
[environment]
type = "elastic-plane"
point = [1.0, 0.0]
normal = [-1.0, 0.0]
stiffness = 10000.0
[controller]
type = "inner-velocity"
inertia = 100.0
damping = 500.0
stiffness = 2500.0
force_gain = [0.0024, 0.0]
[reference]
type = "setpoint"
position = [1.0, 0.0]
force = [10.0, 0.0]
[sweep]
design = "random"
samples = 60
seed = 3
[sweep.parameters]
"environment.stiffness" = "loguniform(1e3, 1e5)"
"controller.force_gain[0]" = "uniform(0.001, 0.003)"
"""
N_SLOW = 60


@pytest.fixture(scope="module")
def slow(tmp_path_factory):
    """The slow sweep's file and its uninterrupted table."""
    folder = tmp_path_factory.mktemp("slow")
    scn = folder / "slow.toml"
    scn.write_text(textwrap.dedent(SLOW_SWEEP))
    whole = run_sweep(prepare_sweep(str(scn)), folder / "whole.parquet", workers=2)
    assert whole.ran == N_SLOW
    return scn, whole.table


def _sweep_process(scn, out):
    code = textwrap.dedent(f"""
        from forcecontrol.sweep import run_sweep, prepare_sweep
        from forcecontrol.sweep.spec import SweepError
        try:
            r = run_sweep(prepare_sweep({str(scn)!r}), {str(out)!r}, workers=1, block_size=1)
            print("OK", r.ran, r.resumed)
        except SweepError as exc:
            print("REFUSED", exc)
    """)
    return subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _n_parts(parts):
    return len(list(parts.glob("part-*.parquet"))) if parts.exists() else 0


@pytest.mark.parametrize("seed", [1, 2])
def test_kill_9_at_random_points_then_resume_gives_the_uninterrupted_table(tmp_path, slow, fault_table, seed):
    """Three SIGKILLs of the sweep process at random delays (fixed seed), each followed by a resume; the last resume
    finishes: the table equals the uninterrupted one, every case exactly once, no part, lock or temporary left."""
    scn, whole = slow
    out = tmp_path / "k.parquet"
    parts = out.with_name(out.name + ".parts")
    rng = random.Random(seed)
    kills = []
    for k in range(3):
        proc = _sweep_process(scn, out)
        t0 = time.monotonic()
        if k == 0:  # a random time from the start: import, preparation or the first blocks
            time.sleep(rng.uniform(0.2, 1.5))
        else:  # a random number of further parts, then a random fraction of a block (mid-block or mid-write)
            target = _n_parts(parts) + rng.randint(1, 12)
            while proc.poll() is None and _n_parts(parts) < target and time.monotonic() - t0 < 60:
                time.sleep(0.001)
            time.sleep(rng.uniform(0.0, 0.05))
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=60)
        assert proc.returncode in (-signal.SIGKILL, 0)
        at = f"{time.monotonic() - t0:.2f} s"
        kills.append(f"{at}: {_n_parts(parts)} parts" if proc.returncode == -signal.SIGKILL else f"{at}: finished first")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SweepWarning)  # a stale lock of a killed process
        res = run_sweep(prepare_sweep(str(scn)), out, workers=2)
    assert res.table["case_id"].tolist() == list(range(N_SLOW))
    import pandas as pd

    pd.testing.assert_frame_equal(res.table, whole, check_exact=True)
    assert not parts.exists() and not out.with_name(out.name + ".lock").exists()
    assert not list(tmp_path.glob(".*.tmp"))
    fault_table.append((f"kill -9 at random points (seed {seed}): " + ", ".join(kills),
                        f"resumed {res.resumed}, ran {res.ran}; table = uninterrupted ({N_SLOW} cases, none lost or twice)"))


def test_a_lock_just_created_and_still_empty_is_not_taken_for_stale(tmp_path, reference):
    """A sweep that has created and locked ``<out>.lock`` but not yet written its pid (the window between the two) owns
    the output: a second sweep refuses. The pid-file lock read the empty file as stale, removed it and ran over the
    first sweep (test_two_sweeps_at_once_on_the_same_output failed so under load: FileNotFoundError on a part)."""
    pytest.importorskip("fcntl")
    out = tmp_path / "t.parquet"
    lock = out.with_name(out.name + ".lock")
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import fcntl, os, sys, time
            fd = os.open({str(lock)!r}, os.O_CREAT | os.O_RDWR, 0o644)
            fcntl.flock(fd, fcntl.LOCK_EX)
            print("held", flush=True)
            time.sleep(60)
        """)],
        stdout=subprocess.PIPE, text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(SweepError, match=r"another sweep \(process starting\) is writing"):
            run_sweep(_prep(), out, block_size=4)
        assert lock.exists() and lock.read_text() == ""  # untouched
    finally:
        holder.kill()
        holder.wait()
    with warnings.catch_warnings():
        warnings.simplefilter("error", SweepWarning)  # the killed holder's flock is gone with it; its empty file is no owner
        res = run_sweep(_prep(), out, block_size=4)
    _same(res.table, reference)
    assert not lock.exists()


def test_two_sweeps_at_once_on_the_same_output(tmp_path, slow, fault_table):
    """Two processes start the same sweep on one --out together: one runs, the other refuses (naming the first);
    the table equals the uninterrupted one."""
    scn, whole = slow
    out = tmp_path / "two.parquet"
    procs = [_sweep_process(scn, out) for _ in range(2)]
    results = [p.communicate(timeout=120) for p in procs]
    outcomes = sorted(out.split()[0] if out else f"rc {p.returncode}: {err[-300:]}" for p, (out, err) in zip(procs, results))
    assert outcomes == ["OK", "REFUSED"], results
    refused = [stdout for stdout, _ in results if stdout.startswith("REFUSED")][0]
    assert "another sweep (process" in refused and "is writing" in refused
    import pandas as pd

    pd.testing.assert_frame_equal(pd.read_parquet(out), whole, check_exact=True)
    assert not out.with_name(out.name + ".lock").exists()
    fault_table.append(("two sweeps at once on one --out", "one ran, the other refused naming its pid; table = uninterrupted"))


# ----------------------------------------------------------------------------- Dask worker loss


def _die_in_block(marker: str, victim: int) -> None:
    """Run on a Dask worker: the first block holding case ``victim`` (on any worker) runs its first case, writes the
    worker's pid to ``marker`` and SIGKILLs the worker, mid-block; a worker the nanny restarts runs blocks normally."""
    import os
    import signal

    import forcecontrol.sweep.block as block

    real = block.run_block

    def dying(jobs, *band):
        if any(j.case_id == victim for j in jobs):
            try:
                fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:  # already killed once: the resubmitted block runs
                return real(jobs, *band)
            real(jobs[:1], *band)  # mid-block: one case done, the rest not
            os.write(fd, str(os.getpid()).encode())
            os.close(fd)
            os.kill(os.getpid(), signal.SIGKILL)
        return real(jobs, *band)

    block.run_block = dying  # the sweep submits forcecontrol.sweep.block.run_block, pickled by reference


def test_dask_worker_killed_mid_block_is_resubmitted(tmp_path, slow, fault_table):
    """SIGKILL a Dask worker (LocalCluster, 2 processes, 1 thread each) in the middle of a block (it dies after the
    block's first case). With allowed-failures = 0 the scheduler gives up on the task at once (KilledWorker): the sweep
    submits the block again with a SweepWarning naming its cases, and the table equals the local run's, every case once.
    (The worker kills itself at a chosen block, so the kill lands mid-block however loaded the machine is; a killer
    thread polling for a busy worker found none in time under load.)"""
    distributed = pytest.importorskip("dask.distributed")
    import dask
    import pandas as pd

    scn, whole = slow
    prep = prepare_sweep(str(scn))  # 60 cases in blocks of 4 (about 0.15 s a block)
    out = tmp_path / "dask.parquet"
    marker = tmp_path / "killed.pid"
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        client.run(_die_in_block, str(marker), 21)  # the block of cases 20-23
        res = run_sweep(prep, out, scheduler=client, block_size=4)
        messages = [str(w.message) for w in caught
                    if issubclass(w.category, SweepWarning) and "lost with its Dask worker" in str(w.message)]
    kills = [f"pid {marker.read_text()} after case 20"] if marker.exists() else []
    # each kill loses the blocks the scheduler had assigned to that worker (one running, maybe one queued)
    assert kills and messages, (kills, messages)
    assert all("the block of cases" in m and "submitted again" in m for m in messages)
    assert any("the block of cases 20-23 was lost" in m for m in messages), messages  # the block it died in
    assert res.ran == prep.n_cases and res.table["case_id"].tolist() == list(range(prep.n_cases))
    pd.testing.assert_frame_equal(res.table, whole, check_exact=True)
    print("\nDask retry evidence:", kills, messages)
    fault_table.append((f"Dask worker SIGKILLed mid-block ({', '.join(kills)}; allowed-failures = 0)",
                        f"{len(messages)} block(s) lost and submitted again, e.g. '{messages[0][:60]}...'; table = local run "
                        f"({prep.n_cases} cases, each once)"))


def test_a_block_failing_with_a_foreign_exception_is_a_sweep_error_naming_its_cases_and_resumes(tmp_path, monkeypatch, reference):
    """A bare ``AssertionError()`` from inside a block (a dependency's assert) became the CLI's raw traceback; now a
    SweepError names the cases and the exception, keeps the stored parts, and the same command resumes to the reference."""
    import forcecontrol.sweep.run as sweep_run

    real = sweep_run.run_block

    def flaky(jobs, *band):
        if any(j.case_id == 5 for j in jobs):
            raise AssertionError()
        return real(jobs, *band)

    out = tmp_path / "t.parquet"
    monkeypatch.setattr(sweep_run, "run_block", flaky)
    with pytest.raises(SweepError, match=r"block of cases 4-7 failed inside the simulator with AssertionError: \(no message\)"):
        run_sweep(_prep(), out, block_size=4, workers=1)
    parts = out.with_name(out.name + ".parts")
    assert any(p.name.startswith("part-00000000-00000003") for p in parts.iterdir())  # the block before it is kept
    monkeypatch.setattr(sweep_run, "run_block", real)
    res = run_sweep(_prep(), out, block_size=4, workers=1)
    assert res.resumed == 4
    assert res.table.equals(reference)
