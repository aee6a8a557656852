"""Figures drawn in a second process that loads matplotlib while the simulation runs.

Loading matplotlib costs about 0.35 s, as much as half of a short ``forcecontrol run``, and a
simulation runs on one core. :func:`start` launches a Python process that loads matplotlib and
:mod:`forcecontrol.viz.plotting` at once, on another core, and then waits for figures to draw;
:meth:`FigureProcess.render` sends it the :func:`~forcecontrol.viz.plotting.figure_jobs` of a finished
run (results, signals, marks, paths) and returns the paths it wrote. The PNG files are the same,
byte for byte, as those drawn in the calling process.

Whenever the second process cannot help, or could draw otherwise than the caller would, the
figures are drawn in the calling process:

* matplotlib's pyplot is loaded here already, on the Agg backend or before any backend was
  chosen (a program that drew to files, a test runner): there is no import left to overlap with
  the simulation, and the second process would only load it once more (about 0.5 s of CPU) to draw
  what this process draws at the same cost (a notebook's backend is left alone: drawing here would
  switch it to Agg, so its figures are drawn by the second process);
* fewer than two usable cores (affinity and the cgroup's CPU quota);
* no interpreter to start (``sys.executable`` empty, or a frozen application);
* warnings set to raise in the caller (they must raise here, as before);
* the process did not start, died, or answered something that is not one path per figure;
* it imported another ``forcecontrol`` or matplotlib than the caller would;
* the results cannot be pickled.

What the process wrote on stderr (matplotlib's warnings, say) is passed on after a good answer and
dropped otherwise. An error of the figure itself (an unknown signal, say) is raised by drawing
again in the calling process, so the caller sees the very exception
:func:`~forcecontrol.viz.plotting.plot_results` raises.

The second process is ``python <the caller's interpreter flags> -c CHILD_CODE``, without the
current folder on its path. It reads one pickled list of jobs on stdin and answers on stdout,
after :data:`ANSWER_MARK`, in JSON: ``{"paths": [...], "modules": {...}}`` or ``{"error": ...}``
(anything else printed on its stdout goes to its stderr or comes before the mark).
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import math
import os
import pickle
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

__all__ = ["FigureProcess", "start", "usable_cores", "drawing_loaded", "command", "CHILD_CODE", "ANSWER_MARK"]

#: what the second process runs (``python -c``): the current folder is dropped from its path, so
#: that it imports what the caller imports (a console script has no current folder on its path).
CHILD_CODE = (
    "import sys\n"
    "if sys.path and sys.path[0] == '':\n"
    "    del sys.path[0]\n"
    "from forcecontrol.viz.render_process import _main\n"
    "_main()\n"
)

#: what precedes the answer on the second process's stdout.
ANSWER_MARK = b"\x00forcecontrol-figures:"

#: how long :meth:`FigureProcess.close` lets the process end by itself before killing it [s].
CLOSE_TIMEOUT = 2.0


def usable_cores() -> int:
    """Cores this process may run on: its affinity mask where the OS has one, capped by a
    cgroup v2 CPU quota (a container's ``--cpus``), rounded down, at least 1."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - macOS, Windows
        n = os.cpu_count() or 1
    try:
        quota, period = Path("/sys/fs/cgroup/cpu.max").read_text().split()[:2]
        if quota != "max":
            n = min(n, max(1, math.floor(int(quota) / int(period))))
    except (OSError, ValueError):
        pass
    return n


def command() -> list[str] | None:
    """The second process's command line, or None when there is no interpreter to start: an
    embedded interpreter without ``sys.executable``, or a frozen application (whose executable is
    the application itself)."""
    exe = sys.executable
    if not exe or getattr(sys, "frozen", False):
        return None
    flags = getattr(subprocess, "_args_from_interpreter_flags", lambda: [])()  # -W, -X, -O, -s, -E, ...
    return [exe, *flags, "-c", CHILD_CODE]


def _warnings_raise() -> bool:
    """Whether a warning filter of this process turns warnings into errors (then the figures are
    drawn here, where those warnings raise)."""
    return any(f[0] == "error" for f in warnings.filters)


def _module_files() -> dict[str, str | None]:
    """Where this process's ``forcecontrol`` and matplotlib come from (matplotlib found, not imported)."""
    mpl = sys.modules.get("matplotlib")
    if mpl is not None:
        mpl_file = getattr(mpl, "__file__", None)
    else:
        spec = importlib.util.find_spec("matplotlib")
        mpl_file = spec.origin if spec is not None else None
    return {"forcecontrol": __file__, "matplotlib": mpl_file}


class FigureProcess:
    """A running (or absent) figure process; :meth:`render` draws the jobs and returns the paths."""

    def __init__(self, proc: subprocess.Popen[bytes] | None):
        self._proc = proc

    @property
    def started(self) -> bool:
        """Whether a second process is running (else :meth:`render` draws in this process)."""
        return self._proc is not None

    def render(self, jobs: list[tuple[tuple[Any, ...], dict[str, Any]]]) -> list[Path]:
        """Draw ``jobs`` (from :func:`~forcecontrol.viz.plotting.figure_jobs`) and return the written paths.

        In the second process when it runs and answers with one path per job; otherwise, or if it
        reports an error, in this process (which raises that error as
        :func:`~forcecontrol.viz.plotting.plot_results` does).
        """
        proc, self._proc = self._proc, None
        if proc is not None:
            paths = _exchange(proc, jobs)
            if paths is not None:
                return paths
        from .plotting import plot_results

        return [plot_results(*args, **kwargs) for args, kwargs in jobs]

    def close(self) -> None:
        """Stop the second process without drawing (the run failed, say): its stdin is closed, so
        that it ends by itself once its imports are done; it is killed after :data:`CLOSE_TIMEOUT`."""
        proc, self._proc = self._proc, None
        if proc is not None:
            _reap(proc, CLOSE_TIMEOUT)

    def __enter__(self) -> FigureProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _exchange(proc: subprocess.Popen[bytes], jobs: list[Any]) -> list[Path] | None:
    """Send the jobs, read the answer; the written paths, or None when the process did not draw
    them as this process would (the caller then draws)."""
    try:
        data = pickle.dumps(jobs, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:  # noqa: BLE001 - something in the results cannot be pickled: draw here
        _reap(proc, CLOSE_TIMEOUT)
        return None
    try:
        out, err = proc.communicate(data)
    except (OSError, ValueError):
        return None
    finally:
        _reap(proc, 0.0)
    if proc.returncode != 0 or ANSWER_MARK not in out:
        return None
    try:
        answer = json.loads(out.rsplit(ANSWER_MARK, 1)[1])
    except ValueError:  # also a UnicodeDecodeError
        return None
    paths = answer.get("paths") if isinstance(answer, dict) else None
    if not (isinstance(paths, list) and len(paths) == len(jobs) and all(isinstance(p, str) for p in paths)):
        return None
    if answer.get("modules") != _module_files():
        return None
    if err:  # the drawing's warnings, as drawing here would have shown them
        sys.stderr.write(err.decode("utf-8", errors="replace"))
    return [Path(p) for p in paths]


def _reap(proc: subprocess.Popen[bytes], timeout: float) -> None:
    for stream in (proc.stdin, proc.stdout, proc.stderr):
        if stream is not None and not stream.closed:
            stream.close()
    try:
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def drawing_loaded() -> bool:
    """Whether this process has loaded matplotlib's pyplot already, on Agg or with no backend chosen yet (then the
    figures are drawn here, where drawing selects Agg)."""
    if "matplotlib.pyplot" not in sys.modules:
        return False
    rc = sys.modules["matplotlib"].rcParams
    try:
        backend = rc._get_backend_or_none()  # None until pyplot resolves one (matplotlib >= 3.7)
    except AttributeError:  # pragma: no cover - older matplotlib: the raw value, a sentinel until resolved
        backend = dict.__getitem__(rc, "backend")
        backend = backend if isinstance(backend, str) else None
    return backend is None or backend.lower() == "agg"


def start(min_cores: int = 2) -> FigureProcess:
    """Launch the figure process when it can help (not :func:`drawing_loaded`), can run beside
    this one (at least ``min_cores`` usable cores) and draws as this process would; else, or if it
    cannot be launched, a :class:`FigureProcess` that draws in this process."""
    cmd = command()
    if cmd is None or drawing_loaded() or usable_cores() < min_cores or _warnings_raise():
        return FigureProcess(None)
    env = {**os.environ, "PYTHONIOENCODING": "utf-8"}  # stderr passed on as UTF-8 (Windows' code pages)
    try:
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    except (OSError, ValueError, TypeError):
        return FigureProcess(None)
    return FigureProcess(proc)


def _main() -> None:
    """The second process: load matplotlib, draw the jobs read on stdin, answer after :data:`ANSWER_MARK`."""
    answer = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # whatever else prints to stdout goes to stderr, not into the answer
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401  (loaded while the caller simulates)

    # the unpickled results' class, loaded now, while the caller simulates (pickle would import it
    # anyway when the jobs arrive; by name, since figures do not depend on the simulator's code)
    importlib.import_module("forcecontrol.sim.result")
    from .plotting import plot_results

    try:
        jobs = pickle.load(sys.stdin.buffer)
    except EOFError:  # the caller closed without jobs
        return
    try:
        reply: dict[str, Any] = {"paths": [str(plot_results(*args, **kwargs)) for args, kwargs in jobs],
                                 "modules": _module_files()}
    except Exception as exc:  # noqa: BLE001 - reported to the caller, which draws again to raise it
        reply = {"error": f"{type(exc).__name__}: {exc}"}
    answer.write(ANSWER_MARK + json.dumps(reply).encode())
    answer.flush()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)  # the files are closed and the answer sent: skip the interpreter's shutdown
