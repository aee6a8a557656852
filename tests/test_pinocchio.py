"""Pinocchio robots: the chapter arm's URDF against the closed form, Panda/UR5 kinematics and dynamics checks."""

from __future__ import annotations

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

from forcecontrol.errors import DimensionError, ParameterError, ScenarioError  # noqa: E402
from forcecontrol.robots import CHAPTER_ARM  # noqa: E402
from forcecontrol.robots.base import RobotModel  # noqa: E402
from forcecontrol.robots.pinocchio import PinocchioRobot, chapter_arm, model_path, panda, ur5  # noqa: E402
from forcecontrol.spatial import euler_xyz_to_rotation, rotation_vector  # noqa: E402


@pytest.fixture(scope="module")
def arm():
    return chapter_arm()


@pytest.fixture(scope="module")
def franka():
    return panda()


def test_chapter_arm_urdf_matches_closed_form_on_random_states(arm):
    """The URDF arm (armature, rotor coupling, friction) gives the closed form's x, J, J̇q̇, B, n, g within 1e-9."""
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(200):
        q, qd = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-5, 5, 2)
        a, b = arm.terms(q, qd), CHAPTER_ARM.terms(q, qd)
        for name, x, y in zip(a._fields, a, b):
            err = float(np.max(np.abs(np.asarray(x) - np.asarray(y))))
            assert err < 1e-9, (name, err)
            worst = max(worst, err)
        assert np.max(np.abs(arm.mass_matrix(q) - CHAPTER_ARM.mass_matrix(q))) < 1e-9
        assert np.max(np.abs(arm.nonlinear_effects(q, qd) - CHAPTER_ARM.nonlinear_effects(q, qd))) < 1e-9
        assert np.max(np.abs(arm.gravity(q) - CHAPTER_ARM.gravity(q))) < 1e-9
        assert np.max(np.abs(arm.jacobian(q) - CHAPTER_ARM.jacobian(q))) < 1e-9


def test_chapter_arm_b12_needs_the_rotor_coupling():
    """Without the explicit k_r2 I_m2 coupling the URDF's b12 is short by exactly 1 kg m² (documented gap)."""
    bare = PinocchioRobot.from_urdf(model_path("chapter_arm"), "tip", task="planar", armature=[100, 100], gravity=[0, -9.81, 0])
    q = np.array([0.3, -1.1])
    d = CHAPTER_ARM.mass_matrix(q) - bare.mass_matrix(q)
    assert np.allclose(d, [[0, 1.0], [1.0, 0]], atol=1e-12)


def test_pinocchio_robot_implements_the_protocol(franka, arm):
    """Panda, UR5 and the URDF arm are RobotModels with the documented dimensions."""
    u = ur5()
    for r, n, m in ((franka, 7, 6), (u, 6, 6), (arm, 2, 2)):
        assert isinstance(r, RobotModel)
        assert (r.nq, r.task_dim) == (n, m)


def test_panda_jacobian_and_jdot_qdot_against_finite_differences(franka):
    """J's rows are d(o_e)/dq and the angular velocity of R_e; J̇q̇ equals the finite difference of J q̇."""
    rng = np.random.default_rng(2)
    q = np.array([0.1, -0.6, 0.2, -2.0, 0.3, 1.7, 0.5]) + rng.normal(0, 0.1, 7)
    qd = rng.normal(0, 1.0, 7)
    J = franka.spatial_jacobian(q)
    h = 1e-6
    R0, p0 = franka.frame_pose(q)
    for i in range(7):
        dq = np.zeros(7)
        dq[i] = h
        Rp, pp = franka.frame_pose(q + dq)
        Rm, pm = franka.frame_pose(q - dq)
        assert np.allclose((pp - pm) / (2 * h), J[:3, i], atol=1e-7)
        w = rotation_vector(Rp @ Rm.T) / (2 * h)
        assert np.allclose(w, J[3:, i], atol=1e-6)
    Jdq_fd = (franka.spatial_jacobian(q + h * qd) - franka.spatial_jacobian(q - h * qd)) @ qd / (2 * h)
    assert np.allclose(franka.spatial_jdot_qdot(q, qd), Jdq_fd, atol=1e-6)
    T = franka.terms(q, qd)
    assert np.allclose(T.J, J) and np.allclose(T.Jdq, franka.spatial_jdot_qdot(q, qd))
    assert np.allclose(euler_xyz_to_rotation(T.x[3:]), R0) and np.allclose(T.x[:3], p0)


def test_panda_mass_matrix_symmetric_positive_definite_and_terms_consistent(franka):
    """B is SPD; terms() agrees with the separate mass_matrix, nonlinear_effects and gravity calls."""
    rng = np.random.default_rng(3)
    for _ in range(10):
        q, qd = rng.uniform(-1.5, 1.5, 7), rng.normal(0, 1, 7)
        T = franka.terms(q, qd)
        assert np.allclose(T.B, T.B.T) and np.linalg.eigvalsh(T.B).min() > 0
        assert np.allclose(T.B, franka.mass_matrix(q))
        assert np.allclose(T.n, franka.nonlinear_effects(q, qd))
        assert np.allclose(T.g, franka.gravity(q))


