"""``forcecontrol ARGS`` run as its own process, forked from one that has already started Python and imported the command.

A command line test pays, before the command does anything, for a new interpreter and its imports (NumPy, Numba,
typer, rich, pydantic, the scenario parts): about 0.35 s of CPU, as much as the whole command for ``analyze`` or
``show``, and the suite runs several hundred of them (issue 33 item 4). Here each pytest worker keeps one *command
server*: a Python process started as the console script starts (same interpreter, same environment, UTF-8) that has
imported :mod:`forcecontrol.cli` and then waits; :func:`run` asks it to fork, and the forked child runs the command as
the console script would (``sys.argv``, the working folder, the environment, stdin, stdout and stderr of its own, the
console script's ``main``) and exits through the interpreter's normal shutdown. Each command starts from the server's
state, never from another command's: what one command changes in its process is gone with it.

What a forked command does not repeat is the interpreter's start and the imports. They stay tested by the commands
that always run in a new process: the README's lines (``journeys_helpers.shell``), the concurrent, cold-cache and
warm-cache runs, and every command given an environment that the imports read (:data:`RUNTIME_VARIABLES` says which
variables may differ). The server also refuses to serve, and every command then runs in a new process, when its imports
printed anything (a warning a user would see), left a thread running (a fork would copy it half-way) or failed.
``FORCECONTROL_TEST_NEW_PROCESSES=1`` makes every command of the suite run in a new process, as before this module.

tests/test_cli_server.py checks that a forked command and a new process give the same exit code, stdout and stderr.
"""

from __future__ import annotations

import atexit
import json
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

#: variables a command reads while it runs, not while Python starts or imports: a request may differ from the server's
#: environment in these (the child runs with the request's values); a difference in any other variable runs a new process
RUNTIME_VARIABLES = frozenset({"COLUMNS", "LINES", "NO_COLOR", "FORCE_COLOR", "TERM", "PYTEST_CURRENT_TEST",
                               "FORCECONTROL_SWEEP_KERNEL", "PWD", "OLDPWD",
                               "FORCECONTROL_TEST_NEW_PROCESSES"})

#: values of these that change nothing when Python already runs in UTF-8 mode (the server is started with PYTHONUTF8=1)
UTF8_VARIABLES = {"PYTHONIOENCODING": {"utf-8", "utf8", "UTF-8", "UTF8"}, "PYTHONUTF8": {"1"}}

#: what the server imports before it serves, besides :mod:`forcecontrol.cli` (whose commands import what they use when
#: they run): what the commands of the suite import, so that a forked command imports almost nothing; with pyplot loaded
#: (no backend chosen), a forked `run` draws its figures itself instead of starting a figure process that would load
#: matplotlib again (forcecontrol.viz.render_process.drawing_loaded; test_cli_server compares the PNGs with a new process's)
PRELOAD = ("forcecontrol.scenarios", "forcecontrol.cli.claim", "forcecontrol.analysis.force", "forcecontrol.sim",
           "typer._adapters", "rich.console", "control", "pinocchio", "forcecontrol.robots.pinocchio", "matplotlib.pyplot")

