"""Defects the fuzz campaign (``tools/fuzz_report.py``, ``tests/fuzz``) found, each refused now as a library error.

Each test names the campaign input that found it (kind, seed, index) and checks the error type and
that the message names the parameter or file and the problem. Special files are read in a
subprocess with a timeout (a hang detector, not a speed test).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import ForceControlError, ParameterError, ScenarioError

HUGE = 10**400  # an integer of 401 digits


_LOAD = """
import sys
from forcecontrol.scenarios import load_scenario
try:
    load_scenario(sys.argv[1])
except Exception as exc:
    print(type(exc).__name__, exc)
"""


@pytest.mark.parametrize("kind", ["fifo", "/dev/zero"])
def test_a_scenario_file_that_is_a_fifo_or_a_device_is_refused_without_blocking(tmp_path, kind):
    """`forcecontrol run pipe.toml` blocked forever and `analyze /dev/zero` read until memory ran out (cli, seed 1)."""
    if kind == "fifo":
        p = tmp_path / "pipe.toml"
        os.mkfifo(p)
    else:
        p = kind
    out = subprocess.run([sys.executable, "-c", _LOAD, str(p)], capture_output=True, text=True, timeout=120).stdout.strip()
    assert out.startswith("ScenarioError"), out
    assert str(p) in out and ("a FIFO" if kind == "fifo" else "a device") in out, out


def test_a_huge_scenario_file_is_refused_by_size(tmp_path, monkeypatch):
    """A scenario file above the size limit is refused before it is read (the limit is lowered here to keep it small)."""
    from forcecontrol.scenarios import core

    p = tmp_path / "big.toml"
    p.write_text('name = "x"\n' + "# padding\n" * 200)
    monkeypatch.setattr(core, "MAX_SCENARIO_BYTES", 100)
    with pytest.raises(ScenarioError, match=r"big.toml.*above the limit of 100 bytes"):
        core.load_scenario(p)


def test_a_folder_named_like_a_table_is_refused_with_bag_keywords(tmp_path):
    """`forcecontrol convert folder.csv` (the CLI passes the bag topics) ended in a raw TypeError (cli, seed 1, case 28)."""
    from forcecontrol.realarm.io import read_recording

    p = tmp_path / "folder.csv"
    p.mkdir()
    with pytest.raises(ParameterError, match=r"folder.csv.*it is a folder"):
        read_recording(p, joint_topic="/joint_states", wrench_topic=None)


@pytest.mark.parametrize("key, value", [("inertia", [HUGE, 1.0]), ("stiffness", HUGE), ("damping", [1.0, HUGE])])
def test_an_integer_beyond_a_float_in_a_gain_is_a_parameter_error(key, value):
    """A 401-digit integer as a gain ended in a raw OverflowError from float() (api, seed 1, cases 21, 65, 101)."""
    kw = {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0, "force_gain": 0.05, key: value}
    with pytest.raises(ParameterError, match=rf"{key} must be .*401 digits"):
        fc.InnerVelocityForceController(fc.PlanarTwoLink(), **kw)


@pytest.mark.parametrize("kw, match", [({"substeps": math.nan}, "substeps must be a positive integer; got nan"),
                                       ({"substeps": math.inf}, "substeps must be a positive integer; got inf"),
                                       ({"substeps": HUGE}, "substeps must be a positive integer; got 1000"),
                                       ({"max_log_bytes": math.nan}, "max_log_bytes must be a positive number"),
                                       ({"max_log_bytes": -1}, "max_log_bytes must be a positive number")])
def test_simulate_refuses_non_finite_substeps_and_log_limit(kw, match):
    """substeps=nan ended in 'cannot convert float NaN to integer'; max_log_bytes=nan ran (NaN compares False) (api, seed 1)."""
    arm = fc.PlanarTwoLink()
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500)
    with pytest.raises(ParameterError, match=match):
        fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=[math.pi / 3, -2 * math.pi / 3], duration=0.02, **kw)


def test_a_non_finite_contact_mode_is_a_parameter_error():
    """Stiffness 1.7e308: an infinite contact mode, then OverflowError in int(ceil(inf)) (scenario, seed 1, case 8)."""
    from forcecontrol.sim.limits import check_substeps

    with pytest.raises(ParameterError, match="non-finite contact mode"):
        check_substeps(4, 100, 0.001, 1.7e308, "python", rate=math.inf, explicit=True)


@pytest.mark.parametrize("column, value", [("fx", 1e300), ("x", -1e308), ("t", 1e300)])
def test_absurd_reference_samples_are_refused(tmp_path, column, value):
    """A sampled reference with a 1e300 force was accepted silently, and one with -1e308 ended in SciPy's raw ValueError."""
    from forcecontrol.trajectories.sampled import SampledReference

    t = 0.01 * np.arange(6)
    cols = {"t": t, "x": 1 + t, "y": 0 * t, "fx": 10 * t, "fy": 0 * t}
    cols[column] = cols[column].copy()
    cols[column][-1] = value
    p = tmp_path / "ref.csv"
    p.write_text("t,x,y,fx,fy\n" + "".join(",".join(repr(float(cols[c][i])) for c in cols) + "\n" for i in range(6)))
    with pytest.raises(ParameterError, match=r"samples must be at most 1e\+12 in magnitude.*at sample 5"):
        SampledReference.from_file(p)


