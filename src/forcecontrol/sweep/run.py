"""Running a sweep: validate and build every case, simulate them in blocks, store each block as it ends.

Cases of the chapter's arm with a built-in environment and controller (the Example 9.1-9.3
schemes) run in the allocation-free compiled kernel :func:`forcecontrol.sim.batch.run_batch`, a
block of cases per call; other cases go through :func:`forcecontrol.sim.simulation.simulate` one by
one. Locally the kernel's blocks run on a thread pool with one thread per core (the kernel releases
the GIL), so no server is needed; the cases simulate() runs (6-D arms) hold the GIL, so their blocks
run on worker processes (:mod:`.processes`); with a Dask scheduler address all blocks run as tasks
on the cluster's workers. The block function is the same everywhere, so the tables are identical.

Storage: the table ``OUT.parquet`` is assembled at the end from parts written atomically as each
block finishes (``OUT.parquet.parts/part-*.parquet``, written to a temporary name and renamed). An
interrupted sweep (Ctrl-C, a killed process or worker) keeps every finished block; running the
same command again reads the parts, runs only the missing cases and assembles the same table.
"""

from __future__ import annotations

import math
import os
import shutil
import sys
import time
import warnings
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from pathlib import Path
from typing import Any

from .spec import SweepDefinition, SweepError, SweepWarning

if sys.version_info >= (3, 11):
    pass
else:  # pragma: no cover
    pass

from .block import run_block
from .prepare import (
    METRIC_COLUMNS,
    CaseJob,
    PreparedSweep,
    load_sweep_scenario,
    prepare_sweep,
)
from .processes import BLOCK_STEPS, keep_finishing, run_processes, sweep_engine, use_processes
from .store import (
    SUM_KEY,
    SweepResult,
    _assemble,
    _done_ids,
    _output_lock,
    _set_aside,
    _sigint_deferred,
    _to_table,
    _write_atomic,
    check_output,
    checksum_fault,
    is_ours,
    read_stamp,
    read_sweep,
    stamp_text,
    with_checksum,
    write_marker,
)

__all__ = [
    "PreparedSweep",
    "SweepResult",
    "CaseJob",
    "load_sweep_scenario",
    "prepare_sweep",
    "run_sweep",
    "run_block",
    "read_sweep",
    "METRIC_COLUMNS",
]


# ----------------------------------------------------------------------------- storage


