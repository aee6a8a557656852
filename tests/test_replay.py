"""Replay: a controller run over a recorded log gives back the simulated torques; trace comparison."""

from __future__ import annotations

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import DimensionError, FrameError, MeasurementError
from forcecontrol.realarm.io import RecordedRun, read_bag, read_recording
from forcecontrol.realarm.replay import compare_traces, recorded_from_simulation, replay
from forcecontrol.scenarios import build_case
from rosfiles_helpers import write_bag


def _simulate(name: str, duration: float):
    """A built-in scenario's first case simulated for ``duration`` [s], and a builder of fresh parts."""
    scn = fc.scenario(name).with_(duration=duration)

    def parts():
        return build_case(scn.cases[0])

    p = parts()
    res = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=p["duration"],
                      sensor=p["sensor"])
    return res, parts


@pytest.fixture(scope="module")
def example_9_2():
    """Example 9.2's first case, simulated (1 s), and a builder of fresh parts."""
    return _simulate("example-9.2", 1.0)


def test_replaying_a_simulation_log_gives_back_its_torques(tmp_path, example_9_2):
    """The same controller over the simulator's own log (Parquet and CSV) commands the simulated torques."""
    res, parts = example_9_2
    data, _ = res.save(tmp_path / "run", format="parquet")
    p = parts()
    out = replay(p["controller"], read_recording(data), p["reference"], p["robot"])
    assert out.t.size == res.t.size
    np.testing.assert_allclose(out.torque, res.torque, rtol=0, atol=1e-9 * np.abs(res.torque).max())
    np.testing.assert_array_equal(out.torque_recorded, res.torque)
    np.testing.assert_allclose(out.force_error, res.reference_block("force") - res.wrench_measured, atol=1e-12)
    assert out.metrics()["torque_difference_max"] < 1e-9 * np.abs(res.torque).max()
    df = out.to_pandas()
    assert {"u1", "u1_recorded", "fx", "fx_error", "fx_reference"} <= set(df.columns)
    # CSV keeps 10 significant digits: the torques agree to that accuracy
    csv, _ = res.save(tmp_path / "run", format="csv")
    p = parts()
    out_csv = replay(p["controller"], read_recording(csv), p["reference"])
    np.testing.assert_allclose(out_csv.torque, res.torque, rtol=0, atol=1e-6 * np.abs(res.torque).max())


def test_replaying_a_ros_bag_of_the_simulation(tmp_path, example_9_2):
    """The log written to a ROS 2 bag (rosbags' writer) replays to the same torques."""
    res, parts = example_9_2
    bag = write_bag(tmp_path / "bag", res.t, res.q, res.qd, res.torque, res.t, res.wrench_measured, frame="base")
    rec = read_bag(bag, wrench_components=2)
    p = parts()
    out = replay(p["controller"], rec, p["reference"], p["robot"])
    np.testing.assert_allclose(out.torque, res.torque, rtol=0, atol=1e-8 * np.abs(res.torque).max())


def test_replay_refuses_mismatched_logs(tmp_path, example_9_2):
    """Wrong joint count, wrench components or frame, and a force controller without a wrench are refused first."""
    res, parts = example_9_2
    p = parts()
    rec = recorded_from_simulation(res)
    three = RecordedRun(t=rec.t, q=np.hstack([rec.q, rec.q[:, :1]]), qd=np.hstack([rec.qd, rec.qd[:, :1]]), wrench=rec.wrench)
    with pytest.raises(DimensionError, match="the controller's robot has 2 joints; the log .* has 3"):
        replay(p["controller"], three, p["reference"])
    six = RecordedRun(t=rec.t, q=rec.q, qd=rec.qd, wrench=np.hstack([rec.wrench, rec.wrench, rec.wrench]))
    with pytest.raises(DimensionError, match=r"needs a 2-component wrench \(fx fy\); the log .* has 6"):
        replay(p["controller"], six, p["reference"])
    other = RecordedRun(t=rec.t, q=rec.q, qd=rec.qd, wrench=rec.wrench, wrench_frame="ft_sensor")
    with pytest.raises(FrameError, match="in the base frame 'base'; the log's is in 'ft_sensor'"):
        replay(p["controller"], other, p["reference"])
    bare = RecordedRun(t=rec.t, q=rec.q, qd=rec.qd)
    with pytest.raises(MeasurementError, match="reads the contact force, but the log .* has no wrench"):
        replay(p["controller"], bare, p["reference"])


