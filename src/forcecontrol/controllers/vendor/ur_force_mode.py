"""Universal Robots ``force_mode`` on a position-interface arm (documented semantics; inferred law, said so)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...core.validate import positive_scalar
from ...errors import ParameterError
from ...laws.vendor import ur_force_mode_step
from ...laws.vendor.layout import UR_FORCE_MODE, UR_FORCE_MODE_STATE
from ...robots.ik import DifferentialIK, JointCommand
from ...spatial.closed_form import rotation_to_euler_xyz, rotvec_to_rotation
from ..base import Measurement, Reference
from ..position_interface import PositionInterfaceController
from .common import axis_vector, check_measurement, pose_error, require_pose_robot, target_pose

__all__ = ["UrForceModeController"]


class UrForceModeController(PositionInterfaceController):
    """URScript ``force_mode(task_frame, selection_vector, wrench, type, limits)`` with
    ``force_mode_set_damping`` and ``force_mode_set_gain_scaling``, once per interface cycle.

    Law (:func:`forcecontrol.laws.vendor.ur_force_mode_step`, **inferred**: UR publishes the
    semantics, not the equations): on each compliant axis of the task frame
    ``v ← (1 − d) v + T G s_g (F_d − F)``, ``|v| ≤ limit``, offset ``+= T v``; non-compliant axes
    follow the program's pose ``reference.position``. The commanded pose (program pose moved by the
    offset along the task frame's axes) goes to the joints through a damped least-squares IK step
    (:class:`~forcecontrol.robots.ik.DifferentialIK`). ``F`` is the measured wrench the robot
    applies to the environment (h_e) in the task frame; the loop settles where it equals
    ``wrench`` on the compliant axes. The non-compliant axes' ``limits`` are deviations before a
    protective stop: an excess is logged as a ``force-mode-deviation`` event (warned once; the first
    also in :attr:`deviation_exceeded`: time, axis, value); the IK's limits as ``ik-limit``.

    Args:
        robot: a :class:`~forcecontrol.robots.servo.PositionInterfaceRobot` on a 6-D arm.
        task_frame: ``p[x, y, z, rx, ry, rz]`` relative to the base (rotation vector) [m, rad].
        selection_vector: six 0/1; wrench: six numbers [N, N m]; frame_type: 2 ("not transformed";
            types 1 and 3, which re-orient the frame from the TCP each cycle, are not modelled).
        limits: six numbers (speed on compliant axes [m/s, rad/s]; deviation otherwise [m, rad]).
        damping: d in [0, 1] (URScript default 0.005; the ROS driver and ur_rtde set 0.025).
        gain_scaling: s_g in [0, 2] (default 1; the ROS driver and ur_rtde set 0.5).
        gain: G [1/kg], the controller's internal admittance gain: NOT published; 0.05 is a nominal
            value chosen so that d = 0.025 at 500 Hz gives a free-space speed of 4 cm/s per 10 N at
            s_g = 1. Identify it from a recorded step.
    """

    GAINS: Any = ("task_frame", "selection_vector", "wrench", "frame_type", "limits", "damping", "gain_scaling", "gain",
                  "servo_description")

    def __init__(self, robot: Any, *, task_frame: Any = (0.0,) * 6, selection_vector: Any = (0, 0, 1, 0, 0, 0),
                 wrench: Any = (0.0,) * 6, frame_type: int = 2, limits: Any = (0.1, 0.1, 0.1, 0.785, 0.785, 0.785),
                 damping: float = 0.005, gain_scaling: float = 1.0, gain: float = 0.05, sample_time: float = 2e-4) -> None:
        require_pose_robot("UrForceModeController", robot)
        self.task_frame = axis_vector("task_frame", task_frame)
        sel = axis_vector("selection_vector", selection_vector)
        if not np.all((sel == 0.0) | (sel == 1.0)):
            raise ParameterError(f"selection_vector must be six 0/1 values (1: compliant); got {list(selection_vector)!r}")
        self.selection_vector = sel
        self.wrench = axis_vector("wrench", wrench)
        if frame_type != 2:
            raise ParameterError(
                f"frame_type must be 2 (the task frame is not transformed); got {frame_type!r}: types 1 (y axis towards the "
                "frame's origin) and 3 (x axis along the TCP velocity) are not modelled"
            )
        self.frame_type = 2
        self.limits = axis_vector("limits", limits, low=0.0, strict_low=True)
        if not 0.0 <= float(damping) <= 1.0:
            raise ParameterError(f"damping must be in [0, 1] (force_mode_set_damping); got {damping!r}")
        if not 0.0 <= float(gain_scaling) <= 2.0:
            raise ParameterError(f"gain_scaling must be in [0, 2] (force_mode_set_gain_scaling); got {gain_scaling!r}")
        self.damping, self.gain_scaling = float(damping), float(gain_scaling)
        self.gain = positive_scalar("gain", gain, "1/kg")
        self.deviation_exceeded: tuple[float, str, float] | None = None
        super().__init__(robot, sample_time)
        self._R_task = rotvec_to_rotation(self.task_frame[3:])
        self._p = UR_FORCE_MODE.pack(6, selection=sel, wrench=self.wrench, limits=self.limits, gain=self.gain,
                                     gain_scaling=self.gain_scaling, damping=self.damping)
        self._k = UR_FORCE_MODE_STATE.size(6)
        self._ik = DifferentialIK(robot, self.interface_period, damping=1e-3)

    def law_state_size(self) -> int:
        """``[v (6), offset (6), q_cmd (n)]``."""
        return UR_FORCE_MODE_STATE.size(6) + int(self.robot.nq)

    def reset_law(self, measurement: Measurement | None, reference: Reference | None) -> None:
        if measurement is not None:
            self.law_state[UR_FORCE_MODE_STATE.size(6) :] = np.asarray(measurement.q, dtype=np.float64)
        self.deviation_exceeded = None

    def command(self, t: float, measurement: Measurement, reference: Reference) -> JointCommand:
        s = self.law_state
        Rt = self._R_task
        h = check_measurement("UrForceModeController", measurement.wrench)
        F = np.concatenate([Rt.T @ h[:3], Rt.T @ h[3:]])
        k = self._k
        ur_force_mode_step(self.interface_period, F, self._p, s[:k])
        R_p, p_p = target_pose(np.asarray(reference.position, dtype=np.float64))
        off = s[UR_FORCE_MODE_STATE.slice("offset", 6)]
        p_c = p_p + Rt @ off[:3]
        R_c = rotvec_to_rotation(Rt @ off[3:]) @ R_p
        R_m, p_m = self.robot.frame_pose(np.asarray(measurement.q, dtype=np.float64))
        dev = pose_error(np.asarray(R_m), np.asarray(p_m), R_p, p_p)
        dev = np.concatenate([Rt.T @ dev[:3], Rt.T @ dev[3:]])
        over = [i for i in range(6) if self.selection_vector[i] == 0.0 and abs(dev[i]) > self.limits[i]]
        if over and self.deviation_exceeded is None:
            self.deviation_exceeded = (float(t), ("x", "y", "z", "rx", "ry", "rz")[over[0]], float(dev[over[0]]))
        self._episode(t, "force-mode-deviation", bool(over), lambda: (
            f"the deviation from the program's pose on non-compliant axis {('x', 'y', 'z', 'rx', 'ry', 'rz')[over[0]]} is "
            f"{dev[over[0]]:.4g}, beyond its limit {self.limits[over[0]]:g}: a UR controller would stop (protective stop)"))
        cmd = self._ik.solve(s[k:], np.concatenate([p_c, rotation_to_euler_xyz(R_c)]))
        self._episode(t, "ik-limit", self._ik.last_limited, lambda: "the IK's joint or speed limits held the command back")
        s[k:] = cmd.q
        return cmd
