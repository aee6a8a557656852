"""``forcecontrol import-config`` / ``export-config`` and ``run`` of an imported controller, as a user runs them (issue 30)."""

from __future__ import annotations

import json
import os
import subprocess
from importlib import resources
from pathlib import Path

import pytest

import cli_server

pytest.importorskip("ruamel.yaml")
pytest.importorskip("pinocchio")

CONFIGS = Path(str(resources.files("forcecontrol.scenarios"))) / "configs"


def _cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONIOENCODING": "utf-8", "COLUMNS": "200"}
    return cli_server.run(list(args), cwd=cwd, env=env, module=True, timeout=900)


def test_import_config_prints_a_scenario_that_loads_and_says_its_notes(tmp_path):
    """import-config of the FZI force example prints a scenario that load_scenario accepts; the keys it does not read
    are named on stderr, and in --json."""
    from forcecontrol.scenarios import load_scenario

    proc = _cli("import-config", str(CONFIGS / "fzi_force.yaml"))
    assert proc.returncode == 0, proc.stderr
    assert "note: pd_gains.trans_x.d" in proc.stderr and "ft_sensor_ref_link = 'sensor_link'" in proc.stderr
    path = tmp_path / "s.toml"
    path.write_text(proc.stdout, encoding="utf-8")
    scn = load_scenario(path)
    assert scn.cases[0].config["controller"]["type"] == "fzi-force"
    doc = json.loads(_cli("import-config", str(CONFIGS / "fzi_force.yaml"), "--json").stdout)
    assert doc["kind"] == "fzi-force" and doc["parameters"]["error_scale"] == 0.5
    assert any("sensor_link" in n for n in doc["notes"])


def test_imported_ros2_scenario_carries_the_tool_whose_weight_the_file_compensates(tmp_path):
    """ros2_admittance.yaml compensates a 23 N tool (CoG.force, CoG.pos [0.1, 0, 0] in the tool frame): the imported
    scenario's UR5 carries that tool (23/9.81 kg there), the controller keeps the file's compensation, and the run
    touches the table it presses on (without the tool it rose 5 cm and never touched, silently)."""
    import forcecontrol as fc

    proc = _cli("import-config", str(CONFIGS / "ros2_admittance.yaml"))
    assert proc.returncode == 0, proc.stderr
    path = tmp_path / "r.toml"
    path.write_text(proc.stdout, encoding="utf-8")
    scn = fc.scenario(path)
    robot = scn.cases[0].config["robot"]
    assert robot["payload_mass"] == pytest.approx(23.0 / 9.81, rel=1e-12) and robot["payload_com"] == [0.1, 0.0, 0.0]
    run = scn.with_(duration=1.0).run()
    assert run.cases[0].result.metadata["controller"]["payload_weight"] == 23.0
    assert run.cases[0].result.peak_contact_force_norm() > 5.0


def test_values_the_controller_refuses_are_neither_imported_nor_written(tmp_path):
    """export-config --set stiffness=[-1, ...] / error_scale=-5 exits 2 naming the key and writes nothing; a file holding
    such a value is refused by import-config (both exited 0, and only `analyze` of the result refused it)."""
    src = tmp_path / "ex.yaml"
    src.write_text((CONFIGS / "fzi_compliance.yaml").read_text(encoding="utf-8"), encoding="utf-8")
    out = tmp_path / "neg.yaml"
    proc = _cli("export-config", str(src), "--set", "error_scale=-5", "--out", str(out))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and not out.exists()
    assert "the fzi-compliance controller refuses these values" in proc.stderr
    assert "key 'error_scale' must be at least 0 (solver.error_scale); got -5.0" in proc.stderr
    proc = _cli("export-config", str(src), "--set", "stiffness=[-1, -1, -1, -1, -1, -1]", "--out", str(out))
    assert proc.returncode == 2 and "stiffness" in proc.stderr and ">= 0" in proc.stderr and not out.exists(), proc.stderr
    src.write_text(src.read_text(encoding="utf-8").replace("error_scale: 0.5", "error_scale: -0.5"), encoding="utf-8")
    proc = _cli("import-config", str(src))
    assert proc.returncode == 2 and "error_scale" in proc.stderr and proc.stdout == "", proc.stderr


