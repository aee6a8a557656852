"""Every input path ends in the library's own error or in standard JSON, never a raw traceback.

Each defect of the hardening issue that reaches the scenario loader or the JSON output has a test.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

import forcecontrol as fc
from forcecontrol.cli import app
from forcecontrol.core.jsonsafe import json_safe
from forcecontrol.errors import ParameterError, ScenarioError
from forcecontrol.scenarios import load_scenario, scenario_source

runner = CliRunner()


def _example(tmp_path, text=None, name="s.toml"):
    src = scenario_source("example-9.2").read_text(encoding="utf-8") if text is None else text
    p = tmp_path / name
    p.write_text(src, encoding="utf-8")
    return p, src


def test_utf16_file_is_refused_naming_the_encoding(tmp_path):
    """A UTF-16 scenario file: ScenarioError saying it is not UTF-8 (looks like UTF-16), not UnicodeDecodeError."""
    _, src = _example(tmp_path)
    p = tmp_path / "utf16.toml"
    p.write_bytes(src.encode("utf-16"))
    with pytest.raises(ScenarioError, match=r"not UTF-8 text \(it looks like UTF-16\).*must be saved as UTF-8"):
        load_scenario(p)


def test_latin1_file_is_refused_with_the_byte(tmp_path):
    """A Latin-1 byte in a file: ScenarioError naming the byte offset (11: after 'name = "caf')."""
    p = tmp_path / "latin1.toml"
    p.write_bytes('name = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(ScenarioError, match=r"not UTF-8 text: byte 11 is b'\\xe9'"):
        load_scenario(p)


def test_utf8_bom_is_accepted(tmp_path):
    """A UTF-8 byte-order mark (as some editors write) is harmless."""
    _, src = _example(tmp_path)
    p = tmp_path / "bom.toml"
    p.write_bytes(b"\xef\xbb\xbf" + src.encode("utf-8"))
    assert load_scenario(p).name == "example-9.2"


@pytest.mark.parametrize("depth", [20, 5000])
def test_deep_nesting_is_refused(tmp_path, depth):
    """Arrays nested 20 or 5000 deep: ScenarioError 'nested too deeply', never RecursionError."""
    _, src = _example(tmp_path)
    p = tmp_path / "deep.toml"
    p.write_text(src.replace("duration = 4.0", "duration = 4.0\nextra = " + "[" * depth + "1" + "]" * depth), encoding="utf-8")
    with pytest.raises(ScenarioError, match="nested too deeply"):
        load_scenario(p)


@pytest.mark.parametrize("seed", [-1, 2**64, 1.5, True, "3"])
def test_bad_seed_is_a_clear_error(seed):
    """A sensor seed must be an integer in [0, 2**63): -1 was a raw numpy ValueError."""
    with pytest.raises(ParameterError, match=r"seed must be an integer in \[0, 2\*\*63\)"):
        fc.ForceSensor(noise_std=0.1, seed=seed)


def test_bad_seed_in_a_scenario_names_the_table(tmp_path):
    """[sensor] seed = -1 in a file: ScenarioError naming [sensor] and the seed."""
    _, src = _example(tmp_path)
    p = tmp_path / "seed.toml"
    p.write_text(src + "\n[sensor]\nnoise_std = 0.1\nseed = -1\n", encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"\[sensor\].*seed must be an integer"):
        load_scenario(p)


def test_unreadable_path_is_a_scenario_error(tmp_path):
    """A folder given as a scenario file: ScenarioError 'cannot be read', not IsADirectoryError."""
    d = tmp_path / "dir.toml"
    d.mkdir()
    with pytest.raises(ScenarioError, match="cannot be read"):
        load_scenario(d)


def test_json_safe_replaces_non_finite_numbers_and_says_where():
    """NaN/inf become null, with their location noted; finite values and numpy scalars pass through."""
    notes: list[str] = []
    out = json_safe({"a": [1.0, math.nan, np.float64(np.inf)], "b": {"c": np.int64(3), "d": -math.inf}}, notes)
    assert out == {"a": [1.0, None, None], "b": {"c": 3, "d": None}}
    assert notes == ["a[1] = nan", "a[2] = inf", "b.d = -inf"]
    json.dumps(out, allow_nan=False)


def test_json_safe_writes_a_negative_zero_as_zero():
    """-0.0 (a zero force along a negated axis) is written 0.0, as a float; other values keep their sign."""
    out = json_safe({"f": [-0.0, np.float64(-0.0), -1e-300]})
    assert json.dumps(out) == '{"f": [0.0, 0.0, -1e-300]}'
    assert all(isinstance(v, float) for v in out["f"])

def test_run_json_is_standard_json_with_a_nan_metric(tmp_path):
    """An expected value that yields NaN: `run --json` still prints standard JSON (null + a note)."""
    from forcecontrol.scenarios import run_scenario

    run = run_scenario("example-9.2")
    run.cases[0].metrics["fx"] = math.nan  # a metric that did not settle
    doc = run.to_json()
    text = json.dumps(doc, allow_nan=False)
    assert json.loads(text)["cases"][0]["settled"]["fx"] is None
    assert "cases[0].settled.fx = nan" in doc["notes"][0]
    res = runner.invoke(app, ["run", "example-9.2", "--json", "--no-figure"])
    assert res.exit_code == 0
    json.loads(res.stdout, parse_constant=lambda c: pytest.fail(f"non-standard JSON constant {c}"))


def test_run_never_overwrites_without_force(tmp_path):
    """A second `run` into the same folder is refused (exit 2, naming the folder and --force); --force overwrites."""
    first = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path)])
    assert first.exit_code == 0, first.output
    png = tmp_path / "example-9.2" / "example-9.2.png"
    before = png.stat().st_mtime_ns
    again = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path)])
    assert again.exit_code == 2
    assert "already holds" in again.output and "--force" in again.output
    assert png.stat().st_mtime_ns == before
    forced = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path), "--force"])
    assert forced.exit_code == 0, forced.output


def test_unwritable_out_is_a_clear_error(tmp_path):
    """--out pointing below a regular file: exit 2 with 'cannot create the output folder', no raw OSError."""
    blocker = tmp_path / "file"
    blocker.write_text("x")
    res = runner.invoke(app, ["run", "example-9.2", "--out", str(blocker / "sub")])
    assert res.exit_code == 2
    assert "cannot create the output folder" in res.output
    assert res.exception is None or isinstance(res.exception, SystemExit)


@pytest.mark.parametrize("name", ["..", "../../escape", "/abs/path", "a/../../b", ".hidden"])
def test_scenario_names_cannot_write_outside_out(tmp_path, name):
    """A scenario named '..' (or with slashes) writes inside --out, under a sanitised folder name."""
    _, src = _example(tmp_path)
    p = tmp_path / "named.toml"
    p.write_text(src.replace('name = "example-9.2"', f"name = {json.dumps(name)}"), encoding="utf-8")
    out = tmp_path / "out"
    res = runner.invoke(app, ["run", str(p), "--out", str(out)])
    assert res.exit_code == 0, res.output
    written = [q for q in tmp_path.rglob("*.png")]
    assert written and all(out in q.parents for q in written)
    assert not (tmp_path / "escape").exists()


def test_unexpected_bounce_fails_the_check(tmp_path):
    """Example 9.2 at 1e7 N/m bounces: the summary warns, JSON counts the losses and --check exits 1."""
    _, src = _example(tmp_path)
    p = tmp_path / "stiff.toml"
    p.write_text(src.replace("environment.stiffness = 10000.0", "environment.stiffness = 1e7")
                 .replace("environment.stiffness = 1000.0", "environment.stiffness = 1e7"), encoding="utf-8")
    res = runner.invoke(app, ["run", str(p), "--no-figure"])
    assert res.exit_code == 0 and "contact lost" in res.output
    res = runner.invoke(app, ["run", str(p), "--no-figure", "--check"])
    assert res.exit_code == 1
    doc = json.loads(runner.invoke(app, ["run", str(p), "--no-figure", "--json"]).stdout)
    lost = [c["settled"]["contact_losses"] for c in doc["cases"]]
    assert all(n > 0 for n in lost)
    assert any(ch["metric"] == "contact_losses" and not ch["ok"] for c in doc["cases"] for ch in c["checks"])


def test_declared_contact_loss_is_reported_not_failed():
    """The impact scenario's naive case bounces by design (allow_contact_loss): counted, no failed check."""
    from forcecontrol.scenarios import run_scenario

    run = run_scenario("impact")
    naive = [c for c in run.cases if c.label.startswith("naive")][0]
    assert naive.metrics["contact_losses"] == 9  # the count for these gains
    assert all(ch["metric"] != "contact_losses" for ch in naive.checks)
    documented = run.cases[0]
    assert documented.metrics["contact_losses"] == 0


def test_top_level_value_every_case_overrides_is_still_checked(tmp_path):
    """A negative stiffness at the top level, overridden by every [[case]], is refused naming the key (it passed before)."""
    _, src = _example(tmp_path)
    assert "stiffness = 1000.0" in src
    p = tmp_path / "shadowed.toml"
    p.write_text(src.replace("stiffness = 1000.0", "stiffness = -1000.0", 1), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"top-level 'environment.stiffness' \(every \[\[case\]\] overrides it\).*stiffness"):
        load_scenario(p)
    for name in ("example-9.1", "example-9.2", "example-9.3", "example-9.4", "impact", "problem-9.10"):
        load_scenario(name)  # the built-in scenarios' shadowed values are valid


def test_figure_signal_that_does_not_exist_is_refused_before_simulating(tmp_path):
    """signals = ["fz"] on the planar arm: ScenarioError at load naming the valid signals (was a KeyError after simulating)."""
    _, src = _example(tmp_path)
    p = tmp_path / "fz.toml"
    assert 'signals = ["y", "fx"]' in src
    p.write_text(src.replace('signals = ["y", "fx"]', 'signals = ["y", "fz"]', 1), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"names no signal 'fz' of this robot; expected one of \['t', 'q1'"):
        load_scenario(p)
