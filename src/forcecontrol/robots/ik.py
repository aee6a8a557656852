"""Differential inverse kinematics: a Cartesian (compliant) frame to joint position commands.

Once per interface cycle, from the previous joint command q_{k−1} (the IK integrates its own
command, as the vendor drivers do, so the servo's lag does not enter the IK)::

    e   = x_t − x(q_{k−1})                 (planar/position task)
    e   = [o_t − o_e; θ(R_t R_eᵀ)]         (pose task: position and rotation vector, base frame)
    Δq  = Jᵀ (J Jᵀ + λ² I)⁻¹ e             (damped least squares, λ = ``damping``)
    Δq ← Δq / max(1, max_i |Δq_i| / (v_max,i T))     (joint speed limit, direction kept)
    q_k = clip(q_{k−1} + Δq, q_min, q_max)            (joint limits)
    q̇_k = Jᵀ (J Jᵀ + λ² I)⁻¹ ẋ_t                      (velocity feed-forward from the frame's twist)

At a regular posture and for small steps the map from the frame's displacement to the arm's is
the identity (``J Δq = e`` up to λ²): the analysis of the sampled loop uses exactly that.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import DimensionError, ParameterError
from ..spatial.closed_form import euler_xyz_to_rotation, rotation_vector
from .base import RobotModel

__all__ = ["DifferentialIK", "JointCommand", "model_limits"]


class JointCommand(NamedTuple):
    """One interface cycle's command: joint positions q (n,) [rad] and velocities q̇ (n,) [rad/s]."""

    q: np.ndarray
    qd: np.ndarray


def model_limits(robot: RobotModel) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """(q_min, q_max, v_max) from a Pinocchio model's URDF limits, None where absent or unbounded."""
    inner = getattr(robot, "robot", robot)
    model = getattr(inner, "model", None)
    if model is None:
        return None, None, None
    lo = np.asarray(model.lowerPositionLimit, dtype=np.float64).copy()
    hi = np.asarray(model.upperPositionLimit, dtype=np.float64).copy()
    v = np.asarray(model.velocityLimit, dtype=np.float64).copy()
    bounded = np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo) and np.all(np.abs(hi) < 1e10)
    vok = np.all(np.isfinite(v)) and np.all(v > 0) and np.all(v < 1e10)
    return (lo, hi, v) if bounded and vok else ((lo, hi, None) if bounded else (None, None, v if vok else None))