def test_absurd_link_mass_in_a_urdf_is_refused(tmp_path):
    """A link with mass="1e300" loaded silently (every torque then overflows) (urdf, seed 1, case 1)."""
    pytest.importorskip("pinocchio")
    from forcecontrol.robots.pinocchio import PinocchioRobot, model_path

    text = model_path("chapter_arm").read_text().replace('<mass value="50"/>', '<mass value="1e300"/>', 1)
    p = tmp_path / "arm.urdf"
    p.write_text(text)
    with pytest.raises(ParameterError, match=r"arm.urdf.*<mass value> must be at most 1e\+09 kg; got 1e\+300"):
        PinocchioRobot.from_urdf(p, "tip", task="planar")


def test_every_refusal_here_is_a_force_control_error():
    """The types used above are the library's (a check of this file's premise)."""
    assert issubclass(ParameterError, ForceControlError) and issubclass(ScenarioError, ForceControlError)


def test_simulate_refuses_a_sensor_that_is_not_a_sensor():
    """simulate(sensor=1 / "x" / object()) ended in AttributeError: no attribute 'sequences' (api, seed 7, case 38)."""
    arm = fc.PlanarTwoLink()
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500)
    for bad in (1, "x", object()):
        with pytest.raises(ParameterError, match="sensor must be a ForceSensor"):
            fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=[math.pi / 3, -2 * math.pi / 3], duration=0.02, sensor=bad)


def _trace(n: int = 20):
    from forcecontrol.realarm.io.recorded import RecordedRun

    t = 0.01 * np.arange(n)
    q = np.column_stack([np.sin(t), np.cos(t)])
    return RecordedRun(t=t, q=q, qd=-q, wrench=np.column_stack([t, 0 * t]))


@pytest.mark.parametrize("shift", [1e308, math.inf, math.nan])
def test_compare_traces_bounds_the_time_shift_searched(shift):
    """--max-shift 1e308 ended in OverflowError in int(round(max_shift / period)) (cli, seed 7, case 3)."""
    from forcecontrol.realarm.traces import compare_traces

    with pytest.raises(ParameterError, match="max_shift must be at most 1,000,000 sample periods"):
        compare_traces(_trace(), _trace(), max_shift=shift)


def test_calibration_plan_refuses_a_negative_seed():
    """calibrate-plan --seed -1 ended in NumPy's raw ValueError 'expected non-negative integer' (cli, seed 7, case 194)."""
    from forcecontrol.realarm.calibration.plan import plan_calibration_poses

    with pytest.raises(ParameterError, match="seed must be a non-negative integer or None; got -1"):
        plan_calibration_poses(fc.PlanarTwoLink(), 6, seed=-1)


