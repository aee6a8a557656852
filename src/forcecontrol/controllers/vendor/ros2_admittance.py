"""ros2_controllers ``admittance_controller`` on a position-interface arm (issue 30, item 3)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...core.validate import nonnegative_scalar
from ...errors import ParameterError
from ...laws.vendor import gravity_compensate, ros2_admittance_rule
from ...laws.vendor.layout import ROS2_ADMITTANCE, ROS2_ADMITTANCE_STATE
from ...robots.ik import DifferentialIK, JointCommand
from ..base import Measurement, Reference
from ..position_interface import PositionInterfaceController
from .common import axis_vector, blockdiag, check_measurement, pose, pose_error, require_pose_robot

__all__ = ["Ros2AdmittanceController"]


class Ros2AdmittanceController(PositionInterfaceController):
    """The ``admittance_controller`` of ros2_controllers (commit 94e74de3), once per interface cycle.

    Law (:func:`forcecontrol.laws.vendor.ros2_admittance_rule`; survey of issue 30, §1), per axis
    of the control frame, on the *measured* displacement x of the sensor frame from the joint
    reference's pose::

        M ẍ + D ẋ + K x = S F,    D = damping_ratio · 2 sqrt(M K)
        q̈_a = (JᵀJ + α_k I)⁻¹ Jᵀ ẍ − joint_damping · q̇_a,   q_cmd = q_ref + q_a

    with the wrench ``F`` on the robot (``−h_e``), the payload's weight removed
    (``payload_weight`` = ``CoG.force`` at ``payload_cog`` = ``CoG.pos``) and the wrench reference
    (``reference.force``, the chapter's f_d, base frame) added, then filtered by the exponential
    smoothing α = ``filter_coefficient`` per cycle. The loop settles where ``h_e = f_d`` on the
    selected axes. (Upstream adds its ``~/wrench_reference`` to the raw reading in the
    ``ft_sensor`` frame: the same f_d is published there as ``R_sᵀ f_d``, and a constant message
    turns with the tool where ``reference.force`` stays in the base.) The joint reference q_ref
    follows ``reference.position`` (a pose ``[o; φ]``) through a damped-least-squares IK step per
    cycle (a trajectory controller in front).

    The sensor, control and payload frames are the robot's controlled frame (``"tool"``) or the
    base (``"base"``); the world frame is the base (gravity along −z).

    Args:
        robot: a :class:`~forcecontrol.robots.servo.PositionInterfaceRobot` on a 6-D arm.
        mass, damping_ratio, stiffness: per axis (x, y, z, rx, ry, rz) [kg, -, N/m; kg m², -, N m/rad].
        selected_axes: per axis, whether the wrench acts (bools).
        joint_damping: [1/s]; filter_coefficient: α in (0, 1]; kinematics_alpha: α_k ≥ 0.
        payload_weight: [N]; payload_cog: (3,) [m] in ``payload_frame``.
        control_frame, payload_frame: ``"tool"`` or ``"base"``.
        sample_time: the simulation step [s].
    """

    GAINS: Any = ("mass", "damping_ratio", "stiffness", "damping", "selected_axes", "joint_damping", "filter_coefficient",
                  "kinematics_alpha", "payload_weight", "payload_cog", "control_frame", "payload_frame", "servo_description")

    def __init__(self, robot: Any, *, mass: Any, damping_ratio: Any, stiffness: Any, selected_axes: Any = True,
                 joint_damping: float = 5.0, filter_coefficient: float = 0.05, kinematics_alpha: float = 0.01,
                 payload_weight: float = 0.0, payload_cog: Any = (0.0, 0.0, 0.0), control_frame: str = "tool",
                 payload_frame: str = "tool", sample_time: float = 2e-4) -> None:
        require_pose_robot("Ros2AdmittanceController", robot)
        self.mass = axis_vector("mass", mass, low=1e-4, unit="kg")
        if np.any(self.mass > 1e6):
            raise ParameterError(f"mass must be in [1e-4, 1e6] on every axis (the project's range); got {self.mass.tolist()}")
        self.damping_ratio = axis_vector("damping_ratio", damping_ratio, low=0.0)
        self.stiffness = axis_vector("stiffness", stiffness, low=0.0, unit="N/m")
        if np.any(self.stiffness > 1e8):
            raise ParameterError(
                f"stiffness must be in [0, 1e8] on every axis (the project's range); got {self.stiffness.tolist()}"
            )
        sel = np.asarray(selected_axes)
        if sel.ndim == 0:
            sel = np.full(6, sel)
        if sel.shape != (6,) or not all(isinstance(b, bool | np.bool_) for b in sel.tolist()):
            raise ParameterError(f"selected_axes must be true/false or six of them (x, y, z, rx, ry, rz); got {selected_axes!r}")
        self.selected_axes = sel.astype(bool)
        self.damping = self.damping_ratio * 2.0 * np.sqrt(self.mass * self.stiffness)
        self.joint_damping = nonnegative_scalar("joint_damping", joint_damping, "1/s")
        a = float(filter_coefficient)
        if not 0.0 < a <= 1.0:
            raise ParameterError(
                f"filter_coefficient must be in (0, 1] (exponential smoothing per cycle); got {filter_coefficient!r}"
            )
        self.filter_coefficient = a
        self.kinematics_alpha = nonnegative_scalar("kinematics_alpha", kinematics_alpha)
        self.payload_weight = float(payload_weight)
        self.payload_cog = np.asarray(payload_cog, dtype=np.float64)
        if self.payload_cog.shape != (3,) or not np.all(np.isfinite(self.payload_cog)) or not np.isfinite(self.payload_weight):
            raise ParameterError(f"payload_cog must be three finite numbers [m] and payload_weight finite [N]; "
                                 f"got {payload_cog!r}, {payload_weight!r}")
        for name, v in (("control_frame", control_frame), ("payload_frame", payload_frame)):
            if v not in ("tool", "base"):
                raise ParameterError(f"{name} must be 'tool' (the robot's controlled frame) or 'base'; got {v!r}")
        self.control_frame, self.payload_frame = control_frame, payload_frame
        self.kinematics_failures = 0
        super().__init__(robot, sample_time)
        self._p = ROS2_ADMITTANCE.pack(6, mass=self.mass, damping=self.damping, stiffness=self.stiffness,
                                       selected=self.selected_axes.astype(float), joint_damping=self.joint_damping,
                                       filter_coefficient=self.filter_coefficient, dls_alpha=self.kinematics_alpha)
        self._ik = DifferentialIK(robot, self.interface_period, damping=1e-3)

    def law_state_size(self) -> int:
        """``[q_ref (n), q_a (n), q̇_a (n), ẋ (6), w_f (6)]``."""
        return int(self.robot.nq) + ROS2_ADMITTANCE_STATE.size(6, int(self.robot.nq))

    def reset_law(self, measurement: Measurement | None, reference: Reference | None) -> None:
        n = int(self.robot.nq)
        if measurement is not None:
            self.law_state[:n] = np.asarray(measurement.q, dtype=np.float64)
        self.kinematics_failures = 0

    def command(self, t: float, measurement: Measurement, reference: Reference) -> JointCommand:
        n = int(self.robot.nq)
        s = self.law_state
        q = np.asarray(measurement.q, dtype=np.float64)
        ref = self._ik.solve(s[:n], np.asarray(reference.position, dtype=np.float64),
                             np.asarray(reference.velocity, dtype=np.float64))
        s[:n] = ref.q
        self._episode(t, "ik-limit", self._ik.last_limited, lambda: "the joint reference's IK limits held it back")
        R, p, J = pose(self.robot, q)
        R_r, p_r = self.robot.frame_pose(ref.q)
        x = pose_error(R, p, np.asarray(R_r), np.asarray(p_r))
        w = -check_measurement("Ros2AdmittanceController", measurement.wrench) + np.asarray(reference.force, dtype=np.float64)
        if self.payload_weight != 0.0:
            gravity_compensate(w, R if self.payload_frame == "tool" else np.eye(3), self.payload_cog, self.payload_weight)
        R6 = blockdiag(R) if self.control_frame == "tool" else np.eye(6)
        law = s[n:]
        if not ros2_admittance_rule(self.interface_period, J, R6, x, w, self._p, law):
            self.kinematics_failures += 1
            return JointCommand(ref.q.copy(), None)  # type: ignore[arg-type]  # the project writes the reference unchanged
        # the position command interface (the example's command_interfaces): positions only, no velocity feed-forward
        return JointCommand(ref.q + law[ROS2_ADMITTANCE_STATE.slice("q_a", 6, n)], None)  # type: ignore[arg-type]
