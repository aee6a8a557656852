"""Issue 28 (items 1 and 5): hostile values are refused before anything is allocated or run.

Each row is a value from the issue's hostile-input campaign; each must end in the library's own
error (exit code 2 from the CLI) whose message names the key, the allowed range and the value,
with no traceback, in bounded time (a subprocess timeout, not a wall-clock assert).
"""

from __future__ import annotations

import os
import subprocess

import pytest
import tomllib

import cli_server
import forcecontrol as fc
from forcecontrol.errors import ForceControlError, ParameterError, ScenarioError
from forcecontrol.scenarios import load_scenario, scenario_source
from forcecontrol.sweep.spec import SweepDefinition

TIMEOUT = 60  # [s] per subprocess: a refusal is immediate, a hang or a 15 GB allocation is not

HUGE = 10**400  # an integer of 401 digits (float() raises OverflowError)


def _scenario(name: str = "example-9.1"):
    return fc.scenario(name)


def _base_toml(name: str = "example-9.1") -> str:
    return scenario_source(name).read_text(encoding="utf-8")


# key path, value, expected fragments of the message (key, range, value)
API_ROWS = [
    ("sensor.zeroing_samples", 10**9, ["zeroing_samples", "100000", "1000000000"]),
    ("sensor.delay_samples", 10**9, ["delay_samples", "100000", "1000000000"]),
    ("sensor.resolution", 1e308, ["resolution", "1000", "1e+308"]),
    ("actuator.delay_samples", 10**8, ["delay_samples", "100000", "100000000"]),
    ("sensor.zeroing_samples", HUGE, ["zeroing_samples", "100000", "401 digits"]),
    ("duration", HUGE, ["duration", "401 digits"]),
    ("controller.stiffness", HUGE, ["stiffness", "401 digits"]),
    ("environment.angle", 1e300, ["angle", "[-360, 360]", "1e+300"]),
    ("robot.q0", [-1e308, 0.0], ["q0", "[-100, 100]", "-1e+308"]),
    ("actuator.resolution", 1e308, ["resolution", "1000", "1e+308"]),
]


@pytest.mark.parametrize("key, value, parts", API_ROWS, ids=[f"{k}={str(v)[:12]}" for k, v, _ in API_ROWS])
def test_api_refuses_hostile_value(key, value, parts):
    """Scenario.with_ refuses each hostile value with a ScenarioError naming the key, its range and the value."""
    scn = _scenario()
    if key.startswith("sensor."):
        scn = scn.with_({"sensor": {}})
    if key.startswith("actuator."):
        scn = scn.with_({"actuator": {}})
    if key == "environment.angle":
        scn = scn.with_({"environment": {"type": "elastic-plane", "point": [1.0, 0.0], "angle": 0.0, "stiffness": 1000.0}})
    with pytest.raises(ScenarioError) as exc:
        scn.with_({key: value})
    msg = str(exc.value)
    for p in parts:
        assert p in msg, (p, msg)


def test_delay_longer_than_the_run_is_refused():
    """A sensor delay of more samples than the run has (force feedback never arrives) names the run's samples."""
    scn = _scenario().with_({"sensor": {}, "duration": 0.5})
    with pytest.raises(ScenarioError, match=r"key 'delay_samples' must be in \[0, 500\].*got 501"):
        scn.with_({"sensor.delay_samples": 501})
    scn.with_({"sensor.delay_samples": 500})  # the bound itself is accepted


def test_schema_printout_shows_ranges():
    """The JSON schema (what 'forcecontrol schema' prints) carries each declared range in the key's description."""
    from forcecontrol.scenarios.model import scenario_json_schema

    text = str(scenario_json_schema())
    assert "in [-360, 360]" in text and "at most 100000, at most the run's samples" in text


@pytest.mark.parametrize("kwargs, match", [
    ({"zeroing_samples": 10**9}, "zeroing_samples must be a non-negative integer, at most 100,000"),
    ({"delay_samples": HUGE}, "delay_samples must be a non-negative integer, at most 100,000.*401 digits"),
])
def test_sensor_constructor_bounds_buffers(kwargs, match):
    """RealisticForceSensor refuses a buffer size beyond the limit in its constructor (before start() allocates it)."""
    with pytest.raises(ParameterError, match=match):
        fc.RealisticForceSensor(**kwargs)


@pytest.mark.parametrize("delay", [10**8, 1e8, HUGE])
def test_actuator_constructor_bounds_delay(delay):
    """Actuator refuses a delay beyond 1e5 samples (ints of any size, floats), no OverflowError or MemoryError."""
    from forcecontrol.sim.actuators import Actuator

    with pytest.raises(ParameterError, match=r"delay must be a whole number of samples in \[0, 100,000\]"):
        Actuator(delay=delay)


