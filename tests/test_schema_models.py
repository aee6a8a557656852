"""The scenario schema is generated from pydantic models: every built-in file fits it, every type is in it."""

from __future__ import annotations

import json

import pytest
import tomllib
from pydantic import ValidationError
from typer.testing import CliRunner

import forcecontrol.scenarios as S
from forcecontrol.cli import app
from forcecontrol.errors import ScenarioError
from forcecontrol.scenarios.model import scenario_json_schema, scenario_model
from forcecontrol.scenarios.schema import CONTROLLERS, ENVIRONMENTS, REFERENCES, Field, check_table

runner = CliRunner()


@pytest.mark.parametrize("name", sorted(S.list_scenarios()))
def test_every_builtin_scenario_file_fits_the_generated_model(name):
    """The model the schema is generated from accepts every built-in file (what the loader accepts)."""
    data = tomllib.loads(S.scenario_source(name).read_text(encoding="utf-8"))
    scenario_model().model_validate(data)


def test_the_generated_model_refuses_what_the_loader_refuses():
    """An unknown key, a wrong type or an unknown part type fails the model as it fails the loader."""
    data = tomllib.loads(S.scenario_source("example-9.2").read_text(encoding="utf-8"))
    for bad in ({"controler": {}}, {"duration": "long"}, {"controller": {"type": "telepathy"}}):
        with pytest.raises(ValidationError):
            scenario_model().model_validate({**data, **bad})
        with pytest.raises(ScenarioError):
            S.load_scenario({**data, **bad})


def test_json_schema_lists_every_registered_type_with_its_keys():
    """`forcecontrol schema --json` is the models' JSON schema: one definition per registered type, its keys."""
    res = runner.invoke(app, ["schema", "--json"])
    assert res.exit_code == 0, res.output
    schema = json.loads(res.stdout)
    assert schema == json.loads(json.dumps(scenario_json_schema()))
    consts = {
        (d["properties"]["type"]["const"], frozenset(d["properties"]) - {"type"})
        for d in schema["$defs"].values() if "type" in d.get("properties", {})
    }
    for registry in (CONTROLLERS, ENVIRONMENTS, REFERENCES):
        for name, spec in registry.items():
            assert (name, frozenset(spec.fields)) in consts, name


def test_a_field_registered_later_appears_in_the_schema():
    """A part registered through register_controller after import shows up in the generated schema."""
    from forcecontrol.scenarios.schema import register_controller

    name = "test-only-controller"
    register_controller(name, {"zeta_gain": Field("number", required=True, doc="a test gain")}, lambda p, c: None)
    try:
        props = [d["properties"] for d in scenario_json_schema()["$defs"].values()
                 if d.get("properties", {}).get("type", {}).get("const") == name]
        assert props and props[0]["zeta_gain"]["description"] == "a test gain"
    finally:
        del CONTROLLERS[name]


def test_check_table_messages_name_table_key_expectation_and_value():
    """Errors come from the models but read as the library's: table, key, what was expected, what was given."""
    fields = {"stiffness": Field("gain", required=True, doc="K_P [N/m]"), "on": Field("bool", default=False)}
    where = "scn.toml: [controller]"
    with pytest.raises(ScenarioError, match=r"\[controller\]: key 'stiffness' must be a number, a list .*got 'x' \(str\)"):
        check_table(where, {"stiffness": "x"}, fields)
    with pytest.raises(ScenarioError, match=r"\[controller\]: unknown key 'stifness'; expected one of: on, stiffness"):
        check_table(where, {"stifness": 1.0}, fields)
    with pytest.raises(ScenarioError, match=r"\[controller\]: missing key 'stiffness' \(K_P \[N/m\]\)"):
        check_table(where, {}, fields)
    with pytest.raises(ScenarioError, match=r"key 'on' must be true or false; got 1 \(int\)"):
        check_table(where, {"stiffness": 1.0, "on": 1}, fields)
    assert check_table(where, {"stiffness": 2}, fields) == {"stiffness": 2, "on": False}
