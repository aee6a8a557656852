"""Admittance control (9.37) on a position-interface arm: compliant frame → IK → the arm's own servo.

The chapter's admittance scheme (Sect. 9.3, Fig. 9.5) with its inner motion loop replaced by what
an industrial arm offers: the compliant frame O_t from (9.37)::

    M_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e          (z̃ = x_d − x_t; pose: desired-frame coordinates (9.9))

is integrated once per interface cycle T_i, exactly with the measured wrench held (ZOH), *then*
used (the command of cycle k already reflects h_e(t_k))::

    ζ_{k+1} = A_d ζ_k + G_d h_k,   ζ = [z̃; z̃̇],   x_t,k = x_d − z̃_{k+1}   (pose: compliant_frame)
    q_c,k = IK(q_c,k−1, x_t,k)     (damped least squares, joint and speed limits: robots.ik)

and the joint command goes through the arm's servo (delay, low-pass, second-order servo, limits:
robots.servo) to the arm. With the servo ideal and fast this is the chapter's scheme; the
servo's bandwidth and the transport delay are what makes it bounce against a stiff environment
(analysis: :mod:`forcecontrol.analysis.servo_loop`). Equilibrium against an elastic plane of
stiffness k along ν (ideal servo, IK exact): the springs k and ``K_Pt,ν = (νᵀ K_Pt⁻¹ ν)⁻¹`` in
series, ``f = k K_Pt,ν / (k + K_Pt,ν) δ_d`` with δ_d the desired frame's penetration (9.22).

Inputs: ``measurement.q, .qd`` (n,), ``measurement.wrench`` h_e (m,) base frame (about the
end-effector origin for a pose task); ``reference.position/velocity`` the desired frame x_d (m,).
Output: joint torques (n,) [N m] of the arm's servo.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.validate import as_gain_matrix, nonnegative_scalar
from ..errors import ParameterError
from ..robots.ik import DifferentialIK, JointCommand
from ..robots.servo import PositionInterfaceRobot
from ..spatial.closed_form import euler_xyz_to_rotation
from .admittance import compliant_frame
from .base import Measurement, Reference
from .position_interface import PositionInterfaceController

__all__ = ["PositionAdmittanceController", "discretise_admittance"]


def discretise_admittance(inertia: np.ndarray, damping: np.ndarray, stiffness: np.ndarray, period: float):
    """(9.37) as ζ = [z̃; z̃̇], ζ̇ = A ζ + G h, discretised exactly over ``period`` with h held.

    Returns:
        (A_d (2m, 2m), G_d (2m, m), A (2m, 2m), G (2m, m)).
    """
    from scipy.linalg import expm  # type: ignore[import-untyped]

    m = inertia.shape[0]
    Mi = np.linalg.inv(inertia)
    A = np.zeros((2 * m, 2 * m))
    A[:m, m:] = np.eye(m)
    A[m:, :m] = -Mi @ stiffness
    A[m:, m:] = -Mi @ damping
    G = np.zeros((2 * m, m))
    G[m:] = Mi
    big = np.zeros((3 * m, 3 * m))
    big[: 2 * m, : 2 * m] = A * period
    big[: 2 * m, 2 * m :] = G * period
    with np.errstate(all="ignore"):
        E = expm(big)
    if not np.all(np.isfinite(E)):
        raise ParameterError(
            f"inertia, damping and stiffness give a compliant frame (9.37) that cannot be discretised at the interface "
            f"period {period:g} s (its matrix exponential overflows); use physically sized gains"
        )
    return E[: 2 * m, : 2 * m], E[: 2 * m, 2 * m :], A, G


class PositionAdmittanceController(PositionInterfaceController):
    """Admittance control (9.37) on a position/velocity-interface arm (see the module docstring).

    Args:
        robot: a :class:`~forcecontrol.robots.servo.PositionInterfaceRobot`.
        inertia, damping, stiffness: M_t, K_Dt, K_Pt of (9.37), SPD (m, m) (K_Pt may be PSD), or
            numbers / (m,) diagonals [kg, N s/m, N/m; rotational rows kg m², N m s/rad, N m/rad].
        sample_time: the servo/simulation step Ts [s] (the interface period is a whole multiple).
        ik_damping: λ of the damped least-squares IK [m].
        velocity_feedforward: also send the compliant frame's twist mapped to joint velocities
            (``q̇_c = J⁺ ẋ_t``) as the servo's velocity feed-forward.
        joint_limits: ``"model"`` (the URDF's position and speed limits) or None.
    """

    GAINS = ("inertia", "damping", "stiffness", "ik_damping", "velocity_feedforward", "servo_description")

    def __init__(
        self, robot: PositionInterfaceRobot, inertia: Any, damping: Any, stiffness: Any, *, sample_time: float = 2e-4,
        ik_damping: float = 1e-3, velocity_feedforward: bool = False, joint_limits: str | None = "model",
    ) -> None:
        if not isinstance(robot, PositionInterfaceRobot):
            raise ParameterError(
                f"robot must be a PositionInterfaceRobot (a torque robot with its JointServo); got {type(robot).__name__}"
            )
        m = int(robot.task_dim)
        self.inertia = as_gain_matrix("inertia", inertia, m)
        self.damping = as_gain_matrix("damping", damping, m)
        self.stiffness = as_gain_matrix("stiffness", stiffness, m, definite=False)
        self.ik_damping = nonnegative_scalar("ik_damping", ik_damping, "m")
        if not isinstance(velocity_feedforward, bool):
            raise ParameterError(f"velocity_feedforward must be true or false; got {velocity_feedforward!r}")
        self.velocity_feedforward = velocity_feedforward
        if joint_limits not in ("model", None):
            raise ParameterError(f"joint_limits must be 'model' or None; got {joint_limits!r}")
        self._m = m
        super().__init__(robot, sample_time)
        lim = "model" if joint_limits == "model" else None
        self.ik = DifferentialIK(robot.robot, self.interface_period, damping=self.ik_damping, lower=lim, upper=lim,
                                 velocity_limit=lim)
        self.pose = self.ik.pose
        self._Ad, self._Gd, self._A, self._G = discretise_admittance(self.inertia, self.damping, self.stiffness,
                                                                      self.interface_period)
        self._Mi = np.linalg.inv(self.inertia)
        self._log_xt: list[np.ndarray] = []

    def law_state_size(self) -> int:
        """[z̃ (m); z̃̇ (m); q_c of the last cycle (n)]."""
        return 2 * int(self.robot.task_dim) + int(self.robot.nq)

    def reset_law(self, measurement: Measurement | None, reference: Reference | None) -> None:
        """Compliant frame on the desired frame at rest; the IK starts from the measured q."""
        m = self._m
        if measurement is not None:
            self.law_state[2 * m :] = measurement.q
        self._log_xt = []
        self.ik_limited_cycles = 0

    def command(self, t: float, measurement: Measurement, reference: Reference) -> JointCommand:
        m = self._m
        s = self.law_state
        h = np.asarray(measurement.wrench, dtype=np.float64)
        if self.pose:
            R_d = euler_xyz_to_rotation(reference.position[3:])
            h_d = np.concatenate([R_d.T @ h[:3], R_d.T @ h[3:]])
        else:
            h_d = h
        zeta = self._Ad @ s[: 2 * m] + self._Gd @ h_d
        s[: 2 * m] = zeta
        z, zd = zeta[:m], zeta[m:]
        if self.pose:
            zdd = self._Mi @ (h_d - self.damping @ zd - self.stiffness @ z)
            ref_t = compliant_frame(reference, z, zd, zdd)
            x_t, xd_t = ref_t.position, ref_t.velocity
        else:
            x_t = np.asarray(reference.position, dtype=np.float64) - z
            xd_t = np.asarray(reference.velocity, dtype=np.float64) - zd
        q_prev = s[2 * m :].copy()
        cmd = self.ik.solve(q_prev, x_t, xd_t if self.velocity_feedforward else None)
        if self.ik.last_limited:
            self.ik_limited_cycles += 1
        self._episode(t, "ik-limit", self.ik.last_limited, lambda: (
            "the IK's joint or speed limits kept the joint command from the compliant frame"))
        s[2 * m :] = cmd.q
        self._log_xt.append(x_t.copy())
        if self.servo.interface == "velocity":
            qd = (cmd.q - q_prev) / self.interface_period
            return JointCommand(cmd.q, qd + (cmd.qd if self.velocity_feedforward else 0.0))
        return JointCommand(cmd.q, cmd.qd if self.velocity_feedforward else None)

    def signals(self) -> dict[str, np.ndarray]:
        """The servo's signals, and ``compliant_frame`` x_t (m,) held over each interface cycle."""
        out = super().signals()
        rows = out["joint_command"].shape[0]
        xt = np.array(self._log_xt).reshape(-1, self._m)
        idx = np.minimum(np.arange(rows) // self.steps_per_cycle, max(xt.shape[0] - 1, 0))
        out["compliant_frame"] = xt[idx] if xt.shape[0] else np.full((rows, self._m), np.nan)
        return out