@pytest.mark.parametrize("param, match", [
    ("environment.stiffness=logspace(3, 6, 1e8)", "gives 100,000,000 values, more than the 1,000,000"),
    ("environment.stiffness=range(1e30)", "more than the 1,000,000"),
    ("x=" + "-" * 100000 + "1", "100,001 characters long, more than the 10,000"),
    ("x=" + "-" * 9000 + "1", "cannot read value"),
    ("x=linspace(1, " + "9" * 401 + ", 3)", "takes numbers of magnitude at most 2\\*\\*63 - 1"),
])
def test_sweep_parameter_limits(param, match):
    """Sweep values are counted, and expressions measured, before anything is materialised or parsed."""
    with pytest.raises(ForceControlError, match=match):
        SweepDefinition.from_options([param])


def test_a_grid_of_more_variations_than_a_sweep_may_have_is_refused_before_it_is_built(tmp_path):
    """Two 10,000-point parameters make a 10^8-case grid: refused at once, naming the product and the limit (it was
    materialised until the memory ran out); the same limit as a random design's samples. The CLI exits 2 at once."""
    import time

    params = ["environment.stiffness=logspace(3, 6, 10000)", "controller.damping[0]=linspace(100, 1000, 10000)"]
    with pytest.raises(ForceControlError, match=r"the grid has 10,000 x 10,000 = 100,000,000 variations, more than the "
                                                r"1,000,000 a sweep may have; use fewer points, or design = 'random'"):
        SweepDefinition.from_options(params)
    SweepDefinition.from_options(["environment.stiffness=logspace(3, 6, 1000)", "controller.damping[0]=linspace(1, 9, 1000)"])
    start = time.monotonic()
    proc = _cli("sweep", "example-9.2", "-p", params[0], "-p", params[1], cwd=tmp_path)
    assert proc.returncode == 2 and "100,000,000 variations" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert time.monotonic() - start < 60


def test_empty_table_in_a_case_names_the_case_and_key(tmp_path):
    """[[case]] with controller.stiffness = {} is an error naming the case and the key (it was dropped silently)."""
    text = _base_toml() + '\n[[case]]\nlabel = "a"\ncontroller.stiffness = {}\n'
    assert tomllib.loads(text)["case"][-1]["controller"]["stiffness"] == {}
    p = tmp_path / "empty.toml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"\[\[case\]\] #\d+: key 'controller.stiffness' is an empty table"):
        load_scenario(p)


def _cli(*args: str, cwd) -> subprocess.CompletedProcess:
    env = {**os.environ, "NUMBA_CACHE_DIR": os.environ.get("NUMBA_CACHE_DIR", str(cwd / "numba"))}
    return cli_server.run(list(args), cwd=cwd, env=env, module=True, timeout=TIMEOUT)


@pytest.mark.parametrize("edit, parts", [
    ("[sensor]\nzeroing_samples = 1000000000\n", ["zeroing_samples", "100000", "1000000000"]),
    ("[sensor]\ndelay_samples = 1000000000\n", ["delay_samples", "100000"]),
    ("[actuator]\ndelay_samples = 100000000\n", ["delay_samples", "100000"]),
    ("[sensor]\nresolution = 1e308\n", ["resolution", "1000"]),
    ("[sensor]\nzeroing_samples = " + "9" * 401 + "\n", ["zeroing_samples", "401 digits"]),
])
@pytest.mark.parametrize("command", ["run", "analyze"])
def test_cli_refuses_hostile_scenario(tmp_path, command, edit, parts):
    """forcecontrol run/analyze on a hostile scenario file: exit code 2, the key and range on stderr, no traceback."""
    text = _base_toml()
    table = edit.split("\n", 1)[0]
    assert table not in text
    p = tmp_path / "hostile.toml"
    p.write_text(text.replace("[[case]]", edit + "\n[[case]]", 1) if "[[case]]" in text else text + "\n" + edit)
    r = _cli(command, str(p), cwd=tmp_path)
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    assert "Traceback" not in r.stderr
    flat = "".join(r.stderr.replace("│", "").split())  # the message may be wrapped in a box
    for part in parts:
        assert part.replace(" ", "") in flat, (part, r.stderr[-2000:])


@pytest.mark.parametrize("args", [
    ["sweep", "example-9.1", "-p", "environment.stiffness=1000,2000", "--workers", "-1"],
    ["compare-trace", "example-9.1", "missing.csv", "--max-shift", "nan"],
])
def test_cli_option_checks(tmp_path, args):
    """--workers -1 and --max-shift nan: a usage error (exit 2) naming the option, no traceback."""
    r = _cli(*args, cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert ("--workers" if "--workers" in args else "--max-shift") in r.stderr


def test_angle_at_the_bound_is_accepted():
    """The range is inclusive: a plane at exactly 360° is accepted (the bound itself is not refused)."""
    scn = _scenario().with_({"environment": {"type": "elastic-plane", "point": [1.0, 0.0], "angle": 360.0, "stiffness": 1e3}})
    assert scn.cases[0].config["environment"]["angle"] == 360.0
