"""The command line: run, list, show, and the --json contract."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from forcecontrol.cli import app

runner = CliRunner()


def test_run_json_contract(tmp_path):
    """`run example-9.2 --json` prints scenario and cases with label, final (t, tip_position, contact_force), peak."""
    res = runner.invoke(app, ["run", "example-9.2", "--json", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["scenario"] == "example-9.2" and len(data["cases"]) == 2
    for case in data["cases"]:
        assert set(case) >= {"label", "final", "peak_contact_force_norm"}
        assert set(case["final"]) >= {"t", "tip_position", "contact_force"}
        assert len(case["final"]["tip_position"]) == 2 and len(case["final"]["contact_force"]) == 2
    forces = sorted(c["final"]["contact_force"][0] for c in data["cases"])
    assert abs(forces[0] - 71.4) < 0.36 and abs(forces[1] - 200.0) < 1.0
    assert (tmp_path / "example-9.2" / "example-9.2.png").stat().st_size > 10_000
    assert data["all_checks_pass"] is True


def test_run_writes_a_figure_a_table_and_data_files(tmp_path):
    """The main job prints a summary table, writes the PNG, and with --data the CSV logs and metadata."""
    res = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path), "--data", "csv", "--check"])
    assert res.exit_code == 0, res.output
    assert "Against the book" in res.stdout and "71.4" in res.stdout
    files = sorted(p.name for p in (tmp_path / "example-9.2").iterdir())
    assert "example-9.2.png" in files and sum(f.endswith(".csv") for f in files) == 2
    assert sum(f.endswith(".json") for f in files) == 2


def test_list_and_show():
    """`list` names the built-ins; `show` prints a TOML that loads back."""
    assert "example-9.1" in runner.invoke(app, ["list"]).stdout
    out = runner.invoke(app, ["show", "example-9.2"]).stdout
    assert out.startswith('name = "example-9.2"')


def test_bad_scenario_exits_2_with_message(tmp_path):
    """A bad file exits with code 2 and the loader's message on stderr."""
    p = tmp_path / "bad.toml"
    p.write_text('name = "x"\n')
    res = runner.invoke(app, ["run", str(p)])
    assert res.exit_code == 2 and "missing key 'duration'" in res.stderr


def test_schema_lists_every_registered_type():
    """`schema` documents the tables and each registered type's keys."""
    out = runner.invoke(app, ["schema"]).stdout
    assert 'type = "impedance"' in out and 'type = "elastic-plane"' in out and "start_position" in out


def test_example_9_3_writes_one_figure_per_scheme(tmp_path):
    """`run example-9.3` writes Figs. 9.9, 9.10 and 9.11 as three files, each with its scheme's cases."""
    res = runner.invoke(app, ["run", "example-9.3", "--json", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    files = json.loads(res.stdout)["files"]
    names = sorted(v.rsplit("/", 1)[1] for k, v in files.items() if k.startswith("figure"))
    assert names == ["example-9.3-fig-9.10.png", "example-9.3-fig-9.11.png", "example-9.3-fig-9.9.png"]