#: the server: started as the console script (its folder first on sys.path, no current folder), imports the command
#: line, reports whether it can fork safely, then serves one request at a time on the file descriptors it is given
SERVER_CODE = r"""
import io, json, os, sys, threading
req_fd, rep_fd, script, log = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
if sys.path and sys.path[0] == "":
    del sys.path[0]
sys.path.insert(0, os.path.dirname(script))  # as the console script: its folder, not the current one
before = dict(os.environ)
err_fd = os.dup(2)
logf = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
os.dup2(logf, 1)
os.dup2(logf, 2)  # what the imports print is what a new process would print: the server refuses to serve if anything
problem = None
try:
    import importlib
    import forcecontrol.cli as cli
    for name in sys.argv[5].split(","):
        importlib.import_module(name)
    sys.stdout.flush(); sys.stderr.flush()
except BaseException as exc:  # noqa: BLE001
    problem = f"the imports failed: {type(exc).__name__}: {exc}"
if problem is None and os.path.getsize(log):
    problem = "the imports printed: " + open(log, encoding="utf-8", errors="replace").read()[:2000]
threads = len(os.listdir("/proc/self/task")) if os.path.isdir("/proc/self/task") else threading.active_count()
if problem is None and threads != 1:
    problem = f"the imports left {threads - 1} thread(s) running (a fork copies them half-way): {threading.enumerate()}"
added = {k: v for k, v in os.environ.items() if before.get(k) != v}  # what the imports set (NUMBA_CACHE_DIR, ...)
removed = [k for k in before if k not in os.environ]
# the server's objects out of the collector's reach (Python's advice for a process that forks without exec): a
# collection in a command then neither walks nor copies them, which made each command's exit 0.3 s slower
import gc
gc.collect()
gc.freeze()
rep = os.fdopen(rep_fd, "w", buffering=1, encoding="utf-8")
req = os.fdopen(req_fd, "r", encoding="utf-8")
rep.write(json.dumps({"ready": problem is None, "problem": problem}) + "\n")
if problem is not None:
    sys.exit(0)
for line in req:
    r = json.loads(line)
    pid = os.fork()
    if pid == 0:  # the command
        try:
            req.close(); rep.close(); os.close(err_fd)
            os.chdir(r["cwd"])
            for fd, path, flags in ((0, os.devnull, os.O_RDONLY), (1, r["stdout"], os.O_WRONLY | os.O_TRUNC),
                                    (2, r["stderr"], os.O_WRONLY | os.O_TRUNC)):
                f = os.open(path, flags)
                os.dup2(f, fd)
                os.close(f)
            os.environ.clear()
            os.environ.update(r["env"])
            os.environ.update(added)
            for k in removed:
                os.environ.pop(k, None)
            if r["module"]:  # python -m forcecontrol: the current folder first on the path, argv[0] the module's file
                sys.path[0] = os.getcwd()
                sys.argv = [os.path.join(os.path.dirname(cli.__file__), os.pardir, "__main__.py"), *r["args"]]
                sys.argv[0] = os.path.normpath(sys.argv[0])
                import runpy
                runpy.run_module("forcecontrol", run_name="__main__", alter_sys=True)
            else:
                sys.argv = [script, *r["args"]]
                sys.exit(cli.main())
        except SystemExit:
            raise
        except BaseException:  # as a new process: the traceback on stderr, exit 1
            import traceback
            traceback.print_exc()
            sys.exit(1)
        sys.exit(0)
    rep.write(json.dumps({"pid": pid}) + "\n")
    _, status = os.waitpid(pid, 0)
    code = -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
    rep.write(json.dumps({"returncode": code}) + "\n")
"""

#: this worker's environment when the suite was collected, before any test changed it: the server's (a server started
#: while a test had set a variable would otherwise hold it, and every later command would differ from it)
_START_ENV = dict(os.environ)

_lock = threading.Lock()
_server: _Server | None = None
_refused: str | None = None


def executable() -> str:
    """The ``forcecontrol`` console script: on PATH, else beside the running interpreter."""
    found = shutil.which("forcecontrol") or shutil.which("forcecontrol", path=str(Path(sys.executable).parent))
    assert found, "the forcecontrol console script is neither on PATH nor beside the interpreter (pip install -e .)"
    return found


def base_environment() -> dict[str, str]:
    """The environment the server starts with: this process's, in UTF-8 mode (as the journeys run the command)."""
    env = dict(os.environ)
    env.setdefault("PYTHONUTF8", "1")
    return env


class _Server:
    """One command server (see the module's docstring)."""

    def __init__(self) -> None:
        self.env = {"PYTHONUTF8": "1", **_START_ENV}
        self.folder = tempfile.mkdtemp(prefix="fc-cli-server-")
        req_r, self._req = os.pipe()
        self._rep, rep_w = os.pipe()
        log = os.path.join(self.folder, "server.log")
        with open(os.path.join(self.folder, "start.log"), "wb") as start_log:  # until the server redirects its own
            self.proc = subprocess.Popen([sys.executable, "-c", SERVER_CODE, str(req_r), str(rep_w), executable(), log,
                                          ",".join(PRELOAD)],
                                         pass_fds=(req_r, rep_w), env=self.env, stdin=subprocess.DEVNULL,
                                         stdout=subprocess.DEVNULL, stderr=start_log, cwd=self.folder)
        os.close(req_r)
        os.close(rep_w)
        self._buf = b""
        hello = self._read(timeout=600.0)
        self.problem = None if hello and hello.get("ready") else (hello or {}).get(
            "problem", "it ended before it was ready: "
            + Path(self.folder, "start.log").read_text(encoding="utf-8", errors="replace")[-2000:])

    def _read(self, timeout: float | None) -> dict[str, Any] | None:
        """The server's next answer (one JSON line), or None when it ended; TimeoutError after ``timeout`` seconds."""
        while b"\n" not in self._buf:
            ready, _, _ = select.select([self._rep], [], [], timeout)
            if not ready:
                raise TimeoutError
            chunk = os.read(self._rep, 65536)
            if not chunk:
                return None
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return json.loads(line)

    def call(self, args: list[str], cwd: str, env: dict[str, str], module: bool,
             timeout: float) -> subprocess.CompletedProcess:
        out, err = os.path.join(self.folder, "stdout"), os.path.join(self.folder, "stderr")
        for path in (out, err):
            Path(path).write_bytes(b"")
        request = {"args": args, "cwd": cwd, "env": env, "stdout": out, "stderr": err,
                   "module": module}
        os.write(self._req, (json.dumps(request) + "\n").encode())
        started = self._read(timeout=60.0)
        assert started and "pid" in started, f"the command server did not start the command: {started}"
        try:
            done = self._read(timeout=timeout)
        except TimeoutError:
            os.kill(started["pid"], signal.SIGKILL)
            self._read(timeout=60.0)
            raise subprocess.TimeoutExpired(args, timeout,
                                            Path(out).read_text(encoding="utf-8", errors="replace"),
                                            Path(err).read_text(encoding="utf-8", errors="replace")) from None
        assert done is not None, "the command server ended while a command ran"
        proc = subprocess.CompletedProcess(args, done["returncode"], Path(out).read_text(encoding="utf-8"),
                                           Path(err).read_text(encoding="utf-8"))
        proc.forked = True  # type: ignore[attr-defined]
        return proc

    def close(self) -> None:
        for fd in (self._req, self._rep):
            try:
                os.close(fd)
            except OSError:
                pass
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        shutil.rmtree(self.folder, ignore_errors=True)


