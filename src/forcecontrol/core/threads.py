"""One BLAS thread for the command line's process and the processes it starts, unless the user chose a number.

The library's linear algebra runs on matrices of at most 12 × 12 (the operational space of a 6-D arm,
the analyses' state-space models), where a BLAS thread per core gains nothing. OpenBLAS, the BLAS of
NumPy's and SciPy's wheels, starts one thread per core when it loads and keeps them spinning after
each call: ``forcecontrol design admittance-position ...`` took 2.7 s wall and 4.3 s of CPU, with one
thread the same 2.7 s wall and 2.5 s of CPU; on a machine whose every core runs a sweep worker, each
worker's spinning threads took the other workers' cores.

:func:`one_blas_thread` sets ``OPENBLAS_NUM_THREADS``, ``MKL_NUM_THREADS`` and ``BLIS_NUM_THREADS`` to 1
before NumPy loads, for the console script (``forcecontrol.cli`` calls it first) and, through the
environment, for every process the command starts (sweep workers, the figure renderer, Dask workers on
this machine). It does nothing when the user set any of :data:`USER_VARIABLES` (their choice is
kept) or when NumPy is already loaded (a program that imports the command line in-process: its BLAS
is started, and its threads are the program's business).
"""

from __future__ import annotations

import os
import sys

__all__ = ["one_blas_thread", "one_blas_thread_for_new_processes", "USER_VARIABLES", "SET_VARIABLES"]

#: a user who set any of these chose the BLAS's threads
USER_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")
#: what :func:`one_blas_thread` sets (the BLAS libraries' own variables; OMP_NUM_THREADS is left to other libraries)
SET_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def one_blas_thread() -> bool:
    """Set :data:`SET_VARIABLES` to 1 when NumPy is not loaded and none of :data:`USER_VARIABLES` is set; True if it did."""
    return "numpy" not in sys.modules and one_blas_thread_for_new_processes()


def one_blas_thread_for_new_processes() -> bool:
    """Set :data:`SET_VARIABLES` to 1 unless the user set any of :data:`USER_VARIABLES`; True if it did.

    Whether or not this process has loaded NumPy: the processes it starts afterwards load theirs with one
    thread (the test suite's pytest-xdist workers, started by a process that already loaded NumPy)."""
    if any(os.environ.get(v) for v in USER_VARIABLES):
        return False
    for v in SET_VARIABLES:
        os.environ[v] = "1"
    return True
