"""The robot interface every controller and the simulator rely on.

A robot answers questions about a joint state; it holds no state of its own.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

__all__ = ["RobotModel", "RobotTerms"]


class RobotTerms(NamedTuple):
    """Everything a control law needs about the arm at one joint state.

    Attributes:
        x: operational-space position of the end-effector in the base frame, (m,) [m].
        xd: its velocity ``J q̇``, (m,) [m/s].
        J: geometric Jacobian of the controlled operational coordinates, (m, n).
        Jdq: ``J̇(q, q̇) q̇``, (m,) [m/s²].
        B: joint-space inertia matrix B(q), (n, n) [kg m²].
        n: ``n(q, q̇) = C(q, q̇) q̇ + F q̇ + g(q)`` (8.56), (n,) [N m].
        g: gravity torques g(q), (n,) [N m].
    """

    x: np.ndarray
    xd: np.ndarray
    J: np.ndarray
    Jdq: np.ndarray
    B: np.ndarray
    n: np.ndarray
    g: np.ndarray


@runtime_checkable
class RobotModel(Protocol):
    """What the library needs from a manipulator model (the chapter's (9.1)).

    ``B(q) q̈ + C(q, q̇) q̇ + F q̇ + g(q) = u − Jᵀ(q) h_e``, with ``h_e`` the force the
    end-effector exerts on the environment.
    """

    #: number of joints n.
    nq: int
    #: dimension m of the operational space the controllers work in.
    task_dim: int

    def forward_kinematics(self, q: np.ndarray) -> np.ndarray:
        """End-effector operational coordinates x_e, (m,)."""
        ...

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Jacobian J(q), (m, n)."""
        ...

    def jdot_qdot(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """``J̇(q, q̇) q̇``, (m,)."""
        ...

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """B(q), (n, n)."""
        ...

    def nonlinear_effects(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """n(q, q̇) = C q̇ + F q̇ + g, (n,)."""
        ...

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """g(q), (n,)."""
        ...

    def terms(self, q: np.ndarray, qd: np.ndarray) -> RobotTerms:
        """All of the above at once (the hot path)."""
        ...
