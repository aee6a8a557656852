"""The environment interface: the end-effector pose and twist in, the contact wrench out."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

__all__ = ["Environment", "xyz", "plane_normal_force_at"]


def xyz(a: np.ndarray, space: int) -> tuple[float, float, float]:
    """The first ``space`` (2 or 3) entries of a vector as three floats, z = 0 for a planar one."""
    v = a.tolist()
    return (v[0], v[1], v[2] if space == 3 else 0.0)


def plane_normal_force_at(surface: Any, space: int, p0: float, p1: float, p2: float, v0: float, v1: float,
                          v2: float) -> tuple[float, float, float, float]:
    """``normal_force_at`` of a one-sided elastic plane (``surface.normal``, ``.point``, ``.stiffness``,
    ``.damping``): f_n = max(0, k δ − c ν·ẋ) while δ = ν·(p_r − x) > 0, else 0; and ν."""
    n0, n1, n2 = xyz(surface.normal, space)
    r0, r1, r2 = xyz(surface.point, space)
    delta = n0 * (r0 - p0) + n1 * (r1 - p1) + n2 * (r2 - p2)
    if delta <= 0.0:
        return 0.0, n0, n1, n2
    return max(0.0, surface.stiffness * delta - surface.damping * (n0 * v0 + n1 * v1 + n2 * v2)), n0, n1, n2


class Environment(ABC):
    """An environment that pushes back on the end-effector.

    Convention of the chapter: the wrench returned is h_e, the force the end-effector exerts on
    the environment, expressed in the base frame. The arm feels ``−h_e`` ((9.1): ``−Jᵀ h_e``).
    """

    #: id of this environment's branch in the compiled loop (0: not compiled).
    kind: ClassVar[int] = 0
    #: False when :meth:`wrench` reads only the position and the linear velocity of a 6-D pose ``x = [o_e; φ_e]``
    #: (a surface pressed at o_e): the Python engine's integrator stages then skip the orientation's Euler angles and
    #: pass NaN in their place, so a wrench that read them after all would give NaN, never a silent number.
    reads_orientation: ClassVar[bool] = True
    #: True for an environment with a state of its own (e.g. friction's stick/slip): the simulator's
    #: Python loop then calls ``start(robot, q0, q̇0, rows)`` before the run, ``advance(robot, q, q̇)``
    #: after every integrator step, ``log_sample(k, x, ẋ)`` at every sample, and merges its ``signals()``.
    stateful: ClassVar[bool] = False
    #: operational-space dimension the environment works in.
    dim: int
    #: ``describe()["type"]`` (None: the class name) and the attributes it lists.
    describe_type: ClassVar[str | None] = None
    described: ClassVar[tuple[str, ...]] = ()

    @abstractmethod
    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        """h_e for the end-effector at x (m,) [m] moving at ẋ (m,) [m/s]; (m,) [N]."""

    @abstractmethod
    def max_stiffness(self) -> float:
        """Largest stiffness the environment can show [N/m] (sets the integration step)."""

    def packed(self) -> np.ndarray:
        """Flat parameters for the compiled loop (layout documented by each subclass)."""
        return np.zeros(0)

    def acceleration(self, robot, q: np.ndarray, qd: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint accelerations of the arm in contact and the contact wrench, for torques u held.

        The default is the elastic case: ``q̈ = B⁻¹ (u − n − Jᵀ h_e)`` with ``h_e = wrench(x, ẋ)``.
        Rigid environments override this with constrained dynamics (the reaction depends on u).

        Returns:
            q̈ (n,) [rad/s²] and h_e (m,) [N].
        """
        fast = getattr(robot, "elastic_acceleration", None)
        if fast is not None:  # a robot with its own forward dynamics (Pinocchio's ABA)
            if self.reads_orientation:
                return fast(q, qd, u, self.wrench)
            return fast(q, qd, u, self.wrench, orientation=False)
        T = robot.terms(q, qd)
        h = self.wrench(T.x, T.xd)
        return np.linalg.solve(T.B, u - T.n - T.J.T @ h), h

    def sampled_wrench(self, robot, q: np.ndarray, qd: np.ndarray, u_prev: np.ndarray) -> np.ndarray:
        """The true contact wrench at a sample instant, given the torque held until then.

        Elastic environments ignore ``u_prev``; a rigid one returns the reaction (9.87) under it.
        """
        pose_twist = getattr(robot, "pose_twist", None)
        if pose_twist is not None:  # kinematics only, where the robot offers it
            return self.wrench(*pose_twist(q, qd))
        T = robot.terms(q, qd)
        return self.wrench(T.x, T.xd)

    def describe(self) -> dict[str, Any]:
        """Parameters as plain values (for metadata): ``type`` (:attr:`describe_type`, the class name
        by default) and the attributes named in :attr:`described`, arrays as nested lists."""
        out: dict[str, Any] = {"type": self.describe_type or type(self).__name__}
        for name in self.described:
            value = getattr(self, name)
            out[name] = value.tolist() if isinstance(value, np.ndarray) else value
        return out
