"""The [robot.servo] table is in the scenario schema (table and --json) and checked from the same declarations."""

from __future__ import annotations

import json

import pytest
import tomllib
from typer.testing import CliRunner

import forcecontrol.scenarios as S
from forcecontrol.cli import app
from forcecontrol.errors import ScenarioError
from forcecontrol.scenarios.model import ROBOT_FIELDS, scenario_model
from forcecontrol.scenarios.servo_robot import SERVO_FIELDS

runner = CliRunner()


def _servo_scenario(**servo) -> dict:
    """The built-in servo-admittance scenario with its [robot.servo] table replaced."""
    data = tomllib.loads(S.scenario_source("servo-admittance").read_text(encoding="utf-8"))
    data["robot"]["servo"] = servo
    return data


def test_json_schema_lists_every_servo_key_with_its_range():
    """`schema --json`: [robot] servo refers to a definition holding every [robot.servo] key, its doc and range."""
    res = runner.invoke(app, ["schema", "--json"])
    assert res.exit_code == 0, res.output
    defs = json.loads(res.stdout)["$defs"]
    ref = [q["$ref"] for q in defs["robot"]["properties"]["servo"]["anyOf"] if "$ref" in q][0]
    servo = defs[ref.rsplit("/", 1)[-1]]["properties"]
    assert set(servo) == set(SERVO_FIELDS)
    for key, field in SERVO_FIELDS.items():
        assert servo[key]["description"] == field.described(), key
        if field.low is not None or field.high is not None:
            assert "range:" in servo[key]["description"], key
    assert servo["preset"]["anyOf"][0]["enum"] == list(SERVO_FIELDS["preset"].choices)


def test_schema_table_prints_the_servo_table():
    """`schema` prints a [robot.servo] table naming every key (rate with its range)."""
    out = runner.invoke(app, ["schema"]).stdout
    block = out.split("[robot.servo]", 1)[1].split("[sensor]", 1)[0]
    for key in SERVO_FIELDS:
        assert f"│ {key} " in block, key
    assert "interface rate [Hz] (range: in [1," in block and "100000])" in block


def test_the_loader_checks_servo_keys_from_the_schema_declarations():
    """One source: the [robot] servo field's nested keys are SERVO_FIELDS; the loader and the model refuse the same."""
    assert ROBOT_FIELDS["servo"].fields is SERVO_FIELDS
    bad = [({"rate": 0.5, "bandwidth": 40.0}, r"\[robot\.servo\]: key 'rate' must be in \[1, 100000\] .*got 0\.5"),
           ({"bandwith": 40.0, "rate": 500.0}, r"\[robot\.servo\]: unknown key 'bandwith'; expected one of: .*bandwidth"),
           ({"rate": "fast", "bandwidth": 40.0}, r"\[robot\.servo\]: key 'rate' must be a finite number .*got 'fast' \(str\)"),
           ({"preset": "kuka", "delay": 1}, r"\[robot\.servo\]: key 'preset' must be one of 'ur-e-series'"),
           ({"preset": "kuka-rsi", "delay": -1}, r"\[robot\.servo\]: key 'delay' must be in \[0, 100\]")]
    for servo, msg in bad:
        with pytest.raises(ScenarioError, match=msg):
            S.load_scenario(_servo_scenario(**servo))
    good = _servo_scenario(preset="kuka-rsi", delay=2)
    scenario_model().model_validate(good)  # the schema's model accepts what the loader accepts
    S.load_scenario(good)


def test_vendor_types_list_config_section_and_their_parameters():
    """Each vendor controller type is in `schema` and `schema --json` with 'config', 'section' and every parameter."""
    from forcecontrol.scenarios.parts_vendor import VENDOR_TYPES

    defs = json.loads(runner.invoke(app, ["schema", "--json"]).stdout)["$defs"]
    by_type = {d["properties"]["type"]["const"]: d["properties"] for d in defs.values() if "type" in d.get("properties", {})}
    text = runner.invoke(app, ["schema"]).stdout
    for kind, (_, fields) in VENDOR_TYPES.items():
        assert set(by_type[kind]) == {"type", "config", "section", *fields}, kind
        assert by_type[kind]["config"]["description"].startswith("the controller's own configuration file")
        block = text.split(f'[controller] type = "{kind}"', 1)[1].split("[controller] type =", 1)[0]
        for key in ("config", "section", *fields):
            assert f"│ {key} " in block, (kind, key)


def test_schema_table_shows_the_choices_of_a_str_key():
    """`schema` shows a key with choices by its choices (preset: 'ur-e-series' | 'kuka-rsi' | ...), not as 'string'."""
    out = runner.invoke(app, ["schema"]).stdout
    block = out.split("[robot.servo]", 1)[1].split("[sensor]", 1)[0]
    assert "'ur-e-series'" in block and "'kuka-rsi'" in block and "'position'" in block and "'velocity'" in block
