"""`calibrate --robot NAME`: readings at joint positions (calibrate-plan's poses fed back) calibrated through the robot's
forward kinematics; a known payload is recovered within its uncertainty."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from forcecontrol.cli import app
from forcecontrol.errors import ParameterError
from forcecontrol.realarm.calibration import calibration_data_from_joints, calibration_robot, rotations_from_joints

runner = CliRunner()
G = 9.81


def _readings(R: np.ndarray, m: float, c: np.ndarray, bf: np.ndarray, bt: np.ndarray, rng, sf=0.05, st=0.005):
    """The gravity model f = −m u + b_f, τ = [u]× (m c) + b_τ, u = Rᵀ g (g = (0, 0, −9.81)), with noise."""
    u = np.einsum("kji,j->ki", R, [0.0, 0.0, -G])
    F = -m * u + bf + sf * rng.standard_normal(u.shape)
    T = np.cross(u, m * c) + bt + st * rng.standard_normal(u.shape)
    return F, T


def test_plan_then_calibrate_panda_recovers_the_payload(tmp_path):
    """calibrate-plan panda 8 --out poses.csv, readings of a 1.2 kg payload at (0.01, −0.02, 0.08) m synthesised at the
    plan's own orientations (its --json), then calibrate poses.csv --robot panda: mass, centre of mass and biases within
    3 σ of the truth, and the same numbers as calibrating the plan's rotations given as r11 … r33 columns."""
    poses = tmp_path / "poses.csv"
    out = runner.invoke(app, ["calibrate-plan", "panda", "8", "--out", str(poses), "--json"])
    assert out.exit_code == 0, out.output
    plan = json.loads(out.stdout)
    R = np.array(plan["rotations"])
    df = pd.read_csv(poses)
    assert list(df.columns) == [f"q{i}" for i in range(1, 8)] and len(df) == 8
    m, c = 1.2, np.array([0.01, -0.02, 0.08])
    bf, bt = np.array([0.5, -0.3, 1.0]), np.array([0.02, 0.01, -0.03])
    F, T = _readings(R, m, c, bf, bt, np.random.default_rng(3))
    for j, n in enumerate(("fx", "fy", "fz")):
        df[n] = F[:, j]
    for j, n in enumerate(("tx", "ty", "tz")):
        df[n] = T[:, j]
    df.to_csv(poses, index=False)
    out = runner.invoke(app, ["calibrate", str(poses), "--robot", "panda", "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.stdout)
    assert rep["robot"] == "panda" and "q1" in rep["orientation"] and "panda_hand_tcp" in rep["orientation"]
    par = {p["name"]: p for p in rep["parameters"]}
    truth = {"mass": m, "com_x": c[0], "com_y": c[1], "com_z": c[2], "force_bias_x": bf[0], "force_bias_z": bf[2],
             "torque_bias_y": bt[1]}
    for name, v in truth.items():
        assert abs(par[name]["value"] - v) < 3 * par[name]["std"], (name, par[name], v)
    # the same calibration from the plan's rotations as matrix columns (no robot)
    mat = df[["fx", "fy", "fz", "tx", "ty", "tz"]].copy()
    for i in range(3):
        for j in range(3):
            mat[f"r{i + 1}{j + 1}"] = R[:, i, j]
    mat.to_csv(tmp_path / "matrix.csv", index=False)
    ref = json.loads(runner.invoke(app, ["calibrate", str(tmp_path / "matrix.csv"), "--json"]).stdout)
    np.testing.assert_allclose([p["value"] for p in rep["parameters"]], [p["value"] for p in ref["parameters"]],
                               rtol=1e-9, atol=1e-12)
    assert ref["robot"] is None


def test_planar_arm_orientation_is_the_sum_of_the_joint_angles():
    """The chapter arm's sensor angle through calibrate --robot is φ = q1 + q2 (closed form), and a UR's actual_q_* columns
    are read as the joints; a UR5 orientation is a rotation (RᵀR = I)."""
    arm = calibration_robot("chapter-arm")
    Q = np.array([[0.3, -1.0], [1.2, 0.4], [-2.0, 0.5], [0.0, 2.5]])
    R = rotations_from_joints(arm, Q)
    phi = Q.sum(axis=1)
    np.testing.assert_allclose(R[:, 0, 0], np.cos(phi), atol=1e-12)
    np.testing.assert_allclose(R[:, 1, 0], np.sin(phi), atol=1e-12)
    ur5 = calibration_robot("ur5")
    cols = {f"actual_q_{i}": np.linspace(-1, 1, 5) * (i + 1) * 0.3 for i in range(6)}
    cols.update(fx=np.zeros(5), fy=np.zeros(5), fz=np.ones(5))
    Rr, F, T, Q5, layout = calibration_data_from_joints(cols, ur5)
    assert "UR RTDE" in layout and Q5.shape == (5, 6) and T is None
    np.testing.assert_allclose(np.einsum("kji,kjl->kil", Rr, Rr), np.broadcast_to(np.eye(3), (5, 3, 3)), atol=1e-12)


def test_robot_calibration_errors(tmp_path):
    """Orientation columns and joints together, missing joint columns, --degrees with --robot and an unknown robot are
    refused with messages naming what was given."""
    arm = calibration_robot("chapter-arm")
    with pytest.raises(ParameterError, match=r"orientation column\(s\) \['angle'\] and the robot's joint positions"):
        calibration_data_from_joints({"q1": [0.0], "q2": [0.0], "angle": [0.0], "fx": [0.0], "fy": [1.0]}, arm)
    with pytest.raises(ParameterError, match="the robot has 2 joints: give q1 … q2.*the data has columns"):
        calibration_data_from_joints({"q1": [0.0], "fx": [0.0], "fy": [1.0]}, arm)
    with pytest.raises(ParameterError, match=r"robot must be one of \['chapter-arm', 'panda', 'ur5'\]; got 'kuka'"):
        calibration_robot("kuka")
    pd.DataFrame({"q1": [0.0, 1.0, 2.0, 3.0], "q2": [0.0] * 4, "fx": [0.0] * 4, "fy": [1.0] * 4}).to_csv(tmp_path / "a.csv",
                                                                                                     index=False)
    out = runner.invoke(app, ["calibrate", str(tmp_path / "a.csv"), "--robot", "chapter-arm", "--degrees"])
    assert out.exit_code != 0 and "--degrees applies to a planar 'angle' column" in out.output
