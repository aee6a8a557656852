"""The inverse-dynamics inner loop for redundant arms and near singularities.

The shared loop (9.30) (:func:`forcecontrol.laws.inverse_dynamics`) solves
``J y = a − J̇q̇`` with a square J. Here J is (m, n) with m <= n and may lose rank::

    y = y₀ + Jᵀ (J Jᵀ + λ² I)⁻¹ (r − J y₀),      u = B y + n [+ Jᵀ h_e]

* ``r`` is the task's requested ``J q̈`` (``a − J̇ q̇`` in the chapter's notation);
* ``y₀ = K_n (q_n − q) − D_n q̇`` is a joint-space posture acceleration, acting only in the
  null space of J (the projector ``I − J⁺J`` is implicit in the formula when λ = 0);
* damped least squares with a variable damping (Nakamura/Chiaverini): with σ_min the smallest
  singular value of J, ``λ² = 0`` when ``σ_min >= ε`` and ``λ² = λ_max² (1 − (σ_min/ε)²)``
  below. Away from singularities the task is met exactly (the closed loop keeps the chapter's
  form); near them the requested acceleration is traded for bounded joint accelerations instead
  of huge torques.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import as_vector, gain_scalar, nonnegative_scalar, positive_scalar

__all__ = ["dls_damping", "redundant_acceleration", "NullSpacePosture", "SingularityHandling"]


def dls_damping(JJt: np.ndarray, threshold: float, max_damping: float) -> float:
    """λ² of the variable-damping rule from ``J Jᵀ`` (its smallest eigenvalue is σ_min²)."""
    s2 = float(np.linalg.eigvalsh(JJt)[0])
    e2 = threshold * threshold
    if s2 >= e2:
        return 0.0
    return max_damping * max_damping * (1.0 - max(s2, 0.0) / e2)


def redundant_acceleration(J: np.ndarray, r: np.ndarray, y0: np.ndarray | None, threshold: float, max_damping: float):
    """Joint acceleration ``y = y₀ + Jᵀ (J Jᵀ + λ² I)⁻¹ (r − J y₀)`` and the λ² used.

    Args:
        J: task Jacobian (m, n), m <= n.
        r: requested ``J y``, (m,).
        y0: posture acceleration (n,) projected in the null space, or None.
        threshold: ε, the σ_min below which damping starts [same units as J].
        max_damping: λ_max.
    """
    JJt = J @ J.T
    lam2 = dls_damping(JJt, threshold, max_damping) if max_damping > 0.0 else 0.0
    if lam2 > 0.0:
        JJt = JJt + lam2 * np.eye(J.shape[0])
    if y0 is None:
        return J.T @ np.linalg.solve(JJt, r), lam2
    return y0 + J.T @ np.linalg.solve(JJt, r - J @ y0), lam2


@dataclass(frozen=True)
class NullSpacePosture:
    """Joint-space posture in the null space: ``y₀ = K_n (q_n − q) − D_n q̇``.

    Args:
        posture: q_n [rad], (n,).
        stiffness: K_n [1/s²] (scalar), damping: D_n [1/s] (scalar).
    """

    posture: Any
    stiffness: float = 25.0
    damping: float = 10.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "posture", as_vector("posture", self.posture))
        object.__setattr__(self, "stiffness", gain_scalar("stiffness", self.stiffness))
        object.__setattr__(self, "damping", gain_scalar("damping", self.damping))

    def acceleration(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """y₀ (n,) [rad/s²]."""
        return self.stiffness * (self.posture - q) - self.damping * qd


@dataclass(frozen=True)
class SingularityHandling:
    """Variable damped least squares: σ_min threshold ε and maximum damping λ_max.

    ``max_damping = 0`` gives the exact (pseudo-)inverse, which fails at a singularity.
    """

    threshold: float = 0.05
    max_damping: float = 0.05

    def __post_init__(self) -> None:
        object.__setattr__(self, "threshold", positive_scalar("threshold", self.threshold))
        object.__setattr__(self, "max_damping", nonnegative_scalar("max_damping", self.max_damping))
