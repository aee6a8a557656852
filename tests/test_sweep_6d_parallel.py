"""6-D sweeps on worker processes (issue 33 item 2): the table of two worker processes is the table of one
thread, bit for bit; a killed worker loses no case (resubmitted, or resumed by the same call); a bad case in a
worker is the library's error naming the case. Few short Panda cases (0.05 s each) keep these cheap."""

from __future__ import annotations

import os
import re
import signal
import warnings

import numpy as np
import pandas as pd
import pytest

from forcecontrol.errors import ForceControlError
from forcecontrol.sweep import SweepDefinition, prepare_sweep
from forcecontrol.sweep import processes as procs
from forcecontrol.sweep import run as sweep_run
from forcecontrol.sweep.run import run_sweep
from forcecontrol.sweep.spec import SweepError, SweepWarning

#: one xdist worker for the module: its fixtures (the reference tables, the compiled 6-D loop) are built once
pytestmark = pytest.mark.xdist_group(name="test_sweep_6d_parallel.py")

NAME = "panda-admittance-contact"  # a 6-D built-in: every case runs in simulate(), which holds the GIL


def _prep(n: int = 6):
    d = SweepDefinition.from_options({"duration": [0.05], "environment.stiffness": np.linspace(3000.0, 8000.0, n).tolist()})
    return prepare_sweep(NAME, d)


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """The tables of one worker (a thread in this process) per engine: what every other run must give."""
    folder = tmp_path_factory.mktemp("ref")
    return {e: run_sweep(_prep(), folder / f"one-{e}.parquet", workers=1, processes=False, engine=e).table
            for e in ("python", "compiled")}


@pytest.fixture
def reference(references):
    return references["python"]


@pytest.fixture
def spy(monkeypatch):
    """Counts the blocks that go to worker processes (the run must really use them)."""
    seen: list[int] = []
    real = sweep_run.run_processes

    def counting(blocks, *args):
        seen.extend(len(b) for b in blocks)
        return real(blocks, *args)

    monkeypatch.setattr(sweep_run, "run_processes", counting)
    return seen


@pytest.mark.parametrize(("engine", "label"), [("python", "simulate"), ("compiled", "simulate-compiled")])
def test_two_worker_processes_give_the_table_of_one_thread(references, engine, label, spy, tmp_path):
    """Two worker processes (one case per block) give the one-thread table bit for bit (NaNs in the same places),
    on either engine of the 6-D cases."""
    res = run_sweep(_prep(), tmp_path / "two.parquet", workers=2, block_size=1, processes=True, engine=engine)
    assert spy == [1] * 6
    assert set(res.table["engine"]) == {label} and (res.table["status"] == "ok").all()
    pd.testing.assert_frame_equal(res.table, references[engine], check_exact=True)


def test_the_compiled_engine_gives_the_python_engine_table_to_round_off(references):
    """The compiled 6-D loop in a sweep: same statuses and flags, every metric within 1e-9 relative of the Python
    engine's (the two integrate the same equations: RK4 with Cholesky against Pinocchio's ABA)."""
    py, cc = references["python"], references["compiled"]
    assert set(cc["engine"]) == {"simulate-compiled"} and set(py["engine"]) == {"simulate"}
    for col in ("status", "stable", "contact_lost", "samples", "integration_substeps"):
        assert cc[col].tolist() == py[col].tolist(), col
    for col in ("settling_time", "overshoot", "steady_state_force_error", "peak_force", "settled_force"):
        np.testing.assert_allclose(cc[col].to_numpy(), py[col].to_numpy(), rtol=1e-9, atol=1e-12, err_msg=col)


def test_auto_picks_the_compiled_engine_for_large_supported_sweeps_only(monkeypatch):
    """sweep_engine: 'auto' is compiled from TREE_MIN_STEPS arm-steps of cases the compiled loop runs (an
    admittance Panda on a table), never for a hybrid task it does not run; an explicit engine wins; a typo is named."""
    jobs = _prep(3).jobs  # 3 cases x 50 samples x 2 sub-steps = 300 arm-steps
    assert procs.sweep_engine(jobs) == "python" and procs.sweep_engine(jobs, "compiled") == "compiled"
    monkeypatch.setattr(procs, "TREE_MIN_STEPS", 300)
    assert procs.sweep_engine(jobs) == "compiled" and procs.sweep_engine(jobs, "python") == "python"
    hybrid = prepare_sweep("panda-table-line", SweepDefinition.from_options({"duration": [0.05]})).jobs
    monkeypatch.setattr(procs, "TREE_MIN_STEPS", 1)
    assert procs.sweep_engine(hybrid) == "python"
    with pytest.raises(SweepError, match=r"engine must be 'auto', 'python' or 'compiled'; got 'fast'"):
        procs.sweep_engine(jobs, "fast")


