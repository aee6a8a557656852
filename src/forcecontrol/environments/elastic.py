"""Elastic environments: a one-sided elastic plane and a general linear spring (9.38), (9.21)."""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit

from ..core.linalg import mv
from ..core.validate import as_gain_matrix, as_vector, nonnegative_scalar
from ..errors import DimensionError, ParameterError
from .base import Environment, plane_normal_force_at
from .surfaces import circle_wrench2

__all__ = ["ElasticPlane", "LinearSpring", "environment_wrench"]


@njit(cache=True)
def plane_wrench(x, xd, normal, point, k, c):  # pragma: no cover - compiled
    """Force on a one-sided frictionless elastic plane.

    With ν the outward unit normal (from the environment towards free space) and
    ``δ = ν · (p_r − x)`` the penetration, ``h_e = max(0, k δ − c ν·ẋ) (−ν)`` while δ > 0, else 0:
    the plane pushes back along its normal and never pulls.
    """
    m = x.shape[0]
    delta = 0.0
    vn = 0.0
    for i in range(m):
        delta += normal[i] * (point[i] - x[i])
        vn += normal[i] * xd[i]
    out = np.zeros(m)
    if delta <= 0.0:
        return out
    mag = k * delta - c * vn
    if mag <= 0.0:
        return out
    for i in range(m):
        out[i] = -mag * normal[i]
    return out


@njit(cache=True)
def environment_wrench(kind, p, x, xd):  # pragma: no cover - compiled
    """Compiled dispatcher over environment kinds (layouts: see each class's ``packed``)."""
    m = x.shape[0]
    if kind == 1:
        return plane_wrench(x, xd, p[0:m], p[m : 2 * m], p[2 * m], p[2 * m + 1])
    if kind == 2:
        mm = m * m
        K = p[0:mm].reshape((m, m))
        D = p[mm : 2 * mm].reshape((m, m))
        return mv(K, x - p[2 * mm : 2 * mm + m]) + mv(D, xd)
    if kind == 3 and m == 2:  # an elastic circle (surfaces.ElasticSphere in 2-D)
        out = np.zeros(m)
        out[0], out[1] = circle_wrench2(p, x[0], x[1], xd[0], xd[1])
        return out
    out = np.zeros(m)
    out[:] = np.nan
    return out


