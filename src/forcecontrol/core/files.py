"""Opening input files safely: regular files only, within a size limit, without echoing their content.

Every reader of a user-named file (sampled references, recorded data, URDFs, calibration tables)
goes through :func:`check_regular` / :func:`read_bytes_limited` so that

* a FIFO, a device (``/dev/zero``), a socket or a folder is refused by ``os.stat`` before it is
  opened, and the file is opened with ``O_NONBLOCK`` so a FIFO swapped in between cannot block;
* a file larger than the limit is refused before it is read (and reading stops at the limit
  should it grow meanwhile): :data:`MAX_TABLE_BYTES` (64 MiB) for URDFs, references and
  calibration tables, :data:`MAX_RECORDING_BYTES` (2 GiB) for recordings; each reader takes a
  ``max_bytes`` keyword to change it;
* messages name the file and the problem, never its content: at most :func:`excerpt`, a short
  escaped excerpt of one offending token.
"""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path
from typing import Any

from ..errors import ParameterError

__all__ = ["MAX_TABLE_BYTES", "MAX_RECORDING_BYTES", "check_regular", "read_bytes_limited", "read_text_limited", "excerpt",
           "column_label"]

#: default size limit of URDFs, sampled references and calibration tables [bytes] (64 MiB).
MAX_TABLE_BYTES = 64 * 2**20
#: default size limit of recordings (CSV/Parquet tables, ROS 2 bags, MCAP files) [bytes] (2 GiB).
MAX_RECORDING_BYTES = 2 * 2**30


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def excerpt(value: Any, limit: int = 24) -> str:
    """A short, escaped excerpt of an offending token for an error message (never a whole line)."""
    s = str(value)
    short = s[:limit]
    return repr(short) + ("..." if len(s) > limit else "")


def column_label(name: Any, index: int) -> str:
    """A column for an error message: its name when it looks like one (a short identifier), else its position.

    A header that is not a list of names (e.g. a binary or an environment file read by mistake)
    is thus never echoed.
    """
    s = str(name)
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.\-]{0,31}", s):
        return repr(s)
    return f"number {index + 1}"


def check_regular(path: str | Path, what: str, max_bytes: int = MAX_TABLE_BYTES) -> Path:
    """``path`` as a Path, after checking it is an existing regular file of at most ``max_bytes``.

    Args:
        path: the file.
        what: what the file holds, for messages: ``"cannot read {what} {path}: {problem}"``.
        max_bytes: the size limit [bytes].

    Raises:
        ParameterError: no such file, not a regular file (folder, FIFO, device, socket), or
            larger than ``max_bytes`` (the message names the file, its kind or size and the limit).
    """
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise ParameterError(f"cannot read {what} {str(p)!r}: it does not exist") from None
    except OSError as exc:
        raise ParameterError(f"cannot read {what} {str(p)!r}: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ParameterError(f"cannot read {what} {str(p)!r}: it is {_kind(st.st_mode)}; a regular file is needed")
    if st.st_size > max_bytes:
        raise ParameterError(
            f"cannot read {what} {str(p)!r}: it is {st.st_size} bytes, above the limit of {max_bytes} bytes "
            "(pass max_bytes= to raise it)"
        )
    return p


def read_bytes_limited(path: str | Path, what: str, max_bytes: int = MAX_TABLE_BYTES) -> bytes:
    """The content of a regular file of at most ``max_bytes`` (see :func:`check_regular`).

    The file is opened with ``O_NONBLOCK`` and checked again through its descriptor, so a FIFO or
    device swapped in after the first check is refused instead of blocking or reading forever.
    """
    p = check_regular(path, what, max_bytes)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(p, flags)
    except OSError as exc:
        raise ParameterError(f"cannot read {what} {str(p)!r}: {exc.strerror}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ParameterError(f"cannot read {what} {str(p)!r}: it is {_kind(st.st_mode)}; a regular file is needed")
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > max_bytes:
                raise ParameterError(
                    f"cannot read {what} {str(p)!r}: it grew above the limit of {max_bytes} bytes while being read"
                )
    except OSError as exc:
        raise ParameterError(f"cannot read {what} {str(p)!r}: {exc.strerror}") from None
    finally:
        os.close(fd)
    return b"".join(chunks)


def read_text_limited(path: str | Path, what: str, max_bytes: int = MAX_TABLE_BYTES) -> str:
    """The UTF-8 text of a regular file of at most ``max_bytes``; a decoding error names the byte offset only."""
    data = read_bytes_limited(path, what, max_bytes)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ParameterError(
            f"cannot read {what} {str(path)!r}: it is not UTF-8 text (byte {exc.start} cannot be decoded)"
        ) from None
