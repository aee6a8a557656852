"""File names built from user data: one safe component, and a check that a path stays inside its folder.

Every file the library writes is named from user data somewhere (a scenario's name, a case
label, a ``[figure] name``, ``--out``). :func:`safe_name` turns such text into one file-name
component (no separators, no ``..``, no control characters, bounded length), and
:func:`inside` checks that a path, symlinks resolved, is inside the folder the user named.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import OutputError

__all__ = ["safe_name", "inside", "MAX_NAME"]

#: longest name component :func:`safe_name` returns (file systems allow 255 bytes; room for suffixes).
MAX_NAME = 120


def safe_name(text: object, default: str = "out") -> str:
    """``text`` as one file-name component: letters, digits, ``_``, single dots and dashes; never '.', '..', a path.

    >>> safe_name("../../etc/x")
    'etc-x'
    """
    s = re.sub(r"[^A-Za-z0-9_.]+", "-", str(text))
    s = re.sub(r"\.{2,}", ".", s).strip("-.")[:MAX_NAME].strip("-.")
    return s or default


def inside(folder: str | Path, path: str | Path) -> Path:
    """``path`` (relative paths are taken in ``folder``) when it resolves inside ``folder``; symlinks resolved.

    Raises:
        OutputError: ``path`` escapes ``folder``.
    """
    folder = Path(folder)
    p = Path(path)
    p = p if p.is_absolute() else folder / p
    root = folder.resolve()
    try:
        p.resolve().relative_to(root)
    except ValueError:
        raise OutputError(
            f"output path {str(path)!r}: expected a file inside the output folder {str(folder)!r}, "
            f"but it resolves to {str(p.resolve())!r}; the name must not contain '..', separators or symlinks out"
        ) from None
    return p
