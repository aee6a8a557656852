"""Replay of a wrench recorded in the end-effector or a sensor frame: rotated per sample into the base frame.

Reference: the simulator logs the wrench in the base frame; the tests convert it by hand with SciPy's
Rotation into the end-effector (or a sensor) frame, and the replay of that log must command the same
torques as the replay of the base-frame log.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import forcecontrol as fc
from forcecontrol.errors import DimensionError, FrameError
from forcecontrol.realarm.conventions import ON_END_EFFECTOR
from forcecontrol.realarm.io import RecordedRun
from forcecontrol.realarm.replay import recorded_from_simulation, replay, wrench_to_base
from forcecontrol.scenarios import build_case
from forcecontrol.spatial import Transform


def _simulate(name: str, duration: float):
    scn = fc.scenario(name).with_(duration=duration)

    def parts():
        return build_case(scn.cases[0])

    p = parts()
    res = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=p["duration"],
                      sensor=p["sensor"])
    return res, parts


@pytest.fixture(scope="module")
def planar():
    return _simulate("example-9.2", 0.3)


@pytest.fixture(scope="module")
def panda():
    pytest.importorskip("pinocchio")
    return _simulate("panda-admittance-contact", 0.3)


def test_planar_end_effector_frame_log_replays_like_the_base_frame_log(planar):
    """Chapter arm: the end-effector frame is rotated by φ = q1 + q2 about z; f_e = R_z(φ)ᵀ f (SciPy).

    Also logged with the opposite sense (the wrench on the end-effector), as a wrist sensor reports it.
    """
    res, parts = planar
    rec = recorded_from_simulation(res)
    phi = rec.q[:, 0] + rec.q[:, 1]
    f3 = np.column_stack([rec.wrench, np.zeros(len(phi))])
    f_ee = Rotation.from_euler("z", phi[:, None]).inv().apply(f3)
    assert np.abs(f_ee[:, 2]).max() < 1e-12 and np.abs(f_ee[:, :2] - rec.wrench).max() > 1.0  # the frames differ here
    in_ee = RecordedRun(t=rec.t, q=rec.q, qd=rec.qd, tau=rec.tau, wrench=-f_ee[:, :2], wrench_frame="end-effector",
                        wrench_sense=ON_END_EFFECTOR)
    p = parts()
    base = replay(p["controller"], rec, p["reference"], p["robot"])
    p = parts()
    ee = replay(p["controller"], in_ee, p["reference"], p["robot"])
    scale = np.abs(base.torque).max()
    np.testing.assert_allclose(ee.torque, base.torque, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(ee.wrench, base.wrench, rtol=0, atol=1e-9)
    np.testing.assert_allclose(base.torque, res.torque, rtol=0, atol=1e-9 * scale)


def test_panda_sensor_frame_log_replays_like_the_base_frame_log(panda):
    """Panda, 6-D admittance control: a wrist sensor 5 cm before the TCP, tilted; its log in its own frame
    about its origin (SciPy's Rotation, μ_s = R_sᵀ (μ + (o_e − o_s) × f)) replays to the base-frame torques.
    """
    res, parts = panda
    robot = parts()["robot"]
    rec = recorded_from_simulation(res)
    assert rec.m == 6 and np.abs(rec.wrench[:, 2]).max() > 5.0  # in contact with the table
    R_es = Rotation.from_euler("xyz", [0.1, -0.2, 0.3])
    p_es = np.array([0.01, -0.02, -0.05])  # the sensor's origin in the end-effector (TCP) frame
    h_s = np.empty_like(rec.wrench)
    for k, q in enumerate(rec.q):
        R_e_mat, o_e = robot.frame_pose(q)
        R_e = Rotation.from_matrix(R_e_mat)
        R_s = R_e * R_es
        o_s = o_e + R_e.apply(p_es)
        f, mu = np.array(rec.wrench[k, :3]), np.array(rec.wrench[k, 3:])  # (SciPy needs writable arrays)
        h_s[k] = np.concatenate([R_s.inv().apply(f), R_s.inv().apply(mu + np.cross(o_e - o_s, f))])
    assert np.abs(h_s[:, 3:]).max() > 0.1  # the offset puts a moment on the sensor
    in_sensor = RecordedRun(t=rec.t, q=rec.q, qd=rec.qd, tau=rec.tau, wrench=h_s, wrench_frame="ft_sensor",
                            wrench_point="ft_sensor")
    X = Transform(R_es.as_matrix(), p_es, parent="panda_hand_tcp", child="ft_sensor")
    p = parts()
    base = replay(p["controller"], rec, p["reference"], p["robot"])
    p = parts()
    sensed = replay(p["controller"], in_sensor, p["reference"], p["robot"], sensor_pose=X)
    scale = np.abs(base.torque).max()
    np.testing.assert_allclose(sensed.wrench, base.wrench, rtol=0, atol=1e-9)
    np.testing.assert_allclose(sensed.torque, base.torque, rtol=0, atol=1e-8 * scale)
    # the end-effector frame under the robot's own frame name, about its origin: rotation only
    h_e = np.array([np.concatenate([Rotation.from_matrix(robot.frame_pose(q)[0]).inv().apply(h[:3]),
                                    Rotation.from_matrix(robot.frame_pose(q)[0]).inv().apply(h[3:])])
                    for q, h in zip(rec.q, np.array(rec.wrench))])
    in_tcp = RecordedRun(t=rec.t, q=rec.q, qd=rec.qd, wrench=h_e, wrench_frame="panda_hand_tcp", wrench_point="panda_hand_tcp")
    p = parts()
    np.testing.assert_allclose(replay(p["controller"], in_tcp, p["reference"], p["robot"]).torque, base.torque,
                               rtol=0, atol=1e-8 * scale)


def test_frame_errors_say_what_to_give(planar, panda):
    """Unknown frames, a sensor pose for another frame, a 6-D end-effector wrench about another point are refused."""
    res, parts = planar
    rec = recorded_from_simulation(res)
    p = parts()
    wrong = RecordedRun(t=rec.t, q=rec.q, qd=rec.qd, wrench=rec.wrench, wrench_frame="ft_sensor", wrench_point="ft_sensor")
    with pytest.raises(FrameError, match="pass sensor_pose= for a sensor frame"):
        replay(p["controller"], wrong, p["reference"])
    X = Transform(np.eye(3), [0.0, 0.0, 0.0], parent="end-effector", child="other")
    with pytest.raises(FrameError, match="sensor_pose must be the pose of the log's wrench frame 'ft_sensor'"):
        replay(p["controller"], wrong, p["reference"], sensor_pose=X)
    X_off = Transform(np.eye(3), [0.0, 0.0, 0.1], parent="end-effector", child="ft_sensor")
    with pytest.raises(FrameError, match="sensor offset .* has 2 components and no moment"):
        replay(p["controller"], wrong, p["reference"], sensor_pose=X_off)
    res6, parts6 = panda
    rec6 = recorded_from_simulation(res6)
    p6 = parts6()
    off_point = RecordedRun(t=rec6.t, q=rec6.q, qd=rec6.qd, wrench=rec6.wrench, wrench_frame="end-effector",
                            wrench_point="flange")
    with pytest.raises(FrameError, match="about 'flange', not the end-effector origin"):
        replay(p6["controller"], off_point, p6["reference"])
    with pytest.raises(DimensionError, match="one row per joint sample"):
        wrench_to_base(p6["robot"], rec6.q, rec6.wrench[:-1])
    with pytest.raises(FrameError, match="has no end-effector orientation"):
        wrench_to_base(object(), rec.q[:1], rec.wrench[:1])  # type: ignore[arg-type]
