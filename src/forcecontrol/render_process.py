"""Figures drawn in a second process that loads matplotlib while the simulation runs.

Loading matplotlib costs about 0.35 s, as much as half of a short ``forcecontrol run``, and a
simulation runs on one core. :func:`start` launches a Python process that loads matplotlib and
:mod:`forcecontrol.plotting` at once, on another core, and then waits for figures to draw;
:meth:`FigureProcess.render` sends it the :func:`~forcecontrol.plotting.figure_jobs` of a finished
run (results, signals, marks, paths) and returns the paths it wrote. The PNG files are the same,
byte for byte, as those drawn in the calling process.

Whenever the second process cannot help, the figures are drawn in the calling process: one core
only, the process did not start, it died or its answer is not understood (what it wrote on stderr
is then dropped; after a good answer it is passed on, e.g. matplotlib's warnings). An error of the figure
itself (an unknown signal, say) is raised by drawing again in the calling process, so the caller
sees the very exception :func:`~forcecontrol.plotting.plot_results` raises.

Run as ``python -m forcecontrol.render_process``, it is the second process: it reads one pickled
list of jobs on stdin and writes a JSON answer on stdout (``{"paths": [...]}`` or ``{"error": ...}``).
"""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
from pathlib import Path
from typing import Any

__all__ = ["FigureProcess", "start", "usable_cores"]

#: the command of the second process (a list, so that tests can replace it).
COMMAND = [sys.executable, "-m", "forcecontrol.render_process"]


def usable_cores() -> int:
    """Cores this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


class FigureProcess:
    """A running (or absent) figure process; :meth:`render` draws the jobs and returns the paths."""

    def __init__(self, proc: subprocess.Popen[bytes] | None):
        self._proc = proc

    @property
    def started(self) -> bool:
        """Whether a second process is running (else :meth:`render` draws in this process)."""
        return self._proc is not None

    def render(self, jobs: list[tuple[tuple[Any, ...], dict[str, Any]]]) -> list[Path]:
        """Draw ``jobs`` (from :func:`~forcecontrol.plotting.figure_jobs`) and return the written paths.

        In the second process when it runs and answers; otherwise, or if it reports an error, in
        this process (which raises that error as :func:`~forcecontrol.plotting.plot_results` does).
        """
        proc, self._proc = self._proc, None
        if proc is not None:
            try:
                data = pickle.dumps(jobs, protocol=pickle.HIGHEST_PROTOCOL)
            except Exception:  # noqa: BLE001 - something in the results cannot be pickled: draw here
                data = None
            answer: Any = {}
            err = b""
            try:
                if data is not None:
                    out, err = proc.communicate(data)
                    answer = json.loads(out) if proc.returncode == 0 else {}
            except (OSError, ValueError):
                answer = {}
            finally:
                _reap(proc)
            if isinstance(answer, dict) and isinstance(answer.get("paths"), list):
                if err:  # the drawing's warnings, as drawing here would have shown them
                    sys.stderr.write(err.decode(errors="replace"))
                return [Path(p) for p in answer["paths"]]
        from .plotting import plot_results

        return [plot_results(*args, **kwargs) for args, kwargs in jobs]

    def close(self) -> None:
        """Stop the second process without drawing (the run failed, say)."""
        proc, self._proc = self._proc, None
        if proc is not None:
            _reap(proc)

    def __enter__(self) -> FigureProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _reap(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.kill()
    proc.wait()
    for stream in (proc.stdin, proc.stdout, proc.stderr):
        if stream is not None and not stream.closed:
            stream.close()


def start(min_cores: int = 2) -> FigureProcess:
    """Launch the figure process when it can run beside this one (at least ``min_cores`` usable
    cores); else, or if it cannot be launched, a :class:`FigureProcess` that draws in this process."""
    if usable_cores() < min_cores:
        return FigureProcess(None)
    try:
        proc = subprocess.Popen(COMMAND, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    except OSError:
        return FigureProcess(None)
    return FigureProcess(proc)


def _main() -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401  (loaded while the caller simulates)

    from .plotting import plot_results
    from .result import SimulationResult  # noqa: F401  (the unpickled results' class)

    try:
        jobs = pickle.load(sys.stdin.buffer)
    except EOFError:  # the caller closed without jobs
        return 0
    try:
        paths = [str(plot_results(*args, **kwargs)) for args, kwargs in jobs]
    except Exception as exc:  # noqa: BLE001 - reported to the caller, which draws again to raise it
        sys.stdout.write(json.dumps({"error": f"{type(exc).__name__}: {exc}"}))
        return 0
    sys.stdout.write(json.dumps({"paths": paths}))
    sys.stdout.flush()
    os._exit(0)  # the files are closed and the answer sent: skip the interpreter's shutdown


if __name__ == "__main__":
    sys.exit(_main())
