"""`forcecontrol analyze` on the vendor controllers' scenarios: the sampled loop that limits, its k_e limit, margin and
verdict (issue 30 item 4); the configuration reader's notes as clean `note:` lines."""

from __future__ import annotations

import json
import math
from importlib import resources
from pathlib import Path

import pytest
import tomllib

from journeys_helpers import forcecontrol

pytest.importorskip("pinocchio")
pytest.importorskip("ruamel.yaml")

CONFIGS = Path(str(resources.files("forcecontrol.scenarios") / "configs"))
W, Z = math.sqrt(2000.0), 0.03 * math.sqrt(2000.0) / 2.0  # servoj gain 2000, lookahead 0.03 s (the scenarios' servo)

# scenario, k_e, the published loop (reported case), the proposed case's changes
ISSUES = [
    ("fzi_issue_21.toml", 2e5, dict(p=0.005, d=0.0001, error_scale=1.0, stiffness=140.0, iterations=5, solver="instantaneous"),
     {"iterations": 1, "error_scale": 0.7}),
    ("fzi_issue_171.toml", 1e5, dict(p=0.021, d=0.001, error_scale=0.68, stiffness=900.0, iterations=2), {"error_scale": 0.2}),
    ("fzi_issue_151.toml", 3e4, dict(p=0.057, d=0.001, error_scale=0.68, stiffness=900.0, iterations=2), {"error_scale": 0.2}),
]


@pytest.mark.parametrize("name, k_e, published, proposed", ISSUES, ids=[i[0] for i in ISSUES])
def test_analyze_says_the_reported_case_bounces_and_the_proposed_one_settles(tmp_path, name, k_e, published, proposed):
    """analyze --json on an FZI report: 'bounces' for the reported case, 'settles' for the proposed one; the limit equals
    fdcc_stability_limit of the published parameters (built here independently) within 1e-6; margin = limit / k_e;
    the equilibrium force is f_d k_e / (K + k_e); units named; the notes are clean lines on stderr and in the JSON."""
    import dataclasses

    from forcecontrol.analysis.vendor_fzi import FdccLoop, fdcc_stability_limit

    proc = forcecontrol(tmp_path, "analyze", CONFIGS / name, "--json")
    doc = json.loads(proc.stdout)
    cases = {c["label"]: c["analysis"] for c in doc["cases"]}
    loop = FdccLoop(rate=500.0, bandwidth=W, damping=Z, **published)
    for label, lp in (("reported", loop), ("proposed", dataclasses.replace(loop, **proposed))):
        a = cases[label]
        limit = fdcc_stability_limit(lp)
        assert a["vendor_loop_verdict"] == ("bounces" if label == "reported" else "settles")
        assert (a["vendor_loop_spectral_radius"] >= 1.0) == (label == "reported")
        assert a["vendor_loop_stability_limit"] == pytest.approx(limit, rel=1e-6)
        assert a["vendor_loop_margin"] == pytest.approx(limit / k_e, rel=1e-9)
        assert a["environment_stiffness"] == k_e
        assert a["steady_fz"] == pytest.approx(-10.0 * k_e / (published["stiffness"] + k_e), rel=1e-6)
        assert "servo" in a["vendor_loop"] and "FZI" in a["vendor_loop"]
    assert doc["units"]["vendor_loop_stability_limit"] == "N/m" and doc["units"]["environment_stiffness"] == "N/m"
    assert all(c.get("analysis_skipped") is None for c in doc["cases"])
    assert any(w["kind"] == "config-note" for w in doc["cases"][0]["warnings"])


def test_analyze_table_names_the_loop_and_units(tmp_path):
    """analyze (table) on #21: the limit row with its unit, both verdicts, no 'no analysis applies'."""
    proc = forcecontrol(tmp_path, "analyze", CONFIGS / "fzi_issue_21.toml")
    assert "vendor_loop_stability_limit [N/m]" in proc.stdout
    assert "bounces" in proc.stdout and "settles" in proc.stdout
    assert "no analysis applies" not in proc.stdout + proc.stderr


