"""`run --json` lists each case's warnings and events: what stderr said (servo/IK limits, config notes, contact lost)."""

from __future__ import annotations

import json

import tomllib

import forcecontrol.scenarios as S
from forcecontrol.scenarios.summary import case_warnings
from journeys_helpers import forcecontrol


def _servo_file(folder, velocity_limit: float | None) -> str:
    """servo-admittance's first case for 0.3 s, with a joint speed limit of the servo when given."""
    text = S.scenario_source("servo-admittance").read_text(encoding="utf-8").replace("duration = 3.0", "duration = 0.3")
    if velocity_limit is not None:
        text = text.replace("delay = 1\n", f"delay = 1\nvelocity_limit = {velocity_limit}\n", 1)
    text = text.split("[[case]]", 1)[0]
    assert tomllib.loads(text)["duration"] == 0.3
    (folder / "servo.toml").write_text(text, encoding="utf-8")
    return "servo.toml"


def test_a_run_whose_servo_limits_act_says_so_in_json_and_on_stderr(tmp_path):
    """A 0.02 rad/s joint speed limit: 'servo-limit' in the case's --json warnings and events (same t) and on stderr."""
    proc = forcecontrol(tmp_path, "run", _servo_file(tmp_path, 0.02), "--json", "--no-figure")
    case = json.loads(proc.stdout)["cases"][0]
    limits = [w for w in case["warnings"] if w["kind"] == "servo-limit"]
    events = [e for e in case["events"] if e["event"] == "servo-limit"]
    assert len(limits) == 1 and len(events) == 1
    assert limits[0]["t"] == events[0]["t"] and 0.0 <= limits[0]["t"] < 0.3
    assert limits[0]["text"] == events[0]["detail"] and "joint(s) [1]" in limits[0]["text"]
    assert "servo's speed/acceleration/jerk limits changed the motion" in proc.stderr


def test_a_run_within_the_servo_limits_has_no_servo_warning(tmp_path):
    """The same case without the speed limit: no 'servo-limit' in --json (warnings and events) nor on stderr."""
    proc = forcecontrol(tmp_path, "run", _servo_file(tmp_path, None), "--json", "--no-figure")
    case = json.loads(proc.stdout)["cases"][0]
    assert all(w["kind"] != "servo-limit" for w in case["warnings"]) and all(e["event"] != "servo-limit" for e in case["events"])
    assert "servo-limit" not in proc.stderr and "speed/acceleration/jerk" not in proc.stderr


def test_contact_loss_and_config_notes_are_warnings_of_the_case():
    """case_warnings: a contact loss counted by the metrics and the reader's config notes become warnings with their kind."""
    from types import SimpleNamespace

    result = SimpleNamespace(metadata={"controller": {"config_notes": ["key 'x' not read"]}},
                             events=[{"t": 0.5, "event": "contact", "detail": "in"},
                                     {"t": 0.2, "event": "ik-limit", "detail": "held"}],
                             peak_contact_force_norm=lambda: 12.0)
    case = SimpleNamespace(result=result, metrics={"contact_losses": 2.0}, checks=[])
    got = case_warnings(case)
    assert [w["kind"] for w in got] == ["config-note", "ik-limit", "contact-lost"]
    assert got[0]["text"] == "key 'x' not read" and got[1]["t"] == 0.2 and got[2]["count"] == 2
    assert "contact lost 2 time(s)" in got[2]["text"] and "allowed by the scenario" in got[2]["text"]


def test_analyze_json_lists_the_config_notes_it_warned(tmp_path):
    """`analyze FILE --json` of a vendor scenario: the reader's notes said on stderr are each case's config-note warnings."""
    from importlib import resources

    configs = resources.files("forcecontrol.scenarios") / "configs"
    for f in ("fzi_issue_21.toml", "fzi_issue_21.yaml"):
        (tmp_path / f).write_text((configs / f).read_text(encoding="utf-8"), encoding="utf-8")
    proc = forcecontrol(tmp_path, "analyze", "fzi_issue_21.toml", "--json")
    cases = json.loads(proc.stdout)["cases"]
    assert len(cases) == 2
    for case in cases:
        notes = [w["text"] for w in case["warnings"] if w["kind"] == "config-note"]
        assert any("solver.error_scale not set" in n for n in notes)
        assert all(n in proc.stderr for n in notes)


