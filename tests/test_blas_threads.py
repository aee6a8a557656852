"""The command line runs BLAS on one thread unless the user chose (``forcecontrol.core.threads``).

Reference outside the library: the kernel's count of the process's threads (``/proc/self/task``)
after NumPy has loaded its BLAS, which starts its threads when it loads.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from forcecontrol.core.threads import USER_VARIABLES

pytestmark = pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="counts threads in /proc (Linux)")

#: the console script's import order (``from forcecontrol.cli import main``), then a LAPACK call
PROBE = ("import os, sys\n"
         "{first}\n"
         "from forcecontrol.cli import main\n"
         "import numpy as np\n"
         "np.linalg.solve(np.eye(3) + 1.0, np.ones(3))\n"
         "print(os.environ.get('OPENBLAS_NUM_THREADS'), len(os.listdir('/proc/self/task')))\n")


def _probe(first: str = "", **env: str) -> tuple[str, int]:
    clean = {k: v for k, v in os.environ.items() if k not in USER_VARIABLES}
    out = subprocess.run([sys.executable, "-c", PROBE.format(first=first)], env={**clean, **env}, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    value, threads = out.stdout.split()
    return value, int(threads)


def _default_threads() -> int:
    """The threads of a process that loaded NumPy alone, nothing set (OpenBLAS's default: one per core)."""
    clean = {k: v for k, v in os.environ.items() if k not in USER_VARIABLES}
    out = subprocess.run([sys.executable, "-c", "import os, numpy; print(len(os.listdir('/proc/self/task')))"], env=clean,
                         capture_output=True, text=True, timeout=300)
    return int(out.stdout)


def test_the_command_line_loads_blas_with_one_thread():
    """No variable set: the console script's process sets OPENBLAS_NUM_THREADS=1 (inherited by what it starts) and
    runs on one thread; a user's two threads are two (the probe can tell them apart)."""
    assert _probe() == ("1", 1)
    assert _probe(OPENBLAS_NUM_THREADS="2") == ("2", 2)


@pytest.mark.parametrize("variable", ["OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS"])
def test_a_users_choice_of_threads_is_kept(variable):
    """A user who set any thread variable keeps it: nothing is set, OpenBLAS starts the threads the user asked for."""
    value, threads = _probe(**{variable: "2"})
    assert threads == 2
    assert value == ("2" if variable == "OPENBLAS_NUM_THREADS" else "None")


def test_a_program_that_loaded_numpy_first_is_left_alone():
    """A program that imported NumPy before the command line keeps its BLAS as it started (and its environment)."""
    assert _probe(first="import numpy") == ("None", _default_threads())
