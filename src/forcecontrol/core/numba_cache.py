"""Numba's on-disk cache, keyed on this package's source.

Numba's ``cache=True`` checks only the source file of the function it compiles, so a compiled
loop that calls a dispatcher in another module keeps running the old dispatcher after that
module changes. To make stale caches impossible, every distinct version of the package's
sources gets its own cache folder: ``<cache root>/forcecontrol-<hash of all .py files>``.

Inside it, every compiled function of the package is cached by :class:`forcecontrol.core.kernel_cache.KernelCache`
(one index per kernel identity, per-law for the loops; locked index updates; data files named from
their key and checked on load), installed by :func:`install_kernel_cache` when Numba is imported;
that module's docstring says how the cache is keyed and why Numba's own cache was not safe here.

The cache root is ``$NUMBA_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/forcecontrol/numba``
(``~/.cache/forcecontrol/numba``). This module must be imported before any module that
decorates functions with ``@njit(cache=True)`` (the package ``__init__`` does so first).

:func:`configure` does not import Numba (that costs about 0.3 s): when Numba is not loaded yet it
sets ``NUMBA_CACHE_DIR``, which Numba reads when it is first imported; child processes (Dask
workers) inherit it and recognise the folder as already configured.
:func:`notify_if_cold` prints one line on stderr when the folder holds no compiled kernels yet.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path
from typing import Any

__all__ = ["configure", "CACHE_DIR", "is_cold", "notify_if_cold", "stable_identities", "kernel_identity", "install_kernel_cache",
           "identity_lock", "build_once", "kernel_array"]

CACHE_DIR: str | None = None
_notified = False


def kernel_array(a: Any, *, frozen: bool = False) -> Any:
    """``a`` as the one array type a kernel's argument is compiled for: float64, C-contiguous, and writable, or
    read-only with ``frozen`` (the controllers' gains, frozen when they are set: no copy on each control step).

    Numba compiles a function again for every new argument type, and an array's type includes its
    layout and its read-only flag: a read-only array (a frozen attribute, a broadcast) or a strided
    one (a column) given to a kernel that has run on ordinary arrays compiles all of it a second time
    (the 6-D loop: 8 s). The same array is returned when it already is one; otherwise a copy (or, for
    ``frozen``, a read-only view). Kernels only read the arrays given to them this way.
    """
    import numpy as np

    if type(a) is np.ndarray and a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable != frozen:
        return a  # already the kernel's type: the common case, on every control step of the 6-D laws
    if not frozen:
        return np.require(a, dtype=np.float64, requirements=("C", "W"))
    out = np.require(a, dtype=np.float64, requirements=("C",))
    if out.flags.writeable:
        out = out.view()
        out.flags.writeable = False
    return out


def _source_hash(root: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def configure() -> str | None:
    """Point Numba's cache at the folder of this source version; return it (None if unusable)."""
    global CACHE_DIR
    name = f"forcecontrol-{_source_hash(Path(__file__).parent.parent)}"  # the whole package, not core/ alone
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "forcecontrol", "numba"
    )
    # a parent process already pointed NUMBA_CACHE_DIR at this version's folder
    folder = base if os.path.basename(os.path.normpath(base)) == name else os.path.join(base, name)
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError:  # pragma: no cover - read-only home: keep Numba's own default
        return None
    numba = sys.modules.get("numba")
    if numba is not None:  # already imported: its config has read the environment
        numba.config.CACHE_DIR = folder  # type: ignore[attr-defined]  # read when a cached function compiles
    else:
        os.environ["NUMBA_CACHE_DIR"] = folder  # read by numba.config on import
    CACHE_DIR = folder
    install_kernel_cache()
    global _cold
    _cold = _empty(folder)  # before any @njit(cache=True) decoration creates its index folders
    return folder


_cold = False


def _empty(folder: str) -> bool:
    try:
        with os.scandir(folder) as it:
            return not any(True for _ in it)
    except OSError:
        return True


def is_cold() -> bool:
    """True when this source version's cache folder was empty when the package was imported (first run)."""
    return CACHE_DIR is not None and _cold


