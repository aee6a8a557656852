"""The operational-space error on the desired frame and its rates (9.8)–(9.14), (9.33)."""

from __future__ import annotations

import numpy as np

from .rotations import euler_xyz_T, rotation_to_euler_xyz

__all__ = ["pose_error", "error_rate", "analytical_jacobian_desired", "b_vector"]


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
