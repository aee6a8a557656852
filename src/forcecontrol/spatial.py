"""Poses, XYZ Euler angles, the operational-space error on the desired frame, frame-tagged wrenches.

The chapter's 6-D quantities (Sect. 9.2.2, 9.3):

* the displacement of the end-effector frame from the desired frame (9.8)
  ``T_e^d = T_d⁻¹ T_e``, ``R_e^d = R_dᵀ R_e``, ``o_{d,e}^d = R_dᵀ (o_e − o_d)``;
* the error (9.9) ``x̃ = −[o_{d,e}^d; φ_{d,e}]`` with φ_{d,e} the XYZ Euler angles of ``R_e^d``;
* ``ω = T(φ) φ̇`` (3.64) for XYZ angles, ``T_A = blockdiag(I, T)``, ``T(0) = I`` (Problem 3.13);
* the analytical Jacobian on the desired frame (9.14) ``J_Ad = T_A⁻¹(φ_{d,e}) blockdiag(R_dᵀ, R_dᵀ) J``;
* ``x̃̇ = −J_Ad q̇ + b`` (9.33), with b in its corrected form (the chapter misprints the first
  block): ``b = [R_dᵀ ȯ_d + S(ω_d^d) o_{d,e}^d; T⁻¹(φ_{d,e}) ω_d^d]``.

XYZ angles have a representation singularity at ``cos φ₂ = 0`` (``det T = cos φ₂``).
:func:`rotation_vector` and :func:`rotvec_T` give the axis-angle alternative (singular only at a
rotation of 2π), used by the 6-D controllers with ``orientation="rotvec"``.

Naming follows the frames: ``R_d`` is the desired frame's rotation in the base frame, ``h_e_d``
a wrench expressed in the desired frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._validate import as_matrix, as_vector, readonly
from .errors import FrameError, ParameterError, SingularityError

__all__ = [
    "skew",
    "euler_xyz_to_rotation",
    "rotation_to_euler_xyz",
    "euler_xyz_T",
    "euler_xyz_T_inv",
    "euler_xyz_T_dot",
    "rotation_vector",
    "rotvec_to_rotation",
    "rotvec_T",
    "check_rotation",
    "pose_error",
    "error_rate",
    "analytical_jacobian_desired",
    "b_vector",
    "Transform",
    "Wrench",
    "Twist",
    "EULER_SINGULARITY_TOL",
]

#: |cos φ₂| below which XYZ Euler angles are treated as singular.
EULER_SINGULARITY_TOL = 1e-3


def skew(v: Any) -> np.ndarray:
    """S(v): the skew-symmetric matrix with ``S(v) w = v × w``, (3, 3)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def euler_xyz_to_rotation(phi: Any) -> np.ndarray:
    """``R = R_x(φ₁) R_y(φ₂) R_z(φ₃)`` (XYZ Euler angles about current axes), (3, 3)."""
    c1, s1 = math.cos(phi[0]), math.sin(phi[0])
    c2, s2 = math.cos(phi[1]), math.sin(phi[1])
    c3, s3 = math.cos(phi[2]), math.sin(phi[2])
    return np.array(
        [
            [c2 * c3, -c2 * s3, s2],
            [c1 * s3 + s1 * s2 * c3, c1 * c3 - s1 * s2 * s3, -s1 * c2],
            [s1 * s3 - c1 * s2 * c3, s1 * c3 + c1 * s2 * s3, c1 * c2],
        ]
    )


def rotation_to_euler_xyz(R: np.ndarray, *, strict: bool = False) -> np.ndarray:
    """XYZ Euler angles φ of a rotation matrix, with ``φ₂ ∈ [−π/2, π/2]``, (3,) [rad].

    Args:
        R: rotation matrix (3, 3).
        strict: raise :class:`SingularityError` at a representation singularity
            (``|cos φ₂| < EULER_SINGULARITY_TOL``) instead of returning one of the infinitely many
            solutions (φ₃ = 0 there).
    """
    s2 = min(1.0, max(-1.0, float(R[0, 2])))
    c2 = math.hypot(R[0, 0], R[0, 1])
    if c2 < EULER_SINGULARITY_TOL:
        if strict:
            raise SingularityError(
                f"XYZ Euler angles are at a representation singularity: cos(phi_2) = {c2:.3g} "
                f"< {EULER_SINGULARITY_TOL} (pitch of ±90°); use orientation='rotvec' or move the desired frame"
            )
        return np.array([math.atan2(R[2, 1], R[1, 1]), math.asin(s2), 0.0])
    return np.array([math.atan2(-R[1, 2], R[2, 2]), math.atan2(s2, c2), math.atan2(-R[0, 1], R[0, 0])])


