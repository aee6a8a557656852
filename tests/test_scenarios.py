"""Scenario files: the schema rejects bad input before simulating; built-ins load and run."""

from __future__ import annotations

import textwrap

import pytest

from forcecontrol.errors import ScenarioError
from forcecontrol.scenarios import list_scenarios, load_scenario, run_scenario

GOOD = textwrap.dedent(
    """
    name = "mine"
    duration = 0.2
    [robot]
    start_position = [1.0, 0.0]
    [environment]
    type = "elastic-plane"
    point = [1.0, 0.0]
    normal = [-1.0, 0.0]
    stiffness = 1000.0
    [controller]
    type = "impedance"
    inertia = 100.0
    damping = 500.0
    stiffness = 2500.0
    [reference]
    type = "setpoint"
    position = [1.1, 0.1]
    """
)


def _write(tmp_path, text):
    p = tmp_path / "scn.toml"
    p.write_text(text)
    return p


def test_a_good_file_loads_and_runs(tmp_path):
    """A minimal user scenario file loads, runs and reports its final state."""
    run = run_scenario(_write(tmp_path, GOOD))
    assert run.cases[0].result.t[-1] == pytest.approx(0.2) and run.cases[0].result.wrench[-1, 0] > 0


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda s: s.replace('inertia = 100.0', 'inertai = 100.0'),
         r"scn.toml: \[controller\] \(type 'impedance'\): unknown key 'inertai'; expected one of: damping, "),
        (lambda s: s.replace('stiffness = 2500.0', 'stiffness = "stiff"'),
         r"\[controller\] \(type 'impedance'\): key 'stiffness' must be a number, a list of numbers .*got 'stiff' \(str\)"),
        (lambda s: s.replace('stiffness = 2500.0', 'stiffness = [[1.0, 2.0], [2.0, 1.0]]'),
         r"\[controller\] \(type 'impedance'\): stiffness must be a symmetric positive definite \(2, 2\) matrix; got eigen"),
        (lambda s: s.replace('inertia = 100.0', 'inertia = [1.0, 2.0, 3.0]'),
         r"inertia must be a symmetric positive definite \(2, 2\) matrix; got shape \(3,\)"),
        (lambda s: s.replace('stiffness = 1000.0', 'stiffness = -1000.0'),
         r"\[environment\] \(type 'elastic-plane'\): stiffness must be a non-negative number; got -1000.0"),
        (lambda s: s.replace('type = "impedance"', 'type = "magic"'),
         r"\[controller\]: key 'type' must be one of .*impedance.*; got 'magic'"),
        (lambda s: s.replace('duration = 0.2', 'duration = -1.0'), r"key 'duration' must be a positive number \[s\]; got -1.0"),
        (lambda s: s.replace('duration = 0.2', 'duration = 0.2\nsample_time = 0.0'),
         r"key 'sample_time' must be a positive number \[s\]; got 0.0"),
        (lambda s: s.replace('duration = 0.2', ''), r"missing key 'duration'"),
        (lambda s: s.replace('start_position = [1.0, 0.0]', 'start_position = [5.0, 0.0]'),
         r"\[robot\]: position \[5.0, 0.0\] is outside the workspace"),
        (lambda s: s.replace('start_position = [1.0, 0.0]', 'q0 = [1.0]'), r"\[robot\]: key 'q0' must have 2 entries; got 1"),
        (lambda s: s + '\n[sensor]\ncutoff = 900.0\n', r"\[sensor\]: cutoff must be below the Nyquist frequency"),
        (lambda s: s + '\ncolour = "red"\n', r"unknown key 'colour'"),
        (lambda s: s.replace('position = [1.1, 0.1]', 'position = [1.1, 0.1, 0.0]'),
         r"\[reference\] must be 2-dimensional like the robot's task space; got 3"),
        (lambda s: s + '\n[[case]]\nlabel = "a"\ncontroler.stiffness = 1.0\n', r"override 'controler.stiffness' names no table"),
        (lambda s: s + '\n[expected]\nwobble = 1.0\n', r"unknown metric 'wobble'"),
        (lambda s: s.replace('[robot]', '[robot\n'), r"not valid TOML"),
        (lambda s: s + '\n[figure]\ncases = ["nope"]\n', r"\[figure\]: key 'cases' names no case 'nope'"),
        (lambda s: s + '\n[[figure]]\nname = "a"\n[[figure]]\nsignals = ["x"]\n',
         r"\[\[figure\]\] #2: missing key 'name' \(several figures need distinct file names\)"),
        (lambda s: s + '\n[figure]\nsignals = "x"\n', r"\[figure\]: key 'signals' must be a non-empty list of strings"),
    ],
)
def test_malformed_files_are_rejected_with_file_key_expected_and_given(tmp_path, edit, match):
    """Each malformed file raises ScenarioError naming the file, the key, the expectation and the value."""
    with pytest.raises(ScenarioError, match=match):
        load_scenario(_write(tmp_path, edit(GOOD)))


def test_unknown_scenario_name_lists_the_built_ins():
    """An unknown name says which built-ins exist."""
    with pytest.raises(ScenarioError, match=r"unknown scenario 'example-9.99'; expected a built-in name \(.*example-9.2"):
        load_scenario("example-9.99")


@pytest.mark.parametrize("name", ["", "  "])
def test_an_empty_scenario_name_is_said_to_be_empty(name):
    """`run ""` said '.: cannot be read: it is a folder' (Path("") is the current folder): now the name is empty."""
    with pytest.raises(ScenarioError, match=r"the scenario name is empty .*expected a built-in name \(.*example-9.2"):
        load_scenario(name)

def test_built_ins_include_examples_9_1_and_9_2():
    """`forcecontrol list` shows the chapter's Examples 9.1 and 9.2."""
    names = list_scenarios()
    assert {"example-9.1", "example-9.2"} <= set(names)


@pytest.mark.parametrize("name", sorted(list_scenarios()))
def test_every_built_in_scenario_validates(name):
    """Every shipped scenario passes its own schema (all cases built before running)."""
    assert load_scenario(name).cases


@pytest.mark.parametrize("key, value, message", [
    ("duration", "-1.0", "key 'duration' must be a positive number [s]; got -1.0"),
    ("sample_time", "0.0", "key 'sample_time' must be a positive number [s]; got 0.0"),
    ("substeps", "0", "key 'substeps' must be a positive integer; got 0"),
    ("tolerance", "-0.1", "key 'tolerance' must be a non-negative number; got -0.1"),
])
def test_a_bad_top_level_setting_is_named_where_it_is_written(tmp_path, key, value, message):
    """A top-level setting no [[case]] sets is refused as the file's top level ('SCN: top level: key ...'), not as
    '[[case]] #1', a table that does not hold it; the same value in the second [[case]] is refused as that case."""
    cases = '\n[[case]]\nlabel = "a"\n[[case]]\nlabel = "b"\n'
    top = GOOD.replace("duration = 0.2\n", "duration = 0.2\n" if key == "duration" else f"duration = 0.2\n{key} = {value}\n")
    if key == "duration":
        top = top.replace("duration = 0.2", "duration = -1.0")
    with pytest.raises(ScenarioError) as exc:
        load_scenario(_write(tmp_path, top + cases))
    assert str(exc.value).endswith(f"scn.toml: top level: {message}"), str(exc.value)
    with pytest.raises(ScenarioError) as exc:
        load_scenario(_write(tmp_path, GOOD + cases + f"{key} = {value}\n"))
    assert str(exc.value).endswith(f"scn.toml: [[case]] #2: {message}"), str(exc.value)
