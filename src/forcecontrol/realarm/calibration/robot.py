"""Calibration readings taken at joint positions: the sensor orientations from the robot's forward kinematics.

``calibrate-plan ROBOT N --out poses.csv`` writes joint positions ``q1 … qn``; a user drives the arm
to each, records the sensor (``fx fy fz [tx ty tz]``) and feeds the same table back:
``calibrate poses.csv --robot ROBOT``. The orientation of each reading is then ``R_S = R_e(q) R_es``,
with ``R_e(q)`` the controlled frame's orientation from the model's forward kinematics (the same
function the plan used, :func:`~forcecontrol.realarm.calibration.sensor_orientation`: Pinocchio's
``frame_pose`` for the Panda and the UR5, ``φ = q1 + q2`` for the chapter's planar arm) and
``R_es`` the sensor's fixed rotation on that frame (identity by default). Joint columns may also be
named as the arms record them: UR RTDE ``actual_q_0 …``, libfranka ``q_0 …``.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...core.files import MAX_TABLE_BYTES
from ...errors import DimensionError, MeasurementError, ParameterError
from .data import _MATRIX, _QUAT, calibration_data_from_columns, read_columns
from .plan import sensor_orientation

__all__ = ["CALIBRATION_ROBOTS", "calibration_robot", "rotations_from_joints", "calibration_data_from_joints",
           "read_joint_calibration_data"]

#: the robots ``calibrate --robot`` and ``calibrate-plan`` know
CALIBRATION_ROBOTS = ("chapter-arm", "panda", "ur5")


def calibration_robot(name: str) -> Any:
    """The robot model called ``name`` (:data:`CALIBRATION_ROBOTS`; Panda and UR5 need Pinocchio).

    Raises:
        ParameterError: an unknown name.
    """
    if name == "chapter-arm":
        from ...robots import CHAPTER_ARM

        return CHAPTER_ARM
    if name in ("panda", "ur5"):
        from ...robots import pinocchio as pm

        return pm.panda() if name == "panda" else pm.ur5()
    raise ParameterError(f"robot must be one of {list(CALIBRATION_ROBOTS)}; got {name!r}")


def rotations_from_joints(robot: Any, joint_positions: Any, *, sensor_rotation: Any = None) -> np.ndarray:
    """Sensor orientations ``R_e(q_i) R_es`` at joint positions (k, nq): (k, 3, 3), or (k, 2, 2) for a planar arm.

    Args:
        robot: a robot model (:func:`calibration_robot`).
        joint_positions: (k, nq) [rad].
        sensor_rotation: ``R_es``, the sensor frame's rotation in the controlled frame (d, d); identity by default.

    Raises:
        DimensionError: joint positions that are not (k, nq), a sensor rotation of the wrong size.
        MeasurementError: NaN or inf in the joint positions or the sensor rotation.
        ParameterError: a sensor rotation that is not a proper rotation matrix.
    """
    Q = np.asarray(joint_positions, dtype=np.float64)
    nq = int(robot.nq)
    if Q.ndim != 2 or Q.shape[1] != nq:
        raise DimensionError(f"joint_positions must have shape (k, {nq}) for this robot; got shape {Q.shape}")
    if not np.all(np.isfinite(Q)):
        raise MeasurementError(f"joint positions must be finite; row {int(np.argwhere(~np.isfinite(Q))[0, 0])} is not")
    orient = sensor_orientation(robot)
    R = np.array([np.asarray(orient(q), dtype=np.float64) for q in Q])
    if sensor_rotation is not None:
        Res = np.asarray(sensor_rotation, dtype=np.float64)
        if Res.shape != R.shape[1:]:
            raise DimensionError(f"sensor_rotation must be {R.shape[1:]} for this robot; got shape {Res.shape}")
        if not np.all(np.isfinite(Res)):
            raise MeasurementError(f"sensor_rotation must be finite; got {Res.tolist()}")
        err = float(np.abs(Res.T @ Res - np.eye(Res.shape[0])).max())
        if err > 1e-6 or np.linalg.det(Res) < 0.0:
            raise ParameterError(f"sensor_rotation must be a proper rotation matrix (RᵀR = I, det R = +1); got |RᵀR − I| = "
                                 f"{err:.3g} and det R = {np.linalg.det(Res):.6g}")
        R = R @ Res
    return R


def _joint_columns(cols: Mapping[str, Any], nq: int) -> tuple[list[str], str]:
    for names, layout in (([f"q{i + 1}" for i in range(nq)], "q1 … qn (calibrate-plan --out)"),
                          ([f"actual_q_{i}" for i in range(nq)], "actual_q_0 … (UR RTDE)"),
                          ([f"q_{i}" for i in range(nq)], "q_0 … (libfranka)")):
        if all(n in cols for n in names):
            return names, layout
    raise ParameterError(f"the robot has {nq} joints: give q1 … q{nq} (as calibrate-plan --out writes them), actual_q_0 … "
                         f"actual_q_{nq - 1} (UR RTDE) or q_0 … q_{nq - 1} (libfranka); the data has columns {sorted(cols)}")


def calibration_data_from_joints(
    columns: Mapping[str, Any], robot: Any, *, sensor_rotation: Any = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray, str]:
    """Rotations (from the joints), forces, moments, the joint positions and the joint layout read.

    Raises:
        ParameterError: missing joint columns, orientation columns as well (two orientations for
            one reading: give one), missing force columns.
    """
    cols = {str(k).strip(): v for k, v in columns.items()}
    lower = {k.lower() for k in cols}
    given = [n for n in (*_QUAT, *_MATRIX, "angle") if n in lower]
    if given:
        raise ParameterError(f"the data has orientation column(s) {given} and the robot's joint positions: give one of them "
                             "(drop the orientation columns to compute them from the joints, or calibrate without --robot)")
    names, layout = _joint_columns(cols, int(robot.nq))
    try:
        Q = np.column_stack([np.asarray(cols[n], dtype=np.float64) for n in names])
    except (TypeError, ValueError):
        raise ParameterError(f"joint columns {names[0]} … must hold numbers") from None
    R = rotations_from_joints(robot, Q, sensor_rotation=sensor_rotation)
    readings = {k: v for k, v in cols.items() if k not in names}
    if R.shape[1] == 2:
        readings["angle"] = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    else:
        for i in range(3):
            for j in range(3):
                readings[f"r{i + 1}{j + 1}"] = R[:, i, j]
    Rr, F, T = calibration_data_from_columns(readings)
    return Rr, F, T, Q, layout


def read_joint_calibration_data(
    path: str | Path, robot: Any, *, sensor_rotation: Any = None, max_bytes: int = MAX_TABLE_BYTES
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray, str]:
    """:func:`calibration_data_from_joints` of a CSV or Parquet file (the file named in errors)."""
    p = Path(path)
    columns = read_columns(p, "calibration data file", max_bytes)
    try:
        return calibration_data_from_joints(columns, robot, sensor_rotation=sensor_rotation)
    except (ParameterError, MeasurementError, DimensionError) as exc:
        raise type(exc)(f"{str(p)!r}: {exc}") from None
