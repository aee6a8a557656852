"""A recorded wrench brought to the library's convention (base axes, moment about the end-effector), and a model's
joint names: what :func:`~forcecontrol.realarm.replay.replay` and :func:`~forcecontrol.realarm.traces.compare_traces`
share."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import DimensionError, FrameError, ParameterError
from ..robots import PlanarTwoLink
from ..robots.base import RobotModel
from ..spatial import Transform
from .io import RecordedRun

__all__ = ["end_effector_rotation", "wrench_to_base", "recorded_wrench_in_base", "model_joint_names"]

def model_joint_names(robot: Any) -> tuple[str, ...] | None:
    """The names of a URDF/Pinocchio robot's joints in its order (what a log's joint columns are matched to), or None
    for a robot without named joints (the chapter's planar arm)."""
    m = getattr(robot, "model", None)
    if m is None or not hasattr(m, "names") or not hasattr(m, "joints"):
        return None
    names = tuple(str(m.names[i]) for i in range(1, int(m.njoints)) if int(m.joints[i].nq) > 0)
    return names if len(names) == int(robot.nq) else None

def end_effector_rotation(robot: RobotModel, q: Any) -> np.ndarray:
    """The end-effector frame's rotation R_e (3, 3) in the base frame at joint positions q.

    Spatial robots (:class:`~forcecontrol.robots.pinocchio.PinocchioRobot`) give it by their
    forward kinematics (``frame_pose``); for the planar arm (:class:`~forcecontrol.robots.PlanarTwoLink`)
    it is the rotation about z by ``q1 + q2``.

    Raises:
        FrameError: the robot model has no end-effector orientation.
    """
    if hasattr(robot, "frame_pose"):
        return np.asarray(robot.frame_pose(q)[0], dtype=np.float64)
    if isinstance(robot, PlanarTwoLink):
        phi = float(np.sum(np.asarray(q, dtype=np.float64)))
        c, s = np.cos(phi), np.sin(phi)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    raise FrameError(
        f"{type(robot).__name__} has no end-effector orientation (no frame_pose); convert the wrench into the base frame first"
    )

def wrench_to_base(robot: RobotModel, q: Any, wrench: Any, *, sensor_pose: Transform | None = None) -> np.ndarray:
    """Wrenches recorded in the end-effector (or a sensor) frame, re-expressed in the base frame, per sample.

    For each sample k, with R_e = R_e(q_k) (:func:`end_effector_rotation`): without a sensor pose
    ``f = R_e f_e``, ``μ = R_e μ_e``; with a sensor at ``(R_es, p_es)`` in the end-effector frame,
    ``R = R_e R_es``, ``f = R f_s``, and the moment moves to the end-effector origin,
    ``μ = R μ_s − r × f`` with ``r = −R_e p_es`` (from the sensor origin to the end-effector's).
    The sense is kept.

    Args:
        robot: the robot model; q: joint positions (N, n) [rad].
        wrench: (N, m) [N, N m]: ``fx fy`` (m = 2, planar: the z component is taken as 0),
            ``fx fy fz`` (3) or ``[f; μ]`` (6).
        sensor_pose: the sensor frame's pose in the end-effector frame, or None.

    Returns:
        (N, m) the wrenches in the base frame, the moments about the end-effector origin.

    Raises:
        DimensionError: q and wrench have different numbers of rows, or m is not 2, 3 or 6.
        FrameError: the robot has no orientation, or a sensor offset with a wrench that has no moment.
    """
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    h = np.atleast_2d(np.asarray(wrench, dtype=np.float64))
    if h.shape[0] != q.shape[0]:
        raise DimensionError(f"wrench must have one row per joint sample ({q.shape[0]}); got shape {h.shape}")
    m = h.shape[1]
    if m not in (2, 3, 6):
        raise DimensionError(f"wrench must have 2 (fx fy), 3 (fx fy fz) or 6 (f; μ) components; got {m}")
    R_es = np.eye(3) if sensor_pose is None else sensor_pose.rotation
    p_es = np.zeros(3) if sensor_pose is None else sensor_pose.translation
    if m < 6 and np.any(p_es != 0.0):
        raise FrameError(
            f"a sensor offset {p_es.tolist()} moves the moment, but the wrench has {m} components and no moment: "
            "record all 6 components, or give a sensor_pose with zero translation"
        )
    out = np.empty_like(h)
    for k in range(h.shape[0]):
        R_e = end_effector_rotation(robot, q[k])
        R = R_e @ R_es
        f = R @ np.concatenate([h[k, :3], np.zeros(3 - min(m, 3))])
        if m == 6:
            r = -(R_e @ p_es)
            out[k] = np.concatenate([f, R @ h[k, 3:] - np.cross(r, f)])
        else:
            out[k] = f[:m]
    return out

def _check_wrench_frame(
    recorded: RecordedRun, robot: RobotModel, base_frame: str, end_effector_frame: str, sensor_pose: Transform | None
) -> None:
    """The log's wrench frame is the end-effector's (any name the robot has for it) or the sensor's, else FrameError."""
    ee_names = {end_effector_frame} | ({robot.frame} if isinstance(getattr(robot, "frame", None), str) else set())
    frame, point = recorded.wrench_frame, recorded.wrench_point
    if sensor_pose is not None:
        if not isinstance(sensor_pose, Transform):
            raise ParameterError(f"sensor_pose must be a forcecontrol Transform; got {type(sensor_pose).__name__}")
        if sensor_pose.parent not in ee_names or sensor_pose.child != frame:
            raise FrameError(
                f"sensor_pose must be the pose of the log's wrench frame {frame!r} in the end-effector frame "
                f"{end_effector_frame!r}; got {sensor_pose.parent}<-{sensor_pose.child}"
            )
        if point != frame:
            raise FrameError(f"a sensor-frame wrench must be about the sensor's origin {frame!r}; the log's is about {point!r}")
        return
    if frame not in ee_names:
        raise FrameError(
            f"the controller needs the wrench in the base frame {base_frame!r}; the log's is in {frame!r}, which is not the "
            f"end-effector frame either ({', '.join(sorted(map(repr, ee_names)))}): pass sensor_pose= for a sensor frame, "
            "base_frame=/end_effector_frame= if it is one of those under another name, or convert it first "
            "(forcecontrol.realarm.conventions, forcecontrol convert)"
        )
    if recorded.m == 6 and point not in ee_names:
        raise FrameError(
            f"the log's 6-D wrench is in the end-effector frame but about {point!r}, not the end-effector origin: "
            "give sensor_pose= (its translation places that point) or move the moment first"
        )

def _check_wrench_convention(recorded: RecordedRun, model: Any, base_frame: str, end_effector_frame: str,
                             sensor_pose: Transform | None) -> None:
    """FrameError unless :func:`recorded_wrench_in_base` can bring the log's wrench to the base frame."""
    if recorded.wrench is None:
        return
    if recorded.wrench_frame != base_frame:
        _check_wrench_frame(recorded, model, base_frame, end_effector_frame, sensor_pose)
    elif recorded.m == 6 and recorded.wrench_point == base_frame and not hasattr(model, "frame_pose"):
        raise FrameError(f"the log's 6-D wrench is about the base origin {base_frame!r}; moving it to the end-effector "
                         f"needs the robot's forward kinematics, which a {type(model).__name__} does not give")

def recorded_wrench_in_base(recorded: RecordedRun, robot: Any, base_frame: str = "base",
                            end_effector_frame: str = "end-effector", sensor_pose: Transform | None = None) -> np.ndarray:
    """The log's wrench (its sense kept) in the library's convention: base axes, moment about the end-effector.

    In the end-effector or a sensor frame: rotated (and moved) per sample by :func:`wrench_to_base`; in the base frame
    about the base origin (a ROS ``WrenchStamped`` in the base frame, 6-D): ``μ_e = μ_o − p_e × f`` with the forward
    kinematics at the recorded q; in the base frame about the end-effector: as it is.

    Raises:
        FrameError: a frame or point it cannot convert from (named), or no wrench.
    """
    if recorded.wrench is None:
        raise FrameError(f"{recorded.source}: the log has no wrench")
    if recorded.t_wrench is not None:
        raise ParameterError(f"{recorded.source}: the wrench has its own times; resample the log first (one q per wrench)")
    _check_wrench_convention(recorded, robot, base_frame, end_effector_frame, sensor_pose)
    if recorded.wrench_frame != base_frame:
        return wrench_to_base(robot, recorded.q, recorded.wrench, sensor_pose=sensor_pose)
    h = np.array(recorded.wrench, dtype=np.float64)
    if recorded.m == 6 and recorded.wrench_point == base_frame:
        p_e = np.array([robot.frame_pose(qk)[1] for qk in recorded.q])
        h[:, 3:] -= np.cross(p_e, h[:, :3])  # μ_e = μ_o − p_e × f
    return h
