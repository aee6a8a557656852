"""Conventions: frame, point and sense of wrenches, and each vendor's documented convention."""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol.errors import FrameError, ParameterError
from forcecontrol.realarm.conventions import (
    BY_END_EFFECTOR,
    ON_END_EFFECTOR,
    SensedWrench,
    from_franka,
    from_mujoco,
    from_ur_force_mode,
    from_ur_tcp_force,
    pose_from_ros,
    pose_to_ros,
    ros_dict,
    ros_message,
    to_franka,
    to_mujoco,
    to_ur_force_mode,
    to_ur_tcp_force,
    twist_about,
    twist_from_ros,
    twist_rotated,
    twist_to_ros,
    wrench_from_ros,
    wrench_to_ros,
)
from forcecontrol.spatial import Transform, Twist

RZ90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
FLIP_X = np.diag([1.0, -1.0, -1.0])  # 180° about x: a tool frame pointing down


def test_sense_change_is_newtons_third_law():
    """The wrench on the end-effector is minus the wrench by it; converting twice gives the original."""
    w = SensedWrench.from_vector([1, 2, 3, 4, 5, 6], frame="base", sense=ON_END_EFFECTOR)
    np.testing.assert_array_equal(w.in_sense(BY_END_EFFECTOR).vector, -np.arange(1, 7))
    np.testing.assert_array_equal(w.in_sense(BY_END_EFFECTOR).in_sense(ON_END_EFFECTOR).vector, w.vector)
    np.testing.assert_array_equal(w.h_e("base", "base"), -np.arange(1, 7))


def test_moment_transport_matches_a_hand_computed_lever():
    """10 N along −z at a point 0.2 m along +x of the old point: about the old point μ = r × f = (0, 2, 0)."""
    # a pure force applied at the new point P (μ_P = 0); about O, r_OP = (0.2, 0, 0): μ_O = r_OP × f
    at_p = SensedWrench.from_vector([0, 0, -10, 0, 0, 0], frame="base", point="P", sense=BY_END_EFFECTOR)
    at_o = at_p.about("O", [-0.2, 0.0, 0.0])  # r from P to O
    np.testing.assert_allclose(at_o.vector, [0, 0, -10, 0, 2.0, 0], atol=1e-12)
    assert at_o.point == "O" and at_o.about("P", [0.2, 0, 0]).vector.tolist() == at_p.vector.tolist()


def test_rotation_and_transform_keep_power_invariant():
    """hᵀv is the same in two frames (the transformations of wrench and twist are dual)."""
    X = Transform(RZ90, [0.3, -0.1, 0.5], parent="base", child="tool")
    w = SensedWrench.from_vector([1.0, -2.0, 3.0, 0.1, 0.2, -0.3], frame="tool", sense=BY_END_EFFECTOR)
    v = Twist([0.2, 0.1, -0.4], [0.5, -0.2, 0.3], "tool", "tool")
    p_tool = v.power(w.wrench)
    p_base = v.transformed(X).power(w.transformed(X).wrench)
    assert abs(p_tool - p_base) < 1e-12
    # rotation only keeps the point; twist helpers follow the same rules
    assert w.rotated(X).point == "tool" and w.rotated(X).frame == "base"
    tw = twist_rotated(v, X)
    np.testing.assert_allclose(tw.linear, RZ90 @ v.linear)
    moved = twist_about(v, "p", [1.0, 0.0, 0.0])
    np.testing.assert_allclose(moved.linear, v.linear + np.cross(v.angular, [1.0, 0.0, 0.0]))


def test_ros_wrench_stamped_round_trip():
    """A WrenchStamped dict: force then torque, expressed in header.frame_id about its origin, stamp {sec, nanosec}.

    Layout: https://docs.ros2.org/latest/api/geometry_msgs/msg/WrenchStamped.html
    """
    msg = {"header": {"stamp": {"sec": 12, "nanosec": 500_000_000}, "frame_id": "ft_sensor"},
           "wrench": {"force": {"x": 1.0, "y": 2.0, "z": 3.0}, "torque": {"x": 0.1, "y": 0.2, "z": 0.3}}}
    w = wrench_from_ros(msg, sense=ON_END_EFFECTOR)
    assert (w.frame, w.point, w.sense, w.stamp) == ("ft_sensor", "ft_sensor", ON_END_EFFECTOR, 12.5)
    np.testing.assert_array_equal(w.vector, [1, 2, 3, 0.1, 0.2, 0.3])
    assert wrench_to_ros(w) == msg
    assert wrench_to_ros(w, sense=BY_END_EFFECTOR)["wrench"]["force"] == {"x": -1.0, "y": -2.0, "z": -3.0}
    with pytest.raises(FrameError, match="about the origin of header.frame_id"):
        wrench_to_ros(w.about("tip", [0, 0, 0.1]))
    with pytest.raises(ParameterError, match=r"missing field 'wrench\.torque\.x' \(no 'torque'"):
        wrench_from_ros({"header": msg["header"], "wrench": {"force": msg["wrench"]["force"]}}, sense=ON_END_EFFECTOR)
    with pytest.raises(ParameterError, match="sense must be"):
        wrench_from_ros(msg, sense="measured")


