"""A key a scenario sets but its part does not use (a schedule's or a law's own gain, under another schedule or law) is
accepted and said: a note on stderr and in `run --json`, a SweepWarning in a sweep (not silently ignored).

What "unused" means is checked against the simulation itself: the response with the key equals the response without
it, bit for bit, and where the condition holds the same key does change the response.
"""

from __future__ import annotations

import copy
import json
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import tomllib

from forcecontrol.scenarios import load_scenario, run_scenario
from forcecontrol.scenarios.model import UnusedKeyNote, unused_key_notes
from forcecontrol.scenarios.schema import CONTROLLERS, ENVIRONMENTS, REFERENCES
from forcecontrol.sweep import SweepDefinition, prepare_sweep
from forcecontrol.sweep.spec import SweepWarning
from journeys_helpers import forcecontrol

BASE = {
    "name": "vi", "duration": 0.4, "sample_time": 0.001,
    "robot": {"model": "chapter-arm", "start_position": [1.0, 0.0]},
    "environment": {"type": "elastic-plane", "point": [1.0, 0.0], "normal": [-1.0, 0.0], "stiffness": 5000.0},
    "controller": {"type": "variable-impedance", "inertia": [10.0, 10.0], "damping": [300.0, 300.0],
                   "stiffness_low": 1000.0, "schedule": "constant"},
    "reference": {"type": "setpoint", "position": [1.05, 0.02]},
}


VI_TOML = """
name = "vi"
duration = 0.4
sample_time = 0.001
[robot]
model = "chapter-arm"
start_position = [1.0, 0.0]
[environment]
type = "elastic-plane"
point = [1.0, 0.0]
normal = [-1.0, 0.0]
stiffness = 5000.0
[controller]
type = "variable-impedance"
inertia = [10.0, 10.0]
damping = [300.0, 300.0]
stiffness_low = 1000.0
schedule = "constant"
stiffness_high = 6000.0
[reference]
type = "setpoint"
position = [1.05, 0.02]
"""


def _with(**controller) -> dict:
    d = copy.deepcopy(BASE)
    d["controller"].update(controller)
    return d


def _run(doc: dict):
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        run = run_scenario(load_scenario(doc))
    return run, [str(w.message) for w in seen if issubclass(w.category, UnusedKeyNote)]


def test_a_schedules_key_under_another_schedule_is_said_and_changes_nothing():
    """schedule = constant with stiffness_high, tank = false with tank_initial: one note each, naming the key, the
    condition and the value; the response equals the one without those keys to the bit."""
    plain, none = _run(_with(tank=False))
    extra, notes = _run(_with(tank=False, stiffness_high=6000.0, tank_initial=0.3, amplitude=50.0))
    assert none == []
    assert len(notes) == 3
    assert any("[controller] key 'stiffness_high' is not used" in n and 'schedule = "directional"' in n
               and 'schedule is "constant"' in n for n in notes), notes
    assert any("'tank_initial'" in n and "tank = true; tank is false" in n for n in notes), notes
    assert any("'amplitude'" in n and 'schedule = "sinusoidal"' in n for n in notes), notes
    a, b = plain.cases[0].result, extra.cases[0].result
    assert np.array_equal(a.q, b.q) and np.array_equal(a.wrench, b.wrench)
    assert [w["kind"] for w in extra.to_json()["cases"][0]["warnings"]].count("unused-key") == 3


def test_the_same_key_under_its_own_schedule_is_used_and_not_noted():
    """schedule = directional: stiffness_high changes the response (the marking is not wrong the other way)."""
    low, notes = _run(_with(schedule="directional", stiffness_high=2000.0, tank=False))
    high, _ = _run(_with(schedule="directional", stiffness_high=8000.0, tank=False))
    assert notes == []
    assert not np.array_equal(low.cases[0].result.q, high.cases[0].result.q)


def test_a_key_one_case_uses_is_not_noted_and_a_case_override_nobody_uses_is():
    """Top-level stiffness_high, case 1 directional, case 2 constant: used (by case 1), no note. An amplitude set
    only in case 2 (constant) is noted, naming that case."""
    doc = _with(schedule="directional", stiffness_high=6000.0)
    doc["case"] = [{"label": "directional"},
                   {"label": "constant", "controller.schedule": "constant", "controller.amplitude": 10.0}]
    run, notes = _run(doc)
    assert len(run.cases) == 2
    assert len(notes) == 1 and "'amplitude'" in notes[0] and "(in case(s) 2)" in notes[0], notes
    assert [w["kind"] for w in run.to_json()["cases"][0]["warnings"]].count("unused-key") == 0
    assert [w["kind"] for w in run.to_json()["cases"][1]["warnings"]].count("unused-key") == 1


