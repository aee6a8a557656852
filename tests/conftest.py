"""Shared fixtures, and how the suite is spread over pytest-xdist's workers.

The README's test line runs ``python -m pytest -q``; pyproject's ``addopts`` adds ``-n auto --dist
loadgroup``: every test goes to whichever worker is free, except the tests of the modules in
:data:`ONE_WORKER`, which share an expensive module- or session-scoped fixture (a site build, a
browser, a Dask cluster, a fuzz warm-up, a set of recorded runs) and are kept on one worker so that
the fixture is built once; likewise the tests named in :data:`ONE_WORKER_TESTS` (the users of one module
fixture in a module whose other tests may spread). The compiled-kernel cache is shared by the workers (it is safe under
concurrency: ``tests/test_kernel_cache.py``).
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.core.threads import one_blas_thread_for_new_processes

#: modules whose tests stay together on one worker (their module/session fixture is expensive)
ONE_WORKER = {
    "test_docs.py", "test_docs_roles.py", "test_workbench_browser.py", "test_fuzz_campaign.py",
    "test_fuzz_scenarios.py", "test_journeys_sweep.py", "test_sweep_faults.py", "test_surface_following.py",
    "test_surface_following_6d.py", "test_rigid.py", "test_monitor.py", "test_problem_9_10.py", "test_journeys.py",
    "test_cli_replay.py", "test_journeys_files.py", "test_python_parity.py", "test_render_process.py",
    "test_ergonomics.py", "test_plotting.py", "test_animation.py", "test_vendor_data.py", "test_replay_frames.py",
    "test_view3d.py", "test_view3d_browser.py", "test_sweep_6d_parallel.py", "test_cli_server.py",
}

#: tests that share a module fixture (or its compiled kernels) and stay together on one worker, the module's
#: other tests spreading: test_batch_lanes.py's ``jobs``/``outputs`` compile the impedance law's scalar and lanes8
#: kernels (about 20 s CPU cold), and its sweep-table test runs the same two; on both workers, both compiled them
#: (tests/compile_census.py, -n 2 on a cold cache)
ONE_WORKER_TESTS = {
    "test_batch_lanes.py": (
        "test_the_random_cases_cover_what_the_lanes_must_handle",
        "test_lanes_with_libm_trig_equal_the_scalar_kernel_to_the_bit",
        "test_lanes_equal_the_scalar_kernel_within_the_trig_bound",
        "test_a_sweep_table_on_lanes_matches_the_scalar_one_and_names_its_kernel",
    ),
}


def pytest_configure(config: pytest.Config) -> None:
    """The workers run BLAS on one thread, as the command line does (:mod:`forcecontrol.core.threads`); matplotlib's
    font cache exists before any worker starts.

    Set here, in the process that starts pytest-xdist's workers, before they load NumPy: with OpenBLAS's
    default (a thread per core, spinning after each call) two workers on two cores took each other's cores;
    tests/test_admittance_servo.py, test_cli_units.py and test_position_interface.py used 36.4 s of CPU for
    25.9 s of wall time, with one thread 24.4 s for 25.1 s. A thread count the user set is kept; the tests of
    the thread rule (tests/test_blas_threads.py) clear these variables for their probes.
    """
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        one_blas_thread_for_new_processes()
        # matplotlib's font cache, built here once if this machine has none (a fresh CI machine): building it starts a
        # timer thread, and a command server (tests/cli_server.py) whose imports (pyplot among them) leave a thread
        # refuses to serve, so that every command of its worker would start a new interpreter
        import matplotlib.font_manager  # noqa: F401


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    """Each test leaves this process's environment as it found it, whatever a library it ran wrote there.

    Dask's LocalCluster writes distributed's pre-spawn environment into the process that starts it (``PYTHONHASHSEED``,
    ``OMP_NUM_THREADS=1``, ``MALLOC_TRIM_THRESHOLD_``, ``__DASK_PARENT_PID``), pyviz_comms ``_PYVIZ_COMMS_INSTALLED``:
    every later subprocess of the worker inherited them (one hash seed for all), and no later command could be forked
    from the worker's command server (tests/cli_server.py), whose environment they no longer matched. Restored after
    the test's setup, call and teardown, so that a module fixture's writes go too.
    """
    before = dict(os.environ)
    yield
    if dict(os.environ) != before:
        os.environ.clear()
        os.environ.update(before)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark the tests of :data:`ONE_WORKER`'s modules with one ``xdist_group`` per module, and each
    :data:`ONE_WORKER_TESTS` group with its own (for the record: the scheduler below is what keeps them together)."""
    for item in items:
        group = _group(item.nodeid)
        if group is not None:
            item.add_marker(pytest.mark.xdist_group(name=group.rsplit("/", 1)[-1]))


def _group(nodeid: str) -> str | None:
    """The ONE_WORKER module a node id belongs to, or its ONE_WORKER_TESTS group (``<path>::shared``), or None."""
    path, _, name = nodeid.partition("::")
    module = path.rsplit("/", 1)[-1]
    if module in ONE_WORKER:
        return path
    return f"{path}::shared" if name.split("[", 1)[0] in ONE_WORKER_TESTS.get(module, ()) else None


def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object:
    """``--dist loadgroup`` that keeps each :data:`ONE_WORKER` module on one worker, by the module's path.

    xdist 3.8's own grouping appends ``@group`` to ``item._nodeid`` in the worker, but pytest 9.2 derives
    ``nodeid`` from ``item._id``: the suffix never reached the scheduler, every test was its own unit, and
    the modules' expensive fixtures were built on both workers (the docs site twice, about 70 s each, in
    the CI run at ba561de). The scheduler is chosen on the controller, from the node ids it already has.
    """
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler.loadgroup import LoadGroupScheduling

    class OneWorkerModules(LoadGroupScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return _group(nodeid) or super()._split_scope(nodeid)

    return OneWorkerModules(config, log)


@pytest.fixture(scope="session")
def arm() -> fc.PlanarTwoLink:
    """The chapter's arm with its data."""
    return fc.PlanarTwoLink()


@pytest.fixture(scope="session")
def q_contact() -> np.ndarray:
    """Elbow-up posture with the tip at [1, 0] (the chapter's start), q0 = [π/3, −2π/3]."""
    return np.array([math.pi / 3, -2 * math.pi / 3])