def test_config_notes_are_clean_note_lines(tmp_path):
    """The reader's notes: each a 'note: ' line on stderr naming the scenario and the config, no Python warning
    machinery (no library file:line, no 'ConfigNote', no source line)."""
    proc = forcecontrol(tmp_path, "analyze", CONFIGS / "fzi_issue_21.toml", "--json")
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    notes = [ln for ln in lines if "fzi_issue_21.yaml" in ln]
    assert len(notes) >= 3 and all(ln.startswith("note: fzi_issue_21.toml: [controller] fzi-compliance") for ln in notes)
    assert "ConfigNote" not in proc.stderr and ".py:" not in proc.stderr and "register_controller" not in proc.stderr
    assert len(set(notes)) == len(notes)  # once, not once per case


def test_analyze_covers_ros2_admittance_and_ur_force_mode(tmp_path):
    """The ros2 admittance example and an imported UR force-mode scenario compliant along the table's normal are analysed
    (no 'no analysis applies'): the loop named, a verdict, a positive limit. The shipped force-mode example is compliant
    along its task frame's x only: import-config puts the table across that push (it put it below the tool, along z,
    whatever the compliant axis), and its steady force is the 20 N of the file; against a table along z that loop is not
    the controller's, and analyze says so (on stderr and in --json) instead of a verdict and a steady force for it."""
    doc = json.loads(forcecontrol(tmp_path, "analyze", CONFIGS / "ros2_admittance_example.toml", "--json").stdout)
    for c in doc["cases"]:
        a = c["analysis"]
        assert a["vendor_loop_verdict"] in ("bounces", "settles") and "admittance" in a["vendor_loop"]
    a = doc["cases"][-1]["analysis"]
    assert a["vendor_loop_stability_limit"] > 0
    script = (CONFIGS / "ur_force_mode.script").read_text(encoding="utf-8")
    assert "[1,0,0,0,0,0], [20,0,40,0,0,0]" in script
    (tmp_path / "z.script").write_text(script.replace("[1,0,0,0,0,0], [20,0,40,0,0,0]", "[0,0,1,0,0,0], [0,0,-10,0,0,0]"),
                                       encoding="utf-8")
    scn = forcecontrol(tmp_path, "import-config", "z.script").stdout
    (tmp_path / "ur.toml").write_text(scn, encoding="utf-8")
    doc = json.loads(forcecontrol(tmp_path, "analyze", "ur.toml", "--json").stdout)
    a = doc["cases"][0]["analysis"]
    assert "force mode" in a["vendor_loop"] and a["vendor_loop_stability_limit"] > 0
    scn = forcecontrol(tmp_path, "import-config", CONFIGS / "ur_force_mode.script").stdout
    (tmp_path / "urx.toml").write_text(scn, encoding="utf-8")
    # the shipped example pushes 20 N along its task frame's x, Rz(0.785) from the base: its table faces that push
    c, s = math.cos(0.785), math.sin(0.785)
    env = tomllib.loads(scn)["environment"]
    assert env["normal"] == pytest.approx([-c, -s, 0.0], abs=1e-9) and env["offset"] == pytest.approx([0.005 * c, 0.005 * s, 0])
    a = json.loads(forcecontrol(tmp_path, "analyze", "urx.toml", "--json").stdout)["cases"][0]["analysis"]
    assert a["vendor_loop_verdict"] == "settles"
    assert [a["steady_fx"], a["steady_fy"], a["steady_fz"]] == pytest.approx([20 * c, 20 * s, 0.0], abs=1e-9)
    # the same controller against a table below the tool (along z, which the force mode holds)
    below = scn.replace(f"offset = {env['offset']!r}".replace("'", ""), "offset = [0.0, 0.0, -0.005]")
    below = below.replace(f"normal = {env['normal']!r}".replace("'", ""), "normal = [0.0, 0.0, 1.0]")
    assert "normal = [0.0, 0.0, 1.0]" in below and "offset = [0.0, 0.0, -0.005]" in below
    (tmp_path / "urx.toml").write_text(below, encoding="utf-8")
    proc = forcecontrol(tmp_path, "analyze", "urx.toml", "--json")
    case = json.loads(proc.stdout)["cases"][0]
    assert case["analysis"]["vendor_loop"] == "not analysed" and "vendor_loop_verdict" not in case["analysis"]
    assert not any(k.startswith("steady_") for k in case["analysis"])
    said = "is on axes selection_vector leaves out (z): along them the arm holds the reference pose"
    assert said in case["analysis"]["vendor_loop_skipped"] and said in case["sampled_loop_skipped"] and said in proc.stderr


