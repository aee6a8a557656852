"""Blocks of cases that hold the GIL on worker processes: 6-D arms and every case ``simulate()`` runs.

The planar batch kernel releases the GIL, so its blocks run on threads (:mod:`.run`). A case run by
:func:`~forcecontrol.sim.simulation.simulate` one at a time (6-D arms: Python and Pinocchio; an
actuator; a stateful sensor) holds it, so threads do not scale. Such blocks go to a pool of worker
processes (:class:`~concurrent.futures.ProcessPoolExecutor`, ``"forkserver"`` context, else
``"spawn"``: no Numba or Pinocchio state forked from the parent; the fork server imports the
simulator once, so a worker starts in about half the time of a spawned one). A block travels
pickled, with its parts as the parent built them (a module an object refers to, such as
Pinocchio's, is sent by name); the worker runs it through the same :func:`~.block.run_block`, one
case at a time, and sends the rows back; the parent stores each block as it ends, as with threads.
The rows are the same numbers as on one thread (tested).

Faults:

- a case that raises in a worker: the parent raises a :class:`SweepError` naming the case and the
  error (its type and message; no worker traceback), after storing the blocks still running;
- a worker that dies (killed, out of memory) breaks the pool: the finished blocks are stored, the
  lost ones submitted again on a new pool with a :class:`SweepWarning`, at most
  :data:`MAX_RESUBMITS` times, then a :class:`SweepError`; the same command resumes;
- a worker that exits by itself (a positive exit code: a Python error or ``sys.exit`` while it starts)
  would do so at every attempt: a :class:`SweepError` at once, which says, when the sweep runs from a
  script, that each worker imports that script and a sweep at its top level needs
  ``if __name__ == "__main__":`` (tested with such a script);
- Ctrl-C: the workers ignore SIGINT; the parent starts nothing new, stores the blocks that are
  running when they end (a second Ctrl-C stops the workers at once) and re-raises, as with threads;
- the parent killed (``kill -9``, the out-of-memory killer): each worker watches its parent's sentinel
  (the pipe the parent holds open while it lives) and exits, saying so on stderr; before, the fork
  server's workers ran on, orphaned, holding the dead command's output pipes open (a caller waiting for
  their end waited for ever).
"""

from __future__ import annotations

import contextlib
import importlib
import io
import multiprocessing
import os
import pickle
import signal
import sys
import threading
import types
import warnings
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from .spec import SweepError, SweepWarning

__all__ = ["run_processes", "use_processes", "sweep_engine", "worker_pids", "MAX_RESUBMITS", "BLOCK_STEPS", "MIN_STEPS",
           "TREE_MIN_STEPS"]

#: times the blocks lost with a dead worker process are submitted again (on a new pool).
MAX_RESUBMITS = 3
#: arm-steps per block of simulate() cases by default: a Panda arm-step (one RK4 step) costs about 150 µs
#: on the Python engine, so a block is 2-3 s of work (balanced between workers, stored as it ends).
BLOCK_STEPS = 15_000
#: fewer arm-steps of simulate() cases than this stay on threads: a worker starts in 1-3 s (imports, cached kernels).
MIN_STEPS = 40_000
#: arm-steps of the 6-D cases the compiled loop runs (sim/loop_tree.py) from which a sweep uses it by default: on a
#: cold cache it compiles for 20-60 s, which a sweep of this size (30 s and more on the Python engine) pays back.
TREE_MIN_STEPS = 200_000
#: what the fork server imports once (each worker forks from it with these loaded).
PRELOAD = ["forcecontrol.sweep.block", "forcecontrol.sim.simulation", "forcecontrol.robots.pinocchio"]
_pool: ProcessPoolExecutor | None = None  # the running pool (worker_pids)


def worker_pids() -> list[int]:
    """The process ids of the running sweep pool's workers (empty when none runs): for monitoring and tests."""
    pool = _pool
    return sorted((getattr(pool, "_processes", None) or {}).keys()) if pool is not None else []


