"""A payload on the arm's last link (issue 30, FZI #177): the robot carries it; the sensor reads its inertial wrench."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from forcecontrol.errors import ForceControlError, ParameterError  # noqa: E402
from forcecontrol.robots.pinocchio import Payload, ur10  # noqa: E402

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


def test_mujoco_refuses_a_payload_it_would_drop():
    """MuJoCo rebuilds the arm from the URDF, which lacks the payload: refused by name rather than silently dropped."""
    from forcecontrol.engines.urdf import _robot_source

    with pytest.raises(ParameterError, match="payload"):
        _robot_source(ur10(payload=Payload(10.94, COM)))
    assert _robot_source(ur10())[1] == "tool0"