def notify_if_cold() -> bool:
    """Print one line on stderr, once per process, if the kernels are about to compile; return whether it did.

    Measured on a 2-core machine (``benchmarks/bench_coldstart.py --profile``): ``run example-9.2``
    compiles 14 functions in about 3.7 s of CPU on a fresh cache at load 6 (16 in 5.4 s before issue 33 item 5); a
    sweep compiles its batch kernel once per control law, a few seconds more each.
    """
    global _notified
    if _notified or not is_cold():
        return False
    _notified = True
    print(
        f"forcecontrol: compiling kernels (first run of this version: a few seconds per command; cached "
        f"afterwards in {CACHE_DIR})",
        file=sys.stderr,
        flush=True,
    )
    return True


_listener_installed = False
WATCHED: tuple[str, ...] = ("forcecontrol",)  # packages whose compiles the notice reports


def install_notice() -> None:
    """Print :func:`notify_if_cold`'s line (or a shorter one) when Numba first compiles one of this package's kernels.

    Uses Numba's event API (``numba:compile`` fires only on a cache miss, after the on-disk cache
    was tried), so a warm cache prints nothing. Imports Numba: call it where Numba is needed anyway.
    """
    global _listener_installed
    if _listener_installed:
        return
    _listener_installed = True
    from numba.core import event

    class _CompileNotice(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            global _notified
            if _notified:
                return
            func = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
            module = str(getattr(func, "__module__", ""))
            if not any(module == w or module.startswith(w + ".") for w in WATCHED):
                return
            if is_cold():
                notify_if_cold()
            else:
                _notified = True
                print("forcecontrol: compiling kernels for a new signature (cached afterwards)", file=sys.stderr, flush=True)

        def on_end(self, ev: event.Event) -> None:
            pass

    event.register("numba:compile", _CompileNotice())


def stable_identities() -> None:
    """Give every compiled function of the package a name-derived identity (once, before any pickling).

    A loop compiled for a law (:func:`forcecontrol.sim.loop.planar_loop`, the sweeps' kernels) is a
    closure over the law, and Numba keys its disk cache on the closure's pickled contents: the
    law and, through it, every compiled function it calls, each pickled with its dispatcher's
    identity, a random UUID per process by default. The cached loop was then never found again
    and recompiled in every process (seconds, and one more cache file each time). With
    identities derived from module and name the key is the same in every process. The cache
    folder is keyed on the package's sources (:func:`configure`), so a changed law never meets a
    loop compiled with its old version.
    """
    from numba.core.registry import CPUDispatcher

    with identity_lock():  # check-and-set atomic: Numba's ``_set_uuid`` asserts the uuid is unset
        # snapshots: another thread may import a module (or set a module attribute) while this runs
        for name in sorted(m for m in list(sys.modules) if m == "forcecontrol" or m.startswith("forcecontrol.")):
            module = sys.modules.get(name)
            for attr, obj in sorted(list(vars(module).items()), key=lambda kv: kv[0]) if module is not None else ():
                # type(), not isinstance(): isinstance reads ``obj.__class__``, which loads a lazily imported
                # module (core.lazy: python-control, 1.3 s) that no compiled run needs
                if issubclass(type(obj), CPUDispatcher) and getattr(obj.py_func, "__module__", None) == name:
                    if getattr(obj, "_MemoMixin__uuid", None) is None:
                        obj._set_uuid(f"forcecontrol:{name}.{attr}")


def identity_lock() -> Any:
    """The lock under which identities are given and per-law kernels built: Numba's own compiler lock (reentrant).

    A sweep runs its blocks on threads. Two threads giving identities at once (or one reading a
    dispatcher's ``_uuid``, which draws a random one when unset, while the other sets it) tripped
    the bare ``assert self.__uuid is None`` in Numba's ``_MemoMixin._set_uuid``: a sweep failed
    with ``AssertionError()`` on a cold start. Numba pickles dispatchers for its cache keys while
    holding this same lock, so holding it here also orders identities before any such pickling.
    """
    from numba.core.compiler_lock import global_compiler_lock

    return global_compiler_lock


def build_once(cache: dict[Any, Any], key: Any, build: Any) -> Any:
    """``cache[key]``, built by ``build()`` on first use under :func:`identity_lock` (once, even from several threads)."""
    value = cache.get(key)
    if value is None:
        with identity_lock():
            value = cache.get(key)
            if value is None:
                value = cache[key] = build()
    return value


def _ours(py_func: object) -> bool:
    module = str(getattr(py_func, "__module__", "") or "")
    return module == "forcecontrol" or module.startswith("forcecontrol.")


def _patch_dispatcher(module: object) -> None:
    """Make ``Dispatcher.enable_caching`` (``cache=True``) use :class:`KernelCache` for this package's functions."""
    cls = getattr(module, "Dispatcher", None)
    original = getattr(cls, "enable_caching", None)
    if original is None or getattr(original, "_forcecontrol", False):
        return

    def enable_caching(self: object) -> None:
        if _ours(getattr(self, "py_func", None)):
            from .kernel_cache import KernelCache

            self._cache = KernelCache(self.py_func)  # type: ignore[attr-defined]
            _identity_at_creation(self)
        else:  # other libraries' and the user's functions keep Numba's own cache
            original(self)

    enable_caching._forcecontrol = True  # type: ignore[attr-defined]
    cls.enable_caching = enable_caching  # type: ignore[union-attr]


def _identity_at_creation(dispatcher: Any) -> None:
    """A module-level function of the package gets its stable identity as it is decorated, before anything can pickle it.

    :func:`stable_identities` ran only where a loop or a kernel was built: a program that pickled a
    controller first (a sweep on a Dask cluster sends its cases' laws to the workers) drew random
    uuids for the laws and everything they call, so every per-law kernel built afterwards in that
    process, and in the workers that unpickled them, had a cache key of its own and compiled again
    (found in the test suite: the lanes kernels, about 60 s of CPU, recompiled in every run on the
    worker that had run the Dask journey first). A closure (``<locals>`` in its name) is left to
    :func:`kernel_identity`, which names it per law.
    """
    qualname = str(getattr(dispatcher.py_func, "__qualname__", "<locals>"))
    if "<locals>" in qualname:
        return
    with identity_lock():
        if getattr(dispatcher, "_MemoMixin__uuid", None) is None:
            dispatcher._set_uuid(f"forcecontrol:{dispatcher.py_func.__module__}.{qualname}")


class _AfterNumbaDispatcher:
    """A meta-path finder that patches ``numba.core.dispatcher`` right after it is first executed."""

    done = False

    def find_spec(self, fullname: str, path: object, target: object = None) -> object:
        if fullname != "numba.core.dispatcher" or self.done:
            return None
        self.done = True
        from importlib.machinery import PathFinder

        spec = PathFinder.find_spec(fullname, path)  # type: ignore[arg-type]
        loader = getattr(spec, "loader", None)
        if loader is None or not hasattr(loader, "exec_module"):
            return spec
        exec_module = loader.exec_module

        def run(module: object) -> None:
            exec_module(module)
            _patch_dispatcher(module)
            if self in sys.meta_path:
                sys.meta_path.remove(self)

        loader.exec_module = run
        return spec


def install_kernel_cache() -> None:
    """Have every ``cache=True`` function of the package use :class:`~forcecontrol.core.kernel_cache.KernelCache`.

    Without importing Numba (0.3 s): if Numba is loaded, its dispatcher is patched now, else right
    after Numba loads it (an import hook), before any module of the package decorates a function.
    Only functions whose module is in this package are concerned.
    """
    module = sys.modules.get("numba.core.dispatcher")
    if module is not None:
        _patch_dispatcher(module)
    elif not any(isinstance(f, _AfterNumbaDispatcher) for f in sys.meta_path):
        sys.meta_path.insert(0, _AfterNumbaDispatcher())  # type: ignore[arg-type]


def kernel_identity(dispatcher: object, identity: str) -> None:
    """Give a compiled closure (a loop built per law) its identity: its pickling uuid and its own cache files."""
    from .kernel_cache import set_identity

    with identity_lock():
        set_identity(dispatcher, identity)
