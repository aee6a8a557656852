"""Sweep rows say what was run: a swept value that replaces what a case set is marked in its label."""

from __future__ import annotations

import pytest

from forcecontrol.sweep.run import prepare_sweep, run_sweep
from forcecontrol.sweep.spec import SweepDefinition


def test_swept_stiffness_marks_the_case_labels_and_is_applied(tmp_path):
    """Sweeping environment.stiffness over Example 9.2: both cases' labels say it is swept; the forces follow (9.32)."""
    d = SweepDefinition.from_options(["environment.stiffness=1000,3000"])
    prep = prepare_sweep("example-9.2", d)
    assert {j.row_label for j in prep.jobs} == {
        "k_x = 1e4 N/m [environment.stiffness swept]", "k_x = 1e3 N/m [environment.stiffness swept]",
    }
    res = run_sweep(prep, out=tmp_path / "t.parquet")
    df = res.table
    assert set(df["case"]) == {"k_x = 1e4 N/m [environment.stiffness swept]", "k_x = 1e3 N/m [environment.stiffness swept]"}
    for k in (1000.0, 3000.0):
        rows = df[df["environment.stiffness"] == k]
        f_hand = k * 2500.0 / (2500.0 + k) * 0.1  # (9.32) at rest: k k_P/(k_P + k) (x_d − x_r)
        assert rows["settled_force"].abs().to_numpy() == pytest.approx([f_hand] * len(rows), rel=2e-3)


def test_sweeping_a_key_the_cases_do_not_set_keeps_their_labels():
    """Sweeping controller.damping (not set by Example 9.2's cases) keeps the labels as they are."""
    d = SweepDefinition.from_options(["controller.damping=400,600"])
    prep = prepare_sweep("example-9.2", d)
    assert {j.row_label for j in prep.jobs} == {"k_x = 1e4 N/m", "k_x = 1e3 N/m"}