def test_replay_converts_the_wrench_sense(example_9_2):
    """A log of the wrench on the end-effector (−h_e) replays like the chapter's h_e."""
    res, parts = example_9_2
    rec = recorded_from_simulation(res)
    flipped = RecordedRun(t=rec.t, q=rec.q, qd=rec.qd, tau=rec.tau, wrench=-rec.wrench, wrench_sense="on-end-effector")
    p = parts()
    out = replay(p["controller"], flipped, p["reference"])
    np.testing.assert_allclose(out.torque, res.torque, rtol=0, atol=1e-9 * np.abs(res.torque).max())


def test_compare_traces_finds_the_shift_and_the_noise_level(example_9_2):
    """A recorded trace = the simulation delayed by 25 ms plus known noise: the shift and RMS errors come back."""
    res, _ = example_9_2
    rng = np.random.default_rng(3)
    sigma_q, sigma_f = 1e-4, 0.5
    n = res.t.size
    rec = RecordedRun(t=res.t + 0.025, q=res.q + sigma_q * rng.standard_normal(res.q.shape), qd=res.qd,
                      wrench=res.wrench_measured + sigma_f * rng.standard_normal((n, 2)))
    cmp = compare_traces(res, rec, max_shift=0.05)
    assert cmp.shift == pytest.approx(0.025, abs=1e-9)
    assert cmp.metrics["position_error_rms"] == pytest.approx(sigma_q, rel=0.1)
    assert cmp.metrics["force_error_rms"] == pytest.approx(sigma_f * np.sqrt(2), rel=0.1)
    assert cmp.metrics["force_error_max"] < 6 * sigma_f


def test_compare_traces_figure(tmp_path, example_9_2):
    """The comparison draws joint positions and forces to a PNG."""
    res, _ = example_9_2
    cmp = compare_traces(res, recorded_from_simulation(res))
    assert cmp.shift == 0.0 and cmp.metrics["force_error_max"] == 0.0
    path = cmp.plot(tmp_path / "cmp.png")
    assert path.stat().st_size > 10_000


def test_replay_and_compare_argument_errors(example_9_2):
    """Wrong controller, robot or reference, and traces that cannot be compared, are refused with the reason."""
    from forcecontrol.errors import ParameterError

    res, parts = example_9_2
    p = parts()
    rec = recorded_from_simulation(res)
    with pytest.raises(ParameterError, match="controller must be a forcecontrol Controller; got str"):
        replay("impedance", rec, p["reference"])
    with pytest.raises(ParameterError, match="is not the robot given"):
        replay(p["controller"], rec, p["reference"], robot=object())  # not the controller's arm
    with pytest.raises(ParameterError, match="reference must be a ReferenceSignal"):
        replay(p["controller"], rec, fc.Reference.setpoint([1.1, 0.1]))
    with pytest.raises(DimensionError, match="reference must be 2-dimensional"):
        replay(p["controller"], rec, fc.Setpoint([1.1, 0.1, 0.0]))
    with pytest.raises(ParameterError, match="wrench must be 'measured' or 'true'"):
        recorded_from_simulation(res, wrench="both")
    three = RecordedRun(t=rec.t, q=np.hstack([rec.q, rec.q[:, :1]]), qd=np.hstack([rec.qd, rec.qd[:, :1]]))
    with pytest.raises(DimensionError, match="the simulated trace has 2 joints, the recorded one 3"):
        compare_traces(res, three)
    later = RecordedRun(t=rec.t + 50.0, q=rec.q, qd=rec.qd)  # 50 s later: no overlap within ±10 ms
    with pytest.raises(MeasurementError, match="overlap by fewer than 10 samples"):
        compare_traces(res, later, max_shift=0.01)