def test_a_killed_worker_is_replaced_and_its_cases_run_again(reference, spy, tmp_path):
    """Killing the workers after the first stored block: the lost blocks run on new workers (a SweepWarning says
    so) and the table is the one-thread table."""
    killed: list[int] = []

    def kill_once(done, total):
        if done > 0 and not killed:
            killed.extend(procs.worker_pids())
            for pid in killed:
                os.kill(pid, signal.SIGKILL)

    with pytest.warns(SweepWarning, match=r"a worker process died; the blocks of cases .* are submitted again"):
        res = run_sweep(_prep(), tmp_path / "k.parquet", workers=2, block_size=1, processes=True, progress=kill_once)
    assert killed
    pd.testing.assert_frame_equal(res.table, reference, check_exact=True)


def test_a_killed_worker_then_a_resumed_run_gives_the_same_table(reference, spy, monkeypatch, tmp_path):
    """With no resubmission allowed, a killed worker stops the sweep with a SweepError (finished blocks kept);
    the same call resumes the missing cases only and the table is the one-thread table."""
    monkeypatch.setattr(procs, "MAX_RESUBMITS", 0)
    out = tmp_path / "r.parquet"
    killed: list[int] = []

    def kill_once(done, total):
        if done > 0 and not killed:
            killed.extend(procs.worker_pids())
            for pid in killed:
                os.kill(pid, signal.SIGKILL)

    with pytest.raises(SweepError, match=r"lost with a worker process 1 times.*run the same command again to resume"):
        run_sweep(_prep(), out, workers=2, block_size=1, processes=True, progress=kill_once)
    assert killed and list(out.with_name(out.name + ".parts").glob("part-*.parquet"))
    res = run_sweep(_prep(), out, workers=2, block_size=1, processes=True)
    assert res.resumed >= 1 and res.ran + res.resumed == 6
    pd.testing.assert_frame_equal(res.table, reference, check_exact=True)


def test_a_pool_found_broken_when_submitting_loses_that_block_only_and_it_is_submitted_again(reference, spy, monkeypatch,
                                                                                             tmp_path):
    """A worker that dies between two submissions breaks the pool before the next submit, which then raises
    BrokenProcessPool itself (the race that ended a CI run with that exception): the block is lost with the pool like a
    running one, a SweepWarning says so, it is submitted again on new workers, and the table is the one-thread table."""
    from concurrent.futures.process import BrokenProcessPool, ProcessPoolExecutor

    calls = []

    class BreaksOnThirdSubmit(ProcessPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):
            calls.append(1)
            if len(calls) == 3:
                raise BrokenProcessPool("a child process terminated abruptly (simulated)")
            return super().submit(fn, *args, **kwargs)

    monkeypatch.setattr(procs, "ProcessPoolExecutor", BreaksOnThirdSubmit)
    with pytest.warns(SweepWarning, match="a worker process died; the blocks of cases .* are submitted again"):
        res = run_sweep(_prep(), tmp_path / "b.parquet", workers=2, block_size=1, processes=True)
    assert len(calls) > 6 and res.ran == 6
    pd.testing.assert_frame_equal(res.table, reference, check_exact=True)


@pytest.mark.parametrize(("bad", "what"), [
    ("reference", r"failed inside the simulator \(worker process\) with AttributeError"),  # a foreign error: named, a defect
    ("q0", r""),  # the library's own error (wrong q0 length): its message, with the case
])
def test_a_bad_case_in_a_worker_is_a_library_error_naming_the_case(bad, what, spy, tmp_path):
    """A case that raises in a worker process ends the sweep with a SweepError (a ForceControlError) that names
    the case by id and label, carries no traceback, and leaves the other finished cases stored."""
    prep = _prep(4)
    prep.jobs[2].parts[bad] = "not a reference" if bad == "reference" else np.zeros(3)
    out = tmp_path / "bad.parquet"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SweepWarning)
        with pytest.raises(SweepError, match=r"^sweep case 2 \('case 1'\)") as info:
            run_sweep(prep, out, workers=2, block_size=1, processes=True)
    assert isinstance(info.value, ForceControlError)
    assert "Traceback" not in str(info.value)
    assert re.search(what, str(info.value))
    parts = list(out.with_name(out.name + ".parts").glob("part-*.parquet"))
    assert parts and not any("-00000002-" in p.name for p in parts)


