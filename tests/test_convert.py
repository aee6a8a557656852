"""Wrench conventions on recorded arrays and ``forcecontrol convert`` (CSV, Parquet, a ROS 2 bag, MCAP).

References: the vendors' documented worked examples (the same numbers as tests/test_conventions.py:
libfranka's O_F_ext_hat_K / K_F_ext_hat_K, UR's actual_TCP_force about the flange, MuJoCo's own
force/torque sensors), hand conversions with SciPy's Rotation, and the tested SensedWrench methods.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from forcecontrol.cli import app
from forcecontrol.errors import DimensionError, MeasurementError, ParameterError
from forcecontrol.realarm.conventions import BY_END_EFFECTOR, CONVENTIONS, SensedWrench, convert_wrenches
from forcecontrol.realarm.io import read_recording
from forcecontrol.spatial import Transform
from rosfiles_helpers import write_bag, write_mcap

runner = CliRunner()
FLIP_X = np.diag([1.0, -1.0, -1.0])  # 180° about x: a tool frame pointing down; quaternion (x, y, z, w) = (1, 0, 0, 0)


def test_franka_worked_example():
    """Pressing 10 N down on a table: O_F_ext_hat_K = (0, 0, −10, 0, 0, 0) ("forces applied by the robot to the environment
    are positive"); K pointing down: K_F_ext_hat_K = (0, 0, +10, ...); the chapter's h_e = (0, 0, −10, 0, 0, 0) from both
    (libfranka robot_state.h)."""
    O_F = np.array([[0.0, 0.0, -10.0, 0.0, 0.0, 0.0]])
    K_F = np.array([[0.0, 0.0, 10.0, 0.0, 0.0, 0.0]])
    h_e = [[0, 0, -10, 0, 0, 0]]
    np.testing.assert_array_equal(convert_wrenches(O_F, "franka-O", "library"), h_e)
    np.testing.assert_allclose(convert_wrenches(K_F, "franka-K", "library", rotations=FLIP_X), h_e, atol=1e-12)
    np.testing.assert_allclose(convert_wrenches(O_F, "franka-O", "franka-K", rotations=FLIP_X), K_F, atol=1e-12)
    np.testing.assert_allclose(convert_wrenches(h_e, "library", "franka-O"), O_F, atol=0)


def test_ur_tcp_force_worked_example():
    """actual_TCP_force about the flange: a tool 0.1 m long pointing down (TCP 0.1 m below the flange), pushed by +5 N
    along the controller's base x at the TCP: reading (5, 0, 0, 0, −0.5, 0). That x is base_link's −x (ur_description: the
    controller's base is Rz(180°) from base_link, the models' root): the push on the tool is (−5, 0, 0) in the library's
    base, so h_e about the TCP = (5, 0, 0, 0, 0, 0). The flange in the end-effector (TCP) frame, whose z points down:
    (0, 0, −0.1)."""
    reading = np.array([[5.0, 0.0, 0.0, 0.0, -0.5, 0.0]])
    p = [0.0, 0.0, -0.1]
    h = convert_wrenches(reading, "ur-tcp", "library", rotations=FLIP_X, flange_offset=p)
    np.testing.assert_allclose(h, [[5, 0, 0, 0, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(convert_wrenches(h, "library", "ur-tcp", rotations=FLIP_X, flange_offset=p), reading, atol=1e-12)
    # CB3 (the moment about the TCP): no offset, no rotation needed
    np.testing.assert_array_equal(convert_wrenches([[5.0, 0, 0, 0, 0, 0]], "ur-tcp", "library"), [[5, 0, 0, 0, 0, 0]])
    np.testing.assert_array_equal(convert_wrenches([[0, 5.0, 1.0, 2.0, 3.0, 4.0]], "ur-tcp", "library"),
                                  [[0, 5, -1, 2, 3, -4]])  # y, m_x, m_y turned, z and m_z kept, all of it flipped in sense


def test_mujoco_sensor_worked_example():
    """MuJoCo's force/torque sensors on a weightless tool (site rotated 90° about z), pushed by (f_env, μ_env):
    converted from the sensor readings with the site's orientation, h_e = −(f_env, μ_env)."""
    mujoco = pytest.importorskip("mujoco")
    xml = """<mujoco><option gravity="0 0 0"/><worldbody>
      <body name="wrist" pos="0 0 1"><body name="tool" pos="0 0 -0.1" euler="0 0 90">
        <geom type="sphere" size="0.01" mass="1e-9"/><site name="ft" pos="0 0 0"/></body></body></worldbody>
      <sensor><force site="ft"/><torque site="ft"/></sensor></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    f_env, mu_env = np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.2, 0.3])
    d.xfrc_applied[m.body("tool").id] = np.concatenate([f_env, mu_env])
    mujoco.mj_forward(m, d)
    R = d.site("ft").xmat.reshape(3, 3).copy()
    h = convert_wrenches(d.sensordata[None, :6].copy(), "mujoco", "library", rotations=R)
    np.testing.assert_allclose(h[0], -np.concatenate([f_env, mu_env]), atol=1e-6)
    np.testing.assert_allclose(convert_wrenches(h, "library", "mujoco", rotations=R)[0], d.sensordata[:6], atol=1e-12)


def test_every_pair_agrees_with_sensed_wrench_and_round_trips():
    """Random samples and orientations: each convention to the library's equals SensedWrench's rotation/transport
    (tested on the vendors' examples), and every pair of conventions round-trips."""
    rng = np.random.default_rng(3)
    N = 5
    h = rng.normal(size=(N, 6))
    R = Rotation.random(N, random_state=4).as_matrix()
    p = np.array([0.02, -0.01, 0.07])
    for name, c in CONVENTIONS.items():
        got = convert_wrenches(h, name, "library", rotations=R, flange_offset=p)
        for k in range(N):
            frame = {"base": "base", "ur-base": "ur", "end-effector": "ee"}[c.axes]
            point = "flange" if c.point == "flange" else "ee"
            w = SensedWrench.from_vector(h[k], frame=frame, point=point, sense=c.sense)
            if c.axes == "end-effector":
                w = w.rotated(Transform(R[k], [0, 0, 0], parent="base", child="ee"))
            elif c.axes == "ur-base":  # ur_description: base_link → base, rpy (0, 0, π)
                w = w.rotated(Transform(Rotation.from_euler("z", np.pi).as_matrix(), [0, 0, 0], parent="base", child="ur"))
            if c.point == "flange":
                w = w.about("ee", -(R[k] @ p))
            np.testing.assert_allclose(got[k], w.h_e("base", "ee"), atol=1e-12, err_msg=name)
        for other in CONVENTIONS:
            there = convert_wrenches(h, name, other, rotations=R, flange_offset=p)
            np.testing.assert_allclose(convert_wrenches(there, other, name, rotations=R, flange_offset=p), h, atol=1e-12)


def test_rotations_printed_to_six_decimals_are_taken_as_the_nearest_rotation():
    """A CSV of end-effector rotations written with 6 decimals is orthonormal to about 1e-6 only (it was refused at
    1e-6): converted as with the exact rotations to 1e-5 of the wrench; 1e-2 off is refused."""
    R = Rotation.random(20, random_state=7).as_matrix()
    h = np.random.default_rng(8).normal(size=(20, 6))
    exact = convert_wrenches(h, "franka-K", "library", rotations=R)
    np.testing.assert_allclose(convert_wrenches(h, "franka-K", "library", rotations=np.round(R, 6)), exact, atol=1e-5)
    with pytest.raises(ParameterError, match=r"orthonormal \(RᵀR = I within 1e-3\)"):
        convert_wrenches(h, "franka-K", "library", rotations=R * 1.01)


def test_planar_and_force_only_wrenches():
    """Two components (fx, fy): rotated about z as (fx, fy, 0); three: the force only."""
    phi = np.array([0.3, -1.2])
    R = Rotation.from_euler("z", phi[:, None]).as_matrix()
    f_ee = np.array([[1.0, 2.0], [-3.0, 0.5]])
    expect = -Rotation.from_euler("z", phi[:, None]).apply(np.column_stack([f_ee, np.zeros(2)]))[:, :2]
    np.testing.assert_allclose(convert_wrenches(f_ee, "ros-on", "library", rotations=R), expect, atol=1e-12)
    f3 = np.array([[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(convert_wrenches(f3, "franka-K", "library", rotations=FLIP_X), [[1, -2, -3]], atol=1e-12)


def test_conversion_errors_name_the_problem():
    """Unknown convention, missing or bad orientation, offsets without moments, NaN, bad shapes."""
    h = np.zeros((2, 6))
    with pytest.raises(ParameterError, match="unknown wrench convention 'franka'; known: library, franka-O"):
        convert_wrenches(h, "franka", "library")
    from forcecontrol.realarm.conventions import WrenchConvention

    with pytest.raises(ParameterError, match=r"WrenchConvention axes must be one of \('base', 'ur-base', 'end-effector'\); "
                                             r"got 'world'"):
        WrenchConvention("mine", "world", "end-effector", BY_END_EFFECTOR, "a frame convert_wrenches would take as the base")
    with pytest.raises(ParameterError, match="needs the end-effector's orientation"):
        convert_wrenches(h, "franka-K", "library")
    with pytest.raises(ParameterError, match="orthonormal"):
        convert_wrenches(h, "franka-K", "library", rotations=2 * np.eye(3))
    with pytest.raises(ParameterError, match=r"sample 0 is a reflection \(det -1\)"):
        convert_wrenches(h, "franka-K", "library", rotations=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(DimensionError, match=r"rotations must have shape \(2, 3, 3\)"):
        convert_wrenches(h, "franka-K", "library", rotations=np.zeros((3, 3, 3)))
    with pytest.raises(DimensionError, match="needs all 6 components"):
        convert_wrenches(np.zeros((2, 3)), "ur-tcp", "library", rotations=np.eye(3), flange_offset=[0, 0, 0.1])
    with pytest.raises(MeasurementError, match=r"wrench\[1, 2\] is not finite"):
        convert_wrenches([[0.0] * 6, [0, 0, np.nan, 0, 0, 0]], "franka-O", "library")
    with pytest.raises(DimensionError, match=r"\(N, 2\), \(N, 3\) or \(N, 6\)"):
        convert_wrenches(np.zeros((2, 4)), "franka-O", "library")


def _table(tmp_path, wrench, quat=None, n=30):
    t = np.arange(n) * 1e-3
    cols = {"t": t, "q1": np.linspace(0, 0.1, n), "q2": np.linspace(0.2, 0.3, n), "qd1": np.full(n, 100.0 / n * 0.1),
            "qd2": np.full(n, 0.1)}
    for j, name in enumerate(["fx", "fy", "fz", "mx", "my", "mz"][: wrench.shape[1]]):
        cols[name] = wrench[:, j]
    if quat is not None:
        for j, name in enumerate(["qx", "qy", "qz", "qw"]):
            cols[name] = np.full(n, quat[j])
    path = tmp_path / "in.csv"
    pd.DataFrame(cols).to_csv(path, index=False)
    return path


def _convert(*args):
    out = runner.invoke(app, ["convert", *map(str, args), "--json"])
    assert out.exit_code == 0, out.output
    return json.loads(out.stdout)


def test_cli_converts_a_franka_k_table_with_orientation_columns(tmp_path):
    """K_F_ext_hat_K = (0, 0, +10), tool pointing down (qx qy qz qw = 1 0 0 0) → h_e = (0, 0, −10) in a Parquet file,
    its convention in the Parquet schema metadata and the JSON beside it; the orientation columns are kept."""
    n = 30
    src = _table(tmp_path, np.tile([0.0, 0.0, 10.0, 0.0, 0.0, 0.0], (n, 1)), quat=[1.0, 0.0, 0.0, 0.0], n=n)
    out = tmp_path / "h_e.parquet"
    rep = _convert(src, "--from", "franka-K", "--to", "library", "--out", out)
    assert rep["samples"] == n and rep["to"]["name"] == "library" and "qx qy qz qw" in rep["orientation"]
    back = read_recording(out)
    np.testing.assert_allclose(back.wrench, np.tile([0, 0, -10, 0, 0, 0], (n, 1)), atol=1e-12)
    meta = json.loads((tmp_path / "h_e.json").read_text())
    assert meta["metadata"]["wrench_convention"]["name"] == "library" and meta["wrench_sense"] == "by-end-effector"
    assert meta["metadata"]["converted_from"]["name"] == "franka-K"
    import pyarrow.parquet as pq

    schema_meta = json.loads(pq.read_schema(out).metadata[b"forcecontrol"])
    assert schema_meta["metadata"]["wrench_convention"]["name"] == "library"
    assert {"qx", "qw"} <= set(pd.read_parquet(out).columns)
    # and back to franka-O (base axes: the orientation is not needed)
    rep2 = _convert(out, "--from", "library", "--to", "franka-O", "--out", tmp_path / "O.csv")
    assert rep2["orientation"] == "not needed"
    np.testing.assert_allclose(read_recording(tmp_path / "O.csv").wrench, np.tile([0, 0, -10, 0, 0, 0], (n, 1)), atol=1e-12)


def test_cli_converts_ur_tcp_force_about_the_flange(tmp_path):
    """The UR worked example through the command: --flange-offset and the orientation columns."""
    n = 12
    src = _table(tmp_path, np.tile([5.0, 0.0, 0.0, 0.0, -0.5, 0.0], (n, 1)), quat=[1.0, 0.0, 0.0, 0.0], n=n)
    _convert(src, "--from", "ur-tcp", "--to", "library", "--flange-offset", "0,0,-0.1", "--out", tmp_path / "o.csv")
    np.testing.assert_allclose(read_recording(tmp_path / "o.csv").wrench, np.tile([5, 0, 0, 0, 0, 0], (n, 1)), atol=1e-12)


def test_cli_converts_an_rtde_recording_from_ur_tcp_once(tmp_path):
    """An RTDE CSV (UR's column names) read by the RTDE reader, which already brings actual_TCP_force into base_link:
    `convert --from ur-tcp --to library` rotates it once, not twice, and says so. Reading (5, 0, 0, 0, 0, 0), a push along
    the controller's base x (base_link's −x) on the tool: h_e = (5, 0, 0, 0, 0, 0), the worked example's CB3 case."""
    names = (["timestamp"] + [f"actual_q_{i}" for i in range(6)] + [f"actual_qd_{i}" for i in range(6)]
             + [f"actual_TCP_force_{i}" for i in range(6)])
    rows = [[0.002 * k, *np.zeros(12), 5.0, 0.0, 0.0, 0.0, 0.0, 0.0] for k in range(5)]
    src = tmp_path / "robot_data.csv"
    src.write_text(",".join(names) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    rep = _convert(src, "--from", "ur-tcp", "--to", "library", "--out", tmp_path / "o.csv")
    np.testing.assert_allclose(read_recording(tmp_path / "o.csv").wrench, np.tile([5, 0, 0, 0, 0, 0], (5, 1)), atol=1e-12)
    assert any("rotated actual_TCP_force from the controller's base into base_link already" in n for n in rep["notes"])


def _planar_log(n=40):
    t = np.arange(n) * 2e-3
    q = np.column_stack([0.4 + 0.5 * t, -1.1 + 2.0 * t])
    qd = np.column_stack([np.full(n, 0.5), np.full(n, 2.0)])
    h_e = np.column_stack([20.0 + 100 * t, -5.0 + 30 * t])  # the library's h_e, base axes
    phi = q[:, 0] + q[:, 1]
    f_on_ee = -Rotation.from_euler("z", phi[:, None]).inv().apply(np.column_stack([h_e, np.zeros(n)]))  # in the tool frame
    return t, q, qd, h_e, np.column_stack([f_on_ee, np.zeros((n, 3))])


def test_cli_converts_a_ros_bag_and_an_mcap_file_with_forward_kinematics(tmp_path):
    """WrenchStamped in the tool frame (the wrench on the end-effector), chapter arm: --robot chapter-arm rotates each
    sample by q1 + q2; a bag (rosbags' writer) → library, an MCAP file (mcap's writer) → franka-O (= h_e: the robot's sense)."""
    t, q, qd, h_e, w = _planar_log()
    bag = write_bag(tmp_path / "bag", t, q, qd, None, t, w, frame="tool0")
    rep = _convert(bag, "--from", "ros-on", "--to", "library", "--robot", "chapter-arm", "--end-effector-frame", "tool0",
                   "--out", tmp_path / "bag.csv")
    assert "chapter-arm" in rep["orientation"] and rep["components"] == 6
    got = read_recording(tmp_path / "bag.csv").wrench
    np.testing.assert_allclose(got[:, :2], h_e, atol=1e-9)
    np.testing.assert_allclose(got[:, 2:], 0.0, atol=1e-9)
    mcap = write_mcap(tmp_path / "run.mcap", t, q, qd, None, t, w, frame="tool0")
    _convert(mcap, "--from", "ros-on", "--to", "franka-O", "--robot", "chapter-arm", "--out", tmp_path / "mcap.parquet")
    rec = read_recording(tmp_path / "mcap.parquet", wrench_sense=BY_END_EFFECTOR)
    np.testing.assert_allclose(rec.wrench[:, :2], h_e, atol=1e-9)
    meta = json.loads((tmp_path / "mcap.json").read_text())
    assert meta["metadata"]["file_wrench_frame"] == "tool0" and meta["wrench_frame"] == "base"


def test_cli_errors(tmp_path):
    """A base-frame bag read as a tool-frame convention, a missing orientation, an existing output: exit 2 with a message."""
    t, q, qd, h_e, w = _planar_log(10)
    bag = write_bag(tmp_path / "bag", t, q, qd, None, t, w, frame="base")
    out = runner.invoke(app, ["convert", str(bag), "--from", "ros-on", "--to", "library", "--robot", "chapter-arm",
                              "--out", str(tmp_path / "x.csv")])
    assert out.exit_code == 2 and "in the base frame 'base', but --from ros-on is in end-effector axes" in out.output
    src = _table(tmp_path, np.zeros((10, 6)), n=10)
    out = runner.invoke(app, ["convert", str(src), "--from", "franka-K", "--to", "library", "--out", str(tmp_path / "y.csv")])
    assert out.exit_code == 2 and "needs the end-effector's orientation" in out.output
    out = runner.invoke(app, ["convert", str(src), "--from", "nope", "--to", "library", "--out", str(tmp_path / "y.csv")])
    assert out.exit_code == 2 and "unknown wrench convention 'nope'" in out.output
    _convert(src, "--from", "franka-O", "--to", "library", "--out", tmp_path / "z.csv")
    out = runner.invoke(app, ["convert", str(src), "--from", "franka-O", "--to", "library", "--out", str(tmp_path / "z.csv")])
    assert out.exit_code == 2 and "already exist" in out.output and "--force" in out.output
    _convert(src, "--from", "franka-O", "--to", "library", "--out", tmp_path / "z.csv", "--force")


def test_force_over_a_users_json_beside_out_says_so_and_not_over_its_own(tmp_path):
    """--force replacing a user's z.json (beside --out z.csv) notes it on stderr and in --json; its own outputs need no note."""
    src = _table(tmp_path, np.zeros((10, 6)), n=10)
    user = tmp_path / "z.json"
    user.write_text('{"mine": true}\n')
    out = runner.invoke(app, ["convert", str(src), "--from", "franka-O", "--to", "library", "--out", str(tmp_path / "z.csv")])
    assert out.exit_code == 2 and "already exist" in out.output and user.read_text() == '{"mine": true}\n'
    rep = _convert(src, "--from", "franka-O", "--to", "library", "--out", tmp_path / "z.csv", "--force")
    assert rep["notes"] == [f"--force: {user} was not written by forcecontrol; it is replaced"]
    assert "wrench_frame" in json.loads(user.read_text())
    again = runner.invoke(app, ["convert", str(src), "--from", "franka-O", "--to", "library", "--out", str(tmp_path / "z.csv"),
                                "--force"])
    assert again.exit_code == 0 and "note:" not in again.stderr
    (tmp_path / "d.json").mkdir()
    out = runner.invoke(app, ["convert", str(src), "--from", "franka-O", "--to", "library", "--out", str(tmp_path / "d.csv"),
                              "--force"])
    assert out.exit_code == 2 and "is an existing folder" in out.output