@pytest.fixture(scope="module")
def panda_run():
    """panda-table-line's first case for 0.3 s (its log in the model's joint order), and a builder of fresh parts."""
    return _simulate("panda-table-line", 0.3)


def _about_base_origin(res, robot) -> np.ndarray:
    """The run's wrenches (base axes, about the end-effector) with the moment about the base origin, as a ROS
    WrenchStamped in the base frame holds it: μ_o = μ_e + p_e × f, p_e by Pinocchio's forward kinematics."""
    h = np.array(res.wrench_measured, dtype=np.float64)
    p_e = np.array([robot.frame_pose(q)[1] for q in res.q])
    h[:, 3:] += np.cross(p_e, h[:, :3])
    return np.ascontiguousarray(h)


def test_a_base_frame_wrench_stamped_is_about_the_base_origin(tmp_path, panda_run):
    """A 6-D WrenchStamped in the base frame holds the moment about the base origin: replay moves it to the
    end-effector (μ_e = μ_o − p_e × f) and gives back the simulated torques; the same data read as about the
    end-effector (wrench_point=) replay alike (it was used as the end-effector's moment: 24 N m off, 4385 N m)."""
    res, parts = panda_run
    robot = parts()["robot"]
    h_o = _about_base_origin(res, robot)
    assert np.abs(h_o[:, 3:] - res.wrench_measured[:, 3:]).max() > 1.0  # the two points differ here
    c = np.ascontiguousarray
    base = write_bag(tmp_path / "base", res.t, c(res.q), c(res.qd), c(res.torque), res.t, h_o, frame="base",
                     names=[f"panda_joint{i}" for i in range(1, 8)])
    ee = write_bag(tmp_path / "ee", res.t, c(res.q), c(res.qd), c(res.torque), res.t, c(res.wrench_measured),
                   frame="base", names=[f"panda_joint{i}" for i in range(1, 8)])
    rec = read_bag(base)
    assert (rec.wrench_frame, rec.wrench_point) == ("base", "base")
    outs = []
    for r in (rec, read_bag(ee, wrench_point="end-effector")):
        p = parts()
        outs.append(replay(p["controller"], r, p["reference"], p["robot"]))
    for out in outs:
        np.testing.assert_allclose(out.torque, res.torque, rtol=0, atol=1e-6 * np.abs(res.torque).max())


def test_a_log_whose_joint_states_list_the_joints_in_another_order_replays_in_the_models(tmp_path, panda_run):
    """A JointState need not follow the URDF's order: a bag whose names and columns are reversed together (the same
    physical run) replays to the same torques as the bag in the model's order, and says it reordered them (it was
    replayed column by column: 16 000 N m off). A bag naming other joints is refused, naming both lists."""
    from forcecontrol.realarm.replay import model_joint_names

    res, parts = panda_run
    names = model_joint_names(parts()["robot"])
    assert names == tuple(f"panda_joint{i}" for i in range(1, 8))
    rev = list(reversed(range(7)))
    outs = []
    for tag, perm in (("model", list(range(7))), ("reversed", rev)):
        c = np.ascontiguousarray  # rows of the log's columns, as a message holds them
        bag = write_bag(tmp_path / tag, res.t, c(res.q[:, perm]), c(res.qd[:, perm]), c(res.torque[:, perm]), res.t,
                        _about_base_origin(res, parts()["robot"]), names=[names[i] for i in perm], frame="base")
        rec = read_bag(bag)
        assert rec.joint_names == tuple(names[i] for i in perm)
        p = parts()
        outs.append(replay(p["controller"], rec, p["reference"], p["robot"]))
    np.testing.assert_allclose(outs[1].torque, outs[0].torque, rtol=0, atol=1e-9)
    np.testing.assert_allclose(outs[0].torque, res.torque, rtol=0, atol=1e-6 * np.abs(res.torque).max())
    ordered = read_bag(tmp_path / "reversed").in_joint_order(names)
    assert ordered.joint_names == names and "reordered to the model's order" in ordered.metadata["notes"][0]
    np.testing.assert_array_equal(ordered.q, res.q)
    other = write_bag(tmp_path / "other", res.t, c(res.q), c(res.qd), c(res.torque), res.t, c(res.wrench_measured),
                      names=[f"joint_{i}" for i in range(7)], frame="base")
    p = parts()
    with pytest.raises(DimensionError, match=r"the log's joints \['joint_0'.*are not the model's \['panda_joint1'"):
        replay(p["controller"], read_bag(other), p["reference"], p["robot"])