def test_the_planar_rigid_hybrids_other_laws_gains_are_said_when_no_case_uses_them():
    """hybrid-rigid-plane keeps velocity_integral_gain and force_integral_gain at the top for its cases that use them:
    no note; with only its force/position case, proportional law, both are unused there, and said."""
    text = resources.files("forcecontrol.scenarios").joinpath("hybrid-rigid-plane.toml").read_text(encoding="utf-8")
    doc = tomllib.loads(text)
    scn = load_scenario(doc)
    assert len(scn.cases) == 3 and unused_key_notes(scn.cases, scn.source) == []
    doc["case"], doc["duration"] = [doc["case"][1]], 0.2
    _, notes = _run(doc)
    keys = sorted(n.split("key '")[1].split("'")[0] for n in notes)
    assert keys == ["force_integral_gain", "velocity_integral_gain"], notes
    assert any('motion = "velocity"; motion is "position"' in n for n in notes)
    assert any('force_law = "integral"; force_law is "proportional"' in n for n in notes)


def test_run_says_it_on_stderr_and_in_json(tmp_path: Path):
    """`forcecontrol run FILE` prints the note; `--json` has it in the case's warnings (kind unused-key)."""
    assert tomllib.loads(VI_TOML) == _with(stiffness_high=6000.0)  # the file is the dict the other tests run
    (tmp_path / "vi.toml").write_text(VI_TOML, encoding="utf-8")
    table = forcecontrol(tmp_path, "run", "vi.toml")
    assert "note: " in table.stderr and "key 'stiffness_high' is not used and its value is ignored" in table.stderr
    doc = json.loads(forcecontrol(tmp_path, "run", "vi.toml", "--json").stdout)
    assert [w["text"] for w in doc["cases"][0]["warnings"] if w["kind"] == "unused-key"] == [
        "vi.toml: [controller] key 'stiffness_high' is not used and its value is ignored: it applies only when "
        'schedule = "directional"; schedule is "constant" (in every case)'
    ]


def test_a_sweep_over_an_unused_key_or_with_one_set_says_so():
    """Sweeping stiffness_high under schedule = constant: a SweepWarning that the values give the same responses; not
    when the sweep also sets the schedule. A key set and unused but not swept: the scenario's note, as a SweepWarning."""
    with pytest.warns(SweepWarning, match=r"'controller.stiffness_high'.*does not use 'stiffness_high'.*same responses"):
        prepare_sweep(_with(), SweepDefinition.from_options({"controller.stiffness_high": [2000.0, 4000.0]}))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        prepare_sweep(_with(), SweepDefinition.from_options({"controller.stiffness_high": [2000.0, 4000.0],
                                                             "controller.schedule": ["constant", "directional"]}))
    assert not [w for w in seen if "stiffness_high" in str(w.message)], [str(w.message) for w in seen]
    with pytest.warns(SweepWarning, match=r"key 'tank_initial' is not used and its value is ignored"):
        prepare_sweep(_with(tank=False, tank_initial=0.2), SweepDefinition.from_options({"environment.stiffness": [1e3, 2e3]}))


def test_every_condition_names_a_key_of_its_table_and_values_it_can_take():
    """Each Field.used_when names another key of the same part, with values that key accepts (its choices, or bools
    for a bool key): a misspelt condition would make a used key look unused, or the reverse."""
    marked = 0
    for registry in (CONTROLLERS, ENVIRONMENTS, REFERENCES):
        for spec in registry.values():
            for key, f in spec.fields.items():
                if f.used_when is None:
                    continue
                marked += 1
                cond, values = f.used_when
                assert cond in spec.fields and cond != key, (spec.name, key)
                c = spec.fields[cond]
                for v in values:
                    ok = (v in c.choices) if c.kind == "str" else (c.kind == "bool" and isinstance(v, bool))
                    assert ok, (spec.name, key, v)
    assert marked >= 11


@pytest.mark.parametrize("figures", [False, True])
def test_analyze_says_it_once_with_or_without_its_figures(tmp_path: Path, figures: bool):
    """`analyze FILE` (and with --figures, which simulates): the note once on stderr, and in --json's notes."""
    (tmp_path / "vi.toml").write_text(VI_TOML, encoding="utf-8")
    extra = ("--figures", "--force") if figures else ()
    table = forcecontrol(tmp_path, "analyze", "vi.toml", *extra)
    assert table.stderr.count("key 'stiffness_high' is not used and its value is ignored") == 1, table.stderr
    doc = json.loads(forcecontrol(tmp_path, "analyze", "vi.toml", "--json", *extra).stdout)
    assert sum("key 'stiffness_high' is not used" in n for n in doc["notes"]) == 1, doc["notes"]