def euler_xyz_T(phi: Any) -> np.ndarray:
    """T(φ) of (3.64) for XYZ angles: ``ω = T(φ) φ̇``, (3, 3); ``det T = cos φ₂``."""
    c1, s1 = math.cos(phi[0]), math.sin(phi[0])
    c2, s2 = math.cos(phi[1]), math.sin(phi[1])
    return np.array([[1.0, 0.0, s2], [0.0, c1, -s1 * c2], [0.0, s1, c1 * c2]])


def euler_xyz_T_inv(phi: Any) -> np.ndarray:
    """T⁻¹(φ) for XYZ angles in closed form, (3, 3); undefined at ``cos φ₂ = 0``."""
    c1, s1 = math.cos(phi[0]), math.sin(phi[0])
    c2, s2 = math.cos(phi[1]), math.sin(phi[1])
    return np.array([[1.0, s1 * s2 / c2, -c1 * s2 / c2], [0.0, c1, s1], [0.0, -s1 / c2, c1 / c2]])


def euler_xyz_T_dot(phi: Any, phid: Any) -> np.ndarray:
    """Ṫ(φ, φ̇), the time derivative of :func:`euler_xyz_T`, (3, 3)."""
    c1, s1 = math.cos(phi[0]), math.sin(phi[0])
    c2, s2 = math.cos(phi[1]), math.sin(phi[1])
    d1, d2 = phid[0], phid[1]
    return np.array(
        [
            [0.0, 0.0, c2 * d2],
            [0.0, -s1 * d1, -c1 * c2 * d1 + s1 * s2 * d2],
            [0.0, c1 * d1, -s1 * c2 * d1 - c1 * s2 * d2],
        ]
    )


