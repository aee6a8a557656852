"""A payload on the arm's last link (issue 30, FZI #177): the robot carries it; the sensor reads its inertial wrench."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from forcecontrol.errors import ForceControlError, ParameterError  # noqa: E402
from forcecontrol.robots.pinocchio import Payload, ur10  # noqa: E402

CONFIGS = Path(str(resources.files("forcecontrol.scenarios"))) / "configs"
Q = np.array([0.3, -1.2, 1.4, -1.7, -1.3, 0.4])
COM = np.array([0.042, -0.223, 0.229])  # FZI #177's CoG in tool0
I_C = np.diag([0.05, 0.08, 0.03])


def _skew(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _com_jacobian(arm, q):
    R, _ = arm.frame_pose(q)
    J = arm.spatial_jacobian(q)
    r = R @ COM
    return J[:3] - _skew(r) @ J[3:], J[3:], R


def test_payload_adds_its_rigid_body_terms_in_closed_form():
    """B and g of the UR10 with a 10.94 kg payload minus those without equal m J_cᵀJ_c + J_ωᵀ R I Rᵀ J_ω and −m J_cᵀ g."""
    bare, loaded = ur10(), ur10(payload=Payload(10.94, COM, I_C))
    Jc, Jw, R = _com_jacobian(bare, Q)
    dB = 10.94 * Jc.T @ Jc + Jw.T @ R @ I_C @ R.T @ Jw
    np.testing.assert_allclose(loaded.mass_matrix(Q) - bare.mass_matrix(Q), dB, atol=1e-10)
    g = np.array([0.0, 0.0, -9.81])
    np.testing.assert_allclose(loaded.gravity(Q) - bare.gravity(Q), -10.94 * Jc.T @ g, atol=1e-9)
    assert loaded.describe()["payload"]["mass"] == 10.94 and "payload" not in bare.describe()


@pytest.mark.parametrize("kw, word", [
    (dict(mass=0.0), "mass"), (dict(mass=float("nan")), "mass"), (dict(mass=1.0, com=(0.0, 0.0)), "com"),
    (dict(mass=1.0, inertia=-np.eye(3)), "inertia"),
])
def test_payload_refuses_unphysical_values(kw, word):
    """A payload without positive mass, with a com of the wrong size or an indefinite inertia is refused by name."""
    with pytest.raises(ForceControlError, match=word):
        Payload(**kw)


def test_mujoco_carries_the_payload_it_used_to_refuse():
    """MuJoCo rebuilds the arm from the URDF, which lacks the payload: the plant adds it (not silently dropped): MuJoCo's
    total mass is the bare arm's plus 10.94 kg, its centre of mass at COM in tool0 (tests/test_payload_mujoco.py)."""
    pytest.importorskip("mujoco")
    from forcecontrol.engines.mujoco import MujocoPlant
    from forcecontrol.environments.spatial import Table

    bare, loaded = (MujocoPlant(a, Table([0.0, 0.0, -5.0])).model for a in (ur10(), ur10(payload=Payload(10.94, COM))))
    assert loaded.body_mass.sum() == pytest.approx(bare.body_mass.sum() + 10.94, rel=1e-12)
    np.testing.assert_allclose(loaded.body_ipos[loaded.body("payload").id], COM, atol=1e-12)


def test_payload_wrench_closed_form_of_a_spinning_point_mass():
    """2 kg at r = (0.3, 0, 0) spinning about z (ω = 3, α = 2 rad/s²): f = m(α×r + ω×(ω×r) − g), τ = r×f + Iα, by hand."""
    from forcecontrol.sensors import payload_wrench

    I = np.diag([0.01, 0.02, 0.05])
    w = payload_wrench(2.0, [0.3, 0, 0], I, [0, 0, 0], [0, 0, 3.0], [0, 0, 2.0], [0, 0, -9.81])
    np.testing.assert_allclose(w, [-5.4, 1.2, 19.62, 0.0, -5.886, 0.46], atol=1e-12)
    wc = payload_wrench(2.0, [0.3, 0, 0], I, [0, 0, 0], [0, 0, 3.0], [0, 0, 2.0], [0, 0, -9.81], gravity_compensated=True)
    np.testing.assert_allclose(wc, [-5.4, 1.2, 0.0, 0.0, 0.0, 0.46], atol=1e-12)


