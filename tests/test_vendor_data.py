"""Recordings in the arms' own layouts: UR RTDE CSV (UR's rtde/csv_writer.py: space-delimited ``<name>_<i>`` columns;
ur_rtde's startFileRecording: the same names, comma-delimited) and libfranka RobotState (operator<<'s JSON, one object
per line; a table with the same names flattened). Poses and wrenches are checked against closed forms."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from forcecontrol.errors import MeasurementError, ParameterError
from forcecontrol.realarm.conventions import BY_END_EFFECTOR, ON_END_EFFECTOR
from forcecontrol.realarm.io import detect_convention, read_recording, read_table, read_vendor

RZ90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
FLIP_X = np.diag([1.0, -1.0, -1.0])


def _ur_rows(n: int = 4) -> tuple[list[str], np.ndarray]:
    names = (["timestamp"] + [f"actual_q_{i}" for i in range(6)] + [f"actual_qd_{i}" for i in range(6)]
             + [f"actual_TCP_pose_{i}" for i in range(6)] + [f"actual_TCP_force_{i}" for i in range(6)])
    rows = []
    for k in range(n):
        q = 0.1 * k + np.arange(6) * 0.01
        rv = [0.0, 0.0, math.pi / 2] if k % 2 == 0 else [math.pi, 0.0, 0.0]  # Rz(90°), then Rx(180°)
        tcp = [0.4, -0.1, 0.3 + 0.01 * k, *rv]
        rows.append([1000.0 + 0.002 * k, *q, *(0.5 * np.ones(6)), *tcp, 1.0, -2.0, 3.0 + k, 0.1, 0.2, 0.3])
    return names, np.array(rows)


def _write(path, names, rows, sep):
    path.write_text(sep.join(names) + "\n" + "\n".join(sep.join(repr(float(v)) for v in r) for r in rows) + "\n")
    return path


@pytest.mark.parametrize("sep", [" ", ","])
def test_ur_rtde_csv_by_field_names(tmp_path, sep):
    """UR's csv_writer (space) and ur_rtde (comma) layouts: t, q, q̇ copied; actual_TCP_pose's rotation vector (0, 0, π/2) is
    Rz(90°) and (π, 0, 0) is diag(1, −1, −1) in the controller's base, which is Rz(180°) in base_link (the models' root):
    the pose and the wrench come rotated into base_link (x, y, m_x, m_y negated), tagged base axes, flange, on the robot."""
    names, rows = _ur_rows()
    path = _write(tmp_path / "robot_data.csv", names, rows, sep)
    run = read_recording(path)
    assert run.metadata["format"] == "ur-rtde" and run.n == 6
    np.testing.assert_allclose(run.t, rows[:, 0])
    np.testing.assert_allclose(run.q, rows[:, 1:7])
    np.testing.assert_allclose(run.qd, 0.5)
    rz180 = np.diag([-1.0, -1.0, 1.0])
    np.testing.assert_allclose(run.pose[0, :3, :3], rz180 @ RZ90, atol=1e-12)
    np.testing.assert_allclose(run.pose[1, :3, :3], rz180 @ FLIP_X, atol=1e-12)
    np.testing.assert_allclose(run.pose[2, :3, 3], [-0.4, 0.1, 0.32])
    np.testing.assert_allclose(run.wrench, rows[:, 19:25] * [-1, -1, 1, -1, -1, 1])
    assert (run.wrench_frame, run.wrench_point, run.wrench_sense) == ("base", "flange", ON_END_EFFECTOR)
    assert any("flange" in note for note in run.metadata["notes"])
    assert any("rotated into base_link" in note for note in run.metadata["notes"])
    X = run.pose_at(0)
    assert (X.parent, X.child) == ("base", "tcp")


def test_ur_rtde_pose_and_wrench_in_the_controllers_base_arrive_in_the_models_root(tmp_path):
    """A UR5 recording as its controller writes it: actual_TCP_pose is tool0 in the URDF's own frame 'base' (the controller's
    Base feature, ur_description's fixed joint from base_link), actual_TCP_force a known world force and moment in 'base'
    axes. Read back: the pose equals the model's forward kinematics of tool0 in its root, the wrench the world one (the
    reference is the URDF's 'base' frame through Pinocchio, not the reader's rotation)."""
    import pinocchio as pin

    from forcecontrol.robots.pinocchio import ur5

    arm = ur5()
    model, data = arm.model, arm.data
    qs = np.array([[0.3, -1.2, 1.5, -0.9, 1.4, 0.2], [-0.8, -1.9, 2.1, -1.6, -1.3, 0.7]])
    h_world = np.array([4.0, -7.0, 12.0, 0.3, -0.5, 0.9])
    rows = []
    for k, q in enumerate(qs):
        pin.framesForwardKinematics(model, data, q)
        o_base = data.oMf[model.getFrameId("base")]
        tcp = o_base.inverse() * data.oMf[model.getFrameId("tool0")]
        R_b = o_base.rotation
        h_base = np.concatenate([R_b.T @ h_world[:3], R_b.T @ h_world[3:]])
        rows.append([10.0 + 0.002 * k, *q, *np.zeros(6), *tcp.translation, *pin.log3(tcp.rotation), *h_base])
    names, _ = _ur_rows()
    run = read_recording(_write(tmp_path / "ur5.csv", names, np.array(rows), ","))
    for k, q in enumerate(qs):
        R, p = arm.frame_pose(q)
        np.testing.assert_allclose(run.pose[k, :3, :3], R, atol=1e-9)
        np.testing.assert_allclose(run.pose[k, :3, 3], p, atol=1e-12)
        np.testing.assert_allclose(run.wrench[k], h_world, atol=1e-12)


def test_franka_json_states_as_operator_prints_them(tmp_path):
    """libfranka's operator<< (one JSON object per line): O_T_EE column-major → the pose (R = Rz(90°), p = (0.3, 0.1, 0.5));
    time [ms] → s; O_F_ext_hat_K kept as the robot's wrench (h_e), tau_J read."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = RZ90, [0.3, 0.1, 0.5]
    lines = []
    for k in range(5):
        st = {"O_T_EE": T.T.reshape(-1).tolist(), "EE_T_K": np.eye(4).reshape(-1).tolist(), "m_ee": 0.73,
              "q": [0.1 * k] * 7, "dq": [0.2] * 7, "tau_J": [1.0] * 7, "O_F_ext_hat_K": [0.0, 0.0, -10.0, 0.0, 0.0, 0.0],
              "K_F_ext_hat_K": [0.0, 0.0, -10.0, 0.0, 0.0, 0.0], "robot_mode": "Move", "time": 5000 + k}
        lines.append(json.dumps(st))
    path = tmp_path / "states.jsonl"
    path.write_text("\n".join(lines) + "\n")
    run = read_recording(path)
    assert run.metadata["format"] == "franka" and run.n == 7
    np.testing.assert_allclose(run.t, 5.0 + 1e-3 * np.arange(5))
    np.testing.assert_allclose(run.pose[3], T, atol=1e-12)
    np.testing.assert_allclose(run.tau, 1.0)
    np.testing.assert_allclose(run.wrench, np.tile([0, 0, -10, 0, 0, 0], (5, 1)))
    assert (run.wrench_frame, run.wrench_point, run.wrench_sense) == ("base", "K", BY_END_EFFECTOR)
    assert run.metadata["wrench_columns"][0] == "O_F_ext_hat_K_0"