@pytest.mark.parametrize("cell, match", [("1e300", r"fx\]?\[?0?\]? is 1e\+300 at row 3|wrench\[0\] is 1e\+300 at row 3"),
                                         ("9" * 401, "beyond a float's range")])
def test_a_recorded_table_with_an_absurd_value_is_refused(tmp_path, cell, match):
    """A trace with a 1e300 N force was read silently; one with a 401-digit integer ended in OverflowError (data, seed 7)."""
    from forcecontrol.errors import MeasurementError
    from forcecontrol.realarm.io import read_recording

    # the force fx holds 1e300; the integer column fy (pandas keeps a 401-digit integer as an object) holds the huge one
    rows = [f"{0.01 * i},0.1,0.2,0,0,{cell if i == 3 and len(cell) < 10 else 1.0},{cell if i == 3 and len(cell) > 10 else 0}"
            for i in range(6)]
    p = tmp_path / "trace.csv"
    p.write_text("t,q1,q2,qd1,qd2,fx,fy\n" + "\n".join(rows) + "\n")
    with pytest.raises(MeasurementError, match=match):
        read_recording(p)


@pytest.mark.parametrize("xyz", ["0 0 0", "nan 0 1", "1 0"])
def test_a_urdf_joint_axis_that_moves_nothing_is_refused(tmp_path, xyz):
    """A revolute joint with <axis xyz="0 0 0"> loaded silently (urdf, seed 7, cases 36, 41, 199)."""
    from forcecontrol.robots.pinocchio import model_path
    from forcecontrol.robots.urdf_check import check_urdf

    text = model_path("chapter_arm").read_text().replace('<axis xyz="0 0 1"/>', f'<axis xyz="{xyz}"/>', 1)
    p = tmp_path / "arm.urdf"
    p.write_text(text)
    with pytest.raises(ParameterError, match=r"arm.urdf'?: joint 'joint1': <axis xyz> must be 3 finite numbers, not all zero"):
        check_urdf(p)


def test_a_singular_admittance_stiffness_in_the_servo_analysis_is_a_parameter_error():
    """analyze ur5-admittance-servo with a singular stiffness ended in LinAlgError (scenario, seed 7, case 78)."""
    from forcecontrol.analysis.servo_loop import ServoLoop

    model = object.__new__(ServoLoop)
    model.nu, model.P, model.K = np.array([1.0, 0.0]), np.eye(2), np.zeros((2, 2))
    with pytest.raises(ParameterError, match="stiffness K is singular"):
        model.equilibrium_force(1e4)


