"""Sweeps of the 6-D built-ins (issue 27): every sweepable key runs the simulation (not only the
preparation) and changes the result where physics says it must; the metrics follow the task's force
direction in 6-D and agree with closed forms (springs in series, the hole's spring law, force regulation)."""

from __future__ import annotations

import copy
import warnings

import numpy as np
import pytest

from forcecontrol.scenarios import build_case, list_scenarios, load_scenario
from forcecontrol.sweep import SweepDefinition, prepare_sweep
from forcecontrol.sweep.run import run_block
from forcecontrol.sweep.spec import SweepWarning

SIX_D = [n for n in list_scenarios() if build_case(load_scenario(n).cases[0])["robot"].task_dim == 6]
TABLES = ("environment", "controller", "reference", "sensor")
METRICS = ("settling_time", "overshoot", "steady_state_force_error", "peak_force", "settled_force")
DURATION = 0.3  # [s] long enough for every contact transient to show; the built-in motions start later


def _perturbed(value):
    """Another value of the same shape: numbers and vectors x 1.3 (an all-zero vector gets 1 in its first
    entry), matrices with 0.1 added to the diagonal (a direction turns)."""
    if isinstance(value, (int, float)):
        return value * 1.3 if value else 0.1
    v = copy.deepcopy(value)
    if v and isinstance(v[0], list):
        for i in range(min(len(v), len(v[0]))):
            v[i][i] += 0.1
        return v
    return [x * 1.3 for x in v] if any(v) else [1.0] + v[1:]


def _keys(name: str) -> list[str]:
    cfg = load_scenario(name).cases[0].config
    return [f"{t}.{k}" for t in TABLES for k, v in (cfg.get(t) or {}).items()
            if k != "type" and not isinstance(v, (str, bool, dict))]


#: keys whose change cannot reach the metrics within DURATION, and why (everything else must change them).
NO_EFFECT = {
    ("panda-admittance-contact", "controller.environment_stiffness"): "used only by the bandwidth check",
    ("panda-table-line", "reference.end_offset"): "the line starts at 0.5 s, after the run",
    ("panda-table-line", "reference.duration"): "the line starts at 0.5 s, after the run",
    ("panda-table-line", "reference.start_time"): "the line starts at 0.5 s (0.65 s perturbed), after the run",
    ("panda-sphere", "reference.end_angle"): "the arc starts at 0.3 s, after the run",
    ("panda-sphere", "reference.speed"): "the arc starts at 0.3 s, after the run",
    ("panda-sphere", "reference.start_time"): "the arc starts at 0.3 s (0.39 s perturbed), after the run",
    ("panda-sphere", "reference.accel_time"): "the arc starts at 0.3 s, after the run",
    ("panda-sphere", "reference.axis"): "a direction: x 1.3 is the same axis",
    **{(name, f"reference.{key}"): why for name in ("panda-unknown-cylinder", "panda-unknown-sphere") for key, why in (
        ("end_angle", "the arc starts at 0.5 s, after the run"), ("speed", "the arc starts at 0.5 s, after the run"),
        ("start_time", "the arc starts at 0.5 s (0.65 s perturbed), after the run"),
        ("accel_time", "the arc starts at 0.5 s, after the run"), ("axis", "a direction: x 1.3 is the same axis"))},
    ("panda-unknown-cylinder", "controller.first_normal"): "a direction: x 1.3 is the same first guess",
    ("panda-unknown-sphere", "controller.first_normal"): "a direction: x 1.3 is the same first guess",
    ("panda-unknown-cylinder", "environment.axis"): "a direction: x 1.3 is the same axis",
    **{(name, f"environment.{key}"): "the contact uses the bump field's formula; the grid only samples it (drawings)"
       for name in ("panda-wipe-heightfield", "panda-spiral-search") for key in ("origin", "spacing", "size")},
    ("panda-wipe-heightfield", "controller.first_normal"): "a direction: x 1.3 is the same first guess",
    **{("panda-wipe-heightfield", f"reference.{key}"): "the line starts at 0.5 s, after the run"
       for key in ("end_offset", "speed", "start_time", "accel_time")},
    ("panda-spiral-search", "controller.normal"): "a direction: x 1.3 is the same normal",
    ("panda-spiral-search", "controller.threshold"): "the search starts at 0.3 s: no drop is looked for in the run",
    ("panda-spiral-search", "controller.start_time"): "the search starts at 0.3 s (0.39 s perturbed), at the run's end",
    **{("panda-spiral-search", f"reference.{key}"): "the spiral starts at 0.3 s (0.39 s perturbed), at the run's end"
       for key in ("pitch", "radius", "speed", "start_time")},
}


