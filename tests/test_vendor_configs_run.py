"""The vendor example scenarios (scenarios/configs/*.toml) run as a user runs them: `forcecontrol run FILE`, defaults,
figure on; the reported settings bounce, the proposed ones settle at the closed-form force."""

from __future__ import annotations

import json
import shutil
from importlib import resources
from pathlib import Path

import pytest
import tomllib

from journeys_helpers import assert_figure, forcecontrol

pytest.importorskip("pinocchio")
pytest.importorskip("ruamel.yaml")

CONFIGS = Path(str(resources.files("forcecontrol.scenarios") / "configs"))


def _fzi(k_e: float, stiffness: float) -> float:
    """The FZI controllers pressing f_d = 10 N on a table of stiffness k_e with compliance K: f = f_d k_e/(K + k_e)."""
    return -10.0 * k_e / (stiffness + k_e)


# file, case that bounces, case that settles, closed-form f_z of the settling case, and where it is read
CASES = [
    ("fzi_issue_21.toml", "reported", "proposed", _fzi(2e5, 140.0), "final"),
    ("fzi_issue_171.toml", "reported", "proposed", _fzi(1e5, 900.0), "final"),
    ("fzi_issue_151.toml", "reported", "proposed", _fzi(3e4, 900.0), "final"),
    # ros2 admittance: w = 10 N down against the table (k_e = 5 kN/m, 1 cm below) and the spring K = 214.3 N/m
    # pulling back to the start: f = k_e (w - 0.01 K)/(K + k_e), the mean over settle_window (a slow ripple decays)
    ("ros2_admittance_example.toml", "documented (filter 0.005)", "filter 0.05", -5000.0 * (10 - 2.143) / 5214.3, "settled"),
]


@pytest.mark.parametrize("name, bounces, settles, f_z, read", CASES, ids=[c[0] for c in CASES])
def test_vendor_example_runs_from_its_file(tmp_path, name, bounces, settles, f_z, read):
    """`forcecontrol run FILE --json` (FILE and its controller's config copied to a fresh folder): exit 0, the figure
    written, the reader's notes on stderr and in the cases' warnings; the reported case loses contact (warned), the
    proposed one keeps it and settles within 1 % of the closed form."""
    config = tomllib.loads((CONFIGS / name).read_text(encoding="utf-8"))["controller"]["config"]
    for f in (name, config):
        shutil.copy(CONFIGS / f, tmp_path / f)
    proc = forcecontrol(tmp_path, "run", name, "--json")
    doc = json.loads(proc.stdout)
    assert_figure(tmp_path / doc["files"]["figure"])
    assert "note: " in proc.stderr and config in proc.stderr and "ConfigNote" not in proc.stderr
    cases = {c["label"]: c for c in doc["cases"]}
    assert set(cases) == {bounces, settles} and doc["all_checks_pass"] is True
    for c in cases.values():
        assert any(w["kind"] == "config-note" for w in c["warnings"])
    bad, good = cases[bounces], cases[settles]
    assert bad["settled"]["contact_losses"] >= 1
    assert [w["count"] for w in bad["warnings"] if w["kind"] == "contact-lost"] == [bad["settled"]["contact_losses"]]
    assert good["settled"]["contact_losses"] == 0 and all(w["kind"] != "contact-lost" for w in good["warnings"])
    got = good["final"]["contact_force"][2] if read == "final" else good["settled"]["fz"]
    assert got == pytest.approx(f_z, rel=0.01)


def test_issue_177_runs_from_its_file(tmp_path):
    """`forcecontrol run fzi_issue_177.toml --json` in a fresh folder: exit 0, figure, config notes; the reported setting
    hits the servo's limits (warned, the shake), the reporter's and the proposed ones do not, and the proposed one has
    moved more than half-way to the target 5 mm above the start."""
    import numpy as np

    from forcecontrol.robots.pinocchio import ur10

    for f in ("fzi_issue_177.toml", "fzi_issue_177.yaml"):
        shutil.copy(CONFIGS / f, tmp_path / f)
    proc = forcecontrol(tmp_path, "run", "fzi_issue_177.toml", "--json")
    doc = json.loads(proc.stdout)
    assert_figure(tmp_path / doc["files"]["figure"])
    assert "note: " in proc.stderr and "servo" in proc.stderr and "ConfigNote" not in proc.stderr
    cases = {c["label"]: c for c in doc["cases"]}
    assert set(cases) == {"reported", "reporter's error_scale 0.002", "proposed"}
    assert any(w["kind"] == "servo-limit" for w in cases["reported"]["warnings"])
    for label in ("reporter's error_scale 0.002", "proposed"):
        assert all(w["kind"] == "config-note" for w in cases[label]["warnings"])
    z0 = ur10().frame_pose(np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0]))[1][2]
    assert 0.5 * 0.005 < cases["proposed"]["final"]["tip_position"][2] - z0 < 0.005


def test_set_prints_each_config_note_once(tmp_path):
    """`run fzi_issue_177.toml --set duration=0.05`: the reader's notes are said once each (--set builds the cases again
    as '<file> (edited)'; they were printed a second time under that name), and the JSON still carries them."""
    for f in ("fzi_issue_177.toml", "fzi_issue_177.yaml"):
        shutil.copy(CONFIGS / f, tmp_path / f)
    proc = forcecontrol(tmp_path, "run", "fzi_issue_177.toml", "--set", "duration=0.05", "--json")
    notes = [line for line in proc.stderr.splitlines() if line.startswith("note: ")]
    assert notes, proc.stderr
    assert len(notes) == len(set(notes)) and not any("(edited)" in n for n in notes), notes
    doc = json.loads(proc.stdout)
    assert all(any(w["kind"] == "config-note" for w in c["warnings"]) for c in doc["cases"])


def test_franka_example_off_its_1_khz_loop_is_said(tmp_path):
    """franka_ros's example filters its gains and limits its torque rate per cycle of the FCI's 1 kHz loop: a scenario
    at another sample time says so (a note, on stderr and in the metadata); at 1 ms nothing is said of it."""
    import warnings

    from forcecontrol.realarm.conventions.configs import read_config
    from forcecontrol.scenarios import build_case, load_scenario
    from forcecontrol.scenarios.parts_vendor import ConfigNote, scenario_toml

    config = tmp_path / "franka.yaml"
    shutil.copy(resources.files("forcecontrol.scenarios") / "configs" / "franka_cartesian_impedance.yaml", config)
    text = scenario_toml(read_config(config))
    assert "sample_time = 0.001\n" in text
    for Ts, said in ((0.0005, True), (0.001, False)):
        path = tmp_path / f"franka-{Ts}.toml"
        path.write_text(text.replace("sample_time = 0.001\n", f"sample_time = {Ts}\n"), encoding="utf-8")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ctl = build_case(load_scenario(path).cases[0])["controller"]
        notes = [str(w.message) for w in caught if issubclass(w.category, ConfigNote) and "FCI's 1 ms" in str(w.message)]
        assert bool(notes) == said and any("FCI's 1 ms" in n for n in ctl.config_notes) == said
