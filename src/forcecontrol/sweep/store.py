"""Sweep storage: parts written atomically as blocks end, the lock on the output, resume and assembly."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import signal
import sys
import threading
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..core import locks
from ..errors import OutputError
from .spec import SweepError, SweepWarning

if sys.version_info >= (3, 11):
    pass
else:  # pragma: no cover
    pass

from .prepare import META_KEY, METRIC_COLUMNS, PreparedSweep

__all__ = ["SweepResult", "read_sweep"]


def _schema(prep: PreparedSweep):
    import pyarrow as pa  # type: ignore[import-untyped]

    kinds = {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_(), "str": pa.string(), "json": pa.string()}
    fields = [pa.field("case_id", pa.int64()), pa.field("case", pa.string())]
    fields += [pa.field(path, kinds[k]) for path, k in prep.columns.items()]
    fields += [pa.field(c, pa.float64()) for c in METRIC_COLUMNS[:5]]
    fields += [pa.field("stable", pa.bool_()), pa.field("contact_lost", pa.bool_())]
    fields += [pa.field("status", pa.string()), pa.field("diverged_at", pa.float64()),
               pa.field("samples", pa.int64()), pa.field("integration_substeps", pa.int64()),
               pa.field("engine", pa.string())]
    meta = {META_KEY: json.dumps(prep.metadata, default=str).encode()}
    return pa.schema(fields, metadata=meta)


def _to_table(rows: list[dict[str, Any]], prep: PreparedSweep):
    import pyarrow as pa  # type: ignore[import-untyped]

    schema = _schema(prep)
    cols: dict[str, list[Any]] = {f.name: [] for f in schema}
    for r in rows:
        for name in cols:
            if name in prep.columns:
                v = r[f"param:{name}"]
                if prep.columns[name] == "json":
                    v = json.dumps(v)
                elif prep.columns[name] == "float":
                    v = float(v)
                cols[name].append(v)
            else:
                cols[name].append(r[name])
    return pa.Table.from_pydict(cols, schema=schema)


@contextlib.contextmanager
def _sigint_deferred():
    """Hold SIGINT (Ctrl-C) back until the block ends, then raise KeyboardInterrupt (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def _write_atomic(table, path: Path) -> None:
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    pq.write_table(table, tmp)
    with open(tmp, "rb") as f:
        os.fsync(f.fileno())
    os.replace(tmp, path)


#: schema-metadata key of a part's (and the table's) checksum: :func:`content_sha256` of its rows.
SUM_KEY = b"forcecontrol.sha256"


def content_sha256(table, sweep_id: str) -> str:
    """SHA-256 of a table's columns (names, types, values; floats exactly) and the sweep's identity."""
    h = hashlib.sha256(f"forcecontrol sweep {sweep_id}\n".encode())
    for name in table.column_names:
        col = table.column(name)
        h.update(f"\0{name}\0{col.type}\0".encode())
        h.update(json.dumps(col.to_pylist(), default=repr).encode())
    return h.hexdigest()


def with_checksum(table, sweep_id: str):
    """``table`` with :data:`SUM_KEY` in its schema metadata (written with it, atomically)."""
    meta = dict(table.schema.metadata or {})
    meta[SUM_KEY] = content_sha256(table, sweep_id).encode()
    return table.replace_schema_metadata(meta)


def checksum_fault(table, sweep_id: str) -> str | None:
    """Why ``table`` fails its checksum (None when it passes)."""
    stored = (table.schema.metadata or {}).get(SUM_KEY)
    if stored is None:
        return "it carries no checksum"
    if stored.decode(errors="replace") != content_sha256(table, sweep_id):
        return "its checksum fails: its content changed after it was written"
    return None


#: key of the parts folder's ``sweep.json`` holding the SHA-256 of the rest of its content.
STAMP_SUM = "sha256"


def _stamp_sha256(doc: dict[str, Any]) -> str:
    body = json.dumps({k: v for k, v in doc.items() if k != STAMP_SUM}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(f"forcecontrol sweep.json\n{body}".encode()).hexdigest()


def stamp_text(metadata: dict[str, Any]) -> str:
    """The parts folder's ``sweep.json``: the sweep's metadata and :data:`STAMP_SUM`, a SHA-256 of it."""
    doc = json.loads(json.dumps(metadata, default=str))
    doc[STAMP_SUM] = _stamp_sha256(doc)
    return json.dumps(doc, indent=2)


def read_stamp(stamp: Path) -> tuple[str | None, str | None]:
    """``(sweep_id, None)`` from a ``sweep.json`` that passes its checksum, else ``(None, why)``."""
    try:
        doc = json.loads(stamp.read_text())
        if not isinstance(doc, dict):
            return None, f"it holds a JSON {type(doc).__name__}, not an object"
    except (ValueError, OSError) as exc:
        return None, type(exc).__name__
    if STAMP_SUM not in doc:
        return None, "it carries no checksum"
    if doc[STAMP_SUM] != _stamp_sha256(doc):
        return None, "its checksum fails: its content changed after it was written"
    return doc.get("sweep_id"), None


def marker_path(out: Path) -> Path:
    """The library's mark beside a sweep table it wrote: ``.<name>.forcecontrol-sweep.json``."""
    return out.with_name(f".{out.name}.forcecontrol-sweep.json")


def write_marker(out: Path, sweep_id: str) -> None:
    m = marker_path(out)
    tmp = m.with_name(f"{m.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps({"sweep_id": sweep_id, "table": out.name}))
    os.replace(tmp, m)


def is_ours(out: Path) -> bool:
    """Whether the file ``out`` is a sweep table this library wrote: its marker names it (or its metadata is a sweep's)."""
    try:
        if json.loads(marker_path(out).read_text()).get("table") == out.name:
            return True
    except (OSError, ValueError, AttributeError):
        pass
    try:
        import pyarrow.parquet as pq  # type: ignore[import-untyped]

        return META_KEY in (pq.read_schema(out).metadata or {})
    except Exception:
        return False


def mark_file(path: Path, sweep_id: str) -> None:
    """Mark a file the sweep wrote beside its table (its figure): ``.<name>.forcecontrol-sweep.json`` naming it."""
    m = marker_path(path)
    tmp = m.with_name(f"{m.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps({"sweep_id": sweep_id, "file": path.name}))
    os.replace(tmp, m)


def check_file_output(path: Path, force: bool, what: str = "figure", sweep_id: Any = None) -> str | None:
    """The rule of :func:`check_output` for a file the sweep writes beside its table (its ``what``).

    A file of the library's own (its mark names it) is replaced when it was drawn for this sweep
    (``sweep_id``, or any sweep when None); one drawn for another sweep (two tables whose names
    differ by their suffix, ``s.parquet`` and ``s.pq``, share ``s.png``) and a user's file only with
    ``force`` (the returned note says so); a folder never.

    Raises:
        OutputError: ``path`` is a folder, a file this library did not write, or another sweep's (and
            not ``force``).
    """
    if path.is_dir():
        raise OutputError(f"the sweep's {what} {str(path)!r} is an existing folder; a folder is never replaced, even "
                          "with --force: choose another --out")
    if not path.exists():
        return None
    try:
        doc = json.loads(marker_path(path).read_text())
    except (OSError, ValueError):
        doc = None
    if isinstance(doc, dict) and doc.get("file") == path.name:
        theirs = doc.get("sweep_id")
        if sweep_id is None or theirs in (None, "None", str(sweep_id)):
            return None
        if not force:
            raise OutputError(f"the sweep's {what} {str(path)!r} was drawn for another sweep (id {theirs}; this "
                              f"one {sweep_id}); it is left untouched: choose another --out, or pass --force to "
                              "replace it")
        return f"--force: {str(path)} was drawn for another sweep (id {theirs}); it is replaced by this sweep's {what}"
    if not force:
        raise OutputError(f"the sweep's {what} {str(path)!r} is an existing file that forcecontrol did not write; it is "
                          "left untouched: choose another --out, or pass --force to replace it")
    return f"--force: {str(path)} was not written by forcecontrol; it is replaced by the sweep's {what}"


def check_output(out: Path, force: bool) -> str | None:
    """Refuse an ``out`` that is not the library's own: a folder always, a user's file unless ``force``.

    Returns a note when ``force`` lets a user's file be replaced (at the end, by the table).

    Raises:
        OutputError: ``out`` is a folder, or a file (or ``<out>.parts``) that is not a sweep of this library.
    """
    parts = out.with_name(out.name + ".parts")
    if parts.exists() and not (parts.is_dir() and ((parts / "sweep.json").exists() or not any(
            not (p.name.startswith("part-") or p.name.startswith(".") or p.name.startswith("sweep.json"))
            for p in parts.iterdir()))):
        raise OutputError(f"--out {str(out)!r}: the sweep keeps its parts in {str(parts)!r}, which exists and is not "
                          "a sweep's parts folder (never replaced); choose another --out")
    if out.is_dir():
        raise OutputError(f"--out {str(out)!r} is an existing folder; expected the path of a Parquet table "
                          f"(e.g. {str(out / 'sweep.parquet')!r}); a folder is never replaced, even with --force")
    if out.exists() and not is_ours(out):
        if not force:
            raise OutputError(f"--out {str(out)!r} is an existing file that is not a sweep table of forcecontrol; "
                              "it is left untouched: choose another --out, or pass --force to replace it")
        return f"--force: {str(out)} is not a sweep table; it is replaced by this sweep's table when the sweep ends"
    return None


def read_sweep(path: str | Path):
    """A sweep table and its definition: ``(pandas.DataFrame, dict)``."""
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    table = pq.read_table(path)
    meta = json.loads((table.schema.metadata or {}).get(META_KEY, b"{}"))
    return table.to_pandas(), meta


@dataclass
class SweepResult:
    """A finished sweep.

    Attributes:
        path: the Parquet table; table: it, as a pandas DataFrame (one row per case).
        metadata: the sweep definition stored with it.
        ran: cases simulated by this call; resumed: cases found already done.
        seconds: wall time of the simulation phase; steps: arm-steps (control samples, all cases)
            simulated by this call; a diverged case counts the samples up to its divergence.
    """

    path: Path
    table: Any
    metadata: dict[str, Any]
    ran: int = 0
    resumed: int = 0
    seconds: float = 0.0
    steps: int = 0
    scheduler: str = "local"
    extra: dict[str, Any] = field(default_factory=dict)


@contextlib.contextmanager
def _output_lock(out: Path):
    """One sweep at a time on an output: ``<out>.lock``, held with an exclusive ``flock`` and holding the owner's pid.

    The kernel drops a dead process's ``flock``, so a lock left by a killed sweep is taken over (with a
    :class:`SweepWarning`), and a live one is never taken: the pid file alone was not enough: a second
    process that read the file between the first one's create and its write of the pid saw no pid,
    called the lock stale, removed it and ran over the first sweep's parts (found under load: the first
    sweep then failed on a part the second had removed). After the ``flock`` the file must still be the
    one at the path (a sweep ending removes it), else it is opened again. A pid written by a live
    process that holds no ``flock`` (an older version) is still refused. Where ``flock`` is missing
    (Windows) or refused (``ENOLCK`` on some network file systems) the pid file alone is used.
    """
    lock = out.with_name(out.name + ".lock")
    fd = _flock_output(lock, out)
    if fd is None:
        with _pid_lock(lock, out):
            yield
        return
    try:
        yield
    finally:
        locks.release(lock, fd)  # removed while held: a waiting process then finds a new file


def _refuse(out: Path, lock: Path, pid: int | str) -> SweepError:
    return SweepError(
        f"another sweep (process {pid}) is writing {str(out)!r}; wait for it or choose another --out "
        f"(remove {str(lock)!r} if that process is gone)"
    )


def _flock_output(lock: Path, out: Path) -> int | None:
    """``flock`` ``lock`` (:func:`forcecontrol.core.locks.try_lock`) and write this pid. None: no flock here."""
    got = locks.try_lock(lock)
    if isinstance(got, str):
        raise _refuse(out, lock, got)
    if got is None:
        return None
    pid = locks.read_pid(got)
    if pid and pid != os.getpid():
        if _alive(pid):  # written by a live process that holds no flock (an older version)
            os.close(got)
            raise _refuse(out, lock, pid)
        warnings.warn(f"taking over the stale lock {lock} (process {pid} is gone)", SweepWarning, stacklevel=5)
    locks.write_pid(got)
    return got


@contextlib.contextmanager
def _pid_lock(lock: Path, out: Path):
    """The pid file alone (no ``flock`` on this system): created exclusively with the pid already in it (a hard link of
    a written temporary file), so a reader never sees it empty; a dead owner's lock is taken over."""
    for _ in range(2):
        tmp = lock.with_name(f"{lock.name}.{os.getpid()}.{threading.get_ident()}.tmp")
        try:
            tmp.write_text(str(os.getpid()))
        except OSError as exc:  # a folder this process cannot write in (the table could not be written there either)
            raise SweepError(f"cannot write next to {str(out)!r} (the sweep's lock {lock.name}): "
                             f"{exc.strerror or exc}; choose another --out") from None
        try:
            os.link(tmp, lock)
        except FileExistsError:
            try:
                pid = int(lock.read_text().strip() or "0")
            except (OSError, ValueError):
                pid = 0
            if pid and pid != os.getpid() and _alive(pid):
                raise _refuse(out, lock, pid) from None
            warnings.warn(f"taking over the stale lock {lock} (process {pid} is gone)", SweepWarning, stacklevel=5)
            lock.unlink(missing_ok=True)
            continue
        finally:
            tmp.unlink(missing_ok=True)
        break
    try:
        yield
    finally:
        lock.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # pragma: no cover - another user's process
        return True
    return True


def _set_aside(path: Path, why: str, what: str = "is unreadable", then: str = "its cases run again") -> None:
    """Move a damaged file of the library's own out of the way (kept for inspection) and say so."""
    aside = path.with_name(f"{path.name}.corrupt-{int(time.time())}")
    os.replace(path, aside)
    warnings.warn(f"{path} {what} ({why}); moved to {aside.name}, {then}", SweepWarning, stacklevel=5)


def _done_ids(parts_dir: Path, prep: PreparedSweep) -> set[int]:
    """Case ids stored in verified parts; a part that cannot be read whole, or belongs to another
    sweep, or holds other cases than its name says, is moved aside (its cases run again)."""
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    done: set[int] = set()
    for p in sorted(parts_dir.glob("part-*.parquet")):
        try:
            table = pq.read_table(p)
            meta = json.loads((table.schema.metadata or {}).get(META_KEY, b"{}"))
            ids = table.column("case_id").to_pylist()
            lo, hi, n = (int(v) for v in p.stem.split("-")[1:4])
        except Exception as exc:
            _set_aside(p, f"{type(exc).__name__}: {str(exc)[:80]}")
            continue
        if meta.get("sweep_id") != prep.sweep_id:
            _set_aside(p, f"it belongs to sweep {meta.get('sweep_id')}")
            continue
        if len(ids) != n or (ids and (min(ids) != lo or max(ids) != hi)):
            _set_aside(p, f"it holds {len(ids)} cases, its name says {n} from {lo} to {hi}")
            continue
        fault = checksum_fault(table, prep.sweep_id)
        if fault is not None:
            _set_aside(p, fault, "is damaged")
            continue
        done.update(ids)
    return done


def _assemble(parts_dir: Path, prep: PreparedSweep):
    import pyarrow as pa  # type: ignore[import-untyped]
    import pyarrow.compute as pc  # type: ignore[import-untyped]
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    schema = _schema(prep)
    tables = [pq.read_table(p).cast(schema) for p in sorted(parts_dir.glob("part-*.parquet"))]
    table = pa.concat_tables(tables) if tables else schema.empty_table()
    table = table.take(pc.sort_indices(table, [("case_id", "ascending")]))
    ids = table.column("case_id").to_pylist()
    if len(set(ids)) != len(ids):  # a block stored twice (a retried task): keep one copy
        keep, seen = [], set()
        for i, c in enumerate(ids):
            if c not in seen:
                seen.add(c)
                keep.append(i)
        table = table.take(pa.array(keep))
        ids = table.column("case_id").to_pylist()
    missing = sorted(set(range(prep.n_cases)) - set(ids))
    if missing:
        raise SweepError(f"the sweep's parts lack {len(missing)} cases (first: {missing[:5]}); run it again to finish")
    return table.replace_schema_metadata(schema.metadata)
