"""Lock files between processes: an exclusive ``flock`` taken without waiting, holding the owner's pid.

Shared by a sweep's output lock (:mod:`forcecontrol.sweep.store`) and a command's claim of its run
folder (:mod:`forcecontrol.cli.claim`). The kernel drops a dead process's ``flock``, so a lock file
left by a killed process is taken over; a live one never is. The holder removes the file while it
still holds the lock (:func:`release`), so a process that opened the old file before it went away
finds, after its own ``flock``, that the file at the path is another one, and opens that instead.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["try_lock", "read_pid", "write_pid", "release"]


def _open(lock: Path) -> int | None:
    """The lock file opened for writing (created), or for reading only when it is another user's (a shared
    folder: the lock still tells a live holder; no pid is written); None when it cannot be opened at all."""
    try:
        return os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
    except PermissionError:
        try:
            return os.open(lock, os.O_RDONLY)
        except OSError:
            return None
    except OSError:
        return None


def try_lock(lock: Path) -> int | str | None:
    """Take the exclusive ``flock`` of ``lock`` without waiting.

    Returns:
        the locked file descriptor (the file at the path; its content is the previous holder's pid, if any);
        or, when a live process holds it, that process's pid as text (``'starting'`` before it wrote it);
        or None where locks are unavailable: no ``fcntl`` (Windows), ``ENOLCK`` (some network file
        systems), or a file that cannot be opened.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        return None
    for _ in range(100):  # the holder may remove the file between our open and our lock: open the new one
        fd = _open(lock)
        if fd is None:
            return None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = read_pid(fd)
            os.close(fd)
            return str(pid) if pid else "starting"
        except OSError:  # ENOLCK and the like
            os.close(fd)
            return None
        try:
            same = os.fstat(fd).st_ino == os.stat(lock).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)
    return "starting"  # pragma: no cover - the file kept being replaced: treat it as held


def read_pid(fd: int) -> int:
    """The pid written in the lock file, 0 when none (or unreadable)."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return int(os.read(fd, 32).decode("ascii", "replace").strip() or "0")
    except (OSError, ValueError):
        return 0


def write_pid(fd: int) -> None:
    """Write this process's pid in the held lock file (best effort: it only names the holder in messages)."""
    try:
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
    except OSError:
        pass


def release(lock: Path, fd: int) -> None:
    """Remove the lock file while holding its lock (a process waiting on it then opens a new one), then drop it."""
    try:
        lock.unlink(missing_ok=True)
    except OSError:  # pragma: no cover - the folder became read-only meanwhile
        pass
    os.close(fd)