@pytest.mark.parametrize("key", ["stiffness", "damping", "inertia"])
def test_an_absurd_gain_is_refused(key):
    """stiffness = 1.7e308 passed every check (finite, positive) and was accepted silently (api, seed 7, case 199)."""
    kw = {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0, "force_gain": 0.05, key: 1.7e308}
    with pytest.raises(ParameterError, match=rf"{key} must have entries of at most 1e\+12 in magnitude.*1.7e\+308"):
        fc.ParallelForcePositionController(fc.PlanarTwoLink(), **kw)
    fc.ParallelForcePositionController(fc.PlanarTwoLink(), **{**kw, key: 1e12})  # the bound itself is accepted


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e308", "9" * 401])
def test_task_refuses_a_time_that_is_not_a_finite_sane_number(value):
    """`task list --json --time nan` (and inf, -inf, 1e308, 401 digits) exited 0 silently (cli, seed 20261126)."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    for name in ("list", "turning-crank"):
        res = CliRunner().invoke(app, ["task", name, "--json", "--time", value])
        assert res.exit_code == 2, (name, res.output)
        assert "--time" in res.output and "at most 1e+09" in res.output, res.output
    assert CliRunner().invoke(app, ["task", "list", "--time", "1e9"]).exit_code == 0  # the bound itself is accepted


def test_calibrate_plan_never_overwrites_a_file_it_did_not_write(tmp_path):
    """`calibrate-plan chapter-arm 6 --out notes.csv` overwrote the user's notes.csv (cli, seed 20261126, 8 cases)."""
    import json

    from typer.testing import CliRunner

    from forcecontrol.cli import app

    notes = tmp_path / "notes.csv"
    notes.write_text("my notes\n")
    res = CliRunner().invoke(app, ["calibrate-plan", "chapter-arm", "6", "--json", "--out", str(notes)])
    assert res.exit_code == 2 and "already exists" in res.output and "--force" in res.output, res.output
    assert notes.read_text() == "my notes\n"  # untouched
    folder = tmp_path / "plan.csv"
    folder.mkdir()
    res = CliRunner().invoke(app, ["calibrate-plan", "chapter-arm", "6", "--out", str(folder), "--force"])
    assert res.exit_code == 2 and "existing folder" in res.output and folder.is_dir(), res.output
    # its own output is replaced without --force, silently; a user's file with --force, with a note in --json
    plan = tmp_path / "plan2.csv"
    for _ in range(2):
        res = CliRunner().invoke(app, ["calibrate-plan", "chapter-arm", "6", "--json", "--out", str(plan)])
        assert res.exit_code == 0, res.output
        assert json.loads(res.stdout)["notes"] == []
    assert plan.read_text().splitlines()[0] == "q1,q2" and len(plan.read_text().splitlines()) == 7
    res = CliRunner().invoke(app, ["calibrate-plan", "chapter-arm", "6", "--json", "--out", str(notes), "--force"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["notes"] == [f"--force: {notes} was not written by forcecontrol; it is replaced"]
    assert notes.read_text().startswith("q1,q2")


@pytest.mark.parametrize("key", ["force_gain", "integral_gain"])
def test_an_absurd_force_gain_is_refused(key):
    """ParallelForcePositionController(force_gain=1.7e308) was accepted silently (api, seed 20261126, case 334)."""
    kw = {"force_gain": 0.05, "integral_gain": 0.1, key: 1.7e308}
    with pytest.raises(ParameterError, match=rf"{key} must have entries of at most 1e\+12 .*in magnitude.*1.7e\+308"):
        fc.ParallelForcePositionController(fc.PlanarTwoLink(), 100, 500, 2500, **kw)
    with pytest.raises(ParameterError, match=rf"{key} must have entries of at most 1e\+12"):
        fc.ParallelForcePositionController(fc.PlanarTwoLink(), 100, 500, 2500, **{**kw, key: [0.0, 2e12]})
    fc.ParallelForcePositionController(fc.PlanarTwoLink(), 100, 500, 2500, **{**kw, key: 1e12})  # the bound is accepted


def test_absurd_variable_stiffness_schedules_are_refused():
    """DirectionalStiffness(high=1e300) (the scenario's stiffness_high) and SinusoidalStiffness(mean=1e300) were accepted."""
    from forcecontrol.controllers.variable import DirectionalStiffness, SinusoidalStiffness

    with pytest.raises(ParameterError, match=r"high must have entries of at most 1e\+12 N/m.*1e\+300"):
        DirectionalStiffness(100.0, 1e300)
    with pytest.raises(ParameterError, match=r"mean must have entries of at most 1e\+12 N/m"):
        SinusoidalStiffness(1e300, 0.0, 1.0)
    assert DirectionalStiffness(100.0, 1e12).high == 1e12


@pytest.mark.parametrize("name, line, bad, match", [
    ("ur5-admittance-servo", "offset = [0.0, 0.0, -0.01]", "offset = [1e308, 0.0, -0.01]",
     r"\[reference\] .*key 'offset' must have entries in \[-1000, 1000\] .*got \[1e\+308"),
    ("variable-stiffness", "stiffness_high = 10000.0", "stiffness_high = 1e300",
     r"\[controller\] .*key 'stiffness_high' must be in \[-1e\+12, 1e\+12\] .*got 1e\+300"),
    ("example-9.4", "end = [1.2, 0.2]", "end = [1.7e308, 0.2]",
     r"\[reference\] .*key 'end' must have entries in \[-1000, 1000\] .*got \[1.7e\+308"),
])
def test_absurd_part_values_in_a_scenario_file_are_refused_at_load(tmp_path, name, line, bad, match):
    """offset = 1e308, stiffness_high = 1e300, end = 1.7e308 were accepted at load (scenario, seed 20261126, 134/305/412)."""
    from importlib import resources

    from forcecontrol.scenarios import load_scenario

    if name.startswith("ur5"):
        pytest.importorskip("pinocchio")
    text = (resources.files("forcecontrol.scenarios") / f"{name}.toml").read_text()
    assert text.count(line) == 1
    p = tmp_path / f"{name}.toml"
    p.write_text(text.replace(line, bad))
    with pytest.raises(ScenarioError, match=match):
        load_scenario(p)


def test_every_number_of_a_built_in_part_has_a_range():
    """Every number, vector and gain key of the library's controllers, environments and references declares a range."""
    from forcecontrol.scenarios import schema

    missing = [(name, key) for reg in (schema.CONTROLLERS, schema.ENVIRONMENTS, schema.REFERENCES)
               for name, spec in reg.items() for key, f in spec.fields.items()
               if f.kind in ("number", "vector", "gain") and f.low is None and f.high is None]
    assert missing == []


@pytest.mark.parametrize("change, match", [({"environment.stiffness": 1.7e308}, r"key .stiffness. must be in \[-1e\+12, 1e"),
                                           ({"duration": 1.7e308}, r"key 'duration' must be at most 1e\+07"),
                                           ({"settle_window": 1e300}, r"key 'settle_window' must be at most 1e\+07")])
def test_with_refuses_absurd_values_like_a_file(change, match):
    """scenario('example-9.2').with_({'duration': 1.7e308}) and the plane's stiffness were accepted (api, 377/393)."""
    with pytest.raises(ScenarioError, match=match):
        fc.scenario("example-9.2").with_(change)


def test_a_settle_window_longer_than_the_run_is_said_and_averages_the_whole_run(tmp_path):
    """settle_window longer than the run was used silently; it is clamped (the whole run averaged) with a note in --json."""
    import json

    from forcecontrol.scenarios.model import SettleWindowNote

    scn = fc.scenario("example-9.2").with_(duration=0.05, settle_window=4.0)
    with pytest.warns(SettleWindowNote, match=r"settle_window 4 s is longer than the run \(0.05 s\): the whole run is averaged"):
        run = scn.run()
    case = run.cases[0]
    assert case.metrics["fx"] == pytest.approx(float(np.mean(case.result.wrench[:, 0])), rel=1e-12)  # the whole run
    doc = run.to_json()
    assert {"kind": "settle-window", "t": None,
            "text": "settle_window 4 s is longer than the run (0.05 s): the whole run is averaged"} in doc["cases"][0]["warnings"]
    p = tmp_path / "short.toml"
    p.write_text(_short_example_9_2())
    res = subprocess.run([sys.executable, "-m", "forcecontrol", "run", str(p), "--json", "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert "settle_window 0.2 s is longer than the run (0.05 s): the whole run is averaged" in res.stderr
    # the 0.05 s run ends in its contact transient: it has not settled either, and says so
    assert [w["kind"] for w in json.loads(res.stdout)["cases"][0]["warnings"]] == ["not-settled", "settle-window"]


def _short_example_9_2() -> str:
    from importlib import resources

    text = (resources.files("forcecontrol.scenarios") / "example-9.2.toml").read_text()
    assert text.count("\nduration = 4.0\n") == 1
    return text.replace("\nduration = 4.0\n", "\nduration = 0.05\nsettle_window = 0.2\n", 1)


def test_fuzz_oracle_hears_warnings_not_empty_lists_nor_the_harness_settle_note():
    """The campaign's oracle: `run --json` has a 'warnings' list in every case (empty: nothing said, still silent), and
    the settle_window note that every shortened 0.05-s run gives answers no mutation but settle_window's."""
    import json

    from fuzz.core import Case, _cli_result

    case = Case("scenario", "run:absurd", 1, "run x.toml (('controller', 'stiffness') = 1e+300)", invalid=True)
    own = Case("scenario", "run:absurd", 2, "run x.toml (('settle_window',) = 5)", invalid=True)
    note = "settle_window 0.1 s is longer than the run (0.05 s): the whole run is averaged"
    empty = json.dumps({"cases": [{"warnings": []}], "notes": []})
    harness = json.dumps({"cases": [{"warnings": [{"kind": "settle-window", "t": None, "text": note}]}], "notes": []})
    said = json.dumps({"cases": [{"warnings": [{"kind": "config-note", "t": None, "text": "clipped"}]}]})
    assert _cli_result(case, 0, empty).outcome == "silent"
    assert _cli_result(case, 0, harness, f"x.py:1: SettleWindowNote: {note}\n  run = f()\n").outcome == "silent"
    assert _cli_result(case, 0, said).outcome == "success"
    assert _cli_result(case, 0, empty, "warning: clipped\n").outcome == "success"
    assert _cli_result(own, 0, harness).outcome == "success"  # the mutation is the window: its note answers it


@pytest.mark.parametrize("option, match", [("--gravity", r"gravity must be a positive number of at most 1000 \[m/s\^2\]; got 1e"),
                                           ("--max-condition", r"max_condition must be a positive number of at most 1e16")])
def test_calibrate_refuses_absurd_gravity_and_condition_limit(tmp_path, option, match):
    """`calibrate calib.csv --json --gravity 1e308` (a 1e-307 kg mass) and --max-condition 1e308 exited 0 (cli 37, 373)."""
    import re

    from typer.testing import CliRunner

    from forcecontrol.cli import app

    p = tmp_path / "calib.csv"  # the campaign's file: 1.2 kg, biases (0.3, -0.2) N, a few mN of noise
    p.write_text("angle,fx,fy\n0,0.3,11.572\n0.785398163397,8.62406102813,8.12406102813\n1.57079632679,12.072,-0.2\n"
                 "2.35619449019,8.62406102813,-8.52406102813\n3.14159265359,0.3,-11.972\n"
                 "3.92699081699,-8.02406102813,-8.52406102813\n4.71238898038,-11.472,-0.2\n"
                 "5.49778714378,-8.02406102813,8.12406102813\n")
    assert CliRunner().invoke(app, ["calibrate", str(p), "--json"]).exit_code == 0  # the file itself is fine
    res = CliRunner().invoke(app, ["calibrate", str(p), "--json", option, "1e308"])
    assert res.exit_code == 2 and re.search(match, " ".join(res.output.split())), res.output


def test_sweep_refuses_an_absurd_worker_count(tmp_path):
    """`sweep ... --workers <401 digits>` exited 0 silently (cli, seed 20261126, case 82)."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    res = CliRunner().invoke(app, ["sweep", "example-9.2", "-p", "sample_time=0.001,0.002", "--out", str(tmp_path / "s.parquet"),
                                   "--no-figure", "--workers", "9" * 401])
    assert res.exit_code == 2 and "--workers" in res.output and "4096" in res.output, res.output
    assert not (tmp_path / "s.parquet").exists()


@pytest.mark.parametrize("name", ["arm-unknown-circle", "panda-unknown-sphere", "panda-spiral-search"])
@pytest.mark.parametrize("value", [0.0, -0.0])
def test_a_zero_stiffness_estimate_is_refused_by_name(name, value):
    """k̂ = -0.0 passed the inclusive range [0, …] and the builder divided by it (fuzz 1019, CI at 0fa85e5)."""
    with pytest.raises(ScenarioError, match=r"stiffness_estimate"):
        fc.scenario(name).with_({"controller.stiffness_estimate": value})