def _context() -> Any:
    """The ``forkserver`` context with :data:`PRELOAD` (if the platform has it, else ``spawn``)."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)  # used when the server starts (once per process)
    return ctx


class _Pickler(pickle.Pickler):
    """Pickles modules by name (a PinocchioRobot holds the ``pinocchio`` module; the worker imports it) and a
    PinocchioRobot without its scratch ``data`` (rebuilt by ``model.createData()`` in the worker: Pinocchio's
    Data pickles to 230 kB and loads in 14 ms, the Model 22 kB in 0.3 ms; every method fills what it reads)."""

    def reducer_override(self, obj: Any) -> Any:
        if isinstance(obj, types.ModuleType):
            return importlib.import_module, (obj.__name__,)
        cls = type(obj)
        if cls.__name__ == "PinocchioRobot" and cls.__module__ == "forcecontrol.robots.pinocchio":
            state = {k: v for k, v in vars(obj).items() if k != "data"}
            return _robot, (cls, state)
        return NotImplemented


def _robot(cls: type, state: dict[str, Any]) -> Any:
    """A PinocchioRobot from its state, with a fresh ``data`` for its model."""
    obj = cls.__new__(cls)
    obj.__dict__.update(state)
    obj.data = obj.model.createData()
    return obj


def dumps(obj: Any) -> bytes:
    """``obj`` pickled as a worker process receives it."""
    buf = io.BytesIO()
    _Pickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump(obj)
    return buf.getvalue()


def use_processes(slow_steps: int, n_blocks: int, workers: int, processes: bool | None) -> bool:
    """Whether the simulate() blocks go to worker processes: ``processes`` if given, else when there are
    at least two workers and two blocks and :data:`MIN_STEPS` arm-steps of them."""
    if processes is not None:
        return bool(processes) and n_blocks > 0
    return workers > 1 and n_blocks > 1 and slow_steps >= MIN_STEPS


def sweep_engine(jobs: list[Any], engine: str = "auto") -> str:
    """The engine of a sweep's 6-D cases (``run_block``'s ``engine``): ``"compiled"`` or ``"python"`` as given, or
    for ``"auto"`` ``"compiled"`` when the cases the compiled loop runs make at least :data:`TREE_MIN_STEPS` arm-steps.

    Decided on all the sweep's cases (not the ones left on resume), so a resumed table is the uninterrupted one.

    Raises:
        SweepError: another value.
    """
    if engine in ("python", "compiled"):
        return engine
    if engine != "auto":
        raise SweepError(f"engine must be 'auto', 'python' or 'compiled'; got {engine!r}")
    from .block import tree_case

    steps = 0
    for j in jobs:
        if not j.fast and tree_case(j):
            steps += j.steps
            if steps >= TREE_MIN_STEPS:
                return "compiled"
    return "python"


def _init_worker() -> None:
    """A worker ignores Ctrl-C: the parent decides (it lets running blocks end and stores them); it exits when its
    parent process ends (:func:`_exit_with_parent`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent = multiprocessing.parent_process()
    sentinel = getattr(parent, "sentinel", None)
    if sentinel is not None:
        threading.Thread(target=_exit_with_parent, args=(sentinel, parent.pid), name="parent-watch",
                         daemon=True).start()


def _exit_with_parent(sentinel: int, parent_pid: int | None) -> None:
    """Wait until the parent's end of ``sentinel`` closes (the parent ended, however), then end this worker.

    The sentinel is the pipe whose write end the parent holds while it lives (multiprocessing's parent sentinel,
    for the forkserver and spawn start methods); it becomes readable only then. ``os._exit``: nothing of the
    block running here is wanted any more (the parent that would store it is gone).
    """
    from multiprocessing.connection import wait as wait_for

    wait_for([sentinel])
    with contextlib.suppress(Exception):
        print(f"forcecontrol sweep worker {os.getpid()}: its sweep process {parent_pid} ended; this worker stops",
              file=sys.stderr, flush=True)
    os._exit(1)


def _portable(exc: BaseException) -> bytes | None:
    """The exception pickled, if it comes back whole (else None: the parent uses its type and message)."""
    try:
        data = pickle.dumps(exc)
        pickle.loads(data)
        return data
    except Exception:
        return None


def work(payload: bytes, settle_band: float, stable_band: float, engine: str = "python") -> tuple[Any, ...]:
    """What a worker runs: ``("ok", rows)``, or ``("error", case_id, label, library, type_name, message, pickled)``
    for the first case that raised (the cases before it are not sent back; the block runs again on resume)."""
    from ..errors import ForceControlError
    from .block import run_block

    jobs = pickle.loads(payload)
    rows: list[dict[str, Any]] = []
    for j in jobs:  # one case at a time (what run_block does for these cases): a fault names its case
        try:
            rows.extend(run_block([j], settle_band, stable_band, engine))
        except Exception as exc:
            return ("error", j.case_id, j.row_label or j.label, isinstance(exc, ForceControlError), type(exc).__name__,
                    str(exc) or "(no message)", _portable(exc))
    return ("ok", rows)


def _rows(out: tuple[Any, ...]) -> list[dict[str, Any]]:
    """The rows a worker sent, or the library's error naming the case that failed."""
    if out[0] == "ok":
        return out[1]
    _, cid, label, library, name, message, data = out
    cause = None
    if data is not None:
        try:
            cause = pickle.loads(data)
        except Exception:  # pragma: no cover - checked in the worker
            cause = None
    where = f"sweep case {cid} ('{label}')"
    if library:
        text = message if message.startswith(where) else f"{where}: {message}"
    else:
        text = (f"{where} failed inside the simulator (worker process) with {name}: {message}; this is a defect of "
                "forcecontrol: please report it with the command. The cases stored so far are kept; the same command resumes")
    raise SweepError(text) from cause


def keep_finishing(pending: dict[Future, list[Any]], rows: Callable[[Any], list[dict[str, Any]] | None],
                   store: Callable[[list[Any], list[dict[str, Any]]], None]) -> None:
    """After Ctrl-C or a failure: cancel the blocks not started, wait for the running ones and store those that end
    well (``rows(result)`` is their rows, or None for a block that failed); the rest run again on resume.

    Shared by the thread pool (:func:`forcecontrol.sweep.run._run_local`) and the process pool (:func:`_one_pool`).
    """
    for f in list(pending):
        if f.cancel():
            pending.pop(f)
    for f, b in pending.items():
        try:
            got = rows(f.result())
        except Exception:  # the block failed, or the pool broke meanwhile
            continue
        if got is not None:
            store(b, got)
    pending.clear()


def _ids(blocks: list[list[Any]]) -> str:
    ids = sorted(j.case_id for b in blocks for j in b)
    return f"{ids[0]}-{ids[-1]}" if len(ids) > 1 else str(ids[0])


def run_processes(blocks: list[list[Any]], workers: int, band: tuple[Any, ...],
                  store: Callable[[list[Any], list[dict[str, Any]]], None]) -> None:
    """Run the blocks on ``min(workers, cores, len(blocks))`` worker processes; ``store(block, rows)`` as each ends.

    More workers than cores: one process per core, with a :class:`SweepWarning` saying so.

    Raises:
        SweepError: a case failed in a worker (named), or the pool broke more than :data:`MAX_RESUBMITS` times.
    """
    queue = list(blocks)
    cores = os.cpu_count() or 1
    if workers > cores:  # each worker holds its own simulator (Pinocchio, Numba kernels): about 0.4 GB
        warnings.warn(f"{workers} workers asked: the cases simulate() runs use {cores} worker processes, one per core "
                      "(more processes would not run faster and each holds about 0.4 GB)", SweepWarning, stacklevel=3)
    n = max(1, min(int(workers), cores, len(queue)))
    ctx = _context()
    breaks = 0
    while queue:
        lost, codes = _one_pool(queue, n, ctx, band, store)
        if not lost:
            return
        breaks += 1
        what = f"the blocks of cases {_ids(lost)}"
        # a Python error or exit in a worker: the same at every attempt (negative: a signal; 255: the fork server could
        # not tell, multiprocessing.popen_forkserver)
        exited = sorted({c for c in codes if c is not None and 0 < c < 255})
        if exited:
            raise SweepError(_exited_message(what, exited))
        if breaks > MAX_RESUBMITS:
            raise SweepError(
                f"{what} were lost with a worker process {breaks} times (the process died: killed, or out of memory); "
                "the cases stored so far are kept: check the machine's memory, then run the same command again to resume"
            )
        warnings.warn(f"a worker process died; {what} are submitted again on new workers "
                      f"(attempt {breaks + 1} of {MAX_RESUBMITS + 1})", SweepWarning, stacklevel=3)
        queue = lost + queue


def _exited_message(what: str, codes: list[int]) -> str:
    """Why the blocks were lost when a worker process ended by itself with ``codes`` (positive exit codes)."""
    text = (f"{what} were lost: a worker process exited with code {', '.join(map(str, codes))} (a Python error or "
            "exit in the worker, its message on stderr above; not a signal, so it is not tried again)")
    main = sys.modules.get("__main__")
    script = getattr(main, "__file__", None)
    # a script run by its path (python my_study.py: no __spec__), not the console script; the sweep's context is
    # forkserver or spawn (_context), never fork, so its workers import it
    if script and getattr(main, "__spec__", None) is None and os.path.basename(script) != "forcecontrol":
        text += (f". Each worker process imports the main script ({script!r}) as it starts (multiprocessing's "
                 "forkserver and spawn start methods): a script that runs a sweep at its top level starts it again in "
                 "every worker; run it under 'if __name__ == \"__main__\":'")
    return text + "; the cases stored so far are kept and the same command resumes"


def _one_pool(queue: list[list[Any]], n: int, ctx: Any, band: tuple[Any, ...],
              store: Any) -> tuple[list[list[Any]], list[int | None]]:
    """Run blocks from ``queue`` (popped as submitted) on one pool until done or the pool breaks; the blocks it lost
    and, when it broke, the exit codes of its worker processes (negative: ended by that signal)."""
    global _pool
    pool = _pool = ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=_init_worker)
    pending: dict[Future, list[Any]] = {}
    lost: list[list[Any]] = []
    clean = False
    try:
        while (queue or pending) and not lost:
            while queue and len(pending) < 2 * n:
                b = queue.pop(0)
                try:
                    pending[pool.submit(work, dumps(b), *band)] = b
                except BrokenProcessPool:  # a worker died since the last wait: this block is lost with the pool
                    lost.append(b)
                    break
            if lost:
                break
            finished, _ = wait(list(pending), return_when=FIRST_COMPLETED)
            for f in finished:
                b = pending.pop(f)
                try:
                    out = f.result()
                except BrokenProcessPool:
                    lost.append(b)
                    continue
                store(b, _rows(out))
        if lost:  # every pending future fails with the pool: keep what finished before it broke
            wait(list(pending))
            for f, b in pending.items():
                if f.exception() is None:
                    store(b, _rows(f.result()))
                else:
                    lost.append(b)
            pending.clear()
        clean = True
        codes: list[int | None] = []
        if lost:
            for p in list((getattr(pool, "_processes", None) or {}).values()):
                p.join(timeout=5)  # the pool terminated the others: a dead worker's own code is positive or its signal
                codes.append(p.exitcode)
        return sorted(lost, key=lambda b: b[0].case_id), codes
    except BaseException:
        # Ctrl-C or a failed case: start nothing new, keep what the running blocks finish
        keep_finishing(pending, lambda out: out[1] if out[0] == "ok" else None, store)
        clean = True
        raise
    finally:
        if not clean:  # a second Ctrl-C while the running blocks end: stop the workers now
            for p in list((getattr(pool, "_processes", None) or {}).values()):
                p.terminate()
        pool.shutdown(wait=True, cancel_futures=True)
        _pool = None