def test_import_config_refuses_an_unknown_type_naming_the_choices():
    """--type abb-egm is refused with the list of formats (exit 2, no traceback)."""
    proc = _cli("import-config", str(CONFIGS / "fzi_force.yaml"), "--type", "abb-egm")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "kind must be one of ros2-admittance, fzi-compliance, fzi-force" in proc.stderr


def test_export_config_changes_only_the_tuned_line_and_refuses_to_overwrite(tmp_path):
    """export-config --set error_scale=0.3 differs from the file in that line only; an existing --out needs --force."""
    src = CONFIGS / "fzi_compliance.yaml"
    out = tmp_path / "tuned.yaml"
    proc = _cli("export-config", str(src), "--set", "error_scale=0.3", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    a, b = src.read_text().splitlines(), out.read_text().splitlines()
    assert [(x, y) for x, y in zip(a, b) if x != y] == [("        error_scale: 0.5", "        error_scale: 0.3")]
    assert len(a) == len(b)
    again = _cli("export-config", str(src), "--set", "error_scale=0.2", "--out", str(out))
    assert again.returncode == 2 and "exists; use --force" in again.stderr


def test_export_config_from_a_tuned_scenario_round_trips(tmp_path):
    """import-config --inline, a tuned value in the scenario, export-config --scenario: the file gets that value,
    and reading it back gives the scenario's parameters."""
    from forcecontrol.realarm.conventions.configs import read_config

    src = tmp_path / "adm.yaml"
    src.write_text((CONFIGS / "ros2_admittance.yaml").read_text())
    toml = _cli("import-config", str(src), "--inline").stdout.replace("filter_coefficient = 0.005", "filter_coefficient = 0.05")
    scn = tmp_path / "adm.toml"
    scn.write_text(toml)
    proc = _cli("export-config", str(src), "--scenario", str(scn), "--in-place")
    assert proc.returncode == 0, proc.stderr
    assert "changed: filter_coefficient" in proc.stderr
    assert read_config(src).parameters["filter_coefficient"] == 0.05
    assert src.read_text() == (CONFIGS / "ros2_admittance.yaml").read_text().replace(
        "filter_coefficient: 0.005", "filter_coefficient: 0.05")


def test_run_of_an_imported_force_controller_settles_at_the_target_force(tmp_path):
    """The scenario import-config prints for the FZI force example runs: on the UR5 through its 500 Hz servo the
    tool presses the table with the reference's 10 N (the force controller's integral action) within 1 %."""
    from forcecontrol.scenarios import run_scenario

    toml = _cli("import-config", str(CONFIGS / "fzi_force.yaml")).stdout
    path = tmp_path / "s.toml"
    path.write_text(toml)
    run = run_scenario(path)
    fz = run.cases[0].result.wrench[-1][2]
    assert fz == pytest.approx(-10.0, rel=0.01)
    meta = run.cases[0].result.metadata["controller"]
    assert meta["config_source"].endswith("fzi_force.yaml") and meta["config_notes"]


def test_a_file_given_to_the_wrong_command_says_which_command_reads_it(tmp_path):
    """import-config of an empty file says it is empty (not 'got NoneType'); of a scenario (.toml) says to run it; run of a
    controller's YAML points to import-config (it said only 'not valid TOML')."""
    (tmp_path / "empty.yaml").write_text("", encoding="utf-8")
    proc = _cli("import-config", "empty.yaml", cwd=tmp_path)
    assert proc.returncode == 2 and "empty.yaml: the file is empty" in proc.stderr and "NoneType" not in proc.stderr
    scn = CONFIGS.parent / "example-9.2.toml"
    proc = _cli("import-config", str(scn))
    assert proc.returncode == 2 and "a .toml file is a scenario" in proc.stderr
    assert "forcecontrol run example-9.2.toml" in proc.stderr and "Traceback" not in proc.stderr
    (tmp_path / "x.yaml").write_text((CONFIGS / "fzi_force.yaml").read_text(encoding="utf-8"), encoding="utf-8")
    proc = _cli("run", "x.yaml", cwd=tmp_path)
    assert proc.returncode == 2 and "not valid TOML" in proc.stderr
    assert "`forcecontrol import-config x.yaml` prints the scenario that runs it" in proc.stderr