def test_analyze_covers_the_fzi_force_controller(tmp_path):
    """The force controller (import-config fzi_force.yaml, 10 N down on a 5 kN/m table): the FZI loop without stiffness
    (one solver step), equilibrium force = f_d (-10 N, the force controller's closed form), margin = limit / k_e."""
    scn = forcecontrol(tmp_path, "import-config", CONFIGS / "fzi_force.yaml").stdout
    (tmp_path / "f.toml").write_text(scn, encoding="utf-8")
    a = json.loads(forcecontrol(tmp_path, "analyze", "f.toml", "--json").stdout)["cases"][0]["analysis"]
    assert "stiffness" not in a["vendor_loop"] and "1 iteration" in a["vendor_loop"]
    assert a["steady_fz"] == pytest.approx(-10.0, rel=1e-9)
    assert a["vendor_loop_margin"] == pytest.approx(a["vendor_loop_stability_limit"] / 5000.0, rel=1e-9)


def test_analyze_says_its_verdict_leaves_out_a_payload_after_the_sensor(tmp_path):
    """FZI #177 (10.94 kg after the sensor): its 'reported' case shakes in simulation while the contact loop 'settles';
    each case says the verdict leaves the payload out (vendor_loop_note); the #21 scenario (no payload) says nothing."""
    doc = json.loads(forcecontrol(tmp_path, "analyze", CONFIGS / "fzi_issue_177.toml", "--json").stdout)
    for case in doc["cases"]:
        note = case["analysis"]["vendor_loop_note"]
        assert note.startswith("the verdict leaves out the 10.94 kg payload after the sensor") and "forcecontrol run" in note
    doc = json.loads(forcecontrol(tmp_path, "analyze", CONFIGS / "fzi_issue_21.toml", "--json").stdout)
    assert all("vendor_loop_note" not in c["analysis"] for c in doc["cases"])


