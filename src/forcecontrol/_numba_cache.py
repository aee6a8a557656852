"""Numba's on-disk cache, keyed on this package's source.

Numba's ``cache=True`` checks only the source file of the function it compiles, so a compiled
loop that calls a dispatcher in another module keeps running the old dispatcher after that
module changes. To make stale caches impossible, every distinct version of the package's
sources gets its own cache folder: ``<cache root>/forcecontrol-<hash of all .py files>``.

The cache root is ``$NUMBA_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/forcecontrol/numba``
(``~/.cache/forcecontrol/numba``). This module must be imported before any module that
decorates functions with ``@njit(cache=True)`` (the package ``__init__`` does so first).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["configure", "CACHE_DIR"]

CACHE_DIR: str | None = None


def _source_hash(root: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def configure() -> str | None:
    """Point Numba's cache at the folder of this source version; return it (None if unusable)."""
    global CACHE_DIR
    import numba

    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "forcecontrol", "numba"
    )
    folder = os.path.join(base, f"forcecontrol-{_source_hash(Path(__file__).parent)}")
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError:  # pragma: no cover - read-only home: keep Numba's own default
        return None
    numba.config.CACHE_DIR = folder  # type: ignore[attr-defined]  # read when a cached function compiles
    CACHE_DIR = folder
    return folder