class DifferentialIK:
    """Damped least-squares differential IK with joint and speed limits (see the module docstring).

    Args:
        robot: the arm (any RobotModel; a pose task needs ``frame_pose`` and ``spatial_jacobian``).
        period: the interface period T [s] (the speed limit allows ``v_max T`` per cycle).
        damping: λ of the damped least squares [m] (0: the exact pseudo-inverse).
        lower, upper: joint limits (n,) [rad]; ``"model"`` reads the URDF's; None: none.
        velocity_limit: joint speed limits (n,) [rad/s]; ``"model"`` reads the URDF's; None: none.
        iterations: Newton steps per cycle (1: the differential IK).
    """

    def __init__(
        self, robot: RobotModel, period: float, *, damping: float = 1e-3, lower: Any = "model", upper: Any = "model",
        velocity_limit: Any = "model", iterations: int = 1,
    ) -> None:
        self.robot = robot
        self.n = int(robot.nq)
        self.m = int(robot.task_dim)
        self.period = positive_scalar("period", period, "s")
        self.damping = nonnegative_scalar("damping", damping, "m")
        if isinstance(iterations, bool) or int(iterations) != iterations or iterations < 1:
            raise ParameterError(f"iterations must be a positive integer; got {iterations!r}")
        self.iterations = int(iterations)
        mlo, mhi, mv = model_limits(robot)
        self.lower = self._vec("lower", mlo if isinstance(lower, str) and lower == "model" else lower)
        self.upper = self._vec("upper", mhi if isinstance(upper, str) and upper == "model" else upper)
        if (self.lower is None) != (self.upper is None):
            raise ParameterError("lower and upper joint limits must be given together (or both None)")
        if self.lower is not None and np.any(self.upper <= self.lower):
            raise ParameterError(
                f"upper joint limits must exceed lower ones; got lower {self.lower.tolist()}, upper {self.upper.tolist()}"
            )
        vl = mv if isinstance(velocity_limit, str) and velocity_limit == "model" else velocity_limit
        self.velocity_limit = self._vec("velocity_limit", vl)
        if self.velocity_limit is not None and np.any(self.velocity_limit <= 0):
            raise ParameterError(f"velocity_limit must be positive per joint; got {self.velocity_limit.tolist()}")
        self.pose = getattr(robot, "task", None) == "pose"
        self.last_limited = False

    def _vec(self, name: str, v: Any) -> np.ndarray | None:
        if v is None:
            return None
        a = np.asarray(v, dtype=np.float64)
        if a.ndim == 0:
            a = np.full(self.n, float(a))
        if a.shape != (self.n,) or not np.all(np.isfinite(a)):
            raise DimensionError(f"{name} must be finite with shape ({self.n},); got {np.asarray(v).tolist()!r}")
        return a

    def error_and_jacobian(self, q: np.ndarray, x_target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The task error e (m,) and the Jacobian it is linear in (m, n) at q."""
        if self.pose:
            R_e, o_e = self.robot.frame_pose(q)  # type: ignore[attr-defined]
            R_t = euler_xyz_to_rotation(x_target[3:])
            e = np.concatenate([x_target[:3] - o_e, rotation_vector(R_t @ R_e.T)])
            return e, np.asarray(self.robot.spatial_jacobian(q))  # type: ignore[attr-defined]
        return x_target - np.asarray(self.robot.forward_kinematics(q)), np.asarray(self.robot.jacobian(q))

    def _dls(self, J: np.ndarray, e: np.ndarray) -> np.ndarray:
        m = J.shape[0]
        return J.T @ np.linalg.solve(J @ J.T + self.damping**2 * np.eye(m), e)

    def solve(self, q_prev: Any, x_target: Any, xd_target: Any = None) -> JointCommand:
        """The joint command for the target frame x_t (m,) (pose: ``[o; φ]`` XYZ angles) and twist ẋ_t (m,).

        Sets ``last_limited`` when a joint or speed limit changed the step.
        """
        q0 = np.asarray(q_prev, dtype=np.float64)
        x_t = np.asarray(x_target, dtype=np.float64)
        if q0.shape != (self.n,):
            raise DimensionError(f"q_prev must have shape ({self.n},); got {q0.shape}")
        if x_t.shape != (self.m,):
            raise DimensionError(f"x_target must have shape ({self.m},); got {x_t.shape}")
        q = q0.copy()
        limited = False
        J = None
        for _ in range(self.iterations):
            e, J = self.error_and_jacobian(q, x_t)
            q = q + self._dls(J, e)
        dq = q - q0
        if self.velocity_limit is not None:
            r = float(np.max(np.abs(dq) / (self.velocity_limit * self.period)))
            if r > 1.0:
                dq = dq / r
                limited = True
        q = q0 + dq
        if self.lower is not None:
            qc = np.clip(q, self.lower, self.upper)
            limited = limited or bool(np.any(qc != q))
            q = qc
        if xd_target is None:
            qd = np.zeros(self.n)
        else:
            xd = np.asarray(xd_target, dtype=np.float64)
            if xd.shape != (self.m,):
                raise DimensionError(f"xd_target must have shape ({self.m},); got {xd.shape}")
            qd = self._dls(J, xd)
            if self.velocity_limit is not None:
                qd = np.clip(qd, -self.velocity_limit, self.velocity_limit)
        self.last_limited = limited
        return JointCommand(q, qd)
