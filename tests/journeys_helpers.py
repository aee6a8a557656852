"""Helpers of the end-to-end journeys (tests/test_journeys*.py): the ``forcecontrol`` command run as a user runs it.

Every journey runs the console script found on PATH (the virtual environment's, beside this
interpreter when PATH lacks it) as a subprocess in a temporary folder, with the user's environment.
"""

from __future__ import annotations

import os
import re
import shlex
import struct
import subprocess
from pathlib import Path

import cli_server
from cli_server import executable

__all__ = ["TIMEOUT", "PNG_MAGIC", "executable", "forcecontrol", "shell", "assert_no_traceback", "png_size",
           "assert_figure", "rich_tables", "number", "fenced_commands"]

#: a cold Numba cache compiles for a few seconds per law; a loaded 2-core machine stretches that.
TIMEOUT = 900.0
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def forcecontrol(cwd: Path, *args: str | Path, ok: bool = True, timeout: float = TIMEOUT) -> subprocess.CompletedProcess:
    """Run ``forcecontrol ARGS`` in ``cwd`` (its own process, forked from this worker's command server:
    tests/cli_server.py); with ``ok``: exit 0 and no traceback on stderr (else the output in the failure)."""
    proc = cli_server.run([str(a) for a in args], cwd=cwd, timeout=timeout)
    if ok:
        shown = "forcecontrol " + " ".join(shlex.quote(str(a)) for a in args)
        assert proc.returncode == 0, f"{shown} (in {cwd}) exited {proc.returncode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}"
        assert_no_traceback(proc)
    return proc


def shell(cwd: Path, line: str, timeout: float = TIMEOUT) -> subprocess.CompletedProcess:
    """Run one line of a document's bash block verbatim (``forcecontrol`` is resolved as on the user's PATH)."""
    env = dict(os.environ)
    env["PATH"] = str(Path(executable()).parent) + os.pathsep + env.get("PATH", "")
    proc = subprocess.run(["bash", "-c", line], cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env,
                          encoding="utf-8")
    assert proc.returncode == 0, f"{line!r} (in {cwd}) exited {proc.returncode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}"
    assert_no_traceback(proc)
    return proc


def assert_no_traceback(proc: subprocess.CompletedProcess) -> None:
    """No Python traceback on stderr or stdout."""
    for stream in (proc.stderr, proc.stdout):
        assert "Traceback (most recent call last)" not in stream, stream[-5000:]


def png_size(path: Path) -> tuple[int, int]:
    """Width and height of a PNG file, read from its IHDR chunk (and the file checked to be a whole PNG)."""
    data = Path(path).read_bytes()
    assert data[:8] == PNG_MAGIC, f"{path} is not a PNG"
    assert data[12:16] == b"IHDR" and data[-8:-4] == b"IEND", f"{path} is a truncated PNG"
    return struct.unpack(">II", data[16:24])


def assert_figure(path: Path, min_side: int = 300, min_bytes: int = 10_000) -> None:
    """A valid PNG of a sensible size: both sides at least ``min_side`` pixels, not a blank few-byte image."""
    w, h = png_size(path)
    assert w >= min_side and h >= min_side and w <= 10_000 and h <= 10_000, f"{path}: {w} x {h} pixels"
    assert Path(path).stat().st_size >= min_bytes, f"{path}: only {Path(path).stat().st_size} bytes"


def rich_tables(text: str) -> list[list[dict[str, str]]]:
    """The tables of a command's output (rich box drawing) as lists of rows {header: cell}.

    A cell that rich wrapped over several lines is joined back (a continuation line has one
    non-empty cell).
    """
    tables: list[list[dict[str, str]]] = []
    header: list[str] = []
    for line in text.splitlines():
        line = line.rstrip()
        if line.startswith("┏"):
            header = []
            tables.append([])
        elif line.startswith("┃"):
            cells = [c.strip() for c in line.strip("┃").split("┃")]
            header = cells if not header else [f"{a} {b}".strip() for a, b in zip(header, cells)]
        elif line.startswith("│") and tables:
            cells = [c.strip() for c in line.strip("│").split("│")]
            rows = tables[-1]
            if rows and len(cells) >= 3 and sum(bool(c) for c in cells) == 1:  # one wrapped cell's next line
                for k, c in zip(header, cells):
                    if c:
                        rows[-1][k] = f"{rows[-1][k]} {c}"
            else:
                rows.append(dict(zip(header, cells)))
    return tables


def number(cell: str) -> float:
    """A table cell as a float (``-0.000`` and ``1e+04`` included)."""
    m = re.fullmatch(r"[-+]?[0-9.]+(e[-+]?[0-9]+)?", cell.strip())
    assert m, f"not a number: {cell!r}"
    return float(cell)


def fenced_commands(markdown: str, language: str = "bash") -> list[str]:
    """The ``forcecontrol ...`` lines of a Markdown file's fenced blocks of ``language``, verbatim (comments dropped)."""
    out = []
    for block in re.findall(rf"```{language}\n(.*?)```", markdown, flags=re.S):
        for line in block.splitlines():
            line = line.split(" #")[0].strip() if not line.lstrip().startswith("#") else ""
            for part in line.split("&&"):
                part = part.strip()
                if part.startswith("forcecontrol "):
                    out.append(part)
    return out