@pytest.mark.parametrize("compensated", [False, True])
def test_sensor_reads_the_wrench_that_rnea_needs_to_carry_the_payload(compensated):
    """On the UR10 moving with constant q̈ (backward differences exact), the sensor's reading w at every sample from the
    fourth equals the second implementation Jᵀ w = RNEA(loaded) − RNEA(bare) (weight removed when compensated)."""
    import pinocchio as pin

    from forcecontrol.sensors import PayloadForceSensor

    P = Payload(10.94, COM, I_C)
    bare, loaded = ur10(), ur10(payload=P)
    Ts, v, a = 0.0005, np.array([0.4, -0.3, 0.5, 0.8, -0.6, 1.0]), np.array([3.0, -2.0, 4.0, -5.0, 6.0, 8.0])
    s = PayloadForceSensor(loaded, gravity_compensated=compensated)
    s.start(20, 6, Ts, np.zeros(6), Q)
    for k in range(1, 12):
        t = k * Ts
        q, qd = Q + v * t + 0.5 * a * t * t, v + a * t
        got = s.measure(k, t, np.zeros(6), q)
        if k < 4:
            continue
        dtau = pin.rnea(loaded.model, loaded.data, q, qd, a) - pin.rnea(bare.model, bare.data, q, qd, a)
        if compensated:
            dtau -= loaded.gravity(q) - bare.gravity(q)
        ref = np.linalg.solve(loaded.spatial_jacobian(q).T, dtau)
        np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-6)
    assert not compensated or abs(ref[2]) < 0.5 * 10.94 * 9.81  # the weight (107 N) is not in it


def test_payload_sensor_adds_the_contact_wrench_and_refuses_a_bare_robot():
    """At rest the compensated reading is the contact wrench itself; a robot without a payload is refused by name."""
    from forcecontrol.sensors import PayloadForceSensor

    s = PayloadForceSensor(ur10(payload=Payload(10.94, COM)))
    h = np.array([1.0, -2.0, -10.0, 0.1, 0.2, 0.3])
    s.start(10, 6, 0.001, h, Q)
    for k in range(1, 6):
        np.testing.assert_allclose(s.measure(k, k * 0.001, h, Q), h, atol=1e-9)
    with pytest.raises(ParameterError, match="payload"):
        PayloadForceSensor(ur10())


@pytest.mark.parametrize("robot, word", [
    ({"model": "panda", "payload_mass": 5.0}, "payload_mass"),
    ({"model": "ur10", "payload_com": [0.0, 0.0, 0.1]}, "payload_com"),
    ({"model": "ur10", "payload_mass": -1.0}, "mass"),
    ({"model": "ur5", "payload_weight_in_reading": "true"}, "payload_weight_in_reading"),
])
def test_scenario_payload_keys_are_refused_where_they_would_be_ignored(tmp_path, robot, word):
    """[robot] payload_mass on a model without payload support (the UR5 and UR10 have it), payload_com alone, a
    negative mass, or payload_weight_in_reading without a payload: ScenarioError."""
    import tomllib

    from forcecontrol.errors import ScenarioError
    from forcecontrol.scenarios import run_scenario

    text = (CONFIGS / "fzi_issue_177.toml").read_text(encoding="utf-8")
    cfg = tomllib.loads(text)
    lines = [f"model = {robot['model']!r}".replace("'", '"'), "q0 = [0.0, -1.57, 1.57, -1.57, -1.57, 0.0]"]
    lines += [f"{k} = {v}" for k, v in robot.items() if k != "model"]
    head, tail = text.split("[robot]\n", 1)[0], text.split("[robot.servo]", 1)[1]
    body = head + "[robot]\n" + "\n".join(lines) + "\n\n[robot.servo]" + tail
    (tmp_path / "s.toml").write_text(body, encoding="utf-8")
    (tmp_path / cfg["controller"]["config"]).write_text((CONFIGS / cfg["controller"]["config"]).read_text(), encoding="utf-8")
    with pytest.raises(ScenarioError, match=word):
        run_scenario(tmp_path / "s.toml")
