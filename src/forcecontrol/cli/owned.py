"""Single output files a command writes at a path the user named (``calibrate-plan --out``): the library's rule.

An existing file is overwritten only when forcecontrol wrote it (a mark beside it,
``.<name>.forcecontrol-<command>.json``, as ``convert`` and ``sweep`` mark their outputs) or when
the user passed ``--force``; then a note says that a file forcecontrol did not write is replaced.
A folder is never replaced.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..errors import OutputError

__all__ = ["claim_output", "mark_output", "is_ours"]


def _mark_path(path: Path, command: str) -> Path:
    return path.with_name(f".{path.name}.forcecontrol-{command}.json")


def is_ours(path: Path, command: str) -> bool:
    """``path`` carries the mark ``command`` writes beside its outputs (and the mark names this file)."""
    try:
        doc = json.loads(_mark_path(path, command).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and doc.get("file") == path.name


def claim_output(path: Path, command: str, force: bool, option: str = "--out") -> list[str]:
    """Check that ``command`` may write ``path``; return the notes to show (stderr and ``--json``).

    Raises:
        OutputError: ``path`` is a folder, or an existing file forcecontrol did not write and ``force`` is off.
    """
    if path.is_dir():
        raise OutputError(f"{option} {str(path)!r} is an existing folder; expected a file path (a folder is never "
                          "replaced, even with --force)")
    if not (path.exists() or path.is_symlink()) or is_ours(path, command):
        return []
    if not force:
        raise OutputError(f"{option} {str(path)!r} already exists and was not written by forcecontrol {command}; "
                          "pass --force to overwrite it, or name another file")
    return [f"--force: {path} was not written by forcecontrol; it is replaced"]


def mark_output(path: Path, command: str) -> None:
    """Mark ``path`` as written by ``command`` (so that a later run may replace it without ``--force``)."""
    try:
        _mark_path(path, command).write_text(json.dumps({"file": path.name}), encoding="utf-8")
    except OSError:  # the file itself was written; without a mark the next run asks for --force
        pass