def test_ros_pose_quaternion_is_x_y_z_w():
    """PoseStamped orientation (x, y, z, w) = (0, 0, sin 45°, cos 45°) is +90° about z: it maps x to y.

    geometry_msgs/Quaternion is x, y, z, w: https://docs.ros2.org/latest/api/geometry_msgs/msg/Quaternion.html
    """
    s = math.sin(math.pi / 4)
    msg = {"header": {"stamp": {"sec": 1, "nanosec": 0}, "frame_id": "base"},
           "pose": {"position": {"x": 0.5, "y": 0.0, "z": 0.2}, "orientation": {"x": 0.0, "y": 0.0, "z": s, "w": s}}}
    X, t = pose_from_ros(msg, child="tool")
    np.testing.assert_allclose(X.rotation @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-12)
    assert (X.parent, X.child, t) == ("base", "tool", 1.0)
    back = pose_to_ros(X, stamp=1.0)
    assert back["pose"]["orientation"] == pytest.approx(msg["pose"]["orientation"])
    bad = {**msg, "pose": {**msg["pose"], "orientation": {"x": 0.0, "y": 0.0, "z": 1.0, "w": 1.0}}}
    with pytest.raises(ParameterError, match="unit quaternion"):
        pose_from_ros(bad, child="tool")


def test_ros_twist_stamped_round_trip_and_point_check():
    """TwistStamped: linear then angular, in header.frame_id at its origin."""
    tw = Twist([0.1, 0.0, 0.0], [0.0, 0.0, 1.0], "base", "base")
    d = twist_to_ros(tw, stamp=2.0)
    back, t = twist_from_ros(d)
    assert t == 2.0 and back.vector.tolist() == tw.vector.tolist()
    with pytest.raises(FrameError, match="twist_about"):
        twist_to_ros(twist_about(tw, "tip", [1, 0, 0]))


def test_rosbags_message_objects_round_trip_through_cdr():
    """The dict layout builds the rosbags WrenchStamped type, which serialises (CDR) and reads back equal."""
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    w = SensedWrench.from_vector([1, 2, 3, 4, 5, 6], frame="tool0", sense=ON_END_EFFECTOR, stamp=3.25)
    msg = ros_message(wrench_to_ros(w), "geometry_msgs/msg/WrenchStamped", ts)
    raw = ts.serialize_cdr(msg, "geometry_msgs/msg/WrenchStamped")
    again = ts.deserialize_cdr(bytes(raw), "geometry_msgs/msg/WrenchStamped")
    got = wrench_from_ros(again, sense=ON_END_EFFECTOR)
    assert got.vector.tolist() == w.vector.tolist() and got.stamp == 3.25 and got.frame == "tool0"
    assert ros_dict(again) == wrench_to_ros(w)
    with pytest.raises(ParameterError, match="has no field"):
        ros_message({"header": {}, "wrench": {}, "extra": 1}, "geometry_msgs/msg/WrenchStamped", ts)


