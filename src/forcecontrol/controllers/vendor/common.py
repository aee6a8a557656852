"""What the vendor controllers share: checked per-axis parameters, poses and pose errors of a 6-D arm."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...core.validate import as_vector, check_gain_size
from ...errors import DimensionError, ParameterError
from ...spatial.closed_form import euler_xyz_to_rotation, rotation_vector

__all__ = ["AXES", "axis_vector", "require_pose_robot", "pose", "pose_error", "blockdiag"]

#: the six Cartesian axes in the projects' order (x, y, z, rx, ry, rz).
AXES = ("x", "y", "z", "rx", "ry", "rz")


def axis_vector(name: str, value: Any, *, low: float | None = None, strict_low: bool = False, unit: str = "") -> np.ndarray:
    """A number (all six axes) or six numbers (x, y, z, rx, ry, rz), finite, optionally bounded below.

    Raises:
        DimensionError: not one or six numbers; ParameterError: outside the range (the message
            names the axis, the bound and the value).
    """
    a = np.asarray(value, dtype=np.float64) if not isinstance(value, str) else None
    if a is None or a.ndim > 1 or (a.ndim == 1 and a.size != 6):
        raise DimensionError(f"{name} must be a number or six numbers (x, y, z, rx, ry, rz); got {value!r}")
    a = np.full(6, float(a)) if a.ndim == 0 else as_vector(name, a, 6).copy()
    if low is not None:
        for i, v in enumerate(a):
            if v < low or (strict_low and v == low):
                rel = ">" if strict_low else ">="
                raise ParameterError(f"{name} must be {rel} {low:g}{(' ' + unit) if unit else ''} on every axis; "
                                     f"got {v:g} on axis {AXES[i]}")
    check_gain_size(name, a, unit)  # gains, limits, wrenches: 1.7e308 is finite but means nothing
    return a


def require_pose_robot(who: str, robot: Any) -> None:
    """The vendor controllers work on a 6-D arm (task 'pose': frame_pose and spatial_jacobian)."""
    inner = getattr(robot, "robot", robot)
    if getattr(inner, "task", None) != "pose" or not hasattr(inner, "frame_pose") or not hasattr(inner, "spatial_jacobian"):
        raise ParameterError(
            f"{who} works on a 6-D arm (a Pinocchio robot with task='pose': UR5, UR10, Panda, URDF); "
            f"got {type(inner).__name__} with task {getattr(inner, 'task', None)!r}"
        )


def pose(robot: Any, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R (3, 3), p (3,), J (6, n)) of the robot's controlled frame at q, base frame."""
    R, p = robot.frame_pose(q)
    return np.asarray(R), np.asarray(p), np.ascontiguousarray(robot.spatial_jacobian(q), dtype=np.float64)


def target_pose(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) of a task-space reference ``[o; φ]`` (XYZ angles, the library's pose task)."""
    return euler_xyz_to_rotation(np.asarray(x[3:6], dtype=np.float64)), np.asarray(x[:3], dtype=np.float64)


def pose_error(R_a: np.ndarray, p_a: np.ndarray, R_b: np.ndarray, p_b: np.ndarray) -> np.ndarray:
    """``[p_a − p_b; θ(R_a R_bᵀ)]`` (6,): the displacement of pose a from pose b (angle·axis), base frame."""
    return np.concatenate([p_a - p_b, rotation_vector(R_a @ R_b.T)])


def blockdiag(R: np.ndarray) -> np.ndarray:
    """``blockdiag(R, R)`` (6, 6)."""
    out = np.zeros((6, 6))
    out[:3, :3] = R
    out[3:, 3:] = R
    return out


def check_measurement(who: str, h: Any) -> np.ndarray:
    """The measured wrench h_e as a (6,) vector (the vendor controllers' arms are 6-D)."""
    w = np.asarray(h, dtype=np.float64)
    if w.shape != (6,):
        raise DimensionError(f"{who}: measurement.wrench must have shape (6,) (force and moment); got shape {w.shape}")
    return w