class ElasticPlane(Environment):
    """A frictionless, one-sided elastic plane (a line in 2-D) of any orientation.

    The contact force is along the plane's normal: ``f_e = k δ (−ν)`` with δ the penetration
    below the rest surface, plus an optional damping ``c δ̇``; it never pulls (unilateral).
    Example 9.2's plane ``x = 1`` has ``point = [1, 0]``, ``normal = [-1, 0]``, and gives
    ``f_x = k_x (x_e − x_r) > 0`` in contact.

    Args:
        point: a point of the undeformed surface, (m,) [m].
        normal: outward normal, pointing from the environment into free space, (m,); normalised.
        stiffness: k along the normal [N/m], > 0.
        damping: c along the normal [N s/m], >= 0.
    """

    kind: ClassVar[int] = 1
    describe_type: ClassVar[str | None] = "elastic-plane"
    described: ClassVar[tuple[str, ...]] = ("point", "normal", "stiffness", "damping")

    def __init__(self, point: Any, normal: Any, stiffness: float, damping: float = 0.0) -> None:
        self.point = as_vector("point", point)
        self.dim = int(self.point.shape[0])
        if self.dim not in (2, 3):
            raise DimensionError(f"point must have 2 or 3 components; got shape {self.point.shape}")
        nv = np.array(as_vector("normal", normal, self.dim))
        norm = float(np.linalg.norm(nv))
        if norm < 1e-12:
            raise ParameterError(f"normal must be a non-zero vector; got {nv.tolist()}")
        nv /= norm
        nv.flags.writeable = False
        self.normal = nv
        self.stiffness = nonnegative_scalar("stiffness", stiffness)
        if self.stiffness == 0.0:
            raise ParameterError("stiffness must be a positive number; got 0.0")
        self.damping = nonnegative_scalar("damping", damping)

    @classmethod
    def inclined(cls, angle: float, through: Any, stiffness: float, damping: float = 0.0) -> ElasticPlane:
        """The planar plane of Example 9.4: at ``angle`` [rad] to x0, through ``through``.

        The constraint frame has x_c along the plane and y_c out of the environment,
        ``R_c = [[cos a, −sin a], [sin a, cos a]]`` (9.85); the environment lies on the −y_c side.
        """
        normal = [-math.sin(angle), math.cos(angle)]
        return cls(through, normal, stiffness, damping)

    def penetration(self, x: Any) -> float:
        """δ = ν · (p_r − x) [m]: positive inside the environment."""
        return float(self.normal @ (self.point - np.asarray(x, dtype=np.float64)))

    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        """:func:`plane_wrench` in plain Python, the same sums in the same order (equal to the bit): a call costs
        less than entering the compiled one, and a compiled run's held wrench before t = 0 compiles nothing."""
        xs = np.asarray(x, dtype=np.float64).tolist()
        vs = np.asarray(xd, dtype=np.float64).tolist()
        nu, p = self.normal.tolist(), self.point.tolist()
        delta = 0.0
        vn = 0.0
        for i in range(len(xs)):
            delta += nu[i] * (p[i] - xs[i])
            vn += nu[i] * vs[i]
        mag = self.stiffness * delta - self.damping * vn
        if delta <= 0.0 or mag <= 0.0:
            return np.zeros(len(xs))
        return np.array([-mag * n for n in nu[: len(xs)]])

    def normal_force_at(self, p0: float, p1: float, p2: float, v0: float, v1: float,
                        v2: float) -> tuple[float, float, float, float]:
        """(f_n, ν0, ν1, ν2) at the point p moving at v, on scalars (a planar plane: p2 = v2 = 0, ν2 = 0), for the
        contact models built on this plane (:class:`~forcecontrol.environments.friction.FrictionalContact`)."""
        return plane_normal_force_at(self, self.dim, p0, p1, p2, v0, v1, v2)

    def stiffness_matrix(self) -> np.ndarray:
        """K = k ν νᵀ, the (m, m) positive semi-definite stiffness while in contact."""
        return self.stiffness * np.outer(self.normal, self.normal)

    def damping_matrix(self) -> np.ndarray:
        """``c n nᵀ`` (m, m) [N s/m]: the damping in contact (while the contact pushes)."""
        return self.damping * np.outer(self.normal, self.normal)

    def max_stiffness(self) -> float:
        return self.stiffness

    def packed(self) -> np.ndarray:
        """``[ν (m), p_r (m), k, c]``."""
        return np.concatenate([self.normal, self.point, [self.stiffness, self.damping]])


class LinearSpring(Environment):
    """A bilateral linear spring ``h_e = K (x_e − x_r) + D ẋ_e`` (9.38) with K symmetric PSD.

    Args:
        stiffness: K, symmetric positive semi-definite (m, m) [N/m] (scalar or diagonal allowed).
        rest_position: x_r, (m,) [m].
        damping: D, symmetric positive semi-definite (m, m) [N s/m]; zero by default.
    """

    kind: ClassVar[int] = 2
    describe_type: ClassVar[str | None] = "linear-spring"
    described: ClassVar[tuple[str, ...]] = ("stiffness", "rest_position", "damping")

    def __init__(self, stiffness: Any, rest_position: Any, damping: Any = 0.0) -> None:
        self.rest_position = as_vector("rest_position", rest_position)
        self.dim = int(self.rest_position.shape[0])
        self.stiffness = as_gain_matrix("stiffness", stiffness, self.dim, definite=False)
        self.damping = as_gain_matrix("damping", damping, self.dim, definite=False)

    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        return self.stiffness @ (np.asarray(x) - self.rest_position) + self.damping @ np.asarray(xd)

    def stiffness_matrix(self) -> np.ndarray:
        """K, (m, m)."""
        return np.array(self.stiffness)

    def damping_matrix(self) -> np.ndarray:
        """D (m, m) [N s/m]."""
        return np.array(self.damping)

    def max_stiffness(self) -> float:
        return float(np.linalg.eigvalsh(self.stiffness).max())

    def packed(self) -> np.ndarray:
        """``[K (m²), D (m²), x_r (m)]``."""
        return np.concatenate([self.stiffness.ravel(), self.damping.ravel(), self.rest_position])
