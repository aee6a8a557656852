"""`forcecontrol design <vendor scheme> --config FILE`: the tuned parameters, the checks, and the user's file written back
with only the tuned keys changed (issue 30 item 4)."""

from __future__ import annotations

import json
import math
import re
import shutil
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from journeys_helpers import forcecontrol

pytest.importorskip("ruamel.yaml")

CONFIGS = Path(str(resources.files("forcecontrol.scenarios") / "configs"))
MARGIN = 10 ** (6 / 20)  # the default 6 dB gain margin on k_e


def _design(tmp_path: Path, *args: str) -> dict:
    return json.loads(forcecontrol(tmp_path, "design", *args, "--json").stdout)


def test_fzi_21_designed_yaml_settles_in_simulation(tmp_path):
    """design fzi-compliance --config fzi_issue_21.yaml (instantaneous solver, k up to 2e5 N/m) --out: the #21 scenario run
    with the written YAML (its own override cases removed) holds contact and settles at f_d k_e/(K + k_e) within 1 %."""
    pytest.importorskip("pinocchio")
    from forcecontrol.scenarios import run_scenario

    shutil.copy(CONFIGS / "fzi_issue_21.yaml", tmp_path / "mine.yaml")
    doc = _design(tmp_path, "fzi-compliance", "--config", "mine.yaml", "--k-min", "1e4", "--k-max", "2e5",
                  "--solver", "instantaneous", "--servo-bandwidth", str(math.sqrt(2000.0)),
                  "--servo-damping", str(0.03 * math.sqrt(2000.0) / 2), "--out", "tuned.yaml")
    assert [c["key"] for c in doc["changed"]] and doc["stability_limit"] >= MARGIN * 2e5 > doc["stability_limit_before"]
    assert [c["vendor_loop_verdict"] for c in doc["checks"]] == ["settles"] * 3
    text = (CONFIGS / "fzi_issue_21.toml").read_text(encoding="utf-8").split("[[case]]")[0]
    text = text.replace('config = "fzi_issue_21.yaml"', 'config = "tuned.yaml"')
    (tmp_path / "tuned.toml").write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = run_scenario(tmp_path / "tuned.toml")
    fz = np.asarray(run.cases[0].result.wrench)[:, 2]
    n = len(fz)
    assert not np.any(fz[n // 2 :] > -1e-9)  # contact held: no bounce
    assert fz[-1] == pytest.approx(-10.0 * 2e5 / (140.0 + 2e5), rel=0.01)


def test_round_trip_keeps_the_files_comments_and_other_keys(tmp_path):
    """The written file: every line of the user's file kept byte for byte except the tuned keys' (comments included);
    read back, the tuned key has the designed value and every other parameter is unchanged."""
    from forcecontrol.realarm.conventions.configs import read_config

    src = CONFIGS / "fzi_issue_171.yaml"
    doc = _design(tmp_path, "fzi-compliance", "--config", str(src), "--k-min", "1e4", "--k-max", "1e5", "--out", "t.yaml")
    new = {c["key"]: c["new"] for c in doc["changed"]}
    assert set(new) == {"error_scale"}
    old_lines = src.read_text(encoding="utf-8").splitlines()
    new_lines = (tmp_path / "t.yaml").read_text(encoding="utf-8").splitlines()
    assert len(old_lines) == len(new_lines)
    differ = [(a, b) for a, b in zip(old_lines, new_lines, strict=True) if a != b]
    assert len(differ) == 1 and "error_scale" in differ[0][1]
    assert any(ln.lstrip().startswith("#") for ln in new_lines)
    before, after = read_config(src).parameters, read_config(tmp_path / "t.yaml").parameters
    assert after["error_scale"] == new["error_scale"]
    assert {k: v for k, v in after.items() if k != "error_scale"} == {k: v for k, v in before.items() if k != "error_scale"}


def test_out_refuses_a_file_it_did_not_write_without_force(tmp_path):
    """--out onto the user's own file: refused without --force (exit != 0, the file untouched); its own output is
    replaced on a second run without --force."""
    (tmp_path / "mine.yaml").write_text((CONFIGS / "fzi_issue_171.yaml").read_text(encoding="utf-8"), encoding="utf-8")
    args = ("design", "fzi-compliance", "--config", "mine.yaml", "--k-min", "1e4", "--k-max", "1e5")
    proc = forcecontrol(tmp_path, *args, "--out", "mine.yaml", ok=False)
    assert proc.returncode != 0 and "--force" in proc.stderr
    assert (tmp_path / "mine.yaml").read_text(encoding="utf-8") == (CONFIGS / "fzi_issue_171.yaml").read_text(encoding="utf-8")
    forcecontrol(tmp_path, *args, "--out", "t.yaml")
    forcecontrol(tmp_path, *args, "--out", "t.yaml")


def test_ros2_and_force_mode_designs_meet_the_margin_on_independent_loops(tmp_path):
    """ros2-admittance (mass raised) and ur-force-mode (gain_scaling lowered): the values read back from the written
    file, put in loops built here, have a k_e limit >= 2 (6 dB) x k_max; the file's own values do not."""
    from forcecontrol.analysis.vendor_loops import Ros2AdmittanceLoop, UrForceModeLoop, stability_limit
    from forcecontrol.realarm.conventions.configs import read_config

    servo = dict(rate=500.0, bandwidth=44.7, damping=0.67, delay=1)
    _design(tmp_path, "ros2-admittance", "--config", str(CONFIGS / "ros2_admittance.yaml"), "--k-min", "1e3",
            "--k-max", "2e4", "--out", "r.yaml")
    for path, ok in ((CONFIGS / "ros2_admittance.yaml", False), (tmp_path / "r.yaml", True)):
        p = read_config(path, "ros2-admittance").parameters
        loop = Ros2AdmittanceLoop(mass=p["mass"][2], damping_ratio=p["damping_ratio"][2], stiffness=p["stiffness"][2],
                                  joint_damping=p["joint_damping"], filter_coefficient=p["filter_coefficient"],
                                  kinematics_alpha=p["kinematics_alpha"], **servo)
        assert (stability_limit(loop) >= MARGIN * 2e4) == ok
    _design(tmp_path, "ur-force-mode", "--config", str(CONFIGS / "ur_force_mode.script"), "--k-min", "1e3",
            "--k-max", "1e5", "--out", "u.script")
    for path, ok in ((CONFIGS / "ur_force_mode.script", False), (tmp_path / "u.script", True)):
        p = read_config(path, "ur-force-mode").parameters
        loop = UrForceModeLoop(gain=p.get("gain", 0.05), gain_scaling=p["gain_scaling"], damping_force_mode=p["damping"],
                               **servo)
        assert (stability_limit(loop) >= MARGIN * 1e5) == ok
    assert re.search(r"force_mode_set_gain_scaling\(\s*0\.0", (tmp_path / "u.script").read_text(encoding="utf-8"))


def test_design_table_lists_key_old_new_and_the_checks(tmp_path):
    """The table: the changed key with old and new values and the margin in words; the checks at k_min, √(k_min k_max),
    k_max with their verdicts."""
    out = forcecontrol(tmp_path, "design", "fzi-compliance", "--config", str(CONFIGS / "fzi_issue_171.yaml"),
                       "--k-min", "1e4", "--k-max", "1e5").stdout
    assert "error_scale" in out and "0.68" in out and "k_e limit" in out
    assert "31622.8" in out and "100000" in out and out.count("settles") == 3


def test_vendor_design_runs_at_the_files_rate_unless_rate_is_given(tmp_path):
    """fzi_compliance.yaml gives update_rate 100: the design's loop runs at 100 Hz without a note (as `analyze` does);
    an explicit --rate 500 is used and said; a file without a rate (ros2_admittance.yaml) is designed at 500 Hz, said."""
    args = ("fzi-compliance", "--config", str(CONFIGS / "fzi_compliance.yaml"), "--k-min", "1e3", "--k-max", "1e4")
    own = _design(tmp_path, *args)
    assert own["requirements"]["rate"] == 100.0 and not any("update_rate" in n for n in own["notes"]), own["notes"]
    forced = _design(tmp_path, *args, "--rate", "500")
    assert forced["requirements"]["rate"] == 500.0
    assert "the file's update_rate 100 Hz differs from --rate 500 Hz: the loop runs at --rate" in forced["notes"]
    bare = _design(tmp_path, "ros2-admittance", "--config", str(CONFIGS / "ros2_admittance.yaml"), "--k-min", "1e3",
                   "--k-max", "2e4")
    assert bare["requirements"]["rate"] == 500.0
    assert "no update_rate in the file: the loop is analysed at 500 Hz (--rate sets another)" in bare["notes"]


def test_design_names_every_scheme_and_its_own_options_when_refusing(tmp_path):
    """A misspelt scheme is refused listing all ten the command designs (the message listed the chapter's five); a
    reversed range names --k-min and --k-max, as typed (it named an API argument, stiffness_range)."""
    proc = forcecontrol(tmp_path, "design", "inner-velocty", "--k-min", "1e3", "--k-max", "1e4", ok=False)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert ("SCHEME must be one of impedance, inner-position, inner-velocity, parallel, hybrid, admittance-position, "
            "fzi-compliance, fzi-force, ros2-admittance, ur-force-mode; got 'inner-velocty'") in proc.stderr
    proc = forcecontrol(tmp_path, "design", "impedance", "--k-min", "1e5", "--k-max", "1e3", ok=False)
    assert proc.returncode == 2 and "--k-min and --k-max must satisfy 0 < k_min <= k_max < inf; got 100000, 1000" in proc.stderr


def test_design_refuses_what_the_controller_refuses_and_says_what_reading_the_file_did(tmp_path):
    """A ros2_controllers YAML with mass 0 on x: `design --config` stops before any loop is designed (exit 2, the key, the
    bound and the value named), as `import-config` does; a ROS 1 FZI file whose stiffness the dynamic_reconfigure server
    clamps: the design goes on and says the clamp on stderr and in --json's notes (it was silent)."""
    text = (CONFIGS / "ros2_admittance.yaml").read_text(encoding="utf-8")
    assert "\n        - 5.5\n" in text
    (tmp_path / "zero.yaml").write_text(text.replace("\n        - 5.5\n", "\n        - 0.0\n", 1), encoding="utf-8")
    bad = forcecontrol(tmp_path, "design", "ros2-admittance", "--config", "zero.yaml", "--k-min", "1e3", "--k-max", "1e5",
                       ok=False)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr, bad.stderr
    assert re.search(r"mass must be >= 0\.0001 kg on every axis; got 0 on axis x", bad.stderr), bad.stderr
    text = (CONFIGS / "fzi_issue_21.yaml").read_text(encoding="utf-8")
    assert "trans_z: 140\n" in text
    (tmp_path / "soft.yaml").write_text(text.replace("trans_z: 140\n", "trans_z: -140\n", 1), encoding="utf-8")
    args = ("design", "fzi-compliance", "--config", "soft.yaml", "--k-min", "1e3", "--k-max", "1e5")
    said = "stiffness.trans_z = -140.0 is outside its ROS 1 dynamic_reconfigure range [100, 5000]"
    assert said in forcecontrol(tmp_path, *args).stderr
    assert any(said in n for n in json.loads(forcecontrol(tmp_path, *args, "--json").stdout)["notes"])
