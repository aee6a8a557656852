"""One command at a time per output folder: the claim that ``run``, ``replay`` and ``compare-trace`` take.

Two commands started at once with the same output chose the same folder: each saw it missing or
empty, and both wrote into it (one run's figure and logs over the other's, with no word said). A
command now claims its folder before it writes: an exclusive ``flock`` on
``.<folder name>.forcecontrol-run.lock`` beside the folder, holding the owner's pid, kept until the
command ends (then the file is removed). A folder that a live process has claimed is skipped by the
default output (the next free ``<name>-2``, ...) and refused with an explicit ``--out`` (with or without
``--force``: two writers would mix their files). The kernel drops the lock of a killed process, so a
claim left behind by one is taken over. Where ``flock`` is missing (Windows) or refused (``ENOLCK`` on
some network file systems) the folder is used unclaimed, as before.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["FolderClaim", "claim", "holder", "lock_path"]


def lock_path(folder: Path) -> Path:
    """The claim's lock file of ``folder``: hidden, beside it (never inside: the folder holds only the run's files);
    absolute, so that a release after a change of the working folder removes this file and no other."""
    folder = folder.absolute()
    return folder.with_name(f".{folder.name}.forcecontrol-run.lock")


class FolderClaim:
    """A held claim (``fd`` None: unclaimed, where locks are unavailable); :meth:`release` ends it."""

    def __init__(self, lock: Path, fd: int | None) -> None:
        self.lock = lock
        self._fd = fd

    @property
    def held(self) -> bool:
        return self._fd is not None

    def release(self) -> None:
        """Remove the lock file while holding the lock (a process waiting on it then opens a new one), then drop it."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            self.lock.unlink(missing_ok=True)
        except OSError:  # pragma: no cover - the folder's parent became read-only meanwhile
            pass
        os.close(fd)


def holder(owner: str) -> str:
    """The words for a claim's holder in a message: 'process 1234', or 'a process that is starting'."""
    return f"process {owner}" if owner.isdigit() else "a process that is starting"


def _owner(fd: int) -> str:
    """The holder's pid as its lock file says, or 'starting' (locked, its pid not written yet)."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return os.read(fd, 32).decode("ascii", "replace").strip() or "starting"
    except OSError:  # pragma: no cover
        return "starting"


def _open(lock: Path) -> int | None:
    """The lock file opened for writing (created), or for reading only when it is another user's (a shared output
    root: the lock then still tells a live holder; the pid is not written); None when it cannot be opened at all."""
    try:
        return os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
    except PermissionError:
        try:
            return os.open(lock, os.O_RDONLY)
        except OSError:
            return None
    except OSError:
        return None


def claim(folder: Path) -> FolderClaim | str:
    """Claim ``folder`` (its parent must exist): the held claim, or the pid (text) of the live process holding it
    (``'starting'`` when it has not written it yet)."""
    lock = lock_path(folder)
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: no claim, as before
        return FolderClaim(lock, None)
    for _ in range(100):  # the holder may remove the file between our open and our lock: open the new one
        fd = _open(lock)
        if fd is None:  # a parent we cannot write in: prepare_output's own checks say so
            return FolderClaim(lock, None)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            owner = _owner(fd)
            os.close(fd)
            return owner
        except OSError:  # pragma: no cover - ENOLCK (some network file systems): unclaimed, as before
            os.close(fd)
            return FolderClaim(lock, None)
        try:
            same = os.fstat(fd).st_ino == os.stat(lock).st_ino
        except FileNotFoundError:
            same = False
        if same:
            try:  # the pid only names the holder in messages: a full disk does not stop the claim
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode("ascii"))
            except OSError:
                pass
            return FolderClaim(lock, fd)
        os.close(fd)
    return "starting"  # pragma: no cover - the file kept being replaced: treat the folder as busy