def _franka_columns(n: int, K_F, R=FLIP_X, p=(0.4, 0.0, 0.2)):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    cols = {"time": 1000.0 + np.arange(n)}
    for i in range(7):
        cols[f"q_{i}"] = np.full(n, 0.1 * i)
        cols[f"dq_{i}"] = np.zeros(n)
    for i, v in enumerate(T.T.reshape(-1)):
        cols[f"O_T_EE_{i}"] = np.full(n, v)
    for i, v in enumerate(K_F):
        cols[f"K_F_ext_hat_K_{i}"] = np.full(n, v)
    return cols


def test_franka_table_k_frame_wrench_rotated_into_the_base(tmp_path):
    """Only K_F_ext_hat_K recorded, K pointing down (R = diag(1, −1, −1)): K_F = (0, 0, +10, 1, 0, 0) is (0, 0, −10, 1, 0, 0)
    in base axes = h_e (pressing 10 N down); sense='on-robot' tags it as the wrench on the robot (the override)."""
    import pandas as pd

    cols = _franka_columns(6, [0.0, 0.0, 10.0, 1.0, 0.0, 0.0])
    path = tmp_path / "franka.csv"
    pd.DataFrame(cols).to_csv(path, index=False)
    run = read_table(path)
    np.testing.assert_allclose(run.wrench, np.tile([0, 0, -10, 1, 0, 0], (6, 1)), atol=1e-12)
    assert run.wrench_sense == BY_END_EFFECTOR and "K_F_ext_hat_K rotated" in run.metadata["notes"][0]
    over = read_recording(path, format="franka", sense="on-robot")
    assert over.wrench_sense == ON_END_EFFECTOR and over.metadata["wrench_sense_source"] == "override"
    assert any("sense" in note for note in over.metadata["notes"])


