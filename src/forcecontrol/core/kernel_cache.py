"""The on-disk cache of this package's compiled kernels, safe when processes fill it at the same time.

Numba's own cache (``numba.core.caching``) keeps one index file per function, named from the
function's module, qualified name and line, and numbers its data files by the count of entries
in that index. Every law's compiled loop is the same closure (``_make_loop.<locals>.run``,
likewise the sweeps' kernels and ``on_arm``), so all laws shared one index; and ``save`` is an
unlocked read-modify-write of the index: two processes saving different laws at once both read
the same index, both pick ``…-N.nbc``, and the index entry of one law ends up pointing at the
other law's machine code, which a later process loads and runs (wrong physics, silently).

Here the cache is keyed as follows:

* **folder**: ``<root>/forcecontrol-<hash of the package's sources>/`` (:mod:`.numba_cache`), then
  Numba's per-source-folder subfolder;
* **index file** (``<identity>.k1.nbi``): one per kernel *identity*: module and qualified name
  for a module-level function; for a closure built per law, the identity its factory gives it
  (:func:`set_identity`: the loop, its variant and the law's stable name), so two laws never share
  an index. The index also holds the identity, Numba's version and the source stamp;
* **entry**: Numba's index key (signature, CPU and features, hashes of the bytecode and of the
  closure's pickled contents, which name the law);
* **data file** (``<identity>.<digest of the entry key>.nbc``): named from the key, never from a
  count, so different entries cannot share a file; it stores the identity and the key digest
  beside the machine code, and a load whose stored identity or digest differs from the one
  asked for is refused (one line on stderr; the kernel recompiles and the entry is rewritten).

A process that misses a kernel compiles it under an exclusive ``flock`` on ``<identity>.k1.compile``,
held until the result is saved: another process missing the same kernel meanwhile waits, then loads
it (a cold cache shared by several processes compiles each kernel once; the wait is bounded by
``COMPILE_WAIT``). Writes hold an exclusive ``flock`` on ``<identity>.lock`` around reading and rewriting the
index (the data file is written first, atomically, under its content-derived name); loads
hold a shared lock while they read the index and the data file. Locks work between processes
on one machine and between Dask workers sharing a local folder. On NFS, ``flock`` works where
the server supports locking (NFSv4, or v3 with lockd); where it fails (``ENOLCK``, or no
``fcntl`` on Windows) the cache runs without the lock: an index entry can then be lost (the
kernel recompiles once more), never point at another entry's code, because data names come
from the keys and every load is checked.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pickle
import re
import sys
import time
from collections.abc import Iterator
from typing import Any

import numba
from numba.core import event
from numba.core.caching import FunctionCache, IndexDataCacheFile
from numba.core.runtime import rtsys
from numba.core.serialize import dumps

__all__ = ["KernelCache", "set_identity", "key_digest", "scan", "FORMAT"]

FORMAT = "forcecontrol-kernel-1"  # stored in every index and data file of this format
_SUFFIX = ".k1"  # file names of this format: <identity>.k1.nbi, <identity>.k1.<digest>.nbc, <identity>.k1.lock
_warned: set[str] = set()


def key_digest(key: Any) -> str:
    """A digest of Numba's index key (signature, CPU, bytecode and closure hashes): names the entry's data file."""
    return hashlib.sha256(repr(key).encode()).hexdigest()[:24]


def _slug(identity: str) -> str:
    s = identity.replace("forcecontrol:", "").replace("forcecontrol.", "")
    s = re.sub(r"[^A-Za-z0-9._-]+", "_", s).strip("._")
    return s[:100]


def _filename_base(identity: str, explicit: bool) -> str:
    tag = f"py{sys.version_info[0]}{sys.version_info[1]}{getattr(sys, 'abiflags', '')}"
    # an explicit identity (a closure's) is slugged: a short hash keeps two identities with one slug apart
    extra = "-" + hashlib.sha256(identity.encode()).hexdigest()[:8] if explicit else ""
    return f"{_slug(identity)}{extra}.{tag}{_SUFFIX}"


def _say(message: str) -> None:
    if message not in _warned:
        _warned.add(message)
        print(f"forcecontrol: {message}", file=sys.stderr, flush=True)


def _lock_file(path: str) -> tuple[Any, int] | None:
    """``(fcntl, fd)`` of a lock file opened (created if missing) for ``flock``; None where there can be no lock: no
    ``fcntl`` (Windows) or a folder that cannot be written (a read-only cache)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        return None
    try:
        return fcntl, os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError:  # pragma: no cover - a read-only cache folder
        return None


