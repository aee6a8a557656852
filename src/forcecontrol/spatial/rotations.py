"""Rotations: XYZ Euler angles, rotation vectors and their rate maps T(φ), T(θ).

Conversions between rotation matrices, XYZ Euler angles and rotation vectors go through
``scipy.spatial.transform.Rotation`` (``"XYZ"``, upper case: intrinsic rotations about the
current axes, ``R = R_x(φ₁) R_y(φ₂) R_z(φ₃)``, the chapter's convention). The rate maps T(φ) of
(3.64) and T(θ) are the chapter's closed forms (SciPy has none). Code that runs every sample uses
:mod:`.closed_form` (same results, about 40x faster per call).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.validate import as_matrix, readonly
from ..errors import ParameterError
from .closed_form import EULER_SINGULARITY_TOL, euler_singularity

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
    "wrap_angle",
    "EULER_SINGULARITY_TOL",
]


def _rotation_class() -> Any:
    from scipy.spatial.transform import Rotation  # scipy.spatial costs ~0.1 s to import: only when needed

    return Rotation


def wrap_angle(a: Any) -> Any:
    """An angle (or an array of angles) [rad] brought into [−π, π): the difference of two XYZ
    angles that name the same turn is 0, not 2π."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def skew(v: Any) -> np.ndarray:
    """S(v): the skew-symmetric matrix with ``S(v) w = v × w``, (3, 3)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def euler_xyz_to_rotation(phi: Any) -> np.ndarray:
    """``R = R_x(φ₁) R_y(φ₂) R_z(φ₃)`` (XYZ Euler angles about current axes), (3, 3)."""
    return _rotation_class().from_euler("XYZ", np.asarray(phi, dtype=np.float64)[:3]).as_matrix()


def rotation_to_euler_xyz(R: np.ndarray, *, strict: bool = False) -> np.ndarray:
    """XYZ Euler angles φ of a rotation matrix, with ``φ₂ ∈ [−π/2, π/2]``, (3,) [rad].

    Args:
        R: rotation matrix (3, 3).
        strict: raise :class:`SingularityError` at a representation singularity
            (``|cos φ₂| < EULER_SINGULARITY_TOL``) instead of returning one of the infinitely many
            solutions (φ₃ = 0 there, φ₁ from the remaining 2×2 block).
    """
    R = np.asarray(R, dtype=np.float64)
    c2 = math.hypot(R[0, 0], R[0, 1])
    if c2 < EULER_SINGULARITY_TOL:
        if strict:
            raise euler_singularity(c2)
        s2 = min(1.0, max(-1.0, float(R[0, 2])))
        return np.array([math.atan2(R[2, 1], R[1, 1]), math.asin(s2), 0.0])
    return _rotation_class().from_matrix(R).as_euler("XYZ")


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
    """``R = exp(S(θ))`` for a rotation vector θ (axis times angle), (3, 3)."""
    return _rotation_class().from_rotvec(np.asarray(theta, dtype=np.float64)[:3]).as_matrix()


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector θ = axis · angle of R, angle in [0, π], (3,) [rad]."""
    return _rotation_class().from_matrix(np.asarray(R, dtype=np.float64)).as_rotvec()


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
