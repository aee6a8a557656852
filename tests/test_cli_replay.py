"""The `replay` and `compare-trace` commands on files the tests write (CSV, a ROS 2 bag, an MCAP file)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import forcecontrol as fc
from forcecontrol.cli import app
from forcecontrol.scenarios import build_case
from rosfiles_helpers import write_bag, write_mcap

runner = CliRunner()


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Example 9.2's first case simulated for 0.5 s, written as CSV, a ROS 2 bag and an MCAP file."""
    folder = tmp_path_factory.mktemp("logs")
    scn = fc.scenario("example-9.2")
    p = build_case(scn.cases[0])
    res = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=0.5,
                      sensor=p["sensor"])
    csv, _ = res.save(folder / "run", format="csv")
    bag = write_bag(folder / "bag", res.t, res.q, res.qd, res.torque, res.t, res.wrench_measured)
    mcap = write_mcap(folder / "run.mcap", res.t, res.q, res.qd, res.torque, res.t, res.wrench_measured)
    return res, {"csv": csv, "bag": bag, "mcap": mcap}


@pytest.mark.parametrize("kind", ["csv", "bag", "mcap"])
def test_replay_command_gives_back_the_recorded_torques(tmp_path, logs, kind):
    """`replay example-9.2 DATA --json`: the replayed torques equal the recorded ones; table and figure written."""
    res, files = logs
    out = runner.invoke(app, ["replay", "example-9.2", str(files[kind]), "--out", str(tmp_path), "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.stdout)
    assert rep["samples"] == res.t.size and rep["period"] == 0.001
    assert rep["metrics"]["torque_difference_max"] < 1e-6 * np.abs(res.torque).max()
    table = np.genfromtxt(rep["files"]["table"], delimiter=",", names=True)
    np.testing.assert_allclose(table["u1"], res.torque[:, 0], atol=1e-6 * np.abs(res.torque).max())
    assert (tmp_path / "example-9.2-replay").is_dir()
    with open(rep["files"]["figure"], "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"


def test_replay_command_table_output_and_missing_topic(tmp_path, logs):
    """Without --json a table is printed; a missing topic exits 2 listing the bag's topics."""
    _, files = logs
    out = runner.invoke(app, ["replay", "example-9.2", str(files["bag"]), "--out", str(tmp_path)])
    assert out.exit_code == 0, out.output
    assert "torque_difference_max" in out.stdout and "force_error_rms" in out.stdout
    out = runner.invoke(app, ["replay", "example-9.2", str(files["bag"]), "--out", str(tmp_path / "b"),
                              "--wrench-topic", "/wrench"])
    assert out.exit_code == 2 and "no wrench topic '/wrench'; the file has: /force_torque_sensor_broadcaster/wrench" in out.stderr


@pytest.mark.parametrize("command", ["replay", "compare-trace"])
def test_topics_given_for_a_file_without_topics_are_refused(tmp_path, logs, command):
    """--joint-topic / --wrench-topic select a bag's or MCAP file's topics: on a CSV log they would be ignored, so they
    are refused before anything runs (exit 2, naming the options); the defaults given explicitly are accepted."""
    _, files = logs
    out = runner.invoke(app, [command, "example-9.2", str(files["csv"]), "--out", str(tmp_path / "a"),
                              "--wrench-topic", "/x", "--joint-topic", "/y"])
    assert out.exit_code == 2, out.output
    assert "--joint-topic and --wrench-topic select what is read from a ROS bag or MCAP file" in out.stderr
    assert not (tmp_path / "a").exists()
    out = runner.invoke(app, [command, "example-9.2", str(files["csv"]), "--out", str(tmp_path / "c"),
                              "--joint-names", "j1,j2"])
    assert out.exit_code == 2 and "--joint-names selects what is read from a ROS bag or MCAP file" in out.stderr
    out = runner.invoke(app, [command, "example-9.2", str(files["csv"]), "--out", str(tmp_path / "b"),
                              "--joint-topic", "/joint_states"])
    assert out.exit_code == 0, out.output


@pytest.mark.parametrize("command", ["replay", "compare-trace"])
def test_a_gripper_on_the_joint_state_topic_is_passed_over_and_joint_names_choose(tmp_path, logs, command):
    """A bag whose /joint_states also carries a gripper's messages: the arm's joints are replayed (the records equal the
    clean bag's) and the passed-over messages are said on stderr; with two sets of two joints the command asks for
    --joint-names (exit 2), and --joint-names j1,j2 reads the arm."""
    res, files = logs
    one = [(s + 0.0005, ["finger"], [0.04]) for s in res.t[:20]]
    two = [(s + 0.0005, ["finger_l", "finger_r"], [0.04, 0.04]) for s in res.t[:20]]
    bags = {n: write_bag(tmp_path / n, res.t, res.q, res.qd, res.torque, res.t, res.wrench_measured, others=o)
            for n, o in (("one", one), ("two", two))}
    clean = json.loads(runner.invoke(app, [command, "example-9.2", str(files["bag"]), "--out", str(tmp_path / "c"),
                                           "--json"]).stdout)
    out = runner.invoke(app, [command, "example-9.2", str(bags["one"]), "--out", str(tmp_path / "a"), "--json"])
    assert out.exit_code == 0, out.output
    assert json.loads(out.stdout)["metrics"] == clean["metrics"]
    said = "20 JointState message(s) of another set of joints (finger) passed over: the log reads j1, j2"
    assert said in out.stderr and any(n.startswith(said) for n in json.loads(out.stdout)["notes"])
    out = runner.invoke(app, [command, "example-9.2", str(bags["two"]), "--out", str(tmp_path / "b")])
    assert out.exit_code == 2 and "2 sets of 2 joints (j1, j2; finger_l, finger_r): name the joints" in out.stderr
    out = runner.invoke(app, [command, "example-9.2", str(bags["two"]), "--out", str(tmp_path / "d"), "--json",
                              "--joint-names", "j1,j2"])
    assert out.exit_code == 0, out.output
    assert json.loads(out.stdout)["metrics"] == clean["metrics"]

def test_compare_trace_command_against_a_scenario(tmp_path, logs):
    """`compare-trace example-9.2 RECORDED`: the scenario's own trace matches (zero shift, tiny errors) and a figure is drawn."""
    _, files = logs
    out = runner.invoke(app, ["compare-trace", "example-9.2", str(files["mcap"]), "--out", str(tmp_path), "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.stdout)
    assert rep["metrics"]["shift"] == 0.0
    assert rep["metrics"]["position_error_max"] < 1e-9 and rep["metrics"]["force_error_max"] < 1e-6
    assert rep["samples"] == 501
    out = runner.invoke(app, ["compare-trace", str(files["csv"]), str(files["bag"]), "--out", str(tmp_path / "b")])
    assert out.exit_code == 0, out.output
    assert "position_error_rms" in out.stdout and "figure:" in out.stdout


@pytest.mark.parametrize("command", ["replay", "compare-trace"])
def test_stamps_receive_reads_a_bag_whose_driver_left_the_header_stamps_empty(tmp_path, logs, command):
    """A bag whose messages carry header.stamp 0: read by its header stamps it has no time (refused, exit 2, saying
    so and what to give); --stamps receive reads the recorder's times and gives the stamped bag's metrics."""
    res, files = logs
    bag = write_bag(tmp_path / "unstamped", res.t, res.q, res.qd, res.torque, res.t, res.wrench_measured, stamped=False)
    out = runner.invoke(app, [command, "example-9.2", str(bag), "--out", str(tmp_path / "a")])
    assert out.exit_code == 2 and "carry no header stamps (all 0" in out.stderr and "--stamps receive" in out.stderr
    stamped = json.loads(runner.invoke(app, [command, "example-9.2", str(files["bag"]), "--out", str(tmp_path / "c"),
                                             "--json"]).stdout)
    out = runner.invoke(app, [command, "example-9.2", str(bag), "--out", str(tmp_path / "b"), "--json", "--stamps", "receive"])
    assert out.exit_code == 0, out.output
    assert json.loads(out.stdout)["metrics"] == stamped["metrics"]
    out = runner.invoke(app, [command, "example-9.2", str(files["csv"]), "--out", str(tmp_path / "d"), "--stamps", "receive"])
    assert out.exit_code == 2 and "--stamps selects what is read from a ROS bag or MCAP file" in out.stderr


def test_a_larger_hand_taken_for_the_arm_is_refused_naming_the_arms_messages(tmp_path, logs):
    """The chapter's arm names no joints, so a 3-joint hand on its topic is the largest set and is read: the joint count
    is refused, naming the arm's messages that were passed over and the option that chooses them."""
    res, _ = logs
    hand = [(s + 0.0005, ["f1", "f2", "f3"], [0.0, 0.0, 0.0]) for s in res.t]
    bag = write_bag(tmp_path / "hand", res.t, res.q, res.qd, res.torque, res.t, res.wrench_measured, others=hand)
    out = runner.invoke(app, ["replay", "example-9.2", str(bag), "--out", str(tmp_path / "a")])
    assert out.exit_code == 2
    said = " ".join(out.stderr.split())
    assert (f"the log {bag} has 3 (f1, f2, f3); {res.t.size} JointState message(s) of (j1, j2) passed over: choose the "
            "joints with joint_names (--joint-names)") in said, said


def test_replay_window_start_end_gives_the_recorded_torques_of_that_window(tmp_path, logs):
    """`replay --start 0.1 --end 0.3`: 201 samples from t = 0.1 s of the log, the window in --json and in the table, the
    replayed torques equal the recorded ones of those samples (example 9.2's law holds no state)."""
    res, files = logs
    out = runner.invoke(app, ["replay", "example-9.2", str(files["bag"]), "--start", "0.1", "--end", "0.3", "--out",
                              str(tmp_path), "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.stdout)
    assert rep["samples"] == 201 and rep["window"] == pytest.approx([0.1, 0.3], abs=1e-9)
    assert rep["max_gap"] == pytest.approx(0.01) and rep["units"]["window"] == "s"
    assert any("starts from its reset state at t = 0.1 s" in n for n in rep["notes"]), rep.get("notes")
    table = np.genfromtxt(rep["files"]["table"], delimiter=",", names=True)
    np.testing.assert_allclose(table["u1"], res.torque[100:301, 0], atol=1e-6 * np.abs(res.torque).max())
    text = runner.invoke(app, ["replay", "example-9.2", str(files["csv"]), "--start", "0.1", "--out", str(tmp_path / "t")])
    assert text.exit_code == 0, text.output
    assert "window" in text.stdout and "0.1 to 0.5" in text.stdout
    assert "note: the controller starts from its reset state" in text.stderr
    whole = runner.invoke(app, ["replay", "example-9.2", str(files["csv"]), "--start", "0", "--out", str(tmp_path / "w"),
                                "--json"])
    assert whole.exit_code == 0 and "notes" not in json.loads(whole.stdout), whole.output


@pytest.fixture(scope="module")
def gapped(logs, tmp_path_factory):
    """The CSV log with its samples between 0.2 s and 0.25 s dropped: a 0.05 s gap (5 periods over the default 10 ms)."""
    import pandas as pd

    _, files = logs
    df = pd.read_csv(files["csv"])
    df = df[(df["t"] <= 0.2 + 1e-9) | (df["t"] >= 0.25 - 1e-9)]
    path = tmp_path_factory.mktemp("gap") / "gapped.csv"
    df.to_csv(path, index=False)
    return path


@pytest.mark.parametrize("command", ["replay", "compare-trace"])
def test_a_gap_is_refused_naming_the_options_and_max_gap_bridges_it(tmp_path, gapped, command):
    """A 0.05 s gap: refused (exit 2) with the options that get past it; --max-gap 0.06 bridges it (replay says the
    gap it allowed); replay --end 0.2 stops before it."""
    out = runner.invoke(app, [command, "example-9.2", str(gapped), "--out", str(tmp_path / "a")])
    assert out.exit_code == 2, out.output
    assert "gap of 0.05 s after t = 0.2 s" in out.stderr and "--max-gap" in out.stderr
    if command == "replay":
        assert "--start/--end" in out.stderr
    ok = runner.invoke(app, [command, "example-9.2", str(gapped), "--max-gap", "0.06", "--out", str(tmp_path / "b"),
                             "--json"])
    assert ok.exit_code == 0, ok.output
    if command == "replay":
        rep = json.loads(ok.stdout)
        assert rep["max_gap"] == 0.06 and rep["samples"] == 501
        before = runner.invoke(app, [command, "example-9.2", str(gapped), "--end", "0.2", "--out", str(tmp_path / "c"),
                                     "--json"])
        assert before.exit_code == 0, before.output
        assert json.loads(before.stdout)["samples"] == 201


@pytest.mark.parametrize("args, match", [
    (["--start", "nan"], "must be a finite time"),
    (["--end", "inf"], "must be a finite time"),
    (["--max-gap", "0"], "must be a finite time > 0"),
    (["--max-gap", "nan"], "must be a finite time > 0"),
    (["--start", "5"], "outside the joint states recording"),
    (["--start", "0.3", "--end", "0.1"], "start must be before end"),
    (["--start", "0.4999"], "shorter than one period"),
])
def test_replay_refuses_a_bad_window_or_gap(tmp_path, logs, args, match):
    _, files = logs
    out = runner.invoke(app, ["replay", "example-9.2", str(files["csv"]), *args, "--out", str(tmp_path)])
    assert out.exit_code == 2 and match in out.output, out.output


def test_resample_refuses_a_window_that_is_not_a_finite_time(logs):
    from forcecontrol.errors import ParameterError
    from forcecontrol.realarm.io import read_recording

    _, files = logs
    rec = read_recording(files["csv"])
    for kw in ({"start": float("nan")}, {"end": float("inf")}, {"start": "0.1"}):
        with pytest.raises(ParameterError, match=f"{next(iter(kw))} must be a finite time"):
            rec.resample(0.001, **kw)