def test_franka_external_wrench_is_the_wrench_the_robot_applies():
    """libfranka: O_F_ext_hat_K is the "estimated external wrench (force, torque) acting on stiffness frame,
    expressed relative to the base frame. Forces applied by the robot to the environment are positive, while
    forces applied by the environment on the robot are negative" (libfranka robot_state.h, 0.8.0 to 0.15.0).

    Worked example: the end-effector presses down on a table with 10 N: the robot applies (0, 0, −10), so
    O_F_ext_hat_K = (0, 0, −10, 0, 0, 0) = the chapter's h_e. With the K frame pointing down
    (R = diag(1, −1, −1)), K_F_ext_hat_K = Rᵀ O_F = (0, 0, +10, ...), and rotating it back to the base gives
    the same h_e (the relation of libfranka issue #112). sense= overrides it for an arm found to differ.
    """
    O_F = [0.0, 0.0, -10.0, 0.0, 0.0, 0.0]
    w = from_franka(O_F)
    assert (w.frame, w.point, w.sense) == ("panda_link0", "panda_K", BY_END_EFFECTOR)
    np.testing.assert_array_equal(w.h_e("panda_link0", "panda_K"), [0, 0, -10, 0, 0, 0])
    K_F = np.concatenate([FLIP_X.T @ O_F[:3], FLIP_X.T @ O_F[3:]])
    wk = from_franka(K_F, expressed_in="stiffness")
    X = Transform(FLIP_X, [0.3, 0.0, 0.4], parent="panda_link0", child="panda_K")
    np.testing.assert_allclose(wk.rotated(X).h_e("panda_link0", "panda_K"), [0, 0, -10, 0, 0, 0], atol=1e-12)
    np.testing.assert_array_equal(to_franka(w.in_sense(ON_END_EFFECTOR)), O_F)
    np.testing.assert_array_equal(from_franka(O_F, sense=ON_END_EFFECTOR).h_e("panda_link0", "panda_K"), [0, 0, 10, 0, 0, 0])
    with pytest.raises(ParameterError, match="expressed_in must be"):
        from_franka(O_F, expressed_in="flange")