def _blocks(jobs: list[CaseJob], workers: int, block_size: int | None, target: int = 2_000_000,
            spread: int = 2) -> list[list[CaseJob]]:
    """Consecutive blocks of ``block_size`` cases, by default about ``target`` arm-steps each (the batch kernel:
    about half a second) and at least ``spread`` blocks per worker."""
    if not jobs:
        return []
    if block_size is not None:
        size = max(1, int(block_size))
    else:
        mean_steps = sum(j.steps for j in jobs) / len(jobs)
        size = max(1, min(int(target // max(mean_steps, 1.0)), math.ceil(len(jobs) / (spread * workers))))
    return [jobs[i : i + size] for i in range(0, len(jobs), size)]


def run_sweep(
    sweep: PreparedSweep | Any,
    out: str | Path,
    definition: SweepDefinition | None = None,
    *,
    scheduler: Any = None,
    workers: int | None = None,
    block_size: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    overwrite: bool = False,
    processes: bool | None = None,
    engine: str = "auto",
) -> SweepResult:
    """Run (or resume) a sweep and write its table to ``out`` (Parquet).

    Table: one row per case, sorted by ``case_id``: ``case`` (scenario case label), one column
    per swept parameter (named by its path), ``settling_time`` [s], ``overshoot`` [%],
    ``steady_state_force_error`` [N], ``peak_force`` [N], ``settled_force`` [N], ``stable``,
    ``contact_lost``, ``status`` (``"ok"`` or the divergence cause), ``diverged_at`` [s],
    ``samples``, ``integration_substeps`` (RK4 steps per sample), ``engine`` (``"batch"``: the
    compiled kernel, ``"simulate"``: one by one, ``"simulate-compiled"``: one by one on the compiled
    6-D loop, see ``engine``). The definition is in the schema metadata
    (:func:`read_sweep`).

    Args:
        sweep: a :class:`PreparedSweep`, or a scenario (name, path, dict) with ``definition``.
        out: the table's path; finished blocks go to ``<out>.parts/`` until the end.
        scheduler: a Dask scheduler address (``"tcp://host:8786"``) or a ``dask.distributed.Client``;
            None runs locally on ``workers`` workers (default: all cores): threads for the batch
            kernel's cases, processes for the cases simulate() runs (see ``processes``).
        block_size: cases per block (default: about 2·10⁶ arm-steps per block).
        progress: ``progress(done, total)`` after each stored block (done includes resumed cases).
        overwrite: discard a previous table or parts of a *different* sweep at ``out``, and replace
            (when the sweep ends) a file at ``out`` that is not a sweep table (``--force``; a
            :class:`SweepWarning` says so). A folder at ``out`` is never replaced.
        processes: run the cases simulate() runs (6-D arms; they hold the GIL) on worker processes
            (:mod:`.processes`; blocks of about :data:`~.processes.BLOCK_STEPS` arm-steps): True always,
            False never (threads), None (default) when ``workers`` > 1 and they make at least
            :data:`~.processes.MIN_STEPS` arm-steps in two blocks or more. The table is the same.
        engine: the engine of the 6-D cases the compiled loop runs (:mod:`forcecontrol.sim.loop_tree`:
            impedance or admittance on a Table or ConstantWrench): ``"compiled"`` (about 5-20x faster, equal
            to the Python engine to round-off; the table's ``engine`` column says ``"simulate-compiled"``),
            ``"python"``, or ``"auto"`` (default): compiled when they make at least
            :data:`~.processes.TREE_MIN_STEPS` arm-steps (its first run compiles for 20-60 s).

    The library's own outputs are recognised by their mark (the table's metadata, a hidden
    ``.<name>.forcecontrol-sweep.json`` beside it, ``sweep.json`` in the parts folder); only those
    are ever moved or replaced. Each part and the table carry a SHA-256 of their rows and the
    sweep's id: a part that fails it on resume is set aside (``*.corrupt-<time>`` in the parts
    folder) and its cases run again, with a :class:`SweepWarning`. ``sweep.json`` carries a
    SHA-256 of its content: one that fails it (or is unreadable) is set aside and rewritten, with
    a :class:`SweepWarning`, and each part is then verified against this sweep on its own.

    Raises:
        SweepError: ``out`` holds a different sweep (and not ``overwrite``); an unknown ``engine``; a case failed
            in a worker process (named), or worker processes kept dying (:mod:`.processes`).
        OutputError: ``out`` is a folder, or a file that is not a sweep table (and not ``overwrite``).
    """
    prep = sweep if isinstance(sweep, PreparedSweep) else prepare_sweep(sweep, definition)
    engine = sweep_engine(prep.jobs, engine)  # checked (and decided on every case) before anything is written
    out = Path(out)
    parts_dir = out.with_name(out.name + ".parts")
    stamp = parts_dir / "sweep.json"
    note = check_output(out, overwrite)
    if note:
        warnings.warn(note, SweepWarning, stacklevel=2)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepError(f"cannot create the folder of {str(out)!r}: {exc.strerror or exc}; choose another --out") from exc
    with _output_lock(out):
        return _run_locked(prep, out, parts_dir, stamp, scheduler, workers, block_size, progress, overwrite, processes, engine)


def _run_locked(prep, out, parts_dir, stamp, scheduler, workers, block_size, progress, overwrite, processes=None,
                engine="auto") -> SweepResult:
    if out.exists() and is_ours(out):  # (a user's file is refused by check_output, or replaced at the end with --force)
        try:
            import pyarrow.parquet as pq  # type: ignore[import-untyped]

            stored = pq.read_table(out)
            _, meta = read_sweep(out)
        except Exception as exc:  # a truncated or corrupt table: rebuild it from parts or runs
            _set_aside(out, f"{type(exc).__name__}: {str(exc)[:80]}")
            meta = None
        if meta is not None and meta.get("sweep_id") == prep.sweep_id and SUM_KEY in (stored.schema.metadata or {}):
            fault = checksum_fault(stored, prep.sweep_id)
            if fault is not None:
                _set_aside(out, fault, "is damaged")
                meta = None
        if meta is not None and meta.get("sweep_id") == prep.sweep_id:
            table, meta = read_sweep(out)
            if progress is not None:
                progress(prep.n_cases, prep.n_cases)
            return SweepResult(out, table, meta, 0, prep.n_cases)
        if meta is not None:
            if not overwrite:
                raise SweepError(
                    f"{out} holds a different sweep (id {meta.get('sweep_id')}, this one {prep.sweep_id}); "
                    "choose another output path, or --overwrite (overwrite=True) to replace it"
                )
            out.unlink()
    if parts_dir.exists():
        old = None
        if stamp.exists():
            old, fault = read_stamp(stamp)
            if fault is not None:  # a corrupt stamp: the parts' own metadata (and checksums) decide; it is rewritten
                what = "is damaged" if "checksum" in fault else "is unreadable"
                _set_aside(stamp, fault, what, "rewritten; each part is verified against this sweep")
        if old is None:
            old = prep.sweep_id  # no readable stamp: each part is verified against this sweep below
        if old != prep.sweep_id:
            if not overwrite:
                raise SweepError(
                    f"{parts_dir} holds parts of a different sweep (id {old}, this one {prep.sweep_id}); "
                    "choose another output path or overwrite it"
                )
            shutil.rmtree(parts_dir)
    created = not parts_dir.exists()  # removed again if the run fails before it stores a part (a bad scheduler)
    parts_dir.mkdir(parents=True, exist_ok=True)
    if not stamp.exists():
        tmp = stamp.with_name(".sweep.json.tmp")
        tmp.write_text(stamp_text(prep.metadata))
        os.replace(tmp, stamp)
    for t in parts_dir.glob(".*.tmp"):  # left by a killed run (the lock says no one else writes here)
        t.unlink()
    done = _done_ids(parts_dir, prep)
    todo = [j for j in prep.jobs if j.case_id not in done]
    resumed = prep.n_cases - len(todo)
    total = prep.n_cases
    if progress is not None:
        progress(resumed, total)
    counter = {"done": resumed, "steps": 0}

    def store(block: list[CaseJob], rows: list[dict[str, Any]]) -> None:
        ids = [j.case_id for j in block]
        name = f"part-{min(ids):08d}-{max(ids):08d}-{len(ids)}.parquet"
        with _sigint_deferred():  # a Ctrl-C during the write takes effect once the part is in place
            _write_atomic(with_checksum(_to_table(rows, prep), prep.sweep_id), parts_dir / name)
        counter["done"] += len(block)
        counter["steps"] += sum(r["_steps"] for r in rows)
        if progress is not None:
            progress(counter["done"], total)

    t0 = time.perf_counter()
    band = (prep.definition.settle_band, prep.definition.stable_band, sweep_engine(prep.jobs, engine))  # run_block's arguments
    where = "local"
    try:
        if scheduler is None:
            n = workers or os.cpu_count() or 1
            slow = [j for j in todo if not j.fast]
            slow_blocks = _blocks(slow, n, block_size, BLOCK_STEPS, 4)
            if use_processes(sum(j.steps for j in slow), len(slow_blocks), n, processes):
                _run_local(_blocks([j for j in todo if j.fast], n, block_size), n, band, store)
                run_processes(slow_blocks, n, band, store)
            else:
                _run_local(_blocks(todo, n, block_size), n, band, store)
        else:
            where = _run_dask(scheduler, todo, block_size, band, store)
    except Exception:
        if created and not any(parts_dir.glob("part-*.parquet")):  # nothing to resume: leave no folder behind
            shutil.rmtree(parts_dir, ignore_errors=True)
        raise
    seconds = time.perf_counter() - t0
    table = _assemble(parts_dir, prep)
    _write_atomic(with_checksum(table, prep.sweep_id), out)
    write_marker(out, prep.sweep_id)
    shutil.rmtree(parts_dir, ignore_errors=True)
    df, meta = read_sweep(out)
    return SweepResult(out, df, meta, len(todo), resumed, seconds, counter["steps"], where)


def _run_local(blocks, workers: int, band, store) -> None:
    """Blocks on a thread pool (the kernel releases the GIL); each block stored as it ends."""
    if not blocks:
        return
    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="fc-sweep")
    pending: dict[Future, list[CaseJob]] = {}
    queue = list(blocks)
    try:
        while queue or pending:
            while queue and len(pending) < 2 * workers:
                b = queue.pop(0)
                pending[pool.submit(run_block, b, *band)] = b
            finished, _ = wait(list(pending), return_when=FIRST_COMPLETED)
            for f in finished:
                b = pending.pop(f)
                store(b, _block_result(f, b))
    except BaseException:
        # Ctrl-C: keep what the running blocks finish, start nothing new
        keep_finishing(pending, lambda rows: rows, store)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _block_result(f: Future, block: list[CaseJob]) -> list[dict[str, Any]]:
    """The rows of a finished block; an exception that is not the library's own becomes a :class:`SweepError` naming the cases."""
    from ..errors import ForceControlError

    try:
        return f.result()
    except (ForceControlError, KeyboardInterrupt):
        raise
    except Exception as exc:
        ids = [j.case_id for j in block]
        raise SweepError(
            f"the block of cases {min(ids)}-{max(ids)} failed inside the simulator with {type(exc).__name__}: "
            f"{str(exc) or '(no message)'}; this is a defect of forcecontrol: please report it with the command. "
            "The cases stored so far are kept; the same command resumes"
        ) from exc


def _client(scheduler: Any):
    from dask.distributed import Client

    if isinstance(scheduler, Client):
        return scheduler, False
    try:
        return Client(scheduler, set_as_default=False), True
    except (OSError, ValueError, TypeError) as exc:  # unreachable, timed out, not an address
        raise SweepError(f"--scheduler {scheduler!r}: cannot connect to a Dask scheduler there "
                         f"({type(exc).__name__}: {exc}); expected an address such as tcp://HOST:8786") from None


#: times a block lost with its worker (``KilledWorker``, a cancelled future) is submitted again.
MAX_RESUBMITS = 3


def _lost_errors() -> tuple[type[BaseException], ...]:
    """The exceptions by which Dask reports a task lost with its worker (not an error of the task itself)."""
    from concurrent.futures import CancelledError

    from dask.distributed import KilledWorker

    return (KilledWorker, CancelledError)


def _run_dask(scheduler: Any, todo: list[CaseJob], block_size: int | None, band, store) -> str:
    """Blocks as tasks on a Dask cluster; each block stored as it ends.

    A worker that dies takes its running task with it: the scheduler reruns the task elsewhere
    until ``distributed.scheduler.allowed-failures`` is spent, then reports ``KilledWorker``.
    Such a block (or one whose future was cancelled) is submitted again, up to
    :data:`MAX_RESUBMITS` times, with a :class:`SweepWarning` naming its cases; a block that is
    already stored is never stored twice.

    Raises:
        SweepError: a block was lost more than :data:`MAX_RESUBMITS` times.
    """
    from dask.distributed import as_completed

    lost = _lost_errors()
    client, own = _client(scheduler)
    try:
        workers = max(1, sum(client.nthreads().values()))
        futures: dict[Any, list[CaseJob]] = {}
        for b in _blocks(todo, workers, block_size):
            f = client.submit(run_block, b, *band, pure=False, retries=2)
            futures[f] = b
        stored: set[Any] = set()
        attempts: dict[int, int] = {}
        try:
            pending = as_completed(list(futures), loop=client.loop)
            for f in pending:
                b = futures[f]
                try:
                    rows = f.result()
                except lost as exc:
                    ids = [j.case_id for j in b]
                    n = attempts[ids[0]] = attempts.get(ids[0], 0) + 1
                    what = f"the block of cases {min(ids)}-{max(ids)}"
                    if n > MAX_RESUBMITS:
                        raise SweepError(
                            f"{what} was lost with its Dask worker {n} times ({type(exc).__name__}); "
                            "the cluster keeps losing workers: check their memory and logs, then run again to resume"
                        ) from exc
                    warnings.warn(
                        f"{what} was lost with its Dask worker ({type(exc).__name__}: {str(exc)[:120]}); "
                        f"submitted again (attempt {n + 1} of {MAX_RESUBMITS + 1})",
                        SweepWarning, stacklevel=5,
                    )
                    g = client.submit(run_block, b, *band, pure=False, retries=2)
                    futures[g] = b
                    pending.add(g)
                    continue
                store(b, rows)
                stored.add(f)
        except BaseException:
            # Ctrl-C: keep the blocks the cluster has already finished, cancel the rest
            for f, b in futures.items():
                if f not in stored and f.status == "finished":
                    try:
                        store(b, f.result(timeout=5))
                    except Exception:  # pragma: no cover - result lost with its worker
                        pass
            client.cancel(list(futures))
            raise
        return str(client.scheduler.address)
    finally:
        if own:
            client.close()