def test_mixed_and_malformed_recordings_are_refused(tmp_path):
    """A recording that mixes UR, libfranka or library columns is refused naming the columns of each; a row-major O_T_EE,
    a missing timestamp, text in a field and an explicit format that does not match are errors naming what was wrong."""
    with pytest.raises(ParameterError, match=r"mixes conventions \(ur-rtde: timestamp, actual_q_0.*library table: q1"):
        detect_convention(["timestamp", "actual_q_0", "q1", "fx"])
    with pytest.raises(ParameterError, match="ur-rtde: actual_TCP_force_0.*franka: O_F_ext_hat_K_0"):
        detect_convention(["actual_TCP_force_0", "O_F_ext_hat_K_0"])
    names, rows = _ur_rows()
    mixed = _write(tmp_path / "mixed.csv", names + ["fx"], np.column_stack([rows, rows[:, 0]]), ",")
    with pytest.raises(ParameterError, match="mixes conventions.*library table: fx"):
        read_recording(mixed)
    import pandas as pd

    cols = _franka_columns(3, [0.0] * 6, R=np.eye(3), p=(0.4, 0.0, 0.2))
    T = np.eye(4)
    T[:3, 3] = [0.4, 0.0, 0.2]
    for i, v in enumerate(T.reshape(-1)):  # row-major by mistake: the translation lands in the bottom row
        cols[f"O_T_EE_{i}"] = np.full(3, v)
    pd.DataFrame(cols).to_csv(tmp_path / "rowmajor.csv", index=False)
    with pytest.raises(MeasurementError, match="O_T_EE at row 0 is not a column-major rigid transform.*row-major"):
        read_table(tmp_path / "rowmajor.csv")
    no_t = _write(tmp_path / "no_t.csv", names[1:], rows[:, 1:], ",")
    with pytest.raises(ParameterError, match="needs the 'timestamp' column"):
        read_recording(no_t)
    (tmp_path / "text.csv").write_text(",".join(names) + "\n" + ",".join(["0"] + ["x"] * (len(names) - 1)) + "\n")
    with pytest.raises(MeasurementError, match="column 'actual_q_0' is not numeric"):
        read_recording(tmp_path / "text.csv")
    ur = _write(tmp_path / "ur.csv", names, rows, ",")
    with pytest.raises(ParameterError, match="format 'franka' was asked, but the columns are a ur-rtde recording"):
        read_recording(ur, format="franka")
    with pytest.raises(ParameterError, match="sense must be 'on-robot'.*got 'up'"):
        read_vendor(ur, sense="up")
    with pytest.raises(ParameterError, match=r"ur-rtde recording has the vendor's documented wrench convention \(wrench_frame "
                                             r"'base'\); wrench_frame='end-effector' does not apply"):
        read_table(ur, wrench_frame="end-effector")
    assert read_table(ur, wrench_sense=ON_END_EFFECTOR).wrench_sense == ON_END_EFFECTOR  # consistent with UR's documentation
    assert any("vendor's documented on-end-effector" in n for n in read_table(ur).metadata["notes"])  # the default, not used
    (tmp_path / "s.jsonl").write_text('{"q": [0], "dq": [0], "time": 0}\n{"q": [1], "dq": [0], "time": 1}\n')
    with pytest.raises(ParameterError, match="wrench_point='flange' does not apply"):
        read_recording(tmp_path / "s.jsonl", wrench_point="flange")
    assert read_recording(tmp_path / "s.jsonl").n == 1
    lib = tmp_path / "lib.csv"
    lib.write_text("t,q1,qd1\n0,0,0\n1,0,0\n")
    with pytest.raises(ParameterError, match="sense='on-robot' applies to a vendor's recording"):
        read_table(lib, sense="on-robot")


