"""The suite's ONE_WORKER modules really run on one xdist worker (their expensive fixtures built once).

xdist 3.8's own ``xdist_group`` never took effect under pytest 9.2 (it edits ``item._nodeid``, which pytest 9.2 no
longer reads): the docs site was built on both workers. tests/conftest.py schedules the groups by module path.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _workers(*files: str) -> dict[str, set[str]]:
    """Run ``pytest -n 2 -v FILES``; the workers each file's tests ran on."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-n", "2", "-v", "-p", "no:cacheprovider", "--durations=0", *files],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-3000:]
    ran = re.findall(r"^\[(gw\d)\] .*? (?:PASSED|FAILED|SKIPPED) (tests/\S+?)::", proc.stdout, flags=re.M)
    return {f: {w for w, g in ran if g == f} for f in files}


def test_a_one_worker_module_runs_on_one_worker_and_an_ordinary_one_on_both():
    """`pytest -n 2 -v`: every test of a ONE_WORKER module (test_vendor_data.py) runs on one worker, also beside another
    module; an ordinary module run alone (test_law_layout.py, 23 tests) is spread over both workers."""
    both = _workers("tests/test_vendor_data.py", "tests/test_law_layout.py")
    assert len(both["tests/test_vendor_data.py"]) == 1, both
    assert _workers("tests/test_law_layout.py")["tests/test_law_layout.py"] == {"gw0", "gw1"}


def test_the_users_of_a_shared_module_fixture_are_one_unit_of_the_scheduler():
    """conftest's grouping: test_batch_lanes.py's users of ``jobs``/``outputs`` (and its sweep-table test, which compiles
    the same impedance kernels) map to one group, its other tests to none (they spread), a ONE_WORKER module's tests to
    the module; and that list is exactly those tests (a new user of the fixture cannot be forgotten)."""
    import inspect

    import conftest
    import test_batch_lanes

    users = {name for name, f in vars(test_batch_lanes).items() if name.startswith("test_") and callable(f)
             and {"jobs", "outputs"} & set(inspect.signature(f).parameters)}
    same_kernels = {"test_a_sweep_table_on_lanes_matches_the_scalar_one_and_names_its_kernel"}
    assert same_kernels <= set(vars(test_batch_lanes)) and len(users) == 3
    assert users | same_kernels == set(conftest.ONE_WORKER_TESTS["test_batch_lanes.py"])
    module = "tests/test_batch_lanes.py"
    assert {conftest._group(f"{module}::{name}") for name in users} == {f"{module}::shared"}
    assert conftest._group(f"{module}::test_every_law_runs_on_lanes_within_the_trig_bound[example-9.3-parameters0]") is None
    assert conftest._group(f"{module}::test_sincos_special_values") is None
    assert conftest._group("tests/test_vendor_data.py::test_x[1]") == "tests/test_vendor_data.py"
    assert conftest._group("tests/test_law_layout.py::test_x") is None
