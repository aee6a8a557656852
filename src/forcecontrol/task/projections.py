"""Weighted pseudo-inverses and projections of the selection matrices.

Weighted pseudo-inverses (9.55), S_f and S_v from a constraint or a parametrisation, K′ (9.70)
and C′ (9.72), and the wrench map of a change of frame (Sect. 9.5.1).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.validate import as_matrix, as_square
from ..errors import DimensionError, ParameterError

#: the degrees of freedom of each space, in vector order.
DOFS: dict[int, tuple[str, ...]] = {6: ("x", "y", "z", "rx", "ry", "rz"), 2: ("x", "y")}
#: velocity and force quantity keys of each DOF, in vector order.
VELOCITY_KEYS: dict[int, tuple[str, ...]] = {6: ("vx", "vy", "vz", "wx", "wy", "wz"), 2: ("vx", "vy")}
FORCE_KEYS: dict[int, tuple[str, ...]] = {6: ("fx", "fy", "fz", "mx", "my", "mz"), 2: ("fx", "fy")}
#: how the chapter prints each quantity (constraint frame superscript c).
SYMBOLS = {
    "vx": "ȯ_x^c", "vy": "ȯ_y^c", "vz": "ȯ_z^c", "wx": "ω_x^c", "wy": "ω_y^c", "wz": "ω_z^c",
    "fx": "f_x^c", "fy": "f_y^c", "fz": "f_z^c", "mx": "μ_x^c", "my": "μ_y^c", "mz": "μ_z^c",
}

#: relative tolerance of the reciprocity and rank checks.
_TOL = 1e-9


def _scipy_linalg():  # scipy.linalg costs ~0.1 s to import: loaded on first use
    import scipy.linalg  # type: ignore[import-untyped]

    return scipy.linalg


def _weight(name: str, value: Any, d: int) -> np.ndarray:
    """A symmetric positive definite (d, d) weight; a scalar or a vector means a diagonal.

    Definiteness is checked relative to the largest eigenvalue (``λ_min > 1e-14 λ_max``), so that
    weights transformed by a change of units (entries spanning many decades) are accepted.
    """
    what = f"{name} must be a symmetric positive definite ({d}, {d}) matrix"
    a = as_square(what, value, d)
    scale = float(np.abs(a).max()) if a.size else 1.0
    if not np.allclose(a, a.T, rtol=1e-12, atol=1e-14 * scale):
        raise ParameterError(f"{what}; got a non-symmetric matrix")
    a = 0.5 * (a + a.T)
    w = np.linalg.eigvalsh(a)
    if w.max() <= 0.0 or w.min() <= 1e-14 * w.max():
        raise ParameterError(f"{what}; got eigenvalues {np.array2string(w, precision=6)}")
    return a


def _space_dim(name: str, d: int) -> None:
    if d < 1:
        raise DimensionError(f"{name} must have at least one row; got {d}")


def weighted_pseudo_inverse(selection: Any, weight: Any = None, *, name: str = "selection") -> np.ndarray:
    """Weighted left pseudo-inverse (9.55): ``S† = (Sᵀ W S)⁻¹ Sᵀ W``.

    ``λ = S† h`` minimises ``(h − S λ)ᵀ W (h − S λ)`` (Problem 9.5); when ``h ∈ R(S)`` it is the
    exact solution whatever W.

    Args:
        selection: S, (d, k) with full column rank k.
        weight: W, symmetric positive definite (d, d); identity by default (a scalar or a
            vector of length d means a diagonal matrix).
        name: the parameter's name in error messages.

    Returns:
        S†, (k, d).

    Raises:
        ParameterError: W is not symmetric positive definite, or S is rank deficient.
    """
    S = as_matrix(name, selection)
    d, k = S.shape
    W = np.eye(d) if weight is None else _weight("weight", weight, d)
    _full_column_rank(name, S)
    G = S.T @ W @ S
    return np.linalg.solve(G, S.T @ W)


def _full_column_rank(name: str, S: np.ndarray) -> None:
    k = S.shape[1]
    if k == 0:
        return
    sv = np.linalg.svd(S, compute_uv=False)
    rank = int(np.sum(sv > _TOL * max(1.0, float(sv[0]))))
    if rank < k:
        raise ParameterError(
            f"{name} must have full column rank {k} (independent directions); got rank {rank} "
            f"(singular values {np.round(sv, 12).tolist()})"
        )


def force_selection_from_constraint(jacobian: Any, constraint_jacobian: Any) -> np.ndarray:
    """S_f from the constraint Jacobian (9.53): ``S_f = J⁻ᵀ(q) J_φᵀ(q)``.

    Args:
        jacobian: the manipulator's Jacobian J(q), square (d, d), nonsingular.
        constraint_jacobian: J_φ(q) = ∂φ/∂q, (m, d), rank m.

    Returns:
        S_f, (d, m).
    """
    J = as_matrix("jacobian", jacobian)
    d = J.shape[0]
    if J.shape != (d, d):
        raise DimensionError(f"jacobian must be square (d, d); got shape {J.shape}")
    Jphi = as_matrix("constraint_jacobian", constraint_jacobian)
    if Jphi.shape[1] != d:
        raise DimensionError(f"constraint_jacobian must have shape (m, {d}); got shape {Jphi.shape}")
    try:
        S_f = np.linalg.solve(J.T, Jphi.T)
    except np.linalg.LinAlgError as exc:
        raise ParameterError("jacobian must be nonsingular to compute S_f = J⁻ᵀ J_φᵀ (9.53); got a singular matrix") from exc
    _full_column_rank("constraint_jacobian", Jphi.T)
    return S_f


def velocity_selection_from_parametrisation(jacobian: Any, rho_jacobian: Any) -> np.ndarray:
    """S_v from the Jacobian of the parametrisation q = ρ(r) (9.63): ``S_v = J(q) J_ρ(r)``.

    Args:
        jacobian: J(q), (d, d).
        rho_jacobian: J_ρ(r) = ∂ρ/∂r, (d, d − m), full column rank.

    Returns:
        S_v, (d, d − m).
    """
    J = as_matrix("jacobian", jacobian)
    Jr = as_matrix("rho_jacobian", rho_jacobian)
    if Jr.shape[0] != J.shape[1]:
        raise DimensionError(f"rho_jacobian must have shape ({J.shape[1]}, k); got shape {Jr.shape}")
    _full_column_rank("rho_jacobian", Jr)
    return J @ Jr


def partial_stiffness(force_selection: Any, compliance: Any) -> np.ndarray:
    """K′ (9.70): ``K′ = S_f (S_fᵀ C S_f)⁻¹ S_fᵀ``, the stiffness of a partially constrained contact.

    Equal to ``P_f K`` with ``P_f`` built with the weight ``W = C`` and ``K = C⁻¹`` (Problem 9.6).

    Args:
        force_selection: S_f, (d, m).
        compliance: C, symmetric positive definite (d, d) [m/N, rad/(N m)].
    """
    S_f = as_matrix("force_selection", force_selection)
    C = _weight("compliance", compliance, S_f.shape[0])
    _full_column_rank("force_selection", S_f)
    return S_f @ np.linalg.solve(S_f.T @ C @ S_f, S_f.T)


def partial_compliance(velocity_selection: Any, compliance: Any, velocity_weight: Any = None) -> np.ndarray:
    """C′ (9.72): ``C′ = (I − P_v) C`` with ``P_v = S_v S_v†`` (S_v† with ``velocity_weight``).

    With ``velocity_weight = C⁻¹ = K`` (the elastic-energy norm the chapter suggests) C′ is
    symmetric; ``S_fᵀ C′ S_f = S_fᵀ C S_f`` and ``S_v† C′ = O`` hold for any weight.
    """
    S_v = as_matrix("velocity_selection", velocity_selection)
    d = S_v.shape[0]
    C = _weight("compliance", compliance, d)
    P_v = S_v @ weighted_pseudo_inverse(S_v, velocity_weight, name="velocity_selection")
    return (np.eye(d) - P_v) @ C


def _rotation(name: str, R: Any, dims: tuple[int, ...] = (2, 3)) -> np.ndarray:
    R = as_matrix(name, R)
    if R.shape[0] != R.shape[1] or R.shape[0] not in dims:
        shapes = " or ".join(f"({k}, {k})" for k in dims)
        raise DimensionError(f"{name} must be a rotation matrix of shape {shapes}; got shape {R.shape}")
    err = float(np.max(np.abs(R.T @ R - np.eye(R.shape[0]))))
    if err > 1e-9 or np.linalg.det(R) < 0:
        raise ParameterError(
            f"{name} must be a rotation matrix (Rᵀ R = I, det R = +1); got |Rᵀ R − I| = {err:.3g}, "
            f"det R = {np.linalg.det(R):.6g}"
        )
    return R


def wrench_rotation(R: np.ndarray, dim: int) -> np.ndarray:
    """The map ``D`` of a rotation R on wrenches (and twists) of a ``dim``-space."""
    if dim == 6:
        if R.shape != (3, 3):
            raise DimensionError(f"rotation must be (3, 3) for a 6-D task; got shape {R.shape}")
        return _scipy_linalg().block_diag(R, R)
    if R.shape != (dim, dim):
        raise DimensionError(f"rotation must be ({dim}, {dim}) for a {dim}-D task; got shape {R.shape}")
    return R
