"""Closed forms of the rotation conversions, for code that runs every sample.

:mod:`forcecontrol.spatial.rotations` converts with ``scipy.spatial.transform.Rotation``, about
40x slower per single rotation (≈60 µs vs 1.4 µs for matrix → XYZ angles on this machine). The
per-sample paths (the 6-D spring's wrench at every integrator stage, the admittance filter, the
Pinocchio and MuJoCo poses) use these closed forms instead; ``tests/test_spatial.py`` checks them
against scipy's Rotation on random inputs. Same names and conventions as the public functions.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import SingularityError

__all__ = ["euler_xyz_to_rotation", "rotation_to_euler_xyz", "rotvec_to_rotation", "rotation_vector", "EULER_SINGULARITY_TOL"]

#: |cos φ₂| below which XYZ Euler angles are treated as singular.
EULER_SINGULARITY_TOL = 1e-3


def _skew(v: Any) -> np.ndarray:
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
            raise euler_singularity(c2)
        return np.array([math.atan2(R[2, 1], R[1, 1]), math.asin(s2), 0.0])
    return np.array([math.atan2(-R[1, 2], R[2, 2]), math.atan2(s2, c2), math.atan2(-R[0, 1], R[0, 0])])


def rotvec_to_rotation(theta: Any) -> np.ndarray:
    """Rodrigues: ``R = exp(S(θ))`` for a rotation vector θ (axis times angle), (3, 3)."""
    th = np.asarray(theta, dtype=np.float64)
    a = float(np.linalg.norm(th))
    S = _skew(th)
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
    if math.pi - a < 1e-3:
        # near π, w = 2 sin(a) axis loses its digits: the angle from atan2 and the axis from the
        # symmetric part, (R + Rᵀ)/2 = cos(a) I + (1 − cos a) n nᵀ (accurate to rounding up to π)
        a = math.atan2(0.5 * float(np.linalg.norm(w)), c)
        N = (0.5 * (R + R.T) - c * np.eye(3)) / (1.0 - c)
        i = int(np.argmax(np.diag(N)))
        axis = N[:, i] / math.sqrt(max(N[i, i], 1e-300))
        if w @ axis < 0:
            axis = -axis
        return a * axis / np.linalg.norm(axis)
    return a / (2.0 * math.sin(a)) * w


def euler_singularity(c2: float) -> SingularityError:
    """The error for XYZ Euler angles at their representation singularity (``cos φ₂ = c2`` ≈ 0)."""
    return SingularityError(
        f"XYZ Euler angles are at a representation singularity: cos(phi_2) = {c2:.3g} "
        f"< {EULER_SINGULARITY_TOL} (pitch of ±90°); use orientation='rotvec' or move the desired frame"
    )