class _LockedFiles(IndexDataCacheFile):
    """One kernel's index and data files: locked index updates, key-named data files, identity checked on load."""

    def __init__(self, cache_path: str, filename_base: str, source_stamp: Any, identity: str) -> None:
        super().__init__(cache_path, filename_base, source_stamp)
        self._base = filename_base
        self._identity = identity
        self._lock_path = os.path.join(cache_path, filename_base + ".lock")

    def data_name(self, key: Any) -> str:
        return f"{self._base}.{key_digest(key)}.nbc"

    @contextlib.contextmanager
    def _locked(self, exclusive: bool) -> Iterator[None]:
        opened = _lock_file(self._lock_path)
        if opened is None:  # no lock here: loads still work (see the module docstring)
            yield
            return
        fcntl, fd = opened
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
            except OSError as exc:  # pragma: no cover - NFS without lock support
                _say(f"kernel cache lock unavailable on {self._lock_path} ({exc.strerror}); continuing without it")
            yield
        finally:
            os.close(fd)  # releases the lock

    def flush(self) -> None:
        with self._locked(exclusive=True):
            self._save_index({})

    def save(self, key: Any, data: Any) -> None:
        name = self.data_name(key)
        digest = key_digest(key)
        # the data first, atomically under its own name: an index entry never points at a half-written file
        self._save_data(name, (FORMAT, self._identity, digest, data))
        with self._locked(exclusive=True):
            overloads = self._load_index()
            if overloads.get(key) != name:
                overloads[key] = name
                self._save_index(overloads)

    def load(self, key: Any) -> Any:
        with self._locked(exclusive=False):
            name = self._load_index().get(key)
            if name is None:
                return None
            try:
                stored = self._load_data(name)
            except OSError:  # removed since the index was written: a miss
                return None
            except Exception as exc:  # a truncated or foreign file: recompile
                _say(f"kernel cache file {name} is unreadable ({type(exc).__name__}); recompiling {self._identity}")
                return None
        ok = isinstance(stored, tuple) and len(stored) == 4 and stored[:3] == (FORMAT, self._identity, key_digest(key))
        if not ok:
            who = stored[1] if isinstance(stored, tuple) and len(stored) == 4 else "an unknown kernel"
            _say(f"kernel cache entry {name} holds {who}, not {self._identity} as its index says; "
                 "recompiling it (run `forcecontrol cache --verify`)")
            return None
        return stored[3]

    def _load_index(self) -> dict[Any, str]:
        """The entries of this kernel's index ({} when missing, of another Numba version or source stamp, or foreign)."""
        info = read_index(self._index_path)
        if info is None or info["stamp"] != self._source_stamp or info["identity"] != self._identity:
            return {}
        return info["entries"]

    def _save_index(self, overloads: dict[Any, str]) -> None:
        payload = dumps((FORMAT, self._identity, self._source_stamp, overloads))
        with self._open_for_write(self._index_path) as f:
            pickle.dump(self._version, f, protocol=-1)
            f.write(payload)


