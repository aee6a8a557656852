"""Force/torque sensor calibration as a workflow: plan the poses, identify, compensate, tare, watch for drift.

The model is :class:`~forcecontrol.sensors.ToolGravity`'s: a static reading in free space at
sensor orientation R_S (sensor frame S in the base frame), with ``u = R_Sᵀ g`` gravity in S,

    f_S = −u m + b_f
    τ_S = [u]× p + b_τ                 (3-D)        τ_S = u_x p_y − u_y p_x + b_τ      (planar)

with m the tool's mass, ``p = m c`` its first moment (c the centre of mass in S) and b_f, b_τ the
sensor's biases. Both equations are linear in their unknowns, so :func:`calibrate` solves two
ordinary least-squares problems (forces in (m, b_f), moments in (p, b_τ)) and reports each
parameter's standard uncertainty from the residual covariance ``σ² (AᵀA)⁻¹``, σ² estimated per
problem as ``RSS / (rows − unknowns)``; c = p / m and its uncertainty by first-order propagation.
:func:`~forcecontrol.sensors.identify_tool_gravity` gives the same estimates (same regressors,
tested), without the uncertainty and the checks.

How similar the poses are is read from the *normalised* regressor: the same matrices built
with the unit gravity direction ``û = R_Sᵀ g/|g|``, one block per problem. Its condition number
(largest over smallest singular value) is 1 for ideal force poses (Σ û_i = 0) and grows without
bound as the orientations approach each other; it does not depend on units nor on the number of
poses. :func:`plan_calibration_poses` picks joint configurations that keep it small.

Readings at joint positions (``calibrate-plan --out`` fed back): :func:`read_joint_calibration_data`
computes the sensor orientations through the robot's forward kinematics (:mod:`.robot`).

Whether the orientations are the sensor's: :func:`frame_check` (run by :func:`calibrate`) tests the
force model against any linear map of gravity, ``f = A u + b`` (an F-test of nested least squares),
and gives the turned sensor frame that fits best (the rotation nearest to ``−A/m``, orthogonal
Procrustes): a sensor mounted turned on the flange is found, with the ``sensor_rotation`` to
calibrate it with (:class:`~forcecontrol.errors.CalibrationMisfitWarning`).

On the arm: :meth:`CalibrationResult.compensate` turns a raw reading into the contact wrench in
any orientation, :func:`tare` re-estimates the biases from readings at one known pose (the
payload kept), and :class:`DriftDetector` compares free-space readings with the model online
and flags a bias change larger than the noise allows.
"""

from __future__ import annotations

from .core import MAX_CONDITION, MISFIT_P, CalibrationResult, FrameCheck, calibrate, frame_check, regressor_condition, tare
from .data import calibration_data_from_columns, read_calibration_data, read_columns
from .drift import DriftCheck, DriftDetector
from .plan import CalibrationPlan, plan_calibration_poses, sensor_orientation
from .robot import (
    CALIBRATION_ROBOTS,
    calibration_data_from_joints,
    calibration_robot,
    read_joint_calibration_data,
    rotations_from_joints,
)

__all__ = [
    "MAX_CONDITION",
    "MISFIT_P",
    "CalibrationPlan",
    "CalibrationResult",
    "DriftCheck",
    "DriftDetector",
    "calibrate",
    "FrameCheck",
    "frame_check",
    "plan_calibration_poses",
    "regressor_condition",
    "sensor_orientation",
    "tare",
    "calibration_data_from_columns",
    "read_calibration_data",
    "read_columns",
    "CALIBRATION_ROBOTS",
    "calibration_robot",
    "rotations_from_joints",
    "calibration_data_from_joints",
    "read_joint_calibration_data",
]
