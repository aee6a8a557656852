"""The compiled serial-chain dynamics (robots/compiled_tree.py) against Pinocchio, on random states."""

from __future__ import annotations

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

from forcecontrol.errors import ForceControlError, ParameterError  # noqa: E402
from forcecontrol.robots.compiled_tree import chol_solve, compile_tree, tree_support  # noqa: E402
from forcecontrol.robots.pinocchio import Payload, PinocchioRobot, chapter_arm, panda, ur5, ur10  # noqa: E402

TOL = 1e-10


def _compare(robot, rng, n_states=25, scale=3.0):
    tree = compile_tree(robot)
    worst = 0.0
    for _ in range(n_states):
        q = rng.uniform(-scale, scale, robot.nq)
        qd = rng.uniform(-2.0, 2.0, robot.nq)
        R, o, J, Jdq, B, nv, _g = robot.spatial_terms(q, qd)
        got = tree.spatial_terms(q, qd)
        for ref, val in zip((R, o, J, Jdq, B, nv), got):
            worst = max(worst, float(np.max(np.abs(ref - val)) / max(1.0, float(np.max(np.abs(ref))))))
    return worst


@pytest.mark.parametrize("make", [panda, ur5, lambda: chapter_arm("pose"),
                                  lambda: ur10(payload=Payload(3.0, (0.01, 0.02, 0.05), np.diag([0.01, 0.02, 0.03])))],
                         ids=["panda", "ur5", "chapter_arm", "ur10_payload"])
def test_terms_match_pinocchio(make):
    """R_e, o_e, J, J̇q̇, B (armature, rotor coupling, payload) and n + F q̇ equal Pinocchio's to 1e-10 (relative)."""
    assert _compare(make(), np.random.default_rng(7)) < TOL


def _custom_model():
    """A 5-joint chain with every supported joint type (aligned and unaligned revolute/prismatic)."""
    model = pin.Model()
    rng = np.random.default_rng(3)
    ax = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    joints = [pin.JointModelRX(), pin.JointModelPY(), pin.JointModelRevoluteUnaligned(ax),
              pin.JointModelPrismaticUnaligned(np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)), pin.JointModelRZ()]
    parent = 0
    for k, jm in enumerate(joints):
        placement = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-1, 1, 3)), rng.uniform(-0.3, 0.3, 3))
        parent = model.addJoint(parent, jm, placement, f"j{k}")
        A = rng.uniform(-0.1, 0.1, (3, 3))
        model.appendBodyToJoint(parent, pin.Inertia(rng.uniform(0.5, 3.0), rng.uniform(-0.2, 0.2, 3), A @ A.T + 0.05 * np.eye(3)),
                                pin.SE3.Identity())
    model.addFrame(pin.Frame("tool", parent, 0, pin.SE3(pin.rpy.rpyToMatrix(0.2, 0.1, -0.4), np.array([0.05, 0.0, 0.1])),
                             pin.FrameType.OP_FRAME))
    model.armature = rng.uniform(0.0, 0.5, 5)
    return model


def test_all_joint_types_match_pinocchio():
    """Aligned/unaligned revolute and prismatic joints, friction and a rotor coupling: equal to Pinocchio to 1e-10."""
    model = _custom_model()
    F = np.diag([0.1, 0.2, 0.3, 0.4, 0.5])
    Rc = np.zeros((5, 5))
    Rc[0, 2] = Rc[2, 0] = 0.05
    robot = PinocchioRobot(model, "tool", friction=F, rotor_coupling=Rc, gravity=[0.3, -9.0, 1.0])
    assert _compare(robot, np.random.default_rng(11)) < TOL


def test_frame_on_an_inner_joint():
    """A controlled frame on joint 3 of 5: the columns of the later joints are zero, as Pinocchio's."""
    model = _custom_model()
    model.addFrame(pin.Frame("mid", 3, 0, pin.SE3(np.eye(3), np.array([0.0, 0.1, 0.0])), pin.FrameType.OP_FRAME))
    robot = PinocchioRobot(model, "mid")
    assert _compare(robot, np.random.default_rng(5)) < TOL


def test_unsupported_tree_is_refused_with_the_reason():
    """A branching model is refused with a library error naming the joint; tree_support says why."""
    model = pin.Model()
    a = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "a")
    model.appendBodyToJoint(a, pin.Inertia.Random(), pin.SE3.Identity())
    b = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "b")
    model.appendBodyToJoint(b, pin.Inertia.Random(), pin.SE3.Identity())
    model.addFrame(pin.Frame("tip", b, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    robot = PinocchioRobot(model, "tip")
    assert "not a serial chain" in tree_support(robot)
    with pytest.raises(ParameterError, match="serial revolute/prismatic chain.*'b'") as exc:
        compile_tree(robot)
    assert isinstance(exc.value, ForceControlError) and isinstance(exc.value, ValueError)


def test_cholesky_solve_matches_numpy():
    """The compiled Cholesky solve equals numpy.linalg.solve on SPD matrices and reports a non-SPD one."""
    rng = np.random.default_rng(2)
    for n in (1, 2, 6, 7):
        A = rng.normal(size=(n, n))
        A = A @ A.T + n * np.eye(n)
        b = rng.normal(size=n)
        out = np.empty(n)
        assert chol_solve(A, b, np.empty((n, n)), out)
        assert np.allclose(out, np.linalg.solve(A, b), rtol=1e-12, atol=1e-12)
    assert not chol_solve(-np.eye(3), np.ones(3), np.empty((3, 3)), np.empty(3))