def test_processes_are_used_by_default_only_when_they_pay():
    """use_processes: an explicit choice wins; by default two workers, two blocks and MIN_STEPS arm-steps."""
    assert procs.use_processes(10, 2, 2, True) and not procs.use_processes(10**9, 9, 8, False)
    assert not procs.use_processes(10**9, 9, 1, None) and not procs.use_processes(procs.MIN_STEPS - 1, 9, 2, None)
    assert procs.use_processes(procs.MIN_STEPS, 2, 2, None) and not procs.use_processes(procs.MIN_STEPS, 1, 2, None)


UNGUARDED = """
import numpy as np
from forcecontrol.sweep import SweepDefinition, prepare_sweep
from forcecontrol.sweep.run import run_sweep
d = SweepDefinition.from_options({"duration": [0.01], "environment.stiffness": [3000.0, 8000.0]})
run_sweep(prepare_sweep("panda-admittance-contact", d), OUT, workers=2, block_size=1, processes=True)
print("finished")
"""


@pytest.mark.parametrize("guarded", [False, True])
def test_a_script_without_the_main_guard_is_told_so_at_once(guarded, tmp_path):
    """A user's script that runs a process sweep at its top level: each worker imports it again and exits with code 1
    (multiprocessing refuses a process started while one starts). The sweep says so at once, naming the script and the
    guard, instead of resubmitting the blocks four times and blaming memory; the same script under
    ``if __name__ == "__main__":`` runs."""
    import subprocess
    import sys

    body = UNGUARDED.replace("OUT", repr(str(tmp_path / "s.parquet")))
    if guarded:
        lines = body.strip().splitlines()
        body = "\n".join(lines[:3] + ['if __name__ == "__main__":'] + ["    " + s for s in lines[3:]]) + "\n"
    script = tmp_path / "my_study.py"
    script.write_text(body, encoding="utf-8")
    out = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    if guarded:
        assert out.returncode == 0 and "finished" in out.stdout, out.stderr[-3000:]
        return
    assert out.returncode == 1 and "finished" not in out.stdout
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("forcecontrol.sweep.spec.SweepError: the blocks of cases 0-1 were lost: a worker process "
                           "exited with code 1"), last
    assert str(script) in last and "if __name__ == \"__main__\":" in last and "memory" not in last
    assert "submitted again" not in out.stderr  # not resubmitted: the same error at every attempt


KILLED_PARENT = """
import os, signal, sys
from forcecontrol.sweep import SweepDefinition, prepare_sweep
from forcecontrol.sweep import processes
from forcecontrol.sweep.run import run_sweep

def killed_once_running(done, total):
    pids = processes.worker_pids()
    if pids:
        print(" ".join(map(str, pids)), flush=True)
        os.kill(os.getpid(), signal.SIGKILL)  # as `kill -9` or the out-of-memory killer would

if __name__ == "__main__":
    d = SweepDefinition.from_options({"duration": [0.05], "environment.stiffness": [3000.0, 5000.0, 8000.0, 9000.0]})
    run_sweep(prepare_sweep("panda-admittance-contact", d), OUT, workers=2, block_size=1, processes=True,
              progress=killed_once_running)
"""


def _running(pid: int) -> bool:
    """Whether ``pid`` is a live process (not gone, not a zombie waiting for its parent)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as f:
            return f.read().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads process states from /proc")
def test_worker_processes_end_when_the_sweep_process_is_killed(tmp_path):
    """`kill -9` of a process sweep: its worker processes end within seconds, saying why on stderr, and release the
    command's output pipes (before, they ran on, orphaned, and a caller waiting for the command's output hung)."""
    import subprocess
    import sys
    import time

    script = tmp_path / "study.py"
    script.write_text(KILLED_PARENT.replace("OUT", repr(str(tmp_path / "s.parquet"))), encoding="utf-8")
    proc = subprocess.Popen([sys.executable, str(script)], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    out, err = proc.communicate(timeout=120)  # returns only when every holder of the pipes has ended
    assert proc.returncode == -signal.SIGKILL, err[-3000:]
    workers = [int(p) for p in out.split()]
    assert len(workers) == 2, out
    deadline = time.monotonic() + 30
    while any(map(_running, workers)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(map(_running, workers))
    assert err.count("ended; this worker stops") == 2, err[-3000:]