def test_fzi_pd_gains_are_taken_along_the_base_frame_normal_with_a_tilted_tool():
    """FZI applies pd_gains per base axis and only the stiffness in compliance_ref_link: with the tool's x axis along
    the table's normal (base −z) and p = 0.01 on base x, 0.05 on base z, the analysis' loop has p = 0.05 and its
    stability limit is that of FdccLoop(p = 0.05) (about 98 kN/m: a 200 kN/m table bounces), not p = 0.01's (474 kN/m,
    "settles", while the run bounced: 6 contact losses)."""
    import numpy as np

    from forcecontrol.scenarios import build_case, load_scenario
    from forcecontrol.scenarios.core import case_analysis
    from forcecontrol.scenarios.parts_vendor_analysis import loop_limit, vendor_loop

    doc = {
        "name": "fzi-tilted", "duration": 0.2, "sample_time": 0.0005,
        "robot": {"model": "ur5", "q0": [0.0, -1.57, 1.57, -1.57, 0.0, 0.0],
                  "servo": {"preset": "ur-e-series", "rate": 500.0}},
        "environment": {"type": "table", "offset": [0.0, 0.0, -0.005], "stiffness": 200000.0},
        "controller": {"type": "fzi-compliance", "stiffness": [500.0, 500.0, 500.0, 20.0, 20.0, 20.0],
                       "p": [0.01, 0.01, 0.05, 1.5, 1.5, 1.5], "error_scale": 0.5, "compliance_frame": "tool"},
        "reference": {"type": "pose-setpoint", "offset": [0.0, 0.0, -0.02]},
    }
    parts = build_case(load_scenario(doc).cases[0])
    R = np.asarray(parts["robot"].frame_pose(parts["q0"])[0])
    assert abs(abs((R.T @ [0.0, 0.0, 1.0])[0]) - 1.0) < 1e-3  # the tool's x axis is along the normal
    a = case_analysis(parts)
    s = parts["robot"].servo
    servo = (float(s.rate), float(np.min(s.bandwidth)), float(np.asarray(s.damping).flat[0]), int(s.delay))
    base_z = loop_limit(vendor_loop("fzi-compliance", {"p": 0.05, "d": 0.0, "error_scale": 0.5, "stiffness": 500.0}, servo))
    base_x = loop_limit(vendor_loop("fzi-compliance", {"p": 0.01, "d": 0.0, "error_scale": 0.5, "stiffness": 500.0}, servo))
    assert a["vendor_loop_stability_limit"] == pytest.approx(base_z, rel=1e-3) and base_x > 4 * base_z
    assert a["vendor_loop_verdict"] == "bounces"


def test_a_config_found_only_among_the_shipped_examples_is_said(tmp_path):
    """A scenario naming config = "fzi_compliance.yaml" with no such file beside it nor in the working folder runs the
    library's shipped example of that name: said in a note (it was silent: the user's values were replaced by the
    example's); with the user's file beside the scenario, no such note and the user's error_scale is read."""
    text = (
        'name = "press"\nduration = 0.05\nsample_time = 0.0005\nallow_contact_loss = true\n[robot]\nmodel = "ur5"\n'
        "q0 = [0.0, -1.57, 1.57, -1.57, -1.57, 0.0]\n[robot.servo]\npreset = \"ur-e-series\"\nrate = 100.0\n"
        '[environment]\ntype = "table"\noffset = [0.0, 0.0, -0.005]\nstiffness = 5000.0\n'
        '[controller]\ntype = "fzi-compliance"\nconfig = "fzi_compliance.yaml"\n'
        '[reference]\ntype = "pose-setpoint"\noffset = [0.0, 0.0, -0.02]\n'
    )
    (tmp_path / "proj").mkdir()
    (tmp_path / "proj" / "press.toml").write_text(text, encoding="utf-8")
    out = forcecontrol(tmp_path, "analyze", "proj/press.toml")
    assert "'fzi_compliance.yaml' is neither next to the scenario nor in the working folder: the library's shipped " \
           "example" in " ".join(out.stderr.split())
    shipped = resources.files("forcecontrol.scenarios").joinpath("configs", "fzi_compliance.yaml").read_text(encoding="utf-8")
    assert "error_scale: 0.5" in shipped
    (tmp_path / "proj" / "fzi_compliance.yaml").write_text(shipped.replace("error_scale: 0.5", "error_scale: 0.123"),
                                                           encoding="utf-8")
    out = forcecontrol(tmp_path, "analyze", "proj/press.toml", "--json")
    assert "shipped example" not in out.stderr
    assert "error_scale 0.123" in json.loads(out.stdout)["cases"][0]["analysis"]["vendor_loop"]


