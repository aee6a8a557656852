"""Impedance control by inverse dynamics (Sect. 9.3).

With the shared inner loop (9.30) the scheme only chooses the operational acceleration::

    a = ẍ_d + M_d⁻¹ (K_D x̃̇ + K_P x̃ [− h_A]),      x̃ = x_d − x_e

* without force measurement, (9.28): u = B J⁻¹(a − J̇q̇) + n, closed loop (9.29)
  ``M_d x̃̈ + K_D x̃̇ + K_P x̃ = M_d B_A⁻¹ h_A`` (coupled through B_A⁻¹);
* with force measurement, (9.30)–(9.31): u = B J⁻¹(a − J̇q̇) + n + Jᵀ h_e, closed loop (9.32)
  ``M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A``, a linear, decoupled impedance.

(9.31) is used in its corrected form: its first term is ``M_d ẍ_d`` as in (9.28), not the
printed ``M_d x̃̈`` (which would make the law circular); see the reference misprint list.
For the position-only operational space of the planar arm, h_A = f_e and J_A = J.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from .. import laws
from ..core.validate import as_gain_matrix
from ..laws.layout import IMPEDANCE
from ..robots.base import RobotModel
from .base import Controller, Measurement, Reference, runs_law

__all__ = ["ImpedanceController"]


class ImpedanceController(Controller):
    """Impedance control, (9.28) without or (9.30)–(9.31) with force measurement.

    Law: ``u = B(q) J⁻¹(q) (a − J̇ q̇) + n(q, q̇) [+ Jᵀ(q) h_e]`` with
    ``a = ẍ_d + M_d⁻¹ (K_D (ẋ_d − ẋ_e) + K_P (x_d − x_e) [− h_A])``.
    With force measurement the closed loop is the impedance (9.32)
    ``M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A``.

    Inputs: ``measurement.q, .qd`` (n,), ``measurement.wrench`` h_e (m,) [N] (only with
    ``force_measurement``); ``reference.position/velocity/acceleration`` (m,).
    Output: torques (n,) [N m].

    Args:
        robot: the manipulator model, with a position task space (a robot with task='pose' is
            refused: its 6-D form is ``SpatialImpedanceController`` (9.35)).
        inertia: M_d, symmetric positive definite (m, m) [kg] (scalar or diagonal allowed).
        damping: K_D, symmetric positive definite (m, m) [N s/m].
        stiffness: K_P, symmetric positive definite (m, m) [N/m].
        force_measurement: use (9.30)–(9.31) (True) or (9.28) (False).
        posture: for a redundant arm (J of shape (m, n), m < n), a ``NullSpacePosture`` acting
            in the null space of J (None: minimum-norm joint accelerations).
        singularity: a ``SingularityHandling`` (variable damped least squares near a
            singularity), also for a square J; None: the exact J⁻¹ (which fails at a singularity).
        sample_time: Ts [s].
    """

    law = staticmethod(laws.impedance)
    GAINS = ("inertia", "damping", "stiffness", "force_measurement")
    acceleration = staticmethod(laws.impedance_acceleration)
    position_task_only: ClassVar[bool] = True

    def __init__(
        self, robot: RobotModel, inertia: Any, damping: Any, stiffness: Any, force_measurement: bool = True,
        sample_time: float = 1e-3, *, posture: Any = None, singularity: Any = None,
    ) -> None:
        super().__init__(robot, sample_time)
        m = self.m
        self._set_redundancy(posture, singularity)
        self.inertia = as_gain_matrix("inertia", inertia, m)
        self.damping = as_gain_matrix("damping", damping, m)
        self.stiffness = as_gain_matrix("stiffness", stiffness, m)
        self.force_measurement = bool(force_measurement)
        self._Md_inv = np.linalg.inv(self.inertia)
        self._Md_inv.flags.writeable = False
        self._params = IMPEDANCE.pack(
            m, M_d_inv=self._Md_inv, K_D=self.damping, K_P=self.stiffness, use_force=float(self.force_measurement)
        )

    @property
    def uses_force(self) -> bool:  # type: ignore[override]
        return self.force_measurement

    @runs_law
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.28) or (9.30)–(9.31) for this sample (:func:`forcecontrol.laws.impedance`)."""
        return self._law_step(t, measurement, reference)

