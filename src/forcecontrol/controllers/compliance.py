"""Active compliance: PD control with gravity compensation (Sect. 9.2.2).

Two controllers:

* :class:`OperationalSpacePD`, the operational-space law (8.110)/(9.15) whose equilibrium in
  contact is ``K_P x̃ = h_A`` (9.2)–(9.4), an active stiffness K_P (compliance K_P⁻¹);
* :class:`JointSpacePD`, the joint-space law (8.51) whose equilibrium is ``K_P q̃ = Jᵀ h_e``
  (9.24)–(9.26), a posture-dependent compliance ``J K_P⁻¹ Jᵀ``.

For the position-only operational space of the planar arm the analytical and geometric
Jacobians coincide, and (8.110) and (9.15) are the same law with the error in the base frame.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from .. import laws
from ..core.validate import as_gain_matrix, as_vector
from ..laws.layout import JOINT_PD, OS_PD
from ..robots.base import RobotModel
from .base import Controller, Measurement, Reference, runs_law

__all__ = ["OperationalSpacePD", "JointSpacePD"]


class OperationalSpacePD(Controller):
    """Active compliance, operational-space PD with gravity compensation (8.110), (9.15).

    Law: ``u = g(q) + Jᵀ(q) (K_P (x_d − x_e) − K_D J(q) q̇)``.
    Equilibrium in contact (9.2)–(9.4): ``K_P (x_d − x_e) = h_A``; with an elastic environment
    of stiffness K the contact force is (9.22) and the pose error (9.23).

    Inputs: ``measurement.q, .qd`` (n,); ``reference.position`` x_d (m,) [m]. The force
    measurement is not used. Output: torques (n,) [N m].

    Args:
        robot: the manipulator model.
        stiffness: K_P, symmetric positive definite (m, m) [N/m] (scalar or diagonal allowed).
        damping: K_D, symmetric positive definite (m, m) [N s/m].
        sample_time: Ts [s].
    """

    law = staticmethod(laws.os_pd)
    GAINS = ("stiffness", "damping")
    uses_force: ClassVar[bool] = False
    position_task_only: ClassVar[bool] = True

    def __init__(self, robot: RobotModel, stiffness: Any, damping: Any, sample_time: float = 1e-3) -> None:
        super().__init__(robot, sample_time)
        m = self.m
        self.stiffness = as_gain_matrix("stiffness", stiffness, m)
        self.damping = as_gain_matrix("damping", damping, m)
        self._params = OS_PD.pack(m, K_P=self.stiffness, K_D=self.damping)

    @runs_law
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (8.110) for this sample (:func:`forcecontrol.laws.os_pd`)."""
        return self._law_step(t, measurement, reference)


class JointSpacePD(Controller):
    """Joint-space PD with gravity compensation (8.51); in contact, equilibrium (9.24).

    Law: ``u = g(q) + K_P (q_d − q) − K_D q̇``. At equilibrium ``K_P q̃ = Jᵀ h_e`` (9.24) and the
    operational compliance is ``J K_P⁻¹ Jᵀ`` (9.26), which depends on the posture.

    Inputs: ``measurement.q, .qd``; the joint set-point is a constructor argument (the
    operational reference is not used). Output: torques (n,) [N m].

    Args:
        robot: the manipulator model.
        stiffness: K_P, symmetric positive definite (n, n) [N m/rad].
        damping: K_D, symmetric positive definite (n, n) [N m s/rad].
        joint_setpoint: q_d, (n,) [rad].
        sample_time: Ts [s].
    """

    law = staticmethod(laws.joint_pd)
    GAINS = ("stiffness", "damping", "joint_setpoint")
    uses_force: ClassVar[bool] = False

    def __init__(
        self, robot: RobotModel, stiffness: Any, damping: Any, joint_setpoint: Any, sample_time: float = 1e-3,
    ) -> None:
        super().__init__(robot, sample_time)
        n = int(robot.nq)
        self.stiffness = as_gain_matrix("stiffness", stiffness, n)
        self.damping = as_gain_matrix("damping", damping, n)
        self.joint_setpoint = as_vector("joint_setpoint", joint_setpoint, n)
        self._params = JOINT_PD.pack(n, K_P=self.stiffness, K_D=self.damping, q_d=self.joint_setpoint)

    @runs_law
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (8.51) for this sample (:func:`forcecontrol.laws.joint_pd`)."""
        return self._law_step(t, measurement, reference)