def test_ur_actual_tcp_force_base_axes_flange_point_external_sense():
    """UR RTDE actual_TCP_force: "Generalized forces in the TCP", base axes, about the flange on e-Series
    (https://docs.universal-robots.com/tutorials/communication-protocol-tutorials/rtde-guide.html ;
    Universal_Robots_ROS2_Driver PR #1615: "ft is provided by RTDE as a wrench at flange oriented in the base frame").

    Worked example: a tool 0.1 m long below the flange (TCP 0.1 m along base −z) is pushed sideways
    by +5 N along base x at the TCP. About the flange the reading is f = (5, 0, 0), μ = r × f with
    r = (0, 0, −0.1): μ = (0, −0.5, 0). The chapter's h_e about the TCP is (−5, 0, 0, 0, 0, 0).
    """
    reading = [5.0, 0.0, 0.0, 0.0, -0.5, 0.0]
    w = from_ur_tcp_force(reading)
    assert (w.frame, w.point, w.sense) == ("base", "flange", ON_END_EFFECTOR)
    at_tcp = w.about("tcp", [0.0, 0.0, -0.1])
    np.testing.assert_allclose(at_tcp.h_e("base", "tcp"), [-5, 0, 0, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(to_ur_tcp_force(at_tcp.about("flange", [0, 0, 0.1])), reading, atol=1e-12)
    with pytest.raises(FrameError, match="expressed in 'base'"):
        to_ur_tcp_force(SensedWrench.from_vector(reading, frame="tool0", sense=ON_END_EFFECTOR))


def test_ur_force_mode_wrench_is_what_the_robot_applies():
    """ur_msgs/SetForceMode: "The forces/torques the robot will apply to its environment", in the task frame
    (https://docs.ros.org/en/jazzy/p/ur_msgs/srv/SetForceMode.html): the chapter's sense, no sign change.

    Worked example: pressing 20 N down along a task frame whose z points down: wrench (0, 0, 20, 0, 0, 0).
    """
    desired = SensedWrench.from_vector([0, 0, 20, 0, 0, 0], frame="task", sense=BY_END_EFFECTOR)
    np.testing.assert_array_equal(to_ur_force_mode(desired), [0, 0, 20, 0, 0, 0])
    measured_style = desired.in_sense(ON_END_EFFECTOR)  # the same wrench from the environment's side
    np.testing.assert_array_equal(to_ur_force_mode(measured_style), [0, 0, 20, 0, 0, 0])
    assert from_ur_force_mode([0, 0, 20, 0, 0, 0]).sense == BY_END_EFFECTOR
    with pytest.raises(FrameError, match="frame 'task'"):
        to_ur_force_mode(SensedWrench.from_vector([0] * 6, frame="base", sense=BY_END_EFFECTOR))


def test_mujoco_force_torque_sensor_reads_the_parent_on_the_child():
    """MuJoCo's force sensor: "the interaction force between a child and a parent body, expressed in the site
    frame ... the site is attached to the child body, and the force points from the child towards the parent"
    (https://mujoco.readthedocs.io/en/stable/XMLreference.html#sensor-force).

    Worked example run in MuJoCo itself: a weightless tool welded to the wrist, site rotated 90° about z,
    pushed by the environment with f_env = (1, 2, 3) N and μ_env = (0.1, 0.2, 0.3) N m at the site. At
    rest the arm holds it with −(f_env, μ_env), which the sensor reports in the site axes; from_mujoco
    turns it into h_e = −(f_env, μ_env) in the world: what the tool exerts on the environment.
    """
    mujoco = pytest.importorskip("mujoco")
    xml = """<mujoco><option gravity="0 0 0"/><worldbody>
      <body name="wrist" pos="0 0 1"><body name="tool" pos="0 0 -0.1" euler="0 0 90">
        <geom type="sphere" size="0.01" mass="1e-9"/><site name="ft" pos="0 0 0"/></body></body></worldbody>
      <sensor><force site="ft"/><torque site="ft"/></sensor></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    f_env, mu_env = np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.2, 0.3])
    d.xfrc_applied[m.body("tool").id] = np.concatenate([f_env, mu_env])  # world frame, at the body's centre of mass
    mujoco.mj_forward(m, d)
    w = from_mujoco(d.sensordata[:3], d.sensordata[3:], site="ft")
    X = Transform(d.site("ft").xmat.reshape(3, 3), d.site("ft").xpos, parent="world", child="ft")
    np.testing.assert_allclose(w.rotated(X).h_e("world", "ft"), -np.concatenate([f_env, mu_env]), atol=1e-6)
    f, mu = to_mujoco(w, site="ft")
    np.testing.assert_allclose(np.concatenate([f, mu]), d.sensordata[:6], atol=1e-12)


def test_convention_errors_name_what_is_wrong():
    """Each refused conversion says which frame, point or sense was expected and what was given."""
    from forcecontrol.realarm.conventions.ros import seconds_to_stamp
    from forcecontrol.spatial import Wrench

    w = SensedWrench.from_vector([1, 2, 3, 4, 5, 6], frame="base", point="flange", sense=ON_END_EFFECTOR)
    with pytest.raises(FrameError, match="libfranka's external wrench is about 'panda_K'; got one about 'flange'"):
        to_franka(w)
    with pytest.raises(FrameError, match="frame 'site' about 'site'"):
        to_mujoco(w)
    with pytest.raises(FrameError, match="must have sense 'by-end-effector'; got 'on-end-effector'"):
        w.require("base", "flange", BY_END_EFFECTOR)
    assert w.require("base", "flange", ON_END_EFFECTOR).tolist() == [1, 2, 3, 4, 5, 6]
    with pytest.raises(ParameterError, match="wrench must be a forcecontrol Wrench; got list"):
        SensedWrench([1, 2, 3], BY_END_EFFECTOR)
    with pytest.raises(ParameterError, match="stamp must be finite"):
        SensedWrench(Wrench([0, 0, 0], [0, 0, 0]), BY_END_EFFECTOR, stamp=float("nan"))
    with pytest.raises(ParameterError, match="stamp must be finite"):
        seconds_to_stamp(float("inf"))
    assert seconds_to_stamp(1.25) == {"sec": 1, "nanosec": 250_000_000}
    X = Transform(RZ90, [0, 0, 0], parent="base", child="tool")
    with pytest.raises(FrameError, match="needs a twist in 'tool'; got 'base'"):
        twist_rotated(Twist([0, 0, 0], [0, 0, 0], "base", "base"), X)
    bad_frame = {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
                 "wrench": {"force": {"x": 0, "y": 0, "z": 0}, "torque": {"x": 0, "y": 0, "z": 0}}}
    with pytest.raises(FrameError, match="header.frame_id must name the frame"):
        wrench_from_ros(bad_frame, sense=BY_END_EFFECTOR)
    with pytest.raises(FrameError, match="TwistStamped header.frame_id must name a frame"):
        twist_from_ros({"header": bad_frame["header"], "twist": {"linear": {"x": 0, "y": 0, "z": 0},
                                                                  "angular": {"x": 0, "y": 0, "z": 0}}})
    with pytest.raises(ParameterError, match="unknown ROS message type 'geometry_msgs/msg/Nope'"):
        ros_message({}, "geometry_msgs/msg/Nope")
    with pytest.raises(ParameterError, match="geometry_msgs/msg/WrenchStamped needs field 'wrench'"):
        ros_message({"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "a"}}, "geometry_msgs/msg/WrenchStamped")
    with pytest.raises(ParameterError, match="a Wrench has no 'force'|missing field"):
        wrench_from_ros({"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "a"}, "wrench": 3}, sense=BY_END_EFFECTOR)
