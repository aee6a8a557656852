"""Planning the poses of a calibration: well-conditioned sensor orientations within the joint limits."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...core.validate import nonnegative_scalar
from ...errors import DimensionError, ParameterError
from ...sensors.gravity import _force_regressor, _torque_regressor, planar_sensor_rotation
from .core import _condition, _gravity_in_sensor, _normalised_blocks, _rotations

__all__ = ["CalibrationPlan", "sensor_orientation", "plan_calibration_poses"]


@dataclass(frozen=True)
class CalibrationPlan:
    """Joint configurations for a calibration, and how well they condition it.

    Attributes:
        joint_positions: (n, nq) [rad], within the joint limits (less the margin).
        rotations: sensor orientations at those configurations, (n, d, d).
        condition_number: of the normalised gravity regressor (see :func:`regressor_condition`).
        smallest_singular_value: its smallest singular value divided by √n (1 at best for forces).
    """

    joint_positions: np.ndarray
    rotations: np.ndarray
    condition_number: float
    smallest_singular_value: float


def sensor_orientation(robot: Any) -> Callable[[np.ndarray], np.ndarray]:
    """``q -> R_S`` for a robot: planar arms (task dimension 2) give (2, 2), others (3, 3).

    Planar closed-form arms use :func:`~forcecontrol.sensors.planar_sensor_rotation` (φ = Σ q);
    Pinocchio robots use the controlled frame's orientation (``frame_pose``), its x-y block when
    the task is planar.

    Raises:
        ParameterError: the robot has neither ``frame_pose`` nor a planar task.
    """
    if hasattr(robot, "frame_pose"):
        if getattr(robot, "task_dim", 6) == 2:
            return lambda q: robot.frame_pose(q)[0][:2, :2]
        return lambda q: robot.frame_pose(q)[0]
    if getattr(robot, "task_dim", None) == 2:
        return planar_sensor_rotation
    raise ParameterError(
        f"cannot tell the sensor orientation of {type(robot).__name__}: pass orientation=q -> R_S"
    )


def _joint_limits(robot: Any, nq: int, joint_limits: Any, margin: float) -> tuple[np.ndarray, np.ndarray]:
    if joint_limits is not None:
        lo, hi = (np.asarray(v, dtype=np.float64).reshape(-1) for v in joint_limits)
    elif hasattr(robot, "model") and hasattr(robot.model, "lowerPositionLimit"):
        lo = np.array(robot.model.lowerPositionLimit, dtype=np.float64)
        hi = np.array(robot.model.upperPositionLimit, dtype=np.float64)
    else:
        lo, hi = np.full(nq, -math.pi), np.full(nq, math.pi)
    if lo.shape != (nq,) or hi.shape != (nq,):
        raise DimensionError(f"joint_limits must be two vectors of shape ({nq},); got shapes {lo.shape} and {hi.shape}")
    unlimited = ~np.isfinite(lo) | ~np.isfinite(hi) | (hi - lo > 1e6)
    lo = np.where(unlimited, -math.pi, lo)
    hi = np.where(unlimited, math.pi, hi)
    lo, hi = lo + margin, hi - margin
    if np.any(hi <= lo):
        j = int(np.flatnonzero(hi <= lo)[0])
        raise ParameterError(f"joint {j}'s range is empty after the margin {margin} rad: [{lo[j]:.4g}, {hi[j]:.4g}]")
    return lo, hi


def plan_calibration_poses(
    robot: Any,
    n_poses: int,
    *,
    candidates: int = 1000,
    seed: int = 0,
    torques: bool = True,
    margin: float = 0.05,
    joint_limits: Any = None,
    orientation: Callable[[np.ndarray], np.ndarray] | None = None,
) -> CalibrationPlan:
    """Joint configurations that make a well-conditioned calibration, within the joint limits.

    Draws ``candidates`` configurations uniformly within the limits (the model's, less
    ``margin``; ±π for joints without limits), then picks ``n_poses`` of them: greedily by the
    information ``log det(Σ AᵢᵀAᵢ + εI)`` of the normalised gravity regressor, then exchanges
    (each chosen pose against every candidate) while the condition number drops. Only the
    sensor orientation matters; collisions are not checked beyond the joint limits.

    Args:
        robot: a robot model (the planar chapter arm, a Pinocchio robot such as the Panda).
        n_poses: number of poses, at least 3 (planar: 4 with moments).
        candidates: random configurations to choose from.
        seed: seed of the random draw (the plan is reproducible).
        torques: plan for the moments too (centre of mass).
        margin: distance kept from each joint limit [rad].
        joint_limits: (lower, upper) to use instead of the model's, each (nq,) [rad].
        orientation: ``q -> R_S`` instead of :func:`sensor_orientation` (a sensor on another frame).

    Returns:
        A :class:`CalibrationPlan`.

    Raises:
        ParameterError: n_poses or candidates too small, a negative margin, an empty joint range, an
            unknown robot.
    """
    for name, v, low in (("n_poses", n_poses, 3), ("candidates", candidates, 1)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise ParameterError(f"{name} must be an integer >= {low}; got {v!r}")
    if candidates < n_poses:
        raise ParameterError(f"candidates must be at least n_poses ({n_poses}); got {candidates}")
    nq = int(getattr(robot, "nq", 0))
    if nq < 1:
        raise ParameterError(f"robot must be a robot model with nq joints; got {type(robot).__name__}")
    orient = orientation if orientation is not None else sensor_orientation(robot)
    lo, hi = _joint_limits(robot, nq, joint_limits, nonnegative_scalar("margin", margin))
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise ParameterError(f"seed must be a non-negative integer or None; got {seed!r}")
    rng = np.random.default_rng(seed)
    Q = lo + (hi - lo) * rng.random((candidates, nq))
    Rs = np.array([np.asarray(orient(q), dtype=np.float64) for q in Q])
    _rotations(Rs)
    uhat = _gravity_in_sensor(Rs, 1.0)
    # per-candidate information matrices of the two blocks
    Mf = np.array([_force_regressor(u[None]).T @ _force_regressor(u[None]) for u in uhat])
    Mt = np.array([_torque_regressor(u[None]).T @ _torque_regressor(u[None]) for u in uhat]) if torques else None

    def info(Sf, St):  # batched: log det and eigenvalues of each block
        ef = np.linalg.eigvalsh(Sf)
        et = np.linalg.eigvalsh(St) if St is not None else None
        return ef, et

    eps = 1e-6
    chosen: list[int] = []
    Sf = np.zeros(Mf.shape[1:])
    St = np.zeros(Mt.shape[1:]) if Mt is not None else None
    for _ in range(n_poses):
        cf = Sf[None] + Mf
        ef, et = info(cf, St[None] + Mt if St is not None else None)
        score = np.sum(np.log(ef + eps), axis=1) + (np.sum(np.log(et + eps), axis=1) if et is not None else 0.0)
        score[chosen] = -np.inf
        j = int(np.argmax(score))
        chosen.append(j)
        Sf = Sf + Mf[j]
        if St is not None:
            St = St + Mt[j]

    def cond_of(ef, et):
        e = np.concatenate([ef, et], axis=-1) if et is not None else ef
        e = np.maximum(e, 0.0)
        with np.errstate(divide="ignore"):
            return np.sqrt(e.max(axis=-1) / e.min(axis=-1))

    best = float(cond_of(*info(Sf, St)))
    for _ in range(3):  # exchange passes
        improved = False
        for slot in range(n_poses):
            i = chosen[slot]
            cf = Sf[None] - Mf[i] + Mf
            ct = St[None] - Mt[i] + Mt if St is not None else None
            c = cond_of(*info(cf, ct))
            c[chosen] = np.inf
            j = int(np.argmin(c))
            if c[j] < best * (1 - 1e-9):
                best = float(c[j])
                Sf = cf[j]
                if St is not None:
                    St = ct[j]
                chosen[slot] = j
                improved = True
        if not improved:
            break
    sel = np.array(chosen)
    blocks = _normalised_blocks(Rs[sel], torques)
    cond, smin = _condition(blocks)
    return CalibrationPlan(joint_positions=Q[sel], rotations=Rs[sel], condition_number=cond,
                           smallest_singular_value=smin / math.sqrt(n_poses))
