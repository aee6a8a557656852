"""6-D environments: a general six-DOF spring (9.21), a table (planar contact in 3-D), a constant wrench.

All work with the pose operational space of :class:`~forcecontrol.robots.pinocchio.PinocchioRobot`
(``task="pose"``): ``x = [o_e; φ_e]`` (XYZ Euler angles of R_e), ``ẋ = [ȯ_e; ω_e]`` (the twist),
and return ``h_e = [f_e; μ_e]``, the wrench the end-effector exerts on the environment, in the
base frame, the moment about the end-effector origin.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from ..core.validate import as_gain_matrix, as_vector, nonnegative_scalar, positive_scalar
from ..errors import ParameterError
from ..spatial import check_rotation
from ..spatial.closed_form import euler_xyz_to_rotation, rotation_vector  # per integrator stage
from .base import Environment, plane_normal_force_at

__all__ = ["SpatialSpring", "Table", "ConstantWrench"]


def _blockdiag(R: np.ndarray) -> np.ndarray:
    out = np.zeros((6, 6))
    out[:3, :3] = R
    out[3:, 3:] = R
    return out


class SpatialSpring(Environment):
    """A generalised spring between the end-effector frame and a rest frame O_r (9.21).

    ``h_e = K dx_{r,e} + D v_e`` with ``dx_{r,e} = [o_e − o_r; θ]``, θ the rotation vector of
    ``R_e R_rᵀ`` (the elementary rotation of (9.21) for small displacements, exact axis-angle for
    large ones). K and D are given in the rest frame and rotated to the base frame:
    ``K_0 = blockdiag(R_r, R_r) K blockdiag(R_r, R_r)ᵀ``.

    Args:
        stiffness: K, symmetric positive semi-definite (6, 6) [N/m, N/rad, N m/m, N m/rad];
            coupling blocks allowed.
        rest_position: o_r [m], (3,); rest_rotation: R_r (3, 3) (default identity).
        damping: D, symmetric positive semi-definite (6, 6) (default 0).
    """

    described: ClassVar[tuple[str, ...]] = ("stiffness", "damping", "rest_position", "rest_rotation")

    def __init__(self, stiffness: Any, rest_position: Any, rest_rotation: Any = None, damping: Any = 0.0) -> None:
        self.dim = 6
        self.stiffness = as_gain_matrix("stiffness", stiffness, 6, definite=False)
        self.damping = as_gain_matrix("damping", damping, 6, definite=False)
        self.rest_position = as_vector("rest_position", rest_position, 3)
        self.rest_rotation = check_rotation("rest_rotation", np.eye(3) if rest_rotation is None else rest_rotation)
        X = _blockdiag(self.rest_rotation)
        self._K0 = X @ self.stiffness @ X.T
        self._D0 = X @ self.damping @ X.T

    def displacement(self, x: np.ndarray) -> np.ndarray:
        """dx_{r,e} in the base frame, (6,)."""
        R_e = euler_xyz_to_rotation(x[3:])
        return np.concatenate([x[:3] - self.rest_position, rotation_vector(R_e @ self.rest_rotation.T)])

    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        return self._K0 @ self.displacement(x) + self._D0 @ xd

    def max_stiffness(self) -> float:
        return float(np.linalg.eigvalsh(self.stiffness).max())

    def stiffness_matrix(self) -> np.ndarray:
        """K in the base frame, (6, 6) (sets the simulator's integration step)."""
        return np.array(self._K0)

    def damping_matrix(self) -> np.ndarray:
        """D in the base frame, (6, 6) [N s/m, N m s/rad]."""
        return np.array(self._D0)


class Table(Environment):
    """A horizontal-or-not elastic table: one-sided, frictionless point contact at the end-effector origin.

    With ν the outward unit normal and ``δ = ν · (p_r − o_e)`` the penetration:
    ``f_e = max(0, k δ − c ν·ȯ_e) (−ν)`` while δ > 0, else 0; ``μ_e = 0`` (contact at o_e).

    Args:
        point: a point of the undeformed surface [m], (3,); normal: outward normal (3,).
        stiffness: k [N/m] > 0; damping: c [N s/m] >= 0.
    """

    described: ClassVar[tuple[str, ...]] = ("point", "normal", "stiffness", "damping")
    reads_orientation: ClassVar[bool] = False

    def __init__(self, point: Any, normal: Any = (0.0, 0.0, 1.0), stiffness: float = 1e4, damping: float = 0.0) -> None:
        self.dim = 6
        self.point = as_vector("point", point, 3)
        nrm = np.array(as_vector("normal", normal, 3))
        length = float(np.linalg.norm(nrm))
        if length < 1e-12:
            raise ParameterError(f"normal must be a non-zero vector; got {nrm.tolist()}")
        self.normal = nrm / length
        self.stiffness = positive_scalar("stiffness", stiffness)
        self.damping = nonnegative_scalar("damping", damping)

    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        out = np.zeros(6)
        delta = float(self.normal @ (self.point - x[:3]))
        if delta <= 0.0:
            return out
        mag = self.stiffness * delta - self.damping * float(self.normal @ xd[:3])
        if mag > 0.0:
            out[:3] = -mag * self.normal
        return out

    def normal_force_at(self, p0: float, p1: float, p2: float, v0: float, v1: float,
                        v2: float) -> tuple[float, float, float, float]:
        """(f_n, ν0, ν1, ν2) at the tool's position p moving at v, on scalars (for FrictionalContact)."""
        return plane_normal_force_at(self, 3, p0, p1, p2, v0, v1, v2)

    def max_stiffness(self) -> float:
        return self.stiffness

    def stiffness_matrix(self) -> np.ndarray:
        """The (6, 6) stiffness in contact: ``k ν νᵀ`` on the force block, zero elsewhere."""
        K = np.zeros((6, 6))
        K[:3, :3] = self.stiffness * np.outer(self.normal, self.normal)
        return K

    def damping_matrix(self) -> np.ndarray:
        """The (6, 6) damping in contact: ``c ν νᵀ`` on the force block (while the contact pushes)."""
        D = np.zeros((6, 6))
        D[:3, :3] = self.damping * np.outer(self.normal, self.normal)
        return D


class ConstantWrench(Environment):
    """A constant external wrench: ``h_e`` (6,) whatever the pose (a step when the run starts).

    Args:
        wrench: ``[f_e; μ_e]`` [N, N m], base frame, about the end-effector origin.
    """

    kind: ClassVar[int] = 0
    reads_orientation: ClassVar[bool] = False

    def __init__(self, wrench: Any) -> None:
        self.dim = 6
        self.value = as_vector("wrench", wrench, 6)

    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        return np.array(self.value)

    def max_stiffness(self) -> float:
        return 0.0

    def describe(self) -> dict[str, Any]:
        return {"type": "ConstantWrench", "wrench": self.value.tolist()}