def test_a_ros2_admittance_without_z_in_selected_axes_is_not_analysed_along_z_nor_designed(tmp_path):
    """ros2_controllers' admittance with selected_axes z = false on the example's table: the arm holds z (the run never
    touches the table, 1 cm below), so analyze gives no verdict and no steady force along it (it gave -7.53 N) and says
    why; `design` refuses to tune a loop along z the controller does not close; the force mode's example (compliant along
    x only) is designed along x, said."""
    text = (CONFIGS / "ros2_admittance.yaml").read_text(encoding="utf-8")
    assert "        - true # z\n" in text
    (tmp_path / "zoff.yaml").write_text(text.replace("        - true # z\n", "        - false # z\n", 1), encoding="utf-8")
    toml = (CONFIGS / "ros2_admittance_example.toml").read_text(encoding="utf-8")
    (tmp_path / "zoff.toml").write_text(toml.replace('config = "ros2_admittance.yaml"', 'config = "zoff.yaml"'),
                                        encoding="utf-8")
    proc = forcecontrol(tmp_path, "analyze", "zoff.toml", "--json")
    for case in json.loads(proc.stdout)["cases"]:
        assert case["analysis"]["vendor_loop"] == "not analysed" and "steady_fz" not in case["analysis"]
        assert "is on axes selected_axes leaves out (z)" in case["sampled_loop_skipped"]
    assert "selected_axes leaves out (z)" in proc.stderr
    run = json.loads(forcecontrol(tmp_path, "run", "zoff.toml", "--json").stdout)
    assert all(c["peak_contact_force_norm"] == 0.0 for c in run["cases"])  # what the analysis no longer contradicts
    bad = forcecontrol(tmp_path, "design", "ros2-admittance", "--config", "zoff.yaml", "--k-min", "1e3", "--k-max", "1e4",
                       ok=False)
    assert bad.returncode == 2 and "selected_axes leaves out (z)" in bad.stderr and "Traceback" not in bad.stderr
    ur = forcecontrol(tmp_path, "design", "ur-force-mode", "--config", CONFIGS / "ur_force_mode.script", "--k-min", "1e3",
                      "--k-max", "1e5")
    assert "selection_vector makes x compliant, not z: the loop designed is the force mode's along x" in ur.stderr


def test_import_config_inline_keeps_selected_axes_and_a_scenario_can_set_them(tmp_path):
    """`import-config --inline` wrote no selected_axes (a file with z deselected became an all-axes admittance that
    presses the table): the inline scenario now carries them and runs as the file does (no contact, no verdict); a
    scenario sets them itself, and six numbers or five booleans are refused naming the key."""
    text = (CONFIGS / "ros2_admittance.yaml").read_text(encoding="utf-8")
    (tmp_path / "zoff.yaml").write_text(text.replace("        - true # z\n", "        - false # z\n", 1), encoding="utf-8")
    inline = forcecontrol(tmp_path, "import-config", "zoff.yaml", "--inline").stdout
    assert "selected_axes = [true, true, false, true, true, true]" in inline
    (tmp_path / "inline.toml").write_text(inline, encoding="utf-8")
    run = json.loads(forcecontrol(tmp_path, "run", "inline.toml", "--json").stdout)
    assert all(c["peak_contact_force_norm"] == 0.0 for c in run["cases"])
    a = json.loads(forcecontrol(tmp_path, "analyze", "inline.toml", "--json").stdout)["cases"][0]["analysis"]
    assert a["vendor_loop"] == "not analysed"
    pressing = inline.replace("selected_axes = [true, true, false, true, true, true]",
                              "selected_axes = [true, true, true, true, true, true]")
    (tmp_path / "all.toml").write_text(pressing, encoding="utf-8")
    run = json.loads(forcecontrol(tmp_path, "run", "all.toml", "--json").stdout)
    assert all(c["peak_contact_force_norm"] > 1.0 for c in run["cases"])  # the same file with z selected touches
    for bad, said in (("[1, 1, 0, 1, 1, 1]", "selected_axes"), ("[true, true, false, true, true]", "selected_axes")):
        (tmp_path / "bad.toml").write_text(inline.replace("[true, true, false, true, true, true]", bad), encoding="utf-8")
        proc = forcecontrol(tmp_path, "run", "bad.toml", ok=False)
        assert proc.returncode == 2 and said in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
