"""Rigid environments: holonomic constraints φ(q) = 0 simulated with constrained dynamics (Sect. 9.5.1, 9.7.2).

The arm ``B q̈ + n = u − Jᵀ h_e`` meets m frictionless constraints ``φ(q) = 0`` (9.50). The
reaction is ``Jᵀ h_e = J_φᵀ λ``, i.e. ``h_e = S_f λ`` with ``S_f = J⁻ᵀ J_φᵀ`` (9.52)–(9.53), and λ
is whatever keeps the constraint: differentiating (9.51) once more,
``J_φ q̈ + J̇_φ q̇ = s``, gives

    λ = (J_φ B⁻¹ J_φᵀ)⁻¹ (J_φ B⁻¹ (u − n) + J̇_φ q̇ − s),      q̈ = B⁻¹ (u − n − J_φᵀ λ),

the joint-space form of (9.87)–(9.88) (with ``u = Jᵀ γ_e``, ``B_e = J⁻ᵀ B J⁻¹``,
``n_e = J⁻ᵀ n − B_e J̇ q̇`` the two are the same equations).

Drift: with ``s = 0`` the solution of (9.88) keeps φ = 0 only in exact arithmetic; integration
errors make φ and φ̇ drift. It is kept bounded by Baumgarte stabilisation,
``s = −2 ω_b φ̇ − ω_b² φ``: the violation obeys ``φ̈ + 2 ω_b φ̇ + ω_b² φ = 0`` (critically damped,
time constant 1/ω_b), so integration errors decay instead of growing. The default
``ω_b = 100 rad/s`` is fast against the arm's controlled motion yet ``ω_b h = 0.1`` for the RK4
step ``h = 1 ms``. The reaction this adds is of the order of the violation times ``ω_b²`` times
the constrained mass, negligible at the violation levels met (below 1e-9 m in the tests).

Unilateral contact: the environment can only push. With φ ≥ 0 on the free side, a constraint is
active when ``φ ≤ contact_tolerance`` and its multiplier pushes, ``λ ≤ 0`` (the sign of (9.52):
h_e is the force the end-effector exerts, so pushing into a plane whose S_f is its outward
normal has λ < 0, as the λ_d = −50 N of Problem 9.10). A constraint whose λ would pull is
released (an active-set pass), and the arm moves off freely. The contact band
``contact_tolerance`` (1 µm by default) must exceed the stabilised violation: with a band at
round-off level the contact flickers off whenever φ drifts to +1e-9 m, the free dynamics act for
part of an RK4 step, and the violation grows to 1e-7 m (measured); with 1 µm it stays below
1e-10 m on the Problem 9.10 path. Coming back, a penetrating
constraint is re-activated and the Baumgarte term pushes the tip back to the surface: the impact
is not impulsive but a fast critically damped return (penetration about ``|φ̇| /(e ω_b)``).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np

from ..core.linalg import SINGULAR_RCOND
from ..core.validate import as_vector, positive_scalar
from ..errors import DimensionError, ParameterError, SingularityError
from .base import Environment

__all__ = [
    "HolonomicConstraint",
    "OperationalConstraint",
    "PlaneConstraint",
    "CircleConstraint",
    "JointConstraint",
    "RigidEnvironment",
]


class HolonomicConstraint(ABC):
    """m holonomic constraints ``φ(q) = 0`` (9.50) on the arm's joints.

    Attributes:
        size: m, the number of constraint equations.
    """

    size: int

    @abstractmethod
    def value(self, robot, q: np.ndarray) -> np.ndarray:
        """φ(q), (m,) (metres for position constraints; ≥ 0 on the free side)."""

    @abstractmethod
    def jacobian(self, robot, q: np.ndarray) -> np.ndarray:
        """The constraint Jacobian J_φ(q) = ∂φ/∂q, (m, n)."""

    @abstractmethod
    def jdot_qdot(self, robot, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """``J̇_φ(q, q̇) q̇``, (m,)."""

    def terms(self, robot, q: np.ndarray, qd: np.ndarray, T=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """φ, J_φ and J̇_φ q̇ at once (``T`` the robot's terms, when already computed)."""
        return self.value(robot, q), self.jacobian(robot, q), self.jdot_qdot(robot, q, qd)

    def describe(self) -> dict[str, Any]:
        return {"type": type(self).__name__, "size": self.size}


class OperationalConstraint(HolonomicConstraint):
    """A constraint on the end-effector's operational coordinates, ``φ(q) = ψ(x(q))``.

    Then ``J_φ = G(x) J(q)`` with ``G = ∂ψ/∂x`` and ``J̇_φ q̇ = G J̇ q̇ + Ġ ẋ``, and ``S_f = Gᵀ``
    (9.53), independent of the arm.
    """

    dim: int

    @abstractmethod
    def psi(self, x: np.ndarray) -> np.ndarray:
        """ψ(x), (m,)."""

    @abstractmethod
    def gradient(self, x: np.ndarray) -> np.ndarray:
        """G(x) = ∂ψ/∂x, (m, dim)."""

    @abstractmethod
    def gradient_rate(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        """``Ġ(x, ẋ) ẋ``, (m,)."""

    def value(self, robot, q):
        return self.psi(robot.forward_kinematics(q))

    def jacobian(self, robot, q):
        return self.gradient(robot.forward_kinematics(q)) @ robot.jacobian(q)

    def jdot_qdot(self, robot, q, qd):
        T = robot.terms(np.asarray(q, dtype=np.float64), np.asarray(qd, dtype=np.float64))
        return self.terms(robot, q, qd, T)[2]

    def terms(self, robot, q, qd, T=None):
        if T is None:
            T = robot.terms(np.asarray(q, dtype=np.float64), np.asarray(qd, dtype=np.float64))
        G = self.gradient(T.x)
        return self.psi(T.x), G @ T.J, G @ T.Jdq + self.gradient_rate(T.x, T.xd)

    def force_selection(self, x: Any) -> np.ndarray:
        """S_f = Gᵀ(x) (9.53 with J_φ = G J), (dim, m)."""
        return self.gradient(np.asarray(x, dtype=np.float64)).T

    def gradient_dot(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        """Ġ(x, ẋ), (m, dim): needed for Ṡ_f, Ṡ_v of a moving contact geometry."""
        raise NotImplementedError(f"{type(self).__name__} does not provide Ġ")

    def selection(self, x: Any, xd: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """S_f, S_v and Ṡ_v at the end-effector state, for one constraint in the plane (dim 2, m 1).

        ``S_f = n = Gᵀ/|G|`` (9.53, normalised: λ is the force along n [N]), ``S_v = [n_y, −n_x]ᵀ``
        (reciprocal, (9.58); x_c of Example 9.4 for a plane) and ``Ṡ_v`` from
        ``ṅ = (I − n nᵀ) Ġᵀ/|G|``; the columns are unit vectors, so ``S† = Sᵀ`` with W = I.
        """
        if self.dim != 2 or self.size != 1:
            raise ParameterError(
                f"selection follows one constraint in the plane (dim 2, size 1); got dim {self.dim}, size {self.size}"
            )
        x = np.asarray(x, dtype=np.float64)
        xd = np.asarray(xd, dtype=np.float64)
        g = self.gradient(x)[0]
        norm = float(np.linalg.norm(g))
        n = g / norm
        gd = self.gradient_dot(x, xd)[0]
        nd = (gd - n * float(n @ gd)) / norm
        return n[:, None], np.array([[n[1]], [-n[0]]]), np.array([[nd[1]], [-nd[0]]])


class PlaneConstraint(OperationalConstraint):
    """The tip on a rigid plane (a line in 2-D): ``φ = νᵀ (x − p) = 0``.

    Args:
        point: a point of the surface, (dim,) [m].
        normal: outward normal, from the environment into free space, (dim,); normalised.
    """

    size = 1

    def __init__(self, point: Any, normal: Any) -> None:
        self.point = as_vector("point", point)
        self.dim = int(self.point.shape[0])
        nv = np.array(as_vector("normal", normal, self.dim))
        norm = float(np.linalg.norm(nv))
        if norm < 1e-12:
            raise ParameterError(f"normal must be a non-zero vector; got {nv.tolist()}")
        self.normal = nv / norm
        self.normal.flags.writeable = False

    @classmethod
    def inclined(cls, angle: float, through: Any) -> PlaneConstraint:
        """The planar surface of Example 9.4 at ``angle`` to x0 through ``through`` (y_c outward)."""
        return cls(through, [-math.sin(angle), math.cos(angle)])

    def psi(self, x):
        return np.array([float(self.normal @ (x - self.point))])

    def gradient(self, x):
        return self.normal[None, :].copy()

    def gradient_rate(self, x, xd):
        return np.zeros(1)

    def gradient_dot(self, x, xd):
        return np.zeros((1, self.dim))

    def describe(self):
        return {"type": "plane", "point": self.point.tolist(), "normal": self.normal.tolist()}


class CircleConstraint(OperationalConstraint):
    """The tip held on a circle (a crank handle), ``φ = |x − c| − r = 0``; S_f is radial.

    Args:
        center: c, (dim,) [m]; radius: r [m], > 0.
    """

    size = 1

    def __init__(self, center: Any, radius: float) -> None:
        self.center = as_vector("center", center)
        self.dim = int(self.center.shape[0])
        self.radius = positive_scalar("radius", radius)

    def psi(self, x):
        return np.array([float(np.linalg.norm(x - self.center)) - self.radius])

    def gradient(self, x):
        d = x - self.center
        return (d / np.linalg.norm(d))[None, :]

    def gradient_rate(self, x, xd):
        d = x - self.center
        rho = float(np.linalg.norm(d))
        u = d / rho
        return np.array([(float(xd @ xd) - float(u @ xd) ** 2) / rho])

    def gradient_dot(self, x, xd):
        d = x - self.center
        rho = float(np.linalg.norm(d))
        u = d / rho
        return ((xd - u * float(u @ xd)) / rho)[None, :]

    def describe(self):
        return {"type": "circle", "center": self.center.tolist(), "radius": self.radius}


class JointConstraint(HolonomicConstraint):
    """A general joint-space constraint from functions of q.

    Args:
        phi: ``q -> φ(q)``, (m,).
        jacobian: ``q -> J_φ(q)``, (m, n).
        jdot_qdot: ``(q, q̇) -> J̇_φ q̇``; by default a central difference of J_φ along q̇.
        size: m.
    """

    def __init__(
        self,
        phi: Callable[[np.ndarray], Any],
        jacobian: Callable[[np.ndarray], Any],
        size: int,
        jdot_qdot: Callable[[np.ndarray, np.ndarray], Any] | None = None,
    ) -> None:
        if int(size) != size or size < 1:
            raise ParameterError(f"size must be a positive integer; got {size!r}")
        self.size = int(size)
        self._phi, self._jac, self._jdq = phi, jacobian, jdot_qdot

    def value(self, robot, q):
        return np.atleast_1d(np.asarray(self._phi(q), dtype=np.float64))

    def jacobian(self, robot, q):
        return np.atleast_2d(np.asarray(self._jac(q), dtype=np.float64))

    def jdot_qdot(self, robot, q, qd):
        if self._jdq is not None:
            return np.atleast_1d(np.asarray(self._jdq(q, qd), dtype=np.float64))
        eps = 1e-6
        Jp = self.jacobian(robot, q + eps * qd)
        Jm = self.jacobian(robot, q - eps * qd)
        return (Jp - Jm) @ qd / (2.0 * eps)


def _inverse2(B: np.ndarray) -> np.ndarray | None:
    """B⁻¹ of a symmetric positive definite 2×2 inertia by its adjugate (``core.linalg.solve2_spd``'s test),
    or None when B is not numerically positive definite (the caller then solves as before)."""
    b00, b01, b10, b11 = B.ravel().tolist()
    scale = max(abs(b00), abs(b01), abs(b11))
    det = b00 * b11 - b01 * b10
    if not (det > SINGULAR_RCOND * scale * scale and math.isfinite(det)):
        return None
    inv = 1.0 / det
    return np.array(((b11 * inv, -b01 * inv), (-b10 * inv, b00 * inv)))


class RigidEnvironment(Environment):
    """A rigid, frictionless environment: holonomic constraints with constrained dynamics.

    Overrides :meth:`Environment.acceleration` (constrained dynamics (9.87)–(9.88), Baumgarte
    stabilised) and :meth:`Environment.sampled_wrench` (the reaction (9.52) under the torque held);
    ``kind = 0``, so :func:`forcecontrol.simulate` runs its Python loop.

    Args:
        constraint: the constraints φ(q) = 0.
        unilateral: the environment can only push (a surface), and lets go instead of pulling;
            False: bilateral (a gripper on a crank).
        stabilisation_frequency: ω_b [rad/s] of the Baumgarte term.
        contact_tolerance: a unilateral constraint counts as in contact when φ ≤ this [m].
        dim: operational dimension (taken from an operational constraint when omitted).
    """

    kind: ClassVar[int] = 0

    def __init__(
        self,
        constraint: HolonomicConstraint,
        *,
        unilateral: bool = False,
        stabilisation_frequency: float = 100.0,
        contact_tolerance: float = 1e-6,
        dim: int | None = None,
    ) -> None:
        if not isinstance(constraint, HolonomicConstraint):
            raise ParameterError(f"constraint must be a HolonomicConstraint; got {type(constraint).__name__}")
        self.constraint = constraint
        if dim is None:
            dim = getattr(constraint, "dim", None)
            if dim is None:
                raise DimensionError("dim must be given for a joint-space constraint; got None")
        self.dim = int(dim)
        self.unilateral = bool(unilateral)
        self.stabilisation_frequency = positive_scalar("stabilisation_frequency", stabilisation_frequency)
        self.contact_tolerance = positive_scalar("contact_tolerance", contact_tolerance)

    # -- the constrained dynamics
    def solve(self, robot, q: np.ndarray, qd: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
        """q̈, λ (m,) and h_e (dim,) for torques u; zero λ for released unilateral constraints.

        Returns:
            (q̈, λ, h_e, robot terms).
        """
        T = robot.terms(q, qd)
        if self._planar_one and T.B.shape == (2, 2):
            fast = self._solve_planar_one(q, qd, u, T)
            if fast is not None:
                return fast
        phi, Jphi, jdq = self.constraint.terms(robot, q, qd, T)
        w = self.stabilisation_frequency
        s = -2.0 * w * (Jphi @ qd) - w * w * phi
        free = u - T.n
        Binv = _inverse2(T.B) if T.B.shape == (2, 2) else None
        if Binv is not None:  # the planar arm: B⁻¹ in closed form once for both right-hand sides
            Binv_free, Binv_JT = Binv @ free, Binv @ Jphi.T
        else:
            Binv_free = np.linalg.solve(T.B, free)
            Binv_JT = np.linalg.solve(T.B, Jphi.T)
        m = phi.shape[0]
        lam = np.zeros(m)
        active = np.ones(m, dtype=bool)
        if self.unilateral:
            active = phi <= self.contact_tolerance
        for _ in range(m + 1):
            lam[:] = 0.0
            if active.any():
                A = Jphi[active] @ Binv_JT[:, active]
                b = Jphi[active] @ Binv_free + jdq[active] - s[active]
                try:
                    lam[active] = np.linalg.solve(A, b)
                except np.linalg.LinAlgError as exc:
                    raise SingularityError(
                        f"the constraint Jacobian J_φ lost rank at q = {np.asarray(q).tolist()}"
                    ) from exc
            if not self.unilateral:
                break
            pulling = active & (lam > 0.0)
            if not pulling.any():
                break
            active &= ~pulling
        qdd = Binv_free - Binv_JT @ lam
        if isinstance(self.constraint, OperationalConstraint):
            # J_φ = G J, so Jᵀ h_e = J_φᵀ λ = Jᵀ Gᵀ λ: h_e = Gᵀ λ (9.52)-(9.53), for any arm (also redundant)
            h = self.constraint.gradient(T.x).T @ lam
        elif T.J.shape[0] == T.J.shape[1]:
            h = np.linalg.solve(T.J.T, Jphi.T @ lam)  # h_e = J⁻ᵀ J_φᵀ λ (9.52)-(9.53)
        else:
            # a joint-space constraint on a redundant arm: the wrench whose joint torques are closest to J_φᵀ λ
            h = np.linalg.lstsq(T.J.T, Jphi.T @ lam, rcond=None)[0]
        return qdd, lam, h, T

    def _solve_planar_one(self, q: np.ndarray, qd: np.ndarray, u: np.ndarray, T: Any) -> tuple | None:
        """:meth:`solve` for one operational constraint on a 2-joint planar arm, on scalars (the arithmetic of the
        general path, without its 1×1 and 2×2 arrays: equal to round-off, tested); None when B is not numerically
        positive definite (the general path then solves)."""
        Binv = _inverse2(T.B)
        if Binv is None:
            return None
        c = self.constraint
        x, xd = T.x, T.xd
        phi = float(c.psi(x)[0])
        g0, g1 = c.gradient(x)[0].tolist()
        (J00, J01), (J10, J11) = T.J.tolist()
        jp0, jp1 = g0 * J00 + g1 * J10, g0 * J01 + g1 * J11  # J_φ = G J
        jd0, jd1 = T.Jdq.tolist()
        jdq = g0 * jd0 + g1 * jd1 + float(c.gradient_rate(x, xd)[0])
        v0, v1 = qd.tolist()
        w = self.stabilisation_frequency
        s = -2.0 * w * (jp0 * v0 + jp1 * v1) - w * w * phi
        n0, n1 = T.n.tolist()
        u0, u1 = u.tolist()
        f0, f1 = u0 - n0, u1 - n1
        (i00, i01), (i10, i11) = Binv.tolist()
        bf0, bf1 = i00 * f0 + i01 * f1, i10 * f0 + i11 * f1  # B⁻¹ (u − n)
        bj0, bj1 = i00 * jp0 + i01 * jp1, i10 * jp0 + i11 * jp1  # B⁻¹ J_φᵀ
        lam = 0.0
        if not self.unilateral or phi <= self.contact_tolerance:
            A = jp0 * bj0 + jp1 * bj1
            if A == 0.0:
                raise SingularityError(f"the constraint Jacobian J_φ lost rank at q = {np.asarray(q).tolist()}")
            lam = (jp0 * bf0 + jp1 * bf1 + jdq - s) / A
            if self.unilateral and lam > 0.0:  # it would pull: released
                lam = 0.0
        qdd = np.array((bf0 - bj0 * lam, bf1 - bj1 * lam))
        return qdd, np.array((lam,)), np.array((g0 * lam, g1 * lam)), T

    @property
    def _planar_one(self) -> bool:
        c = self.constraint
        return isinstance(c, OperationalConstraint) and c.size == 1 and c.dim == 2 and self.dim == 2

    def acceleration(self, robot, q, qd, u):
        qdd, _, h, _ = self.solve(robot, q, qd, u)
        return qdd, h

    def sampled_wrench(self, robot, q, qd, u_prev):
        return self.solve(robot, q, qd, np.asarray(u_prev, dtype=np.float64))[2]

    def reaction(self, robot, q: Any, qd: Any, u: Any) -> np.ndarray:
        """λ (m,) under the torques u (9.87)."""
        q, qd, u = (np.asarray(v, dtype=np.float64) for v in (q, qd, u))
        return self.solve(robot, q, qd, u)[1]

    def violation(self, robot, q: Any) -> np.ndarray:
        """φ(q), (m,): how far the arm is off the constraint [m]."""
        return self.constraint.value(robot, np.asarray(q, dtype=np.float64))

    # -- the Environment interface
    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        raise ParameterError(
            "a RigidEnvironment's reaction depends on the joint torques, not on the pose alone; "
            "use sampled_wrench(robot, q, qd, u) or reaction(robot, q, qd, u)"
        )

    def max_stiffness(self) -> float:
        """``ω_b²`` [N/m per kg]: the stabilisation loop's stiffness, which sets the RK4 step."""
        return self.stabilisation_frequency**2

    def describe(self) -> dict[str, Any]:
        return {
            "type": "rigid",
            "constraint": self.constraint.describe(),
            "unilateral": self.unilateral,
            "stabilisation_frequency": self.stabilisation_frequency,
            "contact_tolerance": self.contact_tolerance,
        }