class _CompileLock:
    """One kernel's compile, one process at a time: a process that misses the cache waits while another compiles
    the same kernel, then loads what that one saved, instead of compiling it too.

    An exclusive ``flock`` on ``<identity>.k1.compile`` (not the index's lock, which the save takes while this one is
    held). Taken by :meth:`KernelCache.load_overload` on a miss and released once the compile's result is saved
    (:meth:`KernelCache.save_overload`), or when the compile fails (:class:`_ReleaseAfterFailedCompile`), or when the
    process ends (the operating system frees a dead process's locks). A wait is bounded: after :data:`COMPILE_WAIT` seconds
    (another process stopped while compiling) this one compiles without the lock and says so; that it waits, it says
    once (one line on stderr). Where ``flock`` is
    missing or refused, compiles are not serialised (each process compiles, as without this lock).
    """

    def __init__(self, path: str) -> None:
        self.path = path
        self._fd: int | None = None
        self._depth = 0

    @property
    def held(self) -> bool:
        return self._depth > 0

    def acquire(self, ensure_folder: Any) -> bool:
        """Hold the lock (waiting while another process holds it); False if it could not be taken."""
        if self._depth:  # this process compiles this kernel already (a nested compile of it): nothing to wait for
            self._depth += 1
            return True
        try:
            ensure_folder()
        except OSError:  # a read-only cache: nothing is saved there either
            return False
        opened = _lock_file(self.path)
        if opened is None:
            return False
        fcntl, fd = opened
        deadline = time.monotonic() + COMPILE_WAIT
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                _say(f"kernel cache: waiting for another process that is compiling the same kernels (loaded from "
                     f"{os.path.dirname(self.path)} once it is done)")  # once per process: a wait is never silent
                if time.monotonic() > deadline:
                    os.close(fd)
                    _say(f"kernel cache: another process has been compiling {os.path.basename(self.path)} for over "
                         f"{COMPILE_WAIT:.0f} s; compiling it here too")
                    return False
                time.sleep(0.02)
            except OSError:  # pragma: no cover - NFS without lock support: compile without waiting
                os.close(fd)
                return False
        self._fd, self._depth = fd, 1
        return True

    def release(self) -> None:
        if not self._depth:
            return
        self._depth -= 1
        if not self._depth and self._fd is not None:
            os.close(self._fd)  # releases the lock
            self._fd = None


#: the longest a process waits for another's compile of the same kernel [s] (a compile takes seconds; more than this
#: means the other process is stopped or hung)
COMPILE_WAIT = 300.0


def read_index(path: str) -> dict[str, Any] | None:
    """An index file of this format as ``{identity, stamp, entries}``; None if missing, foreign or of another Numba."""
    try:
        with open(path, "rb") as f:
            version = pickle.load(f)
            rest = f.read()
    except FileNotFoundError:
        return None
    if version != numba.__version__:
        return None
    payload = pickle.loads(rest)
    if not (isinstance(payload, tuple) and len(payload) == 4 and payload[0] == FORMAT):
        return None
    return {"identity": payload[1], "stamp": payload[2], "entries": payload[3]}


class KernelCache(FunctionCache):
    """Numba's function cache for one kernel identity, with :class:`_LockedFiles` as its index and data files.

    ``identity`` defaults to the function's module and qualified name (unique for a module-level
    function); a closure built per law gets its own through :func:`set_identity`.
    """

    def __init__(self, py_func: Any, identity: str | None = None) -> None:
        super().__init__(py_func)
        explicit = identity is not None
        self.identity = identity or f"{py_func.__module__}.{py_func.__qualname__}"
        base = _filename_base(self.identity, explicit)
        stamp = self._impl.locator.get_source_stamp()
        self._cache_file = _LockedFiles(self._cache_path, base, stamp, self.identity)
        self._compile_lock = _CompileLock(os.path.join(self._cache_path, base + ".compile"))

    @property
    def index_path(self) -> str:
        return self._cache_file._index_path

    def load_overload(self, sig: Any, target_context: Any) -> Any:
        """Load the cached machine code for ``sig``, or None; without refreshing the whole target context first.

        Numba's ``Cache.load_overload`` calls ``target_context.refresh()`` before every load: the first
        one in a process imports and installs every lowering registry of Numba (about 0.25 s of CPU, a
        quarter of a short ``forcecontrol run``), which only a compile uses, and a compile refreshes the
        contexts itself (``CompilerBase.__init__``). Linking cached code needs the symbols it calls:
        Numba's C helpers and math functions are installed when the context is created, the runtime's
        (NRT: arrays allocated in a kernel) by ``rtsys.initialize``, done here.
        """
        rtsys.initialize(target_context)
        cres = self._load(sig, target_context)
        if cres is not None or not self._enabled:
            return cres
        # a miss: this process compiles the kernel while any other that misses it waits (:class:`_CompileLock`),
        # and a process that waited loads what the first one saved
        if self._compile_lock.acquire(self._impl.locator.ensure_cache_path):
            cres = self._load(sig, target_context)
            if cres is not None:
                self._compile_lock.release()
        return cres

    def _load(self, sig: Any, target_context: Any) -> Any:
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)
        return None  # pragma: no cover - an I/O error swallowed by the guard (Numba's own behaviour)

    def save_overload(self, sig: Any, data: Any) -> None:
        """Save the compiled ``sig`` (Numba's save), then let the processes waiting for it load it."""
        try:
            super().save_overload(sig, data)
        finally:
            self._compile_lock.release()