def test_replay_cli_says_it_reordered_the_joints(tmp_path, panda_run):
    """`forcecontrol replay panda-table-line BAG --json` of the reversed bag: the note, and the model's joint names in
    the recording block."""
    import json

    from forcecontrol.realarm.replay import model_joint_names
    from journeys_helpers import forcecontrol

    res, parts = panda_run
    names = model_joint_names(parts()["robot"])
    rev = list(reversed(range(7)))
    c = np.ascontiguousarray
    write_bag(tmp_path / "bag", res.t, c(res.q[:, rev]), c(res.qd[:, rev]), c(res.torque[:, rev]), res.t,
              _about_base_origin(res, parts()["robot"]), names=[names[i] for i in rev], frame="base")
    doc = json.loads(forcecontrol(tmp_path, "replay", "panda-table-line", "bag", "--json").stdout)
    assert any("reordered to the model's order" in n for n in doc["notes"])
    assert doc["recording"]["joint_names"] == list(names)
    assert doc["metrics"]["torque_difference_max"] < 1.0


def test_compare_trace_cli_matches_the_joints_by_name(tmp_path, panda_run):
    """`forcecontrol compare-trace panda-table-line BAG --json` with the joints reversed in the bag: the note, and the
    position error of the same run (0 to the bag's float precision) instead of the columns compared crosswise."""
    import json

    from forcecontrol.realarm.replay import model_joint_names
    from journeys_helpers import forcecontrol

    res, parts = panda_run
    names = model_joint_names(parts()["robot"])
    rev, c = list(reversed(range(7))), np.ascontiguousarray
    write_bag(tmp_path / "bag", res.t, c(res.q[:, rev]), c(res.qd[:, rev]), c(res.torque[:, rev]), res.t,
              _about_base_origin(res, parts()["robot"]), names=[names[i] for i in rev], frame="base")
    doc = json.loads(forcecontrol(tmp_path, "compare-trace", "panda-table-line", "bag", "--json").stdout)
    assert any("reordered to the model's order" in n for n in doc["notes"])
    assert doc["metrics"]["shift"] == 0.0 and doc["metrics"]["position_error_max"] < 1e-9
    # the base-origin moments compared about the end-effector, as simulated (the scenario's sensor noise aside)
    assert doc["metrics"]["force_error_max"] < 1e-6


def test_compare_traces_converts_an_end_effector_frame_wrench_or_refuses_without_a_robot(panda_run):
    """The same run's wrench logged in the end-effector frame: with the robot, compared in the base frame (errors 0,
    shift 0; it was compared as if in the base frame: 60 N RMS, the shift at its bound); without it, a FrameError."""
    from dataclasses import replace

    from forcecontrol.realarm.replay import end_effector_rotation

    res, parts = panda_run
    robot = parts()["robot"]
    sim = recorded_from_simulation(res)
    R = np.array([end_effector_rotation(robot, q) for q in res.q])
    h = res.wrench_measured
    local = np.hstack([np.einsum("kji,kj->ki", R, h[:, :3]), np.einsum("kji,kj->ki", R, h[:, 3:])])  # Rᵀ f, Rᵀ μ
    rec = replace(sim, wrench=local, wrench_frame="end-effector", source="tool-frame log")
    cmp = compare_traces(res, rec, robot=robot)
    assert cmp.metrics["shift"] == 0.0 and cmp.metrics["force_error_max"] < 1e-9
    with pytest.raises(FrameError, match=r"tool-frame log: the wrench is in frame 'end-effector'.*give the robot"):
        compare_traces(res, rec)
