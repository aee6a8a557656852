"""The built-in scenario "example-9.3" and the `forcecontrol analyze` command."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from forcecontrol.cli import app
from forcecontrol.errors import DriftWarning, ScenarioError
from forcecontrol.scenarios import load_scenario, run_scenario
from forcecontrol.scenarios.report import analyze_scenario

runner = CliRunner()


def test_scenario_has_three_schemes_times_two_stiffnesses():
    """example-9.3 has six cases: inner position, inner velocity, parallel × k_x = 10⁴, 10³."""
    scn = load_scenario("example-9.3")
    kinds = [(c.config["controller"]["type"], c.config["environment"]["stiffness"]) for c in scn.cases]
    assert sorted(kinds) == sorted((s, k) for s in ("inner-position", "inner-velocity", "parallel") for k in (1e4, 1e3))


def test_scenario_runs_and_meets_every_book_value():
    """Running example-9.3 meets all expected values: f_x = 10 N, penetration f_d/k_x, y, and the book's poles."""
    run = run_scenario("example-9.3", engine="compiled")
    missed = [(c.label, ch) for c in run.cases for ch in c.checks if not ch["ok"]]
    assert not missed
    assert sum(len(c.checks) for c in run.cases) == 28


def test_analyze_json_gives_the_book_poles_without_simulating():
    """`analyze example-9.3 --json`: book poles for k_x = 10³ checked, stability limits reported, exit 0."""
    res = runner.invoke(app, ["analyze", "example-9.3", "--json", "--check"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["all_checks_pass"] is True
    case = next(c for c in data["cases"] if c["label"] == "inner velocity, k_x = 1e3 N/m")
    assert case["analysis"]["pole_im_x"] == pytest.approx(7.3314, abs=1e-4)
    assert case["analysis"]["stability_limit_x"] == pytest.approx(1.857e5, rel=1e-3)
    assert data["cases"][0]["analysis"]["stability_limit_x"] == pytest.approx(5.080e5, rel=1e-3)


def test_analyze_table_output_and_other_scenarios():
    """The table form names each case and works for the impedance scenario too (ω_n, ζ of Example 9.2)."""
    res = runner.invoke(app, ["analyze", "example-9.2"])
    assert res.exit_code == 0, res.output
    assert "omega_n_x" in res.stdout and "k_x = 1e4 N/m" in res.stdout
    assert analyze_scenario("example-9.2")["cases"][0]["analysis"]["zeta_y"] == pytest.approx(0.5)


def test_analyze_unknown_scenario_is_a_clear_error():
    """An unknown name exits with code 2 and the loader's message listing the built-ins."""
    res = runner.invoke(app, ["analyze", "example-9.99"])
    assert res.exit_code == 2
    assert "unknown scenario 'example-9.99'" in res.output


def test_scenario_with_force_reference_outside_range_warns_of_drift():
    """A user scenario asking for f_y on the plane x = 1 with c_Fy ≠ 0 reports a DriftWarning when it runs."""
    scn = load_scenario("example-9.3").raw
    data = {k: v for k, v in scn.items() if k != "expected"}
    data.update({"duration": 0.05,
                 "controller": {**scn["controller"], "type": "inner-velocity", "force_gain": [0.0024, 0.0024]},
                 "reference": {**scn["reference"], "force": [10.0, 5.0]}, "name": "drift"})
    with pytest.warns(DriftWarning, match="outside the range of the environment stiffness"):
        run_scenario(load_scenario(data), engine="compiled")


def test_scenario_with_a_bad_force_gain_names_the_key():
    """A negative force_gain in a scenario is a ScenarioError naming the table and the parameter."""
    data = dict(load_scenario("example-9.3").raw)
    data["controller"] = {**data["controller"], "force_gain": [-0.001, 0.0]}
    with pytest.raises(ScenarioError, match=r"\[controller\] \(type 'inner-position'\): force_gain must be non-negative"):
        load_scenario(data)


def test_analyze_figures_writes_one_figure_per_scheme(tmp_path):
    """`analyze example-9.3 --figures` writes three PNGs (like Figs. 9.9–9.11) with the linearised force overlaid."""
    res = runner.invoke(app, ["analyze", "example-9.3", "--json", "--figures", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    files = json.loads(res.stdout)["files"]
    assert len(files) == 3
    for name, f in zip(("innerposition", "innervelocity", "parallel"), files):
        assert name in f and (tmp_path / "example-9.3").exists()
        assert Path(f).stat().st_size > 10_000
    assert "notes" not in json.loads(res.stdout)  # every figure has its linearised overlay


def test_analyze_figures_says_which_figure_has_no_linearised_overlay(tmp_path):
    """Example 9.2's impedance control has no linear force model to overlay: the figure is written and a note (stderr
    and --json) says it is the simulation only (the help promised the overlay for every controller type)."""
    res = runner.invoke(app, ["analyze", "example-9.2", "--json", "--figures", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert len(doc["files"]) == 1 and Path(doc["files"][0]).stat().st_size > 10_000
    assert doc["notes"] == ["figure of ImpedanceController: simulated only, no linearised overlay (the linear model covers "
                            "the direct force schemes on an elastic environment with a set point)"]


def test_analyze_notes_are_one_line_each_on_a_pipe(tmp_path):
    """`analyze example-9.2 --figures` as a subprocess (stderr a pipe): its note is one 'note: ' line, not wrapped at 80
    columns (a reader of the log or a grep finds it whole)."""
    from journeys_helpers import forcecontrol

    proc = forcecontrol(tmp_path, "analyze", "example-9.2", "--figures")
    lines = [ln for ln in proc.stderr.splitlines() if "linearised" in ln or "set point" in ln]
    assert len(lines) == 1 and lines[0].startswith("note: figure of ImpedanceController") and lines[0].endswith("set point)")


def test_analyze_figures_never_overwrite_earlier_files_unless_forced(tmp_path):
    """`analyze --figures` writes as `run` does: a second run in the same folder writes in NAME-2 and says so (stderr and
    --json notes); an --out folder that holds files is refused naming --force, which overwrites; --out or --force
    without --figures writes nothing and says so."""
    from journeys_helpers import forcecontrol

    first = forcecontrol(tmp_path, "analyze", "example-9.2", "--figures", "--json")
    second = forcecontrol(tmp_path, "analyze", "example-9.2", "--figures", "--json")
    one, two = json.loads(first.stdout)["files"], json.loads(second.stdout)["files"]
    assert [Path(p).parent.name for p in one] == ["example-9.2"] and [Path(p).parent.name for p in two] == ["example-9.2-2"]
    assert "writes in 'forcecontrol-out/example-9.2-2'" in second.stderr
    assert any("example-9.2-2" in n for n in json.loads(second.stdout)["notes"])
    png = tmp_path / one[0]
    before = png.stat().st_mtime_ns
    refused = forcecontrol(tmp_path, "analyze", "example-9.2", "--figures", "--out", "forcecontrol-out", ok=False)
    assert refused.returncode == 2 and "--force" in refused.stderr and "Traceback" not in refused.stderr
    assert png.stat().st_mtime_ns == before
    forcecontrol(tmp_path, "analyze", "example-9.2", "--figures", "--out", "forcecontrol-out", "--force")
    assert png.stat().st_mtime_ns != before
    quiet = forcecontrol(tmp_path, "analyze", "example-9.2", "--out", "elsewhere")
    assert "nothing is written without --figures" in quiet.stderr and not (tmp_path / "elsewhere").exists()
