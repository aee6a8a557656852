"""``forcecontrol cache``: where the compiled kernels are cached, how big the cache is; ``--verify``, ``--clear``.

The cache is keyed as :mod:`forcecontrol.core.kernel_cache` says: one folder per version of the
package's sources (``<root>/forcecontrol-<hash>``), one index per kernel (per law for the loops),
data files named from their entry's key and holding the kernel's identity. ``--verify`` checks
every index entry of this version's folder against its data file; ``--clear`` removes every
version's folder (``forcecontrol-<hash>`` under the root, nothing else).
"""

from __future__ import annotations

import os
import re
import shutil
import sys
from typing import Annotated, Any

import typer

from ..core import numba_cache as _numba_cache
from .app import JsonOut, _fail, console, err_console, print_json

__all__ = ["cache_command", "cache_report"]

_VERSION_FOLDER = re.compile(r"^forcecontrol-[0-9a-f]{16}$")


def _size(path: str) -> tuple[int, int]:
    files = size = 0
    for dirpath, _dirs, names in os.walk(path):
        for n in names:
            files += 1
            try:
                size += os.path.getsize(os.path.join(dirpath, n))
            except OSError:  # removed meanwhile
                pass
    return files, size


def cache_report(verify: bool = False, clear: bool = False) -> dict[str, Any]:
    """What ``forcecontrol cache`` prints: ``{root, folder, versions, kernels, entries, files, bytes, ...}``.

    ``verify`` adds ``problems`` (index entries whose data file is missing or belongs to another
    kernel or entry); ``clear`` removes every source version's folder and lists them in ``removed``.
    """
    from ..errors import OutputError

    folder = _numba_cache.CACHE_DIR
    if folder is None:
        raise OutputError("the kernel cache folder could not be created (read-only home?); set NUMBA_CACHE_DIR")
    root = os.path.dirname(os.path.normpath(folder))
    try:
        versions = sorted(n for n in os.listdir(root) if _VERSION_FOLDER.match(n) and os.path.isdir(os.path.join(root, n)))
    except OSError:
        versions = []
    out: dict[str, Any] = {"root": root, "folder": folder, "versions": versions}
    if verify:
        from ..core.kernel_cache import scan

        info = scan(folder)
        out.update({k: info[k] for k in ("entries", "files", "bytes", "problems")})
        out["kernels"] = info["indexes"]
        out["foreign_indexes"] = info["foreign"]
    else:  # without importing Numba: count the index files
        out["kernels"] = sum(n.endswith(".k1.nbi") for _d, _s, names in os.walk(folder) for n in names)
        out["files"], out["bytes"] = _size(folder)
    out["bytes_all_versions"] = sum(_size(os.path.join(root, v))[1] for v in versions)
    if clear:
        removed = []
        for v in versions:
            path = os.path.join(root, v)
            shutil.rmtree(path, ignore_errors=True)
            if not os.path.exists(path):
                removed.append(path)
        out["removed"] = removed
        out["not_removed"] = [os.path.join(root, v) for v in versions if os.path.join(root, v) not in removed]
    return out


def cache_command(
    verify: Annotated[
        bool, typer.Option("--verify", help="check every cached kernel against its index; exit 1 on a mismatch")
    ] = False,
    clear: Annotated[bool, typer.Option("--clear", help="remove the cached kernels of every version of this package")] = False,
    json_out: JsonOut = False,
) -> None:
    """Show where the compiled kernels are cached and how big the cache is; --verify checks it, --clear empties it.

    Keyed on the package's sources (a folder per version), then per kernel and control law (an
    index each), each entry's data file named from its key and checked when loaded; writes are
    locked, so processes compiling at the same time (a sweep's workers, Dask, two terminals) cannot
    mix two laws' machine code.
    """
    try:
        rep = cache_report(verify=verify, clear=clear)
    except Exception as exc:
        from ..errors import ForceControlError

        if isinstance(exc, ForceControlError):
            _fail(exc)
        raise
    problems = rep.get("problems", [])
    if json_out:
        print_json({**rep, "ok": not problems})
    else:
        mb = rep["bytes"] / 1e6
        console.print(f"kernel cache: {rep['folder']}")
        console.print(f"  {rep['kernels']} kernels, {rep['files']} files, {mb:.1f} MB (this version)")
        others = [v for v in rep["versions"] if os.path.join(rep["root"], v) != os.path.normpath(rep["folder"])]
        if others:
            console.print(f"  {len(others)} other source version(s) under {rep['root']}: "
                          f"{(rep['bytes_all_versions'] - rep['bytes']) / 1e6:.1f} MB (--clear removes them)")
        if verify and not problems:
            console.print(f"  verified: {rep['entries']} entries, each data file belongs to its kernel and key")
        for path in rep.get("removed", []):
            console.print(f"removed {path}")
    for path in rep.get("not_removed", []):
        err_console.print(f"forcecontrol cache: could not remove {path}", highlight=False, soft_wrap=True)
    if problems:
        for p in problems:
            sys.stderr.write(f"forcecontrol cache: {p}\n")
        sys.stderr.write(
            f"forcecontrol cache: {len(problems)} cached kernel entr{'y' if len(problems) == 1 else 'ies'} do not match "
            "their index (those kernels recompile when loaded); `forcecontrol cache --clear` removes the cache\n"
        )
        raise typer.Exit(code=1)
