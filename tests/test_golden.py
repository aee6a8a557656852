"""Golden results: every built-in scenario on every engine reproduces the recorded logs.

The files in ``tests/golden/`` were recorded with ``python tools/golden.py record`` on commit
31aefef, before the control laws were moved into one implementation each (issue 12). A change
of architecture must not change a number: each logged signal (every 10th sample and the last)
agrees to 1e-9 relative to the signal's scale (at least 1).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("golden_tool", ROOT / "tools" / "golden.py")
golden = importlib.util.module_from_spec(_spec)
sys.modules["golden_tool"] = golden
_spec.loader.exec_module(golden)  # type: ignore[union-attr]

CASES = []
for path in sorted(golden.GOLDEN_DIR.glob("*.npz")):
    with np.load(path) as data:
        for engine in sorted({k.split("/")[0] for k in data.files}):
            CASES.append(pytest.param(path.stem, engine, id=f"{path.stem}-{engine}"))


@pytest.mark.parametrize(("scenario", "engine"), CASES)
def test_golden(scenario: str, engine: str) -> None:
    """The scenario's logs on this engine equal the recorded ones to 1e-9 of their scale."""
    if engine == "mujoco":
        pytest.importorskip("mujoco")
    if scenario.startswith("panda"):
        pytest.importorskip("pinocchio")
    with np.load(golden.GOLDEN_DIR / f"{scenario}.npz") as f:
        want = {k: f[k] for k in f.files if k.startswith(engine + "/")}
    got = golden.run_engine(scenario, engine)
    assert set(got) == set(want)
    for k, w in want.items():
        scale = max(1.0, float(np.max(np.abs(w))))
        np.testing.assert_allclose(got[k], w, rtol=0, atol=1e-9 * scale, err_msg=k)