def test_gravity_is_gradient_of_potential_energy(franka):
    """g(q) = ∂U/∂q, U from Pinocchio's potential energy, by central differences."""
    q = np.array([0.2, -0.5, 0.1, -1.8, 0.4, 1.5, 0.3])
    data = franka.model.createData()

    def U(q):
        return pin.computePotentialEnergy(franka.model, data, q)

    h = 1e-6
    fd = np.array([(U(q + h * e) - U(q - h * e)) / (2 * h) for e in np.eye(7)])
    assert np.allclose(franka.gravity(q), fd, atol=1e-5)


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"frame": "no_such_frame"}, ParameterError, "frame 'no_such_frame' is not in the model"),
        ({"frame": "tip", "task": "twist"}, ParameterError, "task must be one of"),
        ({"frame": "tip", "armature": [1.0]}, DimensionError, r"armature must have shape \(2,\)"),
        ({"frame": "tip", "rotor_coupling": [[0, 1], [2, 0]]}, ParameterError, "rotor_coupling must be a symmetric"),
    ],
)
def test_bad_model_inputs_are_clear_errors(kwargs, exc, match):
    """A URDF without the named frame, an unknown task, wrong armature size or asymmetric coupling raise clearly."""
    with pytest.raises(exc, match=match):
        PinocchioRobot.from_urdf(model_path("chapter_arm"), **kwargs)


def test_missing_urdf_and_unknown_locked_joint_are_errors(tmp_path):
    """A missing file and an unknown locked joint name raise ParameterError naming them."""
    with pytest.raises(ParameterError, match="does not exist"):
        PinocchioRobot.from_urdf(tmp_path / "none.urdf", "tip")
    with pytest.raises(ParameterError, match="locked joint 'elbow'"):
        PinocchioRobot.from_urdf(model_path("chapter_arm"), "tip", locked_joints=("elbow",))


AMBIGUOUS_URDF = """<robot name="r">
<link name="base"/>
<link name="tip"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="tip" type="revolute"><parent link="base"/><child link="tip"/><axis xyz="0 0 1"/>
<limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
</robot>"""


def test_a_frame_name_shared_by_a_link_and_a_joint_is_refused_unless_its_type_is_given(tmp_path):
    """A URDF link and joint both named 'tip': ParameterError naming both types (not Pinocchio's raw ValueError);
    frame_type='BODY' picks the link, in Python and in a scenario's [robot] table."""
    path = tmp_path / "ambiguous.urdf"
    path.write_text(AMBIGUOUS_URDF)
    with pytest.raises(ParameterError, match=r"frame 'tip' names 2 frames of the model \(types \['JOINT', 'BODY'\]\)"):
        PinocchioRobot.from_urdf(path, "tip", task="planar")
    robot = PinocchioRobot.from_urdf(path, "tip", task="planar", frame_type="BODY")
    assert str(robot.model.frames[robot.frame_id].type).endswith("BODY")
    with pytest.raises(ParameterError, match="frame_type must be one of"):
        PinocchioRobot.from_urdf(path, "tip", task="planar", frame_type="LINK")
    from forcecontrol.scenarios.parts_spatial import pinocchio_robot

    rt = {"model": "urdf", "urdf": str(path), "frame": "tip", "locked_joints": None, "frame_type": None}
    with pytest.raises(ScenarioError, match=r"\[robot\]: frame 'tip' names 2 frames"):
        pinocchio_robot("s.toml", rt)
    assert pinocchio_robot("s.toml", {**rt, "frame_type": "BODY"}).frame_id == robot.frame_id


def test_wrong_state_shape_is_dimension_error(franka):
    """q of the wrong length raises DimensionError."""
    with pytest.raises(DimensionError, match=r"q must have shape \(7,\)"):
        franka.mass_matrix(np.zeros(6))


def test_aba_contact_dynamics_equals_mass_matrix_solve(franka):
    """elastic_acceleration (ABA on u − F q̇ − Jᵀh) equals solve(B, u − n − Jᵀh) from computeAllTerms, in and out of contact."""
    from forcecontrol.environments.spatial import SpatialSpring

    rng = np.random.default_rng(7)
    spring = SpatialSpring(np.diag([3e3, 2e3, 1e4, 30.0, 20.0, 10.0]), [0.3, 0.0, 0.5], damping=np.eye(6) * 5.0)
    robots = [franka, PinocchioRobot(franka.model, franka.frame, task="pose",
                                     armature=rng.uniform(0.1, 1.0, 7), friction=rng.uniform(0, 2, 7))]
    for robot in robots:
        for _ in range(50):
            q = rng.uniform(-1.5, 1.5, 7)
            qd = rng.uniform(-2, 2, 7)
            u = rng.uniform(-20, 20, 7)
            T = robot.terms(q, qd)
            for wrench in (spring.wrench, lambda x, xd: np.zeros(6)):
                h = wrench(T.x, T.xd)
                want = np.linalg.solve(T.B, u - T.n - T.J.T @ h)
                got, h_got = robot.elastic_acceleration(q, qd, u, wrench)
                np.testing.assert_allclose(h_got, h, atol=1e-9 * max(1.0, np.abs(h).max()))
                np.testing.assert_allclose(got, want, atol=1e-8 * max(1.0, np.abs(want).max()))
            x, xd = robot.pose_twist(q, qd)
            np.testing.assert_allclose(x, T.x, atol=1e-12)
            np.testing.assert_allclose(xd, T.xd, atol=1e-12)
