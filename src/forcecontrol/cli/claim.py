"""One command at a time per output folder: the claim that ``run``, ``replay`` and ``compare-trace`` take.

Two commands started at once with the same output chose the same folder: each saw it missing or
empty, and both wrote into it (one run's figure and logs over the other's, with no word said). A
command now claims its folder before it writes: an exclusive ``flock`` on
``.<folder name>.forcecontrol-run.lock`` beside the folder, holding the owner's pid, kept until the
command ends (then the file is removed). A folder that a live process has claimed is skipped by the
default output (the next free ``<name>-2``, ...) and refused with an explicit ``--out`` (with or without
``--force``: two writers would mix their files). The kernel drops the lock of a killed process, so a
claim left behind by one is taken over (:mod:`forcecontrol.core.locks`, shared with the sweeps' output
lock). Where ``flock`` is missing (Windows) or refused (``ENOLCK`` on some network file systems) the
folder is used unclaimed, as before.
"""

from __future__ import annotations

from pathlib import Path

from ..core import locks

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
        """End the claim (:func:`forcecontrol.core.locks.release`); a second call does nothing."""
        fd, self._fd = self._fd, None
        if fd is not None:
            locks.release(self.lock, fd)


def holder(owner: str) -> str:
    """The words for a claim's holder in a message: 'process 1234', or 'a process that is starting'."""
    return f"process {owner}" if owner.isdigit() else "a process that is starting"


def claim(folder: Path) -> FolderClaim | str:
    """Claim ``folder`` (its parent must exist): the held claim, or the pid (text) of the live process holding it
    (``'starting'`` when it has not written it yet)."""
    lock = lock_path(folder)
    got = locks.try_lock(lock)
    if isinstance(got, str):
        return got
    if got is not None:
        locks.write_pid(got)
    return FolderClaim(lock, got)