def rotvec_to_rotation(theta: Any) -> np.ndarray:
    """Rodrigues: ``R = exp(S(θ))`` for a rotation vector θ (axis times angle), (3, 3)."""
    th = np.asarray(theta, dtype=np.float64)
    a = float(np.linalg.norm(th))
    S = skew(th)
    if a < 1e-8:
        return np.eye(3) + S + 0.5 * S @ S
    return np.eye(3) + math.sin(a) / a * S + (1.0 - math.cos(a)) / (a * a) * S @ S


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector θ = axis · angle of R, angle in [0, π], (3,) [rad]."""
    c = min(1.0, max(-1.0, 0.5 * (float(np.trace(R)) - 1.0)))
    a = math.acos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if a < 1e-6:
        return 0.5 * w
    if math.pi - a < 1e-6:
        # near π: axis from the symmetric part
        B = 0.5 * (R + np.eye(3))
        i = int(np.argmax(np.diag(B)))
        axis = B[:, i] / math.sqrt(max(B[i, i], 1e-300))
        if w @ axis < 0:
            axis = -axis
        return a * axis / np.linalg.norm(axis)
    return a / (2.0 * math.sin(a)) * w


def rotvec_T(theta: Any) -> np.ndarray:
    """T(θ) for the rotation vector: ``ω = T(θ) θ̇`` (left Jacobian of SO(3)), (3, 3).

    Singular only when |θ| is a non-zero multiple of 2π (never for angles in [0, π]).
    """
    th = np.asarray(theta, dtype=np.float64)
    a = float(np.linalg.norm(th))
    S = skew(th)
    if a < 1e-6:
        return np.eye(3) + 0.5 * S + S @ S / 6.0
    return np.eye(3) + (1.0 - math.cos(a)) / (a * a) * S + (a - math.sin(a)) / (a**3) * S @ S


def check_rotation(name: str, R: Any) -> np.ndarray:
    """A read-only copy of R after checking it is a rotation matrix (orthonormal, det +1)."""
    R = np.array(as_matrix(name, R, (3, 3)))
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) <= 0:
        raise ParameterError(f"{name} must be a rotation matrix (orthonormal, det = +1); got {R.tolist()}")
    return readonly(R)


def pose_error(o_d: np.ndarray, R_d: np.ndarray, o_e: np.ndarray, R_e: np.ndarray, *, strict: bool = True) -> np.ndarray:
    """The operational-space error on the desired frame (9.8)–(9.9), (6,).

    ``x̃ = −[R_dᵀ (o_e − o_d); φ_{d,e}]``, φ_{d,e} the XYZ Euler angles of ``R_dᵀ R_e``.

    Raises:
        SingularityError: with ``strict``, when φ_{d,e} is at a representation singularity.
    """
    out = np.empty(6)
    out[:3] = -(R_d.T @ (o_e - o_d))
    out[3:] = -rotation_to_euler_xyz(R_d.T @ R_e, strict=strict)
    return out


def error_rate(
    x_tilde: np.ndarray, R_d: np.ndarray, v_e: np.ndarray, v_d: np.ndarray
) -> np.ndarray:
    """x̃̇ from (9.10)–(9.11) for a moving desired frame, (6,).

    Args:
        x_tilde: the error (9.9), (6,).
        R_d: desired rotation (3, 3).
        v_e: end-effector twist [ȯ_e; ω_e], base frame, (6,).
        v_d: desired twist [ȯ_d; ω_d], base frame, (6,).
    """
    o_de_d = -x_tilde[:3]
    w_d_d = R_d.T @ v_d[3:]
    out = np.empty(6)
    out[:3] = -(R_d.T @ (v_e[:3] - v_d[:3]) - np.cross(w_d_d, o_de_d))
    out[3:] = -np.linalg.solve(euler_xyz_T(-x_tilde[3:]), R_d.T @ (v_e[3:] - v_d[3:]))
    return out


def analytical_jacobian_desired(J: np.ndarray, R_d: np.ndarray, phi_de: np.ndarray) -> np.ndarray:
    """(9.14): ``J_Ad = T_A⁻¹(φ_{d,e}) blockdiag(R_dᵀ, R_dᵀ) J``, (6, n)."""
    out = np.empty_like(J, dtype=np.float64)
    out[:3] = R_d.T @ J[:3]
    out[3:] = np.linalg.solve(euler_xyz_T(phi_de), R_d.T @ J[3:])
    return out


def b_vector(x_tilde: np.ndarray, R_d: np.ndarray, od_dot: np.ndarray, omega_d: np.ndarray) -> np.ndarray:
    """The vector b of (9.33), corrected: ``[R_dᵀ ȯ_d + S(ω_d^d) o_{d,e}^d; T⁻¹(φ_{d,e}) ω_d^d]``, (6,)."""
    w_d_d = R_d.T @ omega_d
    out = np.empty(6)
    out[:3] = R_d.T @ od_dot + np.cross(w_d_d, -x_tilde[:3])
    out[3:] = np.linalg.solve(euler_xyz_T(-x_tilde[3:]), w_d_d)
    return out


# ----------------------------------------------------------------------------- frame-tagged data


def _name(what: str, v: Any) -> str:
    if not isinstance(v, str) or not v:
        raise ParameterError(f"{what} must be a non-empty frame name; got {v!r}")
    return v


@dataclass(frozen=True)
class Transform:
    """The pose of frame ``child`` in frame ``parent``: ``p_parent = R p_child + t``.

    Attributes:
        rotation: R, (3, 3); translation: t [m], (3,) (the child's origin in the parent frame).
        parent, child: frame names.
    """

    rotation: np.ndarray
    translation: np.ndarray
    parent: str = "world"
    child: str = "body"

    def __post_init__(self) -> None:
        object.__setattr__(self, "rotation", check_rotation("rotation", self.rotation))
        object.__setattr__(self, "translation", as_vector("translation", self.translation, 3))
        _name("parent", self.parent)
        _name("child", self.child)

    def inverse(self) -> Transform:
        """The pose of ``parent`` in ``child``."""
        R = self.rotation
        return Transform(R.T, -(R.T @ self.translation), parent=self.child, child=self.parent)

    def __matmul__(self, other: Transform) -> Transform:
        """Composition ``X_a_b @ X_b_c = X_a_c``; the inner frames must match."""
        if self.child != other.parent:
            raise FrameError(f"cannot compose: {self.parent}<-{self.child} with {other.parent}<-{other.child}")
        return Transform(
            self.rotation @ other.rotation, self.rotation @ other.translation + self.translation, self.parent, other.child
        )


@dataclass(frozen=True)
class Wrench:
    """A force and a moment, expressed in frame ``frame``, the moment taken about ``point``'s origin.

    Attributes:
        force: f [N], (3,); moment: μ [N m], (3,).
        frame: the frame whose axes the vectors are expressed in.
        point: the frame whose origin the moment is taken about.
    """

    force: np.ndarray
    moment: np.ndarray
    frame: str = "world"
    point: str = "world"

    def __post_init__(self) -> None:
        object.__setattr__(self, "force", as_vector("force", self.force, 3))
        object.__setattr__(self, "moment", as_vector("moment", self.moment, 3))
        _name("frame", self.frame)
        _name("point", self.point)

    @classmethod
    def from_vector(cls, h: Any, frame: str = "world", point: str = "world") -> Wrench:
        """From ``[f; μ]`` (6,)."""
        h = as_vector("wrench", h, 6)
        return cls(h[:3], h[3:], frame, point)

    @property
    def vector(self) -> np.ndarray:
        """``[f; μ]``, (6,)."""
        return np.concatenate([self.force, self.moment])

    def _same(self, other: Wrench, op: str) -> None:
        if not isinstance(other, Wrench):
            raise FrameError(f"cannot {op} a Wrench and a {type(other).__name__}")
        if (self.frame, self.point) != (other.frame, other.point):
            raise FrameError(
                f"cannot {op} wrenches in different frames: ({self.frame}, about {self.point}) and "
                f"({other.frame}, about {other.point}); change one with .transformed() first"
            )

    def __add__(self, other: Wrench) -> Wrench:
        self._same(other, "add")
        return Wrench(self.force + other.force, self.moment + other.moment, self.frame, self.point)

    def __sub__(self, other: Wrench) -> Wrench:
        self._same(other, "subtract")
        return Wrench(self.force - other.force, self.moment - other.moment, self.frame, self.point)

    def require(self, frame: str, point: str) -> np.ndarray:
        """``[f; μ]`` after checking it is expressed in ``frame`` about ``point``, else FrameError."""
        if (self.frame, self.point) != (frame, point):
            raise FrameError(
                f"wrench must be expressed in frame {frame!r} about {point!r}; got frame {self.frame!r} about {self.point!r}"
            )
        return self.vector

    def transformed(self, X: Transform) -> Wrench:
        """The same wrench expressed in ``X.parent`` about ``X.parent``'s origin.

        Needs the wrench in ``X.child`` about ``X.child``'s origin: ``f' = R f``,
        ``μ' = R μ + t × (R f)`` (the dual of the twist transformation).
        """
        if (self.frame, self.point) != (X.child, X.child):
            raise FrameError(
                f"transform {X.parent}<-{X.child} needs a wrench in {X.child!r} about {X.child!r}; "
                f"got frame {self.frame!r} about {self.point!r}"
            )
        f = X.rotation @ self.force
        return Wrench(f, X.rotation @ self.moment + np.cross(X.translation, f), X.parent, X.parent)

    def rotated(self, X: Transform) -> Wrench:
        """Re-express the axes in ``X.parent`` (from ``X.child``), keeping the point."""
        if self.frame != X.child:
            raise FrameError(f"rotation {X.parent}<-{X.child} needs a wrench in {X.child!r}; got {self.frame!r}")
        return Wrench(X.rotation @ self.force, X.rotation @ self.moment, X.parent, self.point)

    def shifted(self, point: str, r: Any) -> Wrench:
        """The moment about a new point, ``r`` the vector from the old point to it (in ``frame``)."""
        r = as_vector("r", r, 3)
        return Wrench(self.force, self.moment - np.cross(r, self.force), self.frame, _name("point", point))


@dataclass(frozen=True)
class Twist:
    """A linear and an angular velocity in frame ``frame``, the linear one of ``point``'s origin.

    Attributes:
        linear: v [m/s], (3,); angular: ω [rad/s], (3,).
    """

    linear: np.ndarray
    angular: np.ndarray
    frame: str = "world"
    point: str = "world"

    def __post_init__(self) -> None:
        object.__setattr__(self, "linear", as_vector("linear", self.linear, 3))
        object.__setattr__(self, "angular", as_vector("angular", self.angular, 3))
        _name("frame", self.frame)
        _name("point", self.point)

    @property
    def vector(self) -> np.ndarray:
        """``[v; ω]``, (6,)."""
        return np.concatenate([self.linear, self.angular])

    def __add__(self, other: Twist) -> Twist:
        if not isinstance(other, Twist) or (self.frame, self.point) != (other.frame, other.point):
            raise FrameError(
                f"cannot add twists in different frames: ({self.frame}, at {self.point}) and "
                f"({getattr(other, 'frame', '?')}, at {getattr(other, 'point', '?')})"
            )
        return Twist(self.linear + other.linear, self.angular + other.angular, self.frame, self.point)

    def transformed(self, X: Transform) -> Twist:
        """The same twist in ``X.parent`` at ``X.parent``'s origin: ``ω' = R ω``, ``v' = R v + t × ω'``."""
        if (self.frame, self.point) != (X.child, X.child):
            raise FrameError(
                f"transform {X.parent}<-{X.child} needs a twist in {X.child!r} at {X.child!r}; "
                f"got frame {self.frame!r} at {self.point!r}"
            )
        w = X.rotation @ self.angular
        return Twist(X.rotation @ self.linear + np.cross(X.translation, w), w, X.parent, X.parent)

    def power(self, wrench: Wrench) -> float:
        """``hᵀ v`` [W]; both must be in the same frame about the same point."""
        if (self.frame, self.point) != (wrench.frame, wrench.point):
            raise FrameError(
                f"power needs a twist and a wrench in the same frame and point; got ({self.frame}, {self.point}) "
                f"and ({wrench.frame}, {wrench.point})"
            )
        return float(self.linear @ wrench.force + self.angular @ wrench.moment)
