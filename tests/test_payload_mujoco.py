"""A payload in the MuJoCo engine (issue 30, FZI #177): a body after MuJoCo's own F/T sensor, checked against the closed
form, Pinocchio's Newton-Euler and the built-in engine; #177 reproduced and fixed in MuJoCo."""

from __future__ import annotations

import math
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

import forcecontrol as fc  # noqa: E402
from forcecontrol.engines.mujoco import MujocoPlant, simulate_mujoco  # noqa: E402
from forcecontrol.environments.spatial import Table  # noqa: E402
from forcecontrol.errors import ParameterError  # noqa: E402
from forcecontrol.robots.pinocchio import Payload, ur10  # noqa: E402
from forcecontrol.sensors import PayloadForceSensor  # noqa: E402

CONFIGS = Path(str(resources.files("forcecontrol.scenarios"))) / "configs"
COG = np.array([0.042, -0.223, 0.229])  # FZI #177's CoG in tool0 [m]
MASS = 10.94
Q0 = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
G = np.array([0.0, 0.0, -9.81])


def _plant(arm, table_below: float = 50.0) -> MujocoPlant:
    _, p = arm.frame_pose(Q0)
    return MujocoPlant(arm, Table(p - np.array([0.0, 0.0, table_below]), stiffness=1e4), sample_time=5e-4)


def _frame_rotation(arm, q):
    pin = arm._pin
    pin.forwardKinematics(arm.model, arm.data, np.asarray(q, float))
    pin.updateFramePlacements(arm.model, arm.data)
    return arm.data.oMf[arm.frame_id].rotation.copy()


def test_static_reading_is_the_weight_at_the_centre_of_mass_lever():
    """At rest MuJoCo's sensor reads f = −m g and τ = (R c) × (−m g) (closed form, R from Pinocchio) within 1e-9 at
    three postures; with the weight compensated (the default, the arm's payload setting) it reads zero."""
    arm = ur10(payload=Payload(MASS, COG))
    plant = _plant(arm)
    reader = plant.payload_reader
    for q in (Q0, Q0 + np.array([0.4, -0.3, 0.5, 1.1, -0.7, 2.0]), np.array([1.0, -0.5, -1.2, 0.3, 1.4, -2.5])):
        plant.data.qpos[:], plant.data.qvel[:] = q, 0.0
        reader.gravity_compensated = False
        r = _frame_rotation(arm, q) @ COG
        expected = np.concatenate([-MASS * G, np.cross(r, -MASS * G)])
        np.testing.assert_allclose(reader.read(plant.data, np.zeros(6)), expected, rtol=0, atol=1e-9 * MASS * 9.81)
        reader.gravity_compensated = True
        np.testing.assert_allclose(reader.read(plant.data, np.zeros(6)), 0.0, atol=1e-9 * MASS * 9.81)


def test_moving_reading_equals_pinocchio_newton_euler_at_the_same_state():
    """At random (q, q̇, q̈), MuJoCo's sensor (cfrc_int after mj_inverse) equals PayloadForceSensor.inertial_wrench
    (Pinocchio's frame acceleration and the Newton-Euler closed form) within 1e-9 of its size, with a full inertia."""
    inertia = np.array([[0.06, 0.005, 0.0], [0.005, 0.05, 0.01], [0.0, 0.01, 0.04]])
    arm = ur10(payload=Payload(MASS, COG, inertia))
    plant = _plant(arm)
    plant.payload_reader.gravity_compensated = False
    builtin = PayloadForceSensor(arm, gravity_compensated=False)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-2, 2, 6), rng.uniform(-2, 2, 6), rng.uniform(-5, 5, 6)
        plant.data.qpos[:], plant.data.qvel[:] = q, qd
        w = builtin.inertial_wrench(q, qd, qdd)
        np.testing.assert_allclose(plant.payload_reader.read(plant.data, qdd), w, rtol=0, atol=1e-9 * np.abs(w).max())
        assert plant.data.ncon == 0  # free space: nothing but the payload is read