def test_a_force_asked_of_a_tool_that_never_touches_is_said_on_stderr_and_in_json(tmp_path):
    """Example 9.3 (f_d = 10 N) with its plane moved 0.8 m beyond the start and 0.3 s to go: the tool never touches; the
    run says so on stderr (`warning: LABEL: the reference asks a contact force ... never touched`) and as a 'no-contact'
    warning of each case in --json; the unchanged scenario touches and says nothing of the kind."""
    args = ("run", "example-9.3", "--set", "duration=0.3", "--set", "environment.point=[1.8, 0.0]")
    table = forcecontrol(tmp_path, *args)
    doc = json.loads(forcecontrol(tmp_path, *args, "--json", "--force").stdout)
    for case in doc["cases"]:
        kinds = [w for w in case["warnings"] if w["kind"] == "no-contact"]
        assert len(kinds) == 1 and "up to 10 N along an axis" in kinds[0]["text"], case["warnings"]
        assert f"warning: {case['label']}: the reference asks a contact force" in table.stdout + table.stderr
    near = json.loads(forcecontrol(tmp_path, "run", "example-9.3", "--set", "duration=0.3", "--json", "--force").stdout)
    assert all(w["kind"] != "no-contact" for c in near["cases"] for w in c["warnings"])


def test_the_checks_table_gives_no_relative_error_for_a_quantity_expected_to_be_zero():
    """contact_losses 19 against 0 printed '+1900.000 %' (the JSON's relative_error is then the difference itself):
    the table shows '—' there, and the percentage elsewhere."""
    from types import SimpleNamespace

    from forcecontrol.scenarios.summary import checks_table

    checks = [{"metric": "contact_losses", "value": 19, "expected": 0, "tolerance": 0, "relative_error": 19.0, "ok": False},
              {"metric": "fx", "value": 201.0, "expected": 200.0, "tolerance": 1.0, "relative_error": 0.005, "ok": True}]
    _, rows = checks_table(SimpleNamespace(cases=[SimpleNamespace(label="a", checks=checks)]))
    assert [r[5] for r in rows] == ["—", "+0.500 %"]


def test_a_sampled_loop_that_cannot_settle_is_said_by_run_as_by_analyze(tmp_path):
    """Example 9.2 on a plane of 2.4e6 N/m, past its sampled stability limit (2.23e6 N/m at T = 1 ms; the simulation
    bounces there, tests/test_sampled_contact.py): `run`, with its table and with --json, says so on stderr and as a
    'sampled-unstable' warning of each case, the very warning `analyze --json` gives; the book's planes get none.
    Before, only `analyze` said it: the run printed its continuous-model numbers without a word."""
    args = ("example-9.2", "--set", "duration=0.3", "--set", "environment.stiffness=2.4e6")
    table = forcecontrol(tmp_path, "run", *args)
    run = forcecontrol(tmp_path, "run", *args, "--json")
    analyzed = json.loads(forcecontrol(tmp_path, "analyze", *args, "--json").stdout)
    doc = json.loads(run.stdout)
    for case, predicted in zip(doc["cases"], analyzed["cases"], strict=True):
        said = [w for w in case["warnings"] if w["kind"] == "sampled-unstable"]
        want = [w for w in predicted["warnings"] if w["kind"] == "sampled-unstable"]
        assert len(said) == 1 and said == want, (said, want)
        assert said[0]["axes"] == ["x"] and said[0]["end_spectral_radius"] >= 1.0
        for proc in (table, run):
            assert f"warning: {said[0]['text']}" in proc.stderr, proc.stderr
    book = json.loads(forcecontrol(tmp_path, "run", "example-9.2", "--set", "duration=0.3", "--json").stdout)
    assert all(w["kind"] != "sampled-unstable" for c in book["cases"] for w in c["warnings"])