def test_the_6d_builtins_are_the_panda_and_ur5_scenarios():
    """The parametrisation below covers the 6-D built-ins `forcecontrol list` shows."""
    assert SIX_D == ["panda-admittance-contact", "panda-peg-in-hole", "panda-sphere", "panda-spiral-search", "panda-table-line",
                     "panda-unknown-cylinder", "panda-unknown-sphere", "panda-wipe-heightfield", "ur5-admittance-servo"]


@pytest.mark.parametrize("name", SIX_D)
def test_every_sweepable_key_of_a_6d_builtin_is_simulated_and_changes_the_result(name):
    """For each key the scenario sets, a sweep case with the perturbed value is simulated (engine simulate,
    status ok, finite metrics) and its metrics differ from the scenario's own, unless NO_EFFECT says why not."""
    base = prepare_sweep(name, SweepDefinition.from_options({"duration": [DURATION]})).jobs[:1]  # the first case, as below
    jobs, keys = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # BandwidthWarning of a perturbed admittance: reported by the scenario layer
        for path in _keys(name):
            table, key = path.split(".", 1)
            value = load_scenario(name).cases[0].config[table][key]
            d = SweepDefinition.from_options({path: [_perturbed(value)], "duration": [DURATION]})
            job = prepare_sweep(name, d).jobs[0]
            job.case_id = len(jobs) + 1
            jobs.append(job)
            keys.append(path)
    rows = run_block(base + jobs, 0.02, 0.05)
    ref = rows[0]
    assert ref["engine"] == "simulate" and ref["status"] == "ok"
    unchanged = []
    for path, row in zip(keys, rows[1:]):
        assert row["engine"] == "simulate" and row["status"] == "ok", path
        assert all(np.isfinite(row[m]) for m in ("peak_force", "settled_force", "steady_state_force_error")), path
        if all(np.isclose(row[m], ref[m], rtol=1e-9, atol=0.0, equal_nan=True) for m in METRICS):
            unchanged.append(path)
    assert unchanged == [p for p in keys if (name, p) in NO_EFFECT]


def test_sweeping_a_check_only_key_says_so():
    """Sweeping the admittance controller's environment_stiffness (bandwidth check only) warns, naming the key."""
    d = SweepDefinition.from_options({"controller.environment_stiffness": [[0, 0, 5000.0, 0, 0, 0], [0, 0, 8000.0, 0, 0, 0]]})
    with pytest.warns(SweepWarning, match=r"'controller.environment_stiffness'.*only in its bandwidth check"):
        prepare_sweep("panda-admittance-contact", d)


def test_admittance_contact_sweep_runs_and_follows_the_springs_in_series():
    """panda-admittance-contact over the table's stiffness: each settled force is k K_Pt/(k + K_Pt) 0.02 (9.22),
    so a stiffer table is penetrated less (f/k); the metrics are along the table's push direction (-z)."""
    d = SweepDefinition.from_options({"environment.stiffness": [2000.0, 5000.0]})
    prep = prepare_sweep("panda-admittance-contact", d)
    assert [j.d.tolist() for j in prep.jobs] == [[0.0, 0.0, -1.0, 0.0, 0.0, 0.0]] * 2
    rows = run_block(prep.jobs, 0.02, 0.05)
    K = 1000.0  # the compliant frame's K_Pt along z (the scenario's controller.stiffness[2])
    for row, k in zip(rows, (2000.0, 5000.0)):
        assert row["engine"] == "simulate" and row["status"] == "ok" and row["stable"]
        assert row["settled_force"] == pytest.approx(k * K / (k + K) * 0.02, rel=1e-4)
    penetration = [r["settled_force"] / k for r, k in zip(rows, (2000.0, 5000.0))]
    assert penetration[1] < penetration[0]


def test_peg_in_hole_metrics_follow_the_lateral_force_the_task_controls():
    """panda-peg-in-hole (f_d = 0, no plane): the metrics follow S_f's first direction (x, Table 9.2); the peak
    lateral force is the hole's spring law k x_0 at the start and the settled lateral force vanishes."""
    d = SweepDefinition.from_options({"environment.offset": [[0.002, 0.0, 0.0], [0.004, 0.0, 0.0]],
                                      "duration": [0.6]})
    prep = prepare_sweep("panda-peg-in-hole", d)
    np.testing.assert_allclose(np.abs(prep.jobs[0].d), [1.0, 0.0, 0.0, 0.0, 0.0, 0.0], atol=1e-6)
    rows = run_block(prep.jobs, 0.02, 0.05)
    k = load_scenario("panda-peg-in-hole").cases[0].config["environment"]["stiffness"][0]
    for row, x0 in zip(rows, (0.002, 0.004)):
        assert row["status"] == "ok"
        assert row["peak_force"] == pytest.approx(k * x0, rel=1e-6)
        assert abs(row["settled_force"]) < 0.01 * k * x0
