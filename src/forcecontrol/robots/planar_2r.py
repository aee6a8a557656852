"""The chapter's two-link planar arm (Example 7.2 with the data of Sect. 8.7), in closed form.

Joint angles: ``q1`` from the base x0 axis, ``q2`` relative at the elbow. The arm moves in a
vertical plane: x0 horizontal, y0 up, gravity along −y0. The tip position is
``p = [a1 c1 + a2 c12, a1 s1 + a2 s12]``; the operational space is that position (m = 2).

Dynamics (motor inertias included, the form of Example 7.2)::

    b11 = I_l1 + m_l1 l1² + k_r1² I_m1 + I_l2 + m_l2 (a1² + l2² + 2 a1 l2 c2) + I_m2 + m_m2 a1²
    b12 = I_l2 + m_l2 (l2² + a1 l2 c2) + k_r2 I_m2
    b22 = I_l2 + m_l2 l2² + k_r2² I_m2
    h   = −m_l2 a1 l2 s2,    C = [[h q̇2, h (q̇1 + q̇2)], [−h q̇1, 0]]
    g1  = g0 ((m_l1 l1 + m_m2 a1 + m_l2 a1) c1 + m_l2 l2 c12),   g2 = g0 m_l2 l2 c12

The kernels below are compiled with Numba and shared by the Python API and the compiled
simulation loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numba import njit

from ..core.linalg import SINGULAR_RCOND as _SINGULAR
from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import DimensionError, WorkspaceError
from .base import RobotTerms

__all__ = ["PlanarTwoLink", "PlanarTwoLinkParameters", "CHAPTER_ARM"]


@dataclass(frozen=True)
class PlanarTwoLinkParameters:
    """Physical data of a two-link planar arm with motors (SI units).

    Defaults are the chapter's arm (``../shared/reference/two-link-arm.md``): the book's
    companion code, Sect. 8.7.
    """

    a1: float = 1.0  #: link 1 length [m]
    a2: float = 1.0  #: link 2 length [m]
    l1: float = 0.5  #: joint 1 to link 1 centre of mass [m]
    l2: float = 0.5  #: joint 2 to link 2 centre of mass [m]
    m_l1: float = 50.0  #: link 1 mass [kg]
    m_l2: float = 50.0  #: link 2 mass [kg]
    I_l1: float = 10.0  #: link 1 inertia about its centre of mass [kg m²]
    I_l2: float = 10.0  #: link 2 inertia about its centre of mass [kg m²]
    m_m1: float = 5.0  #: motor 1 mass [kg] (sits at the base: never enters the dynamics)
    m_m2: float = 5.0  #: motor 2 mass [kg] (sits at the elbow)
    I_m1: float = 0.01  #: rotor 1 inertia [kg m²]
    I_m2: float = 0.01  #: rotor 2 inertia [kg m²]
    k_r1: float = 100.0  #: gear ratio 1
    k_r2: float = 100.0  #: gear ratio 2
    F1: float = 100.0  #: viscous friction at joint 1 (K_r F_m K_r) [N m s/rad]
    F2: float = 100.0  #: viscous friction at joint 2 [N m s/rad]
    gravity: float = 9.81  #: gravity acceleration along −y0 [m/s²]

    def __post_init__(self) -> None:
        for name in ("a1", "a2", "m_l1", "m_l2", "k_r1", "k_r2"):
            positive_scalar(name, getattr(self, name))
        for name in ("l1", "l2", "I_l1", "I_l2", "m_m1", "m_m2", "I_m1", "I_m2", "F1", "F2", "gravity"):
            nonnegative_scalar(name, getattr(self, name))

    def kernel_vector(self) -> np.ndarray:
        """The 12 coefficients the compiled kernels use (layout documented in ``_terms``)."""
        p = self
        b11_0 = (
            p.I_l1 + p.m_l1 * p.l1**2 + p.k_r1**2 * p.I_m1 + p.I_l2
            + p.m_l2 * (p.a1**2 + p.l2**2) + p.I_m2 + p.m_m2 * p.a1**2
        )
        b11_1 = 2.0 * p.m_l2 * p.a1 * p.l2
        b12_0 = p.I_l2 + p.m_l2 * p.l2**2 + p.k_r2 * p.I_m2
        b12_1 = p.m_l2 * p.a1 * p.l2
        b22 = p.I_l2 + p.m_l2 * p.l2**2 + p.k_r2**2 * p.I_m2
        ch = p.m_l2 * p.a1 * p.l2
        gc1 = p.gravity * (p.m_l1 * p.l1 + p.m_m2 * p.a1 + p.m_l2 * p.a1)
        gc2 = p.gravity * p.m_l2 * p.l2
        v = np.array([p.a1, p.a2, b11_0, b11_1, b12_0, b12_1, b22, ch, gc1, gc2, p.F1, p.F2])
        v.flags.writeable = False
        return v


# --------------------------------------------------------------------------- compiled kernels
# K = [a1, a2, b11_0, b11_1, b12_0, b12_1, b22, ch, gc1, gc2, F1, F2]


@njit(cache=True, inline="always")
def _terms_into(q, qd, K, x, xd, J, Jdq, B, nv, g):  # pragma: no cover - compiled
    """Fill x, ẋ, J, J̇q̇, B, n = Cq̇ + Fq̇ + g and g for the state (q, q̇).

    Inlined into its two callers (:func:`_terms` here, ``laws.arm.arm_inputs``), so it is never
    compiled as a function of its own: one compile per caller instead of two (a cold first run
    compiled both, 0.2 s).
    """
    a1 = K[0]
    a2 = K[1]
    c1 = math.cos(q[0])
    s1 = math.sin(q[0])
    c2 = math.cos(q[1])
    s2 = math.sin(q[1])
    c12 = math.cos(q[0] + q[1])
    s12 = math.sin(q[0] + q[1])
    x[0] = a1 * c1 + a2 * c12
    x[1] = a1 * s1 + a2 * s12
    J[0, 0] = -a1 * s1 - a2 * s12
    J[0, 1] = -a2 * s12
    J[1, 0] = a1 * c1 + a2 * c12
    J[1, 1] = a2 * c12
    xd[0] = J[0, 0] * qd[0] + J[0, 1] * qd[1]
    xd[1] = J[1, 0] * qd[0] + J[1, 1] * qd[1]
    w1 = qd[0]
    w12 = qd[0] + qd[1]
    Jdq[0] = -a1 * c1 * w1 * w1 - a2 * c12 * w12 * w12
    Jdq[1] = -a1 * s1 * w1 * w1 - a2 * s12 * w12 * w12
    B[0, 0] = K[2] + K[3] * c2
    B[0, 1] = K[4] + K[5] * c2
    B[1, 0] = B[0, 1]
    B[1, 1] = K[6]
    h = -K[7] * s2
    g[0] = K[8] * c1 + K[9] * c12
    g[1] = K[9] * c12
    # C q̇ with C = [[h q̇2, h (q̇1 + q̇2)], [−h q̇1, 0]]
    nv[0] = h * qd[1] * qd[0] + h * (qd[0] + qd[1]) * qd[1] + K[10] * qd[0] + g[0]
    nv[1] = -h * qd[0] * qd[0] + K[11] * qd[1] + g[1]


@njit(cache=True)
def _terms(q, qd, K):  # pragma: no cover - compiled
    x = np.empty(2)
    xd = np.empty(2)
    J = np.empty((2, 2))
    Jdq = np.empty(2)
    B = np.empty((2, 2))
    nv = np.empty(2)
    g = np.empty(2)
    _terms_into(q, qd, K, x, xd, J, Jdq, B, nv, g)
    return x, xd, J, Jdq, B, nv, g


@njit(cache=True)
def _pose_twist(q, qd, K):  # pragma: no cover - compiled
    """(x0, x1, ẋ0, ẋ1) as scalars, the expressions of :func:`_terms_into`."""
    a1 = K[0]
    a2 = K[1]
    c1 = math.cos(q[0])
    s1 = math.sin(q[0])
    c12 = math.cos(q[0] + q[1])
    s12 = math.sin(q[0] + q[1])
    j00 = -a1 * s1 - a2 * s12
    j01 = -a2 * s12
    j10 = a1 * c1 + a2 * c12
    j11 = a2 * c12
    return a1 * c1 + a2 * c12, a1 * s1 + a2 * s12, j00 * qd[0] + j01 * qd[1], j10 * qd[0] + j11 * qd[1]


@njit(cache=True)
def _plant_terms(q, qd, K):  # pragma: no cover - compiled
    """What the plant needs at (q, q̇) as 13 scalars: x (2), ẋ (2), J (row-major, 4), B00, B01, B11, n (2).

    :func:`_terms`'s arithmetic (called inside the compiled code); scalars cross into Python for a
    fraction of the cost of the seven arrays :func:`_terms` returns."""
    x, xd, J, _Jdq, B, nv, _g = _terms(q, qd, K)
    return x[0], x[1], xd[0], xd[1], J[0, 0], J[0, 1], J[1, 0], J[1, 1], B[0, 0], B[0, 1], B[1, 1], nv[0], nv[1]


@njit(cache=True)
def _coriolis(q, qd, K):  # pragma: no cover - compiled
    h = -K[7] * math.sin(q[1])
    C = np.empty((2, 2))
    C[0, 0] = h * qd[1]
    C[0, 1] = h * (qd[0] + qd[1])
    C[1, 0] = -h * qd[0]
    C[1, 1] = 0.0
    return C


# --------------------------------------------------------------------------- public class


def _state(name: str, v, n: int = 2) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (n,):
        raise DimensionError(f"{name} must have shape ({n},); got shape {a.shape}")
    return a


@dataclass(frozen=True)
class PlanarTwoLink:
    """The two-link planar arm of the chapter, in closed form (implements :class:`RobotModel`).

    Args:
        parameters: physical data; the chapter's arm by default.

    Example:
        >>> arm = PlanarTwoLink()
        >>> q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")   # [π/3, −2π/3]
    """

    parameters: PlanarTwoLinkParameters = field(default_factory=PlanarTwoLinkParameters)
    nq: int = field(default=2, init=False)
    task_dim: int = field(default=2, init=False)
    _K: np.ndarray = field(init=False, repr=False, compare=False)
    _Kf: tuple[float, ...] = field(init=False, repr=False, compare=False)  # _K as floats, for the closed forms

    def __post_init__(self) -> None:
        object.__setattr__(self, "_K", self.parameters.kernel_vector())
        object.__setattr__(self, "_Kf", tuple(self._K.tolist()))

    # The single quantities (x, J, J̇q̇, B, g, n) in plain Python: the expressions of _terms_into, term for term, so equal
    # to the compiled terms() to the bit (tests/test_planar_2r.py); a quarter of the cost of a call into _terms
    # (which boxes seven arrays), and nothing to compile for a run that only asks for them before its loop
    # (contact_rate, the held torque g(q0): 0.6 s of Example 9.2's cold run).
    def _trig(self, q) -> tuple[float, float, float, float, float, float]:
        q0, q1 = _state("q", q).tolist()
        return math.cos(q0), math.sin(q0), math.cos(q1), math.sin(q1), math.cos(q0 + q1), math.sin(q0 + q1)

    # -- kinematics
    def forward_kinematics(self, q) -> np.ndarray:
        """Tip position ``[a1 c1 + a2 c12, a1 s1 + a2 s12]`` [m]."""
        a1, a2 = self._Kf[0], self._Kf[1]
        c1, s1, _, _, c12, s12 = self._trig(q)
        return np.array((a1 * c1 + a2 * c12, a1 * s1 + a2 * s12))

    def joint_positions(self, q) -> np.ndarray:
        """Base, elbow and tip positions in the base frame, (3, 2) [m] (for drawing the arm).

        Raises:
            DimensionError, MeasurementError: ``q`` is not a finite (2,) vector.
        """
        q = _state("q", q)
        p = self.parameters
        elbow = np.array([p.a1 * np.cos(q[0]), p.a1 * np.sin(q[0])])
        return np.vstack([np.zeros(2), elbow, self.forward_kinematics(q)])

    def jacobian(self, q) -> np.ndarray:
        """Geometric Jacobian of the tip position, (2, 2)."""
        a1, a2 = self._Kf[0], self._Kf[1]
        c1, s1, _, _, c12, s12 = self._trig(q)
        return np.array(((-a1 * s1 - a2 * s12, -a2 * s12), (a1 * c1 + a2 * c12, a2 * c12)))

    def jdot_qdot(self, q, qd) -> np.ndarray:
        """``J̇(q, q̇) q̇`` [m/s²]."""
        a1, a2 = self._Kf[0], self._Kf[1]
        c1, s1, _, _, c12, s12 = self._trig(q)
        w1, w2 = _state("qd", qd).tolist()
        w12 = w1 + w2
        return np.array((-a1 * c1 * w1 * w1 - a2 * c12 * w12 * w12, -a1 * s1 * w1 * w1 - a2 * s12 * w12 * w12))

    def inverse_kinematics(self, position, elbow: Literal["up", "down"] = "up") -> np.ndarray:
        """Joint angles that put the tip at ``position``.

        Args:
            position: tip position [x, y] in the base frame [m].
            elbow: ``"up"`` gives q2 <= 0 (the chapter's posture: [1, 0] -> [π/3, −2π/3]),
                ``"down"`` gives q2 >= 0.

        Raises:
            WorkspaceError: the position is out of reach.
        """
        p = _state("position", position)
        if elbow not in ("up", "down"):
            raise WorkspaceError(f"elbow must be 'up' or 'down'; got {elbow!r}")
        a1, a2 = self.parameters.a1, self.parameters.a2
        r2 = float(p @ p)
        c2 = (r2 - a1 * a1 - a2 * a2) / (2.0 * a1 * a2)
        if not (-1.0 - 1e-12 <= c2 <= 1.0 + 1e-12):
            raise WorkspaceError(
                f"position {p.tolist()} is outside the workspace: its distance from the base "
                f"{math.sqrt(r2):.6g} m must lie in [{abs(a1 - a2):.6g}, {a1 + a2:.6g}] m"
            )
        c2 = min(1.0, max(-1.0, c2))
        s2 = math.sqrt(1.0 - c2 * c2) * (-1.0 if elbow == "up" else 1.0)
        q2 = math.atan2(s2, c2)
        q1 = math.atan2(p[1], p[0]) - math.atan2(a2 * s2, a1 + a2 * c2)
        return np.array([q1, q2])

    # -- dynamics
    def mass_matrix(self, q) -> np.ndarray:
        """B(q) [kg m²]."""
        K = self._Kf
        c2 = self._trig(q)[2]
        b12 = K[4] + K[5] * c2
        return np.array(((K[2] + K[3] * c2, b12), (b12, K[6])))

    def coriolis_matrix(self, q, qd) -> np.ndarray:
        """C(q, q̇) of Example 7.2 (Christoffel form, so Ḃ − 2C is skew-symmetric)."""
        return _coriolis(_state("q", q), _state("qd", qd), self._K)

    def friction_matrix(self) -> np.ndarray:
        """F = diag(F1, F2) [N m s/rad]."""
        return np.diag([self.parameters.F1, self.parameters.F2])

    def gravity(self, q) -> np.ndarray:
        """g(q) [N m]."""
        K = self._Kf
        c1, _, _, _, c12, _ = self._trig(q)
        return np.array((K[8] * c1 + K[9] * c12, K[9] * c12))

    def nonlinear_effects(self, q, qd) -> np.ndarray:
        """n(q, q̇) = C q̇ + F q̇ + g (8.56) [N m]."""
        K = self._Kf
        c1, _, _, s2, c12, _ = self._trig(q)
        w0, w1 = _state("qd", qd).tolist()
        h = -K[7] * s2
        g0, g1 = K[8] * c1 + K[9] * c12, K[9] * c12
        return np.array((h * w1 * w0 + h * (w0 + w1) * w1 + K[10] * w0 + g0, -h * w0 * w0 + K[11] * w1 + g1))

    def potential_energy(self, q) -> float:
        """Gravitational potential energy U(q) [J] (zero at y = 0 for every mass)."""
        q = _state("q", q)
        p = self.parameters
        return p.gravity * (
            (p.m_l1 * p.l1 + (p.m_m2 + p.m_l2) * p.a1) * math.sin(q[0])
            + p.m_l2 * p.l2 * math.sin(q[0] + q[1])
        )

    def terms(self, q: np.ndarray, qd: np.ndarray) -> RobotTerms:
        """x, ẋ, J, J̇q̇, B, n, g in one compiled call (the hot path; no shape checks)."""
        return RobotTerms(*_terms(q, qd, self._K))

    # -- the simulator's hot path (Environment.sampled_wrench and .acceleration use these when present)
    def pose_twist(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x, ẋ) of the tip from the kinematics alone, the same numbers as ``terms(q, qd).x, .xd`` (no checks).

        In plain Python, the expressions of :func:`_pose_twist` (the compiled loops' copy) term for term: equal to
        the bit, at half the cost of calling it (and nothing to compile for the held wrench before a compiled run).
        """
        a1, a2 = self._Kf[0], self._Kf[1]
        q0, q1 = np.asarray(q, dtype=np.float64).tolist()
        w0, w1 = np.asarray(qd, dtype=np.float64).tolist()
        c1, s1, c12, s12 = math.cos(q0), math.sin(q0), math.cos(q0 + q1), math.sin(q0 + q1)
        j00, j01, j10, j11 = -a1 * s1 - a2 * s12, -a2 * s12, a1 * c1 + a2 * c12, a2 * c12
        return np.array((a1 * c1 + a2 * c12, a1 * s1 + a2 * s12)), np.array((j00 * w0 + j01 * w1, j10 * w0 + j11 * w1))

    def elastic_acceleration(self, q: np.ndarray, qd: np.ndarray, u: np.ndarray, wrench,
                             orientation: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The plant (9.1) on an elastic environment: ``q̈ = B⁻¹ (u − n − Jᵀ h_e)`` with ``h_e = wrench(x, ẋ)``.

        One compiled call for the terms, then the 2×2 system in closed form, by the inverse as the
        compiled loops do (``core.linalg.solve2_spd``): equal to ``np.linalg.solve(B, u − n − Jᵀ h)``
        to round-off at a fifth of its cost. A B that is not numerically positive definite (a
        non-finite state) goes to ``np.linalg.solve``, which then decides as before (no checks).
        ``orientation`` is accepted for the 6-D robots' signature; a planar task has no angles.

        Returns:
            q̈ (2,) [rad/s²] and h_e (2,) [N].
        """
        x0, x1, v0, v1, j00, j01, j10, j11, b00, b01, b11, n0, n1 = _plant_terms(q, qd, self._K)
        h = np.asarray(wrench(np.array((x0, x1)), np.array((v0, v1))), dtype=np.float64)
        h0, h1 = h.tolist()
        u0, u1 = np.asarray(u, dtype=np.float64).tolist()
        r0 = (u0 - n0) - (j00 * h0 + j10 * h1)
        r1 = (u1 - n1) - (j01 * h0 + j11 * h1)
        scale = max(abs(b00), abs(b01), abs(b11))
        det = b00 * b11 - b01 * b01
        if not (det > _SINGULAR * scale * scale and math.isfinite(det)):
            return np.linalg.solve(np.array(((b00, b01), (b01, b11))), np.array((r0, r1))), h
        inv = 1.0 / det
        return np.array(((b11 * r0 - b01 * r1) * inv, (b00 * r1 - b01 * r0) * inv)), h


#: the chapter's arm with its data.
CHAPTER_ARM = PlanarTwoLink()