class _ReleaseAfterFailedCompile(event.Listener):
    """A compile that raised never reaches ``save_overload``: its kernel's compile lock is released here."""

    def on_start(self, ev: Any) -> None:
        pass

    def on_end(self, ev: Any) -> None:
        cache = getattr((ev.data or {}).get("dispatcher"), "_cache", None)
        # the exception the compile ended with (None after a compile that worked); read directly, as Numba 0.68's
        # Event.is_failed answers True for a compile that worked
        if getattr(ev, "_exc_details", None) is not None and isinstance(cache, KernelCache):
            cache._compile_lock.release()


event.register("numba:compile", _ReleaseAfterFailedCompile())


def set_identity(dispatcher: Any, identity: str) -> None:
    """Give a compiled closure its own identity: its pickling uuid and its own cache index and data files."""
    dispatcher._set_uuid(identity)
    # a name of its own for the compiled symbol: closures of one factory share a qualified name, and
    # Numba's symbol is that name plus a per-process counter, so two laws' closures compiled in two
    # processes got the same symbol and a process that loaded both ran one body for the other
    # (numba issue 10486: wrong forces, crashes)
    name = "k_" + re.sub(r"\W", "_", identity)
    dispatcher.py_func.__name__ = dispatcher.py_func.__qualname__ = name
    if isinstance(getattr(dispatcher, "_cache", None), FunctionCache):
        dispatcher._cache = KernelCache(dispatcher.py_func, identity)


def scan(folder: str) -> dict[str, Any]:
    """Every index and data file under ``folder``, checked: ``{indexes, entries, files, bytes, problems, foreign}``.

    A problem is an index entry whose data file is missing, unreadable, of another identity or
    of another key; ``foreign`` counts index files not of this format (Numba's own, another version).
    """
    out: dict[str, Any] = {"indexes": 0, "entries": 0, "files": 0, "bytes": 0, "problems": [], "foreign": 0}
    for dirpath, _dirs, names in os.walk(folder):
        for n in names:
            out["files"] += 1
            with contextlib.suppress(OSError):
                out["bytes"] += os.path.getsize(os.path.join(dirpath, n))
        for n in sorted(names):
            if not n.endswith(".nbi"):
                continue
            path = os.path.join(dirpath, n)
            try:
                info = read_index(path)
            except Exception as exc:  # noqa: BLE001 - a corrupt index is a finding, not a crash
                out["problems"].append(f"{path}: unreadable index ({type(exc).__name__})")
                continue
            if info is None:
                out["foreign"] += 1
                continue
            out["indexes"] += 1
            base = n[: -len(".nbi")]
            for key, name in info["entries"].items():
                out["entries"] += 1
                digest = key_digest(key)
                where = f"{os.path.join(dirpath, name)} (kernel {info['identity']})"
                if name != f"{base}.{digest}.nbc":
                    out["problems"].append(f"{where}: the index names a data file not derived from its key")
                    continue
                try:
                    with open(os.path.join(dirpath, name), "rb") as f:
                        stored = pickle.loads(f.read())
                except FileNotFoundError:
                    out["problems"].append(f"{where}: data file missing")
                    continue
                except Exception as exc:  # noqa: BLE001
                    out["problems"].append(f"{where}: data file unreadable ({type(exc).__name__})")
                    continue
                if not (isinstance(stored, tuple) and len(stored) == 4 and stored[0] == FORMAT):
                    out["problems"].append(f"{where}: data file of another format")
                elif stored[1] != info["identity"]:
                    out["problems"].append(f"{where}: data file holds kernel {stored[1]}")
                elif stored[2] != digest:
                    out["problems"].append(f"{where}: data file holds another entry of the kernel (key {stored[2]})")
    return out