def test_a_contact_on_the_tool_is_read_through_the_payload_sensor():
    """The tool pressed 2 mm into a 10⁴ N/m table at rest: the reading (weight compensated) is the contact's h_e =
    (0, 0, −k δ) = −20 N in z (closed form) within 1e-6 N, the sphere being carried by the payload body."""
    arm = ur10(payload=Payload(MASS, COG))
    plant = _plant(arm, table_below=-0.002)
    plant.data.qpos[:], plant.data.qvel[:] = Q0, 0.0
    reading = plant.payload_reader.read(plant.data, np.zeros(6))
    np.testing.assert_allclose(reading, [0, 0, -20.0, 0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(plant.contact_wrench(), reading, atol=1e-9)
    assert plant.model.geom_bodyid[plant.ee_geom] == plant.payload_reader.body


def test_spring_and_payload_under_impedance_control_agree_between_engines():
    """UR10 with the payload on a 3-D spring, impedance control stepping 7 cm: at the first sample after the step (the
    motion from rest is quadratic: the built-in's backward differences are exact there) the two sensors agree within
    1e-3; the tool's path within 3e-5 m; the sensed payload wrench, averaged over 20 ms, within 5 % of its peak after
    10 ms; the spring's wrench within 0.2 % of its peak. The sample-level gap is the built-in's q̈ by backward
    differences (1.5 a on the sample after a step of a), not the physics (previous test)."""
    arm = ur10(task="position", payload=Payload(MASS, COG))
    x0 = arm.forward_kinematics(Q0)
    env = fc.LinearSpring(np.diag([2000.0] * 3), x0)
    ref = fc.Setpoint(x0 + np.array([0.0, 0.05, 0.05]))

    def ctl():
        return fc.ImpedanceController(arm, 20.0, 400.0, 1000.0, sample_time=1e-3)

    b = fc.simulate(arm, env, ctl(), ref, q0=Q0, duration=1.0, sensor=PayloadForceSensor(arm))
    m = simulate_mujoco(arm, env, ctl(), ref, q0=Q0, duration=1.0)
    assert m.metadata["mujoco"]["payload"]["mass"] == MASS
    pb, pm = (np.asarray(r.wrench_measured) - np.asarray(r.wrench) for r in (b, m))
    assert np.abs(pb[1]).max() > 10.0
    np.testing.assert_allclose(pm[1], pb[1], rtol=1e-3)
    assert np.abs(np.asarray(b.x) - np.asarray(m.x)).max() < 3e-5
    ker = np.ones(20) / 20
    fb, fm = (np.array([np.convolve(p[:, i], ker, "valid") for i in range(3)]).T for p in (pb, pm))
    assert np.all(np.abs(fb - fm)[10:].max(axis=0) < 0.05 * np.abs(fm).max(axis=0))
    hb, hm = np.asarray(b.wrench), np.asarray(m.wrench)
    assert np.abs(hb - hm).max() < 2e-3 * np.abs(hb).max()


@pytest.fixture(scope="module")
def runs_177():
    from forcecontrol.scenarios import run_scenario

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {e: run_scenario(CONFIGS / "fzi_issue_177.toml", engine=e) for e in ("auto", "mujoco")}


def _rot_ripple(x: np.ndarray, a: int, b: int) -> float:
    n = len(x)
    return float(np.ptp(x[a * n // 4 : b * n // 4, 3:], axis=0).max())


def _growth_rate(r) -> float:
    """The e-folding rate [1/s] of the sensed torque about x: the log-slope of its 10 ms envelope between 1e-3 and 100 N m."""
    w, t = np.asarray(r.wrench_measured)[:, 3], np.asarray(r.t)
    n = len(w) // 20 * 20
    env, tb = np.abs(w[:n]).reshape(-1, 20).max(axis=1), t[:n].reshape(-1, 20)[:, 0]
    ok = (env > 1e-3) & (env < 1e2)
    return float(np.polyfit(tb[ok], np.log(env[ok]), 1)[0])


def test_issue_177_reproduces_in_mujoco_and_the_proposed_p_settles(runs_177):
    """fzi_issue_177.toml with MuJoCo as the plant, the built-in test's criteria: error_scale 0.4 shakes (orientation
    ripple > 0.5 rad in the second half), the reporter's 0.002 and the proposed rotational p 0.3 hold still (< 1e-3 rad);
    in 1 s the reporter's covers < 1 % of the 5 mm step, the proposed one more than half."""
    z0 = ur10().frame_pose(Q0)[1][2]
    reported, reporter, proposed = (np.asarray(c.result.x) for c in runs_177["mujoco"].cases)
    assert all(c.result.metadata["engine"] == "mujoco" for c in runs_177["mujoco"].cases)
    assert _rot_ripple(reported, 2, 4) > 0.5
    for x in (reporter, proposed):
        assert _rot_ripple(x, 2, 4) < 1e-3
    assert 0.0 < reporter[-1, 2] - z0 < 0.01 * 0.005 < 0.5 * 0.005 < proposed[-1, 2] - z0 < 0.005


def test_issue_177_key_numbers_agree_between_engines(runs_177):
    """The two engines on #177: the distance covered in 1 s agrees within 0.1 % (reporter's) and 2 % (proposed); the
    proposed case's tool pose within 5e-5 and its sensed wrench (10 ms average) within 6 % of its peak; the reported
    case's sensed torque grows in both at rates within 30 % of each other (measured 16/s and 19/s)."""
    z0 = ur10().frame_pose(Q0)[1][2]
    b, m = (runs_177[e].cases for e in ("auto", "mujoco"))
    for i, rel in ((1, 1e-3), (2, 0.02)):
        db, dm = (np.asarray(c[i].result.x)[-1, 2] - z0 for c in (b, m))
        assert dm == pytest.approx(db, rel=rel)
    xb, xm = (np.asarray(c[2].result.x) for c in (b, m))
    assert np.abs(xb - xm).max() < 5e-5
    ker = np.ones(20) / 20
    wb, wm = (np.array([np.convolve(np.asarray(c[2].result.wrench_measured)[:, i], ker, "valid") for i in range(5)]).T
              for c in (b, m))
    assert np.all(np.abs(wb - wm).max(axis=0) < 0.06 * np.abs(wb).max(axis=0))
    gb, gm = _growth_rate(b[0].result), _growth_rate(m[0].result)
    assert gb > 5.0 and gm > 5.0 and math.isclose(gb, gm, rel_tol=0.3)


def test_issue_177_shakes_in_mujoco_only_when_the_payload_is_sensed(monkeypatch):
    """The reported case with the payload carried by MuJoCo's arm but its wrench kept from the controller (the sensor
    reads zero; free space) holds still (ripple < 1e-6 rad): the shaking is the sensed inertia's loop, not the dynamics."""
    from forcecontrol.scenarios import build_case, load_scenario

    with warnings.catch_warnings():  # the config's notes and the servo's limit notes
        warnings.simplefilter("ignore")
        parts = build_case(load_scenario(CONFIGS / "fzi_issue_177.toml").cases[0], where="fzi_issue_177.toml")
        plant = MujocoPlant(parts["robot"], parts["environment"], sample_time=parts["controller"].sample_time)
        monkeypatch.setattr(plant.payload_reader, "read", lambda data, qacc=None: np.zeros(6))
        x = np.asarray(plant.run(parts["controller"], parts["reference"], q0=parts["q0"], duration=parts["duration"]).x)
    assert _rot_ripple(x, 2, 4) < 1e-6
    assert plant.model.body_mass[plant.payload_reader.body] == MASS


def test_what_mujoco_cannot_model_with_a_payload_is_refused_by_name():
    """An inertia no rigid body has (principal moments A + B < C: MuJoCo would rebalance it) and a planar task (no
    payload wrench is defined for it, as on the built-in sensor): ParameterError naming what and the value."""
    bad = Payload(MASS, COG, np.diag([0.01, 0.01, 0.05]))
    with pytest.raises(ParameterError, match=r"A \+ B >= C.*0\.05"):
        _plant(ur10(payload=bad))
    with pytest.raises(ParameterError, match="task 'pose' or 'position'.*'planar'"):
        _plant(ur10(task="planar", payload=Payload(MASS, COG)))