def test_resampled_pose_interpolates_the_rotation_on_the_sphere(tmp_path):
    """Between Rz(0) and Rz(90°) (in the controller's base) the resampled pose half-way is Rz(45°) (slerp), the position
    the mean (both then in base_link)."""
    import pandas as pd

    n = 2
    cols = {"timestamp": [0.0, 1.0]}
    for i in range(6):
        cols[f"actual_q_{i}"] = [0.0, 1.0]
        cols[f"actual_qd_{i}"] = [0.0, 0.0]
    for i, (a, b) in enumerate([(0.0, 1.0), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0), (0.0, math.pi / 2)]):
        cols[f"actual_TCP_pose_{i}"] = [a, b]
    path = tmp_path / "two.csv"
    pd.DataFrame(cols).to_csv(path, index=False)
    run = read_recording(path).resample(0.5)
    c = math.cos(math.pi / 4)
    rz180 = np.diag([-1.0, -1.0, 1.0])  # the controller's base in base_link
    np.testing.assert_allclose(run.pose[1, :3, :3], rz180 @ [[c, -c, 0], [c, c, 0], [0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(run.pose[1, :3, 3], [-0.5, 0, 0], atol=1e-12)
    assert run.pose.shape == (3, 4, 4) and n == 2


# ----------------------------------------------------------------------------- the replay command


@pytest.fixture(scope="module")
def panda_run():
    pytest.importorskip("pinocchio")
    import forcecontrol as fc
    from forcecontrol.scenarios import build_case

    scn = fc.scenario("panda-admittance-contact").with_(duration=0.2)
    p = build_case(scn.cases[0])
    res = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=p["duration"],
                      sensor=p["sensor"])
    return res, p["robot"]


def test_replay_a_franka_state_log_with_its_documented_sense_and_the_override(tmp_path, panda_run):
    """The Panda's simulated run written as libfranka states (operator<< JSON lines: q, dq, tau_J, O_T_EE column-major from
    the forward kinematics, O_F_ext_hat_K = h_e as documented): `replay --format franka` gives back the simulated torques;
    `--sense on-robot` flips the wrench (torques differ, the override is said in the JSON notes)."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    res, robot = panda_run
    lines = []
    for k in range(res.t.size):
        R, o = robot.frame_pose(res.q[k])
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, o
        lines.append(json.dumps({"O_T_EE": T.T.reshape(-1).tolist(), "q": res.q[k].tolist(), "dq": res.qd[k].tolist(),
                                 "tau_J": res.torque[k].tolist(), "O_F_ext_hat_K": res.wrench_measured[k].tolist(),
                                 "time": 1e3 * res.t[k]}))
    log = tmp_path / "panda.jsonl"
    log.write_text("\n".join(lines) + "\n")
    runner = CliRunner()
    out = runner.invoke(app, ["replay", "panda-admittance-contact", str(log), "--format", "franka", "--out", str(tmp_path),
                              "--json", "--set", "duration=0.2"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.stdout)
    scale = np.abs(res.torque).max()
    assert rep["metrics"]["torque_difference_max"] < 1e-6 * scale
    assert rep["recording"]["format"] == "franka" and rep["recording"]["wrench_sense"] == BY_END_EFFECTOR
    flipped = runner.invoke(app, ["replay", "panda-admittance-contact", str(log), "--format", "franka", "--sense", "on-robot",
                                  "--out", str(tmp_path), "--force", "--json", "--set", "duration=0.2"])
    assert flipped.exit_code == 0, flipped.output
    rep2 = json.loads(flipped.stdout)
    assert rep2["recording"]["wrench_sense"] == ON_END_EFFECTOR
    assert any("sense='on-robot'" in n for n in rep2["notes"])
    assert rep2["metrics"]["torque_difference_max"] > 1e-3 * scale


def test_replay_sensor_pose_places_a_sensor_frame_wrench(tmp_path, panda_run):
    """A sensor-frame log (a table whose wrench is tagged 'ft_sensor', 5 cm before the TCP, rpy (0.1, −0.2, 0.3); μ_s moved
    by SciPy as in test_replay_frames) replays with --sensor-pose x,y,z,r,p,y — and as 16 numbers — to the simulated torques;
    --sensor-pose on a base-frame log is refused (it would be ignored)."""
    from scipy.spatial.transform import Rotation
    from typer.testing import CliRunner

    import forcecontrol.cli.replay as cli_replay
    from forcecontrol.cli import app
    from forcecontrol.realarm.io import RecordedRun

    res, robot = panda_run
    R_es = Rotation.from_euler("xyz", [0.1, -0.2, 0.3])
    p_es = np.array([0.01, -0.02, -0.05])
    h = np.array(res.wrench_measured)
    h_s = np.empty_like(h)
    for k, q in enumerate(res.q):
        R_e_mat, o_e = robot.frame_pose(q)
        R_s = Rotation.from_matrix(R_e_mat) * R_es
        o_s = o_e + R_e_mat @ p_es
        h_s[k] = np.concatenate([R_s.inv().apply(h[k, :3]), R_s.inv().apply(h[k, 3:] + np.cross(o_e - o_s, h[k, :3]))])
    sensor_rec = RecordedRun(t=res.t, q=res.q, qd=res.qd, tau=res.torque, wrench=h_s, wrench_frame="ft_sensor",
                             wrench_point="ft_sensor")
    logs = [sensor_rec]
    real_read_log = cli_replay.read_log
    cli_replay.read_log = lambda *a, **k: logs[-1]  # the CLI's reader has no --wrench-frame: hand it the sensor-frame log
    try:
        runner = CliRunner()
        scale = np.abs(res.torque).max()
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R_es.as_matrix(), p_es
        for pose in (",".join(repr(float(v)) for v in [*p_es, 0.1, -0.2, 0.3]), ",".join(repr(float(v)) for v in T.reshape(-1))):
            out = runner.invoke(app, ["replay", "panda-admittance-contact", str(tmp_path / "x.csv"), "--sensor-pose", pose,
                                      "--out", str(tmp_path), "--force", "--json", "--set", "duration=0.2"])
            assert out.exit_code == 0, out.output
            rep = json.loads(out.stdout)
            assert rep["metrics"]["torque_difference_max"] < 1e-6 * scale
            assert rep["recording"]["sensor_pose"]["child"] == "ft_sensor"
            np.testing.assert_allclose(rep["recording"]["sensor_pose"]["translation"], p_es)
        logs.append(RecordedRun(t=res.t, q=res.q, qd=res.qd, tau=res.torque, wrench=h))  # base frame
        out = runner.invoke(app, ["replay", "panda-admittance-contact", str(tmp_path / "x.csv"), "--sensor-pose", "0,0,0,0,0,0",
                                  "--out", str(tmp_path), "--force", "--json"])
        assert out.exit_code != 0 and "this log's wrench is in the base frame" in out.output
        logs.append(sensor_rec)
        out = runner.invoke(app, ["replay", "panda-admittance-contact", str(tmp_path / "x.csv"), "--sensor-pose", "1,2,3",
                                  "--out", str(tmp_path), "--force", "--json"])
        assert out.exit_code != 0 and "must be 6 numbers x,y,z,roll,pitch,yaw" in out.output
    finally:
        cli_replay.read_log = real_read_log