def _get_server() -> _Server | None:
    """This worker's command server (started on first use), or None when it refused to serve."""
    global _server, _refused
    if _refused is not None:
        return None
    if _server is None:
        server = _Server()
        if server.problem:
            _refused = server.problem
            server.close()
            print(f"tests/cli_server.py: commands run in new processes: {_refused}", file=sys.stderr)
            return None
        _server = server
        atexit.register(server.close)
    return _server


def differences(env: dict[str, str], server_env: dict[str, str]) -> list[str]:
    """The variables that keep a command with ``env`` from being forked from a server started with ``server_env``:
    those that differ, but for :data:`RUNTIME_VARIABLES` and UTF-8 settings the server already has."""
    out = []
    for k in sorted(set(env) | set(server_env)):
        a, b = env.get(k), server_env.get(k)
        if a == b or k in RUNTIME_VARIABLES:
            continue
        if k in UTF8_VARIABLES and (a is None or a in UTF8_VARIABLES[k]) and (b is None or b in UTF8_VARIABLES[k]):
            continue
        out.append(k)
    return out


def servable(env: dict[str, str], server_env: dict[str, str]) -> bool:
    """Whether a command with ``env`` may be forked from a server started with ``server_env`` (:func:`differences`)."""
    return not differences(env, server_env)


def run(args: list[str], *, cwd: str | Path | None = None, env: dict[str, str] | None = None,
        timeout: float = 900.0, module: bool = False
        ) -> subprocess.CompletedProcess:
    """``forcecontrol ARGS`` (``module``: ``python -m forcecontrol ARGS``), its output captured as text (UTF-8), as
    ``subprocess.run(..., capture_output=True, text=True, encoding="utf-8")`` gives it: forked from this worker's
    command server when it may be (see the module's docstring), else in a new process.

    Args:
        args: the command's arguments (after ``forcecontrol``).
        cwd: the working folder (default: the current one); env: its environment (default: this process's, UTF-8);
        timeout: seconds before the command is killed and :class:`subprocess.TimeoutExpired` raised. Its stdin is
            empty.
    """
    args = [str(a) for a in args]
    cwd = str(Path.cwd() if cwd is None else cwd)
    env = base_environment() if env is None else {**env}
    new_process = os.environ.get("FORCECONTROL_TEST_NEW_PROCESSES", "") not in ("", "0")
    with _lock:
        server = None if new_process else _get_server()
        if server is not None and servable(env, server.env):
            return server.call(args, cwd, env, module, timeout)
    cmd = [sys.executable, "-m", "forcecontrol", *args] if module else [executable(), *args]
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, encoding="utf-8", timeout=timeout,
                          stdin=subprocess.DEVNULL)
    proc.forked = False  # type: ignore[attr-defined]
    return proc


def refused(env: dict[str, str] | None = None) -> str | None:
    """Why a command with ``env`` (default: this process's) runs in a new process here, or None when it is forked."""
    if _refused is not None:
        return f"the server refused to serve: {_refused}"
    if os.environ.get("FORCECONTROL_TEST_NEW_PROCESSES", "") not in ("", "0"):
        return "FORCECONTROL_TEST_NEW_PROCESSES is set"
    if _server is None:
        return None
    diff = differences(base_environment() if env is None else env, _server.env)
    return f"its environment differs from the server's in {diff}" if diff else None
