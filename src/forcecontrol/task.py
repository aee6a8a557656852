"""Task specification: constraint frame, natural and artificial constraints, selection matrices.

Sections 9.5–9.6 of the chapter. An interaction task is described, in a constraint frame
``O_c–x_c y_c z_c`` (fixed, or moving like the crank's), by one *natural* constraint per degree of
freedom, set by the geometry of a rigid frictionless contact, and the complementary *artificial*
constraint, the reference the controller imposes:

* a natural velocity constraint (``ȯ_z^c = 0``) leaves the force along that DOF to the controller
  (artificial ``f_z^c``): that DOF is force controlled, a column of S_f;
* a natural force constraint (``f_x^c = 0``) leaves the velocity to the controller (artificial
  ``ȯ_x^c``): that DOF is velocity controlled, a column of S_v.

The selection matrices satisfy ``h_e = S_f λ`` (9.52), ``v_e = S_v ν`` (9.59) and the reciprocity
``S_fᵀ S_v = O`` (9.58). Their weighted pseudo-inverses (9.55) give ``λ = S_f† h_e`` (9.54) and
``ν = S_v† v_e`` (9.60); ``P_f = S_f S_f†`` and ``P_v = S_v S_v†`` are projections. For a compliant
environment of compliance C, the partially constrained stiffness is K′ (9.70) and the compliance
C′ (9.72).

Spaces: ``dim = 6`` is the full space, wrench ``h = [f; μ]`` and twist ``v = [ȯ; ω]``;
``dim = 2`` is the planar position-only space of the chapter's two-link arm (``f = [f_x, f_y]``,
``ȯ = [ȯ_x, ȯ_y]``). Quantities are named by keys: ``vx vy vz`` (linear velocity ȯ — printed
θ̇/α̇ in Tables 9.1, 9.3, a misprint), ``wx wy wz`` (angular velocity ω), ``fx fy fz`` (force),
``mx my mz`` (moment μ).

Frames: a selection expressed in frame A is changed to frame B with the wrench map D
(``h^B = D h^A``); twists then map with ``D⁻ᵀ`` so that ``hᵀv`` is unchanged, and the weights
follow (``W_f^B = D⁻ᵀ W_f^A D⁻¹``, ``W_v^B = D W_v^A Dᵀ``), which keeps λ and ν invariant
(Sect. 9.5.1). A rotation R gives ``D = blockdiag(R, R)`` (6-D) or ``D = R`` (planar).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.linalg  # type: ignore[import-untyped]

from ._validate import as_matrix, as_vector, readonly
from .errors import DimensionError, FrameError, ParameterError

__all__ = [
    "SelectionMatrices",
    "ConstraintFrame",
    "Task",
    "weighted_pseudo_inverse",
    "planar_rotation",
    "wrench_rotation",
    "force_selection_from_constraint",
    "velocity_selection_from_parametrisation",
    "partial_stiffness",
    "partial_compliance",
    "sliding_on_plane",
    "peg_in_hole",
    "turning_crank",
    "driving_screw",
    "inclined_plane",
    "TASKS",
    "named_task",
]

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


def _weight(name: str, value: Any, d: int) -> np.ndarray:
    """A symmetric positive definite (d, d) weight; a scalar or a vector means a diagonal.

    Definiteness is checked relative to the largest eigenvalue (``λ_min > 1e-14 λ_max``), so that
    weights transformed by a change of units (entries spanning many decades) are accepted.
    """
    what = f"{name} must be a symmetric positive definite ({d}, {d}) matrix"
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{what}; got {value!r}") from exc
    if a.ndim == 0:
        a = float(a) * np.eye(d)
    elif a.shape == (d,):
        a = np.diag(a)
    if a.shape != (d, d):
        raise DimensionError(f"{what}; got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{what}; got non-finite entries {a.tolist()}")
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
        return scipy.linalg.block_diag(R, R)
    if R.shape != (dim, dim):
        raise DimensionError(f"rotation must be ({dim}, {dim}) for a {dim}-D task; got shape {R.shape}")
    return R


@dataclass(frozen=True, init=False, eq=False)
class SelectionMatrices:
    """A checked pair S_f, S_v with the weights of their pseudo-inverses (Sect. 9.5.1).

    Checks, once: S_f is (d, m) and S_v is (d, d − m) with 0 < m < d; both have full column rank;
    they are reciprocal, ``S_fᵀ S_v = O`` (9.58); the weights are symmetric positive definite.

    Args:
        force_selection: S_f, (d, m): the columns span the force controlled subspace R(S_f).
        velocity_selection: S_v, (d, d − m): the columns span the velocity controlled subspace.
        force_weight: W for S_f† (9.55), SPD (d, d); identity by default. ``W = C`` (a compliance)
            makes λ invariant to changes of units and frames.
        velocity_weight: W for S_v†, SPD (d, d); identity by default (``K = C⁻¹`` or a kinetic
            energy metric are the physically consistent choices).
        frame: name of the frame the matrices are expressed in (for messages and tables).

    Attributes:
        force_selection, velocity_selection, force_weight, velocity_weight: as given (read-only).
        force_pinv: S_f†, (m, d); velocity_pinv: S_v†, (d − m, d).
        force_projector: P_f = S_f S_f†; velocity_projector: P_v = S_v S_v†.
    """

    force_selection: np.ndarray
    velocity_selection: np.ndarray
    force_weight: np.ndarray
    velocity_weight: np.ndarray
    force_pinv: np.ndarray
    velocity_pinv: np.ndarray
    force_projector: np.ndarray
    velocity_projector: np.ndarray
    frame: str

    def __init__(
        self,
        force_selection: Any,
        velocity_selection: Any,
        *,
        force_weight: Any = None,
        velocity_weight: Any = None,
        frame: str = "base",
    ) -> None:
        S_f = np.array(as_matrix("force_selection", force_selection))
        d, m = S_f.shape
        _space_dim("force_selection", d)
        S_v = np.array(as_matrix("velocity_selection", velocity_selection))
        if S_v.shape[0] != d:
            raise DimensionError(
                f"velocity_selection must have {d} rows like force_selection; got shape {S_v.shape}"
            )
        if not 0 < m < d:
            raise DimensionError(
                f"force_selection must have between 1 and {d - 1} columns (0 < m < d); got shape {S_f.shape}"
            )
        if S_v.shape[1] != d - m:
            raise DimensionError(
                f"velocity_selection must have d − m = {d} − {m} = {d - m} columns, complementary to "
                f"force_selection; got shape {S_v.shape}"
            )
        _full_column_rank("force_selection", S_f)
        _full_column_rank("velocity_selection", S_v)
        cross = S_f.T @ S_v
        scale = max(1.0, float(np.abs(S_f).max()) * float(np.abs(S_v).max()))
        if float(np.abs(cross).max()) > _TOL * scale:
            raise ParameterError(
                "force_selection and velocity_selection must be reciprocal, S_fᵀ S_v = O (9.58); "
                f"got max |S_fᵀ S_v| = {float(np.abs(cross).max()):.6g}"
            )
        W_f = np.eye(d) if force_weight is None else _weight("force_weight", force_weight, d)
        W_v = np.eye(d) if velocity_weight is None else _weight("velocity_weight", velocity_weight, d)
        pf = np.linalg.solve(S_f.T @ W_f @ S_f, S_f.T @ W_f)
        pv = np.linalg.solve(S_v.T @ W_v @ S_v, S_v.T @ W_v)
        for key, val in (
            ("force_selection", S_f), ("velocity_selection", S_v), ("force_weight", W_f),
            ("velocity_weight", W_v), ("force_pinv", pf), ("velocity_pinv", pv),
            ("force_projector", S_f @ pf), ("velocity_projector", S_v @ pv),
        ):
            object.__setattr__(self, key, readonly(np.array(val)))
        object.__setattr__(self, "frame", str(frame))

    # -- sizes
    @property
    def dim(self) -> int:
        """d, the dimension of the wrench and twist spaces (6, or 2 for the planar arm)."""
        return int(self.force_selection.shape[0])

    @property
    def m(self) -> int:
        """m, the dimension of the force controlled subspace."""
        return int(self.force_selection.shape[1])

    # -- the chapter's maps
    def force_coordinates(self, wrench: Any) -> np.ndarray:
        """λ = S_f† h_e (9.54), (m,)."""
        return self.force_pinv @ as_vector("wrench", wrench, self.dim)

    def velocity_coordinates(self, twist: Any) -> np.ndarray:
        """ν = S_v† v_e (9.60), (d − m,)."""
        return self.velocity_pinv @ as_vector("twist", twist, self.dim)

    def wrench(self, force_coordinates: Any) -> np.ndarray:
        """h = S_f λ (9.52)/(9.64), (d,)."""
        return self.force_selection @ as_vector("force_coordinates", force_coordinates, self.m)

    def twist(self, velocity_coordinates: Any) -> np.ndarray:
        """v = S_v ν (9.59), (d,)."""
        return self.velocity_selection @ as_vector("velocity_coordinates", velocity_coordinates, self.dim - self.m)

    def stiffness(self, compliance: Any) -> np.ndarray:
        """K′ = S_f (S_fᵀ C S_f)⁻¹ S_fᵀ (9.70) for the compliance C (d, d)."""
        return partial_stiffness(self.force_selection, compliance)

    def compliance(self, compliance: Any) -> np.ndarray:
        """C′ = (I − P_v) C (9.72) for the compliance C (d, d), with this object's P_v."""
        C = _weight("compliance", compliance, self.dim)
        return (np.eye(self.dim) - self.velocity_projector) @ C

    def check_references(self, force: Any = None, velocity: Any = None, *, atol: float = 1e-9) -> None:
        """Check that a desired wrench lies in R(S_f) and a desired twist in R(S_v) (Sect. 9.6).

        Raises:
            ParameterError: a reference has a component the natural constraints forbid.
        """
        for name, value, P, space in (
            ("force", force, self.force_projector, "the force controlled subspace R(S_f)"),
            ("velocity", velocity, self.velocity_projector, "the velocity controlled subspace R(S_v)"),
        ):
            if value is None:
                continue
            x = as_vector(name, value, self.dim)
            off = x - P @ x
            if float(np.abs(off).max()) > atol * max(1.0, float(np.abs(x).max())):
                raise ParameterError(
                    f"{name} reference conflicts with the natural constraints: it must lie in {space}; "
                    f"got {x.tolist()}, whose component {np.round(off, 9).tolist()} lies outside it"
                )

    # -- changes of frame and units
    def transformed(self, wrench_map: Any, frame: str | None = None) -> SelectionMatrices:
        """The same selection after ``h' = D h`` (twists ``v' = D⁻ᵀ v``), weights transformed too.

        ``S_f' = D S_f``, ``S_v' = D⁻ᵀ S_v``, ``W_f' = D⁻ᵀ W_f D⁻¹``, ``W_v' = D W_v Dᵀ``: λ, ν,
        reciprocity and the work hᵀv are unchanged (Sect. 9.5.1, invariance).

        Args:
            wrench_map: D, nonsingular (d, d): a rotation, a change of units, a change of point.
            frame: the name of the new frame.
        """
        D = as_matrix("wrench_map", wrench_map, (self.dim, self.dim))
        try:
            Dinv = np.linalg.inv(D)
        except np.linalg.LinAlgError as exc:
            raise ParameterError("wrench_map must be nonsingular; got a singular matrix") from exc
        W_f = Dinv.T @ self.force_weight @ Dinv
        W_v = D @ self.velocity_weight @ D.T
        return SelectionMatrices(
            D @ self.force_selection, Dinv.T @ self.velocity_selection,
            force_weight=0.5 * (W_f + W_f.T), velocity_weight=0.5 * (W_v + W_v.T),
            frame=self.frame if frame is None else frame,
        )

    def rotated(self, rotation: Any, frame: str | None = None) -> SelectionMatrices:
        """Expressed in another frame: ``S^B = D S^A`` with ``D = blockdiag(R, R)`` (or R, planar).

        Args:
            rotation: R = R_A^B, the rotation from frame A (this one) to frame B, (3, 3) or (2, 2).
        """
        R = _rotation("rotation", rotation, (3,) if self.dim == 6 else (self.dim,))
        return self.transformed(wrench_rotation(R, self.dim), frame)

    def matrices(self) -> dict[str, list]:
        """S_f, S_v, S_f†, S_v†, P_f, P_v as plain lists."""
        return {
            "S_f": self.force_selection.tolist(), "S_v": self.velocity_selection.tolist(),
            "S_f_pinv": self.force_pinv.tolist(), "S_v_pinv": self.velocity_pinv.tolist(),
            "P_f": self.force_projector.tolist(), "P_v": self.velocity_projector.tolist(),
        }

    @classmethod
    def from_constraint(
        cls,
        jacobian: Any,
        constraint_jacobian: Any,
        rho_jacobian: Any = None,
        **weights: Any,
    ) -> SelectionMatrices:
        """S_f from J_φ (9.53) and S_v from J_ρ (9.63), or an orthonormal basis of ker S_fᵀ.

        Args:
            jacobian: J(q), (d, d), nonsingular.
            constraint_jacobian: J_φ(q), (m, d).
            rho_jacobian: J_ρ(r), (d, d − m); when omitted S_v spans ker(S_fᵀ) orthonormally.
            **weights: ``force_weight``, ``velocity_weight``, ``frame``.
        """
        S_f = force_selection_from_constraint(jacobian, constraint_jacobian)
        if rho_jacobian is None:
            S_v = scipy.linalg.null_space(S_f.T)
        else:
            S_v = velocity_selection_from_parametrisation(jacobian, rho_jacobian)
        unknown = set(weights) - {"force_weight", "velocity_weight", "frame"}
        if unknown:
            raise ParameterError(
                f"unknown keyword arguments {sorted(unknown)}; valid: force_weight, velocity_weight, frame"
            )
        return cls(S_f, S_v, **weights)


# ---------------------------------------------------------------------------------- frames


class ConstraintFrame:
    """The constraint frame O_c–x_c y_c z_c: fixed, or moving with time (e.g. the crank's).

    Args:
        rotation: R_c, the frame's orientation in the base frame, (3, 3) or (2, 2); or, for a
            moving frame, a function ``t -> R_c(t)``.
        origin: o_c in the base frame, (3,) or (2,); or a function ``t -> o_c(t)``; zero by
            default.
        dim: 3 or 2 (the geometric space; 2 for the planar arm). Inferred from a fixed rotation.
    """

    def __init__(self, rotation: Any = None, origin: Any = None, *, dim: int | None = None) -> None:
        self._rot_fn: Callable[[float], Any] | None = rotation if callable(rotation) else None
        self._org_fn: Callable[[float], Any] | None = origin if callable(origin) else None
        if self._rot_fn is None:
            if rotation is None:
                if dim is None:
                    raise ParameterError("rotation or dim must be given to build a ConstraintFrame; got neither")
                rotation = np.eye(dim)
            R = _rotation("rotation", rotation)
            if dim is not None and R.shape[0] != dim:
                raise DimensionError(f"rotation must be ({dim}, {dim}); got shape {R.shape}")
            self._R = R
            dim = R.shape[0]
        elif dim is None:
            dim = _rotation("rotation(0)", self._rot_fn(0.0)).shape[0]
        if dim not in (2, 3):
            raise DimensionError(f"dim must be 2 or 3; got {dim}")
        self.dim = int(dim)
        if self._org_fn is None:
            self._o = readonly(np.zeros(self.dim)) if origin is None else as_vector("origin", origin, self.dim)

    @property
    def moving(self) -> bool:
        """True when the frame's pose depends on time."""
        return self._rot_fn is not None or self._org_fn is not None

    def rotation(self, t: float = 0.0) -> np.ndarray:
        """R_c(t), the constraint frame's orientation in the base frame."""
        if self._rot_fn is None:
            return self._R
        return _rotation("rotation(t)", self._rot_fn(float(t)), (self.dim,))

    def origin(self, t: float = 0.0) -> np.ndarray:
        """o_c(t) in the base frame [m]."""
        if self._org_fn is None:
            return self._o
        return as_vector("origin(t)", self._org_fn(float(t)), self.dim)

    def rotation_rate(self, t: float = 0.0, step: float = 1e-6) -> np.ndarray:
        """Ṙ_c(t) (zero for a fixed frame; a central difference for a moving one)."""
        if self._rot_fn is None:
            return np.zeros((self.dim, self.dim))
        return (self.rotation(t + step) - self.rotation(t - step)) / (2.0 * step)

    def describe(self, t: float = 0.0) -> dict[str, Any]:
        return {"moving": self.moving, "rotation": self.rotation(t).tolist(), "origin": self.origin(t).tolist()}


def planar_rotation(angle: float) -> np.ndarray:
    """``[[cos a, −sin a], [sin a, cos a]]`` (9.85 for a = π/4)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# ---------------------------------------------------------------------------------- tasks

FrameName = Literal["constraint", "base", "end-effector"]


class Task:
    """An interaction task: natural constraints per DOF, artificial references, a constraint frame.

    Natural constraints are listed by quantity key, one per DOF (``"vz"`` means ``ȯ_z^c = 0``,
    ``"fx"`` means ``f_x^c = 0``); the artificial constraint of each DOF is the other quantity.
    Force controlled DOFs (natural velocity constraint) give the columns of S_f, velocity
    controlled DOFs (natural force constraint) the columns of S_v, in DOF order, in the
    constraint frame. A task may instead give its own reciprocal S_f^c, S_v^c (e.g. the screw
    with a pitch).

    Args:
        name: a short name.
        natural: the natural constraints, one key per DOF (``dim`` keys).
        frame: the constraint frame; the base frame by default.
        references: artificial constraint values in the constraint frame, e.g. ``{"fy": -50.0,
            "vx": 0.1}`` [N, N m, m/s, rad/s]; zero by default. A value for a naturally
            constrained quantity (other than 0) conflicts with the task and is an error.
        force_weight, velocity_weight: weights of S_f†, S_v† in the constraint frame (9.55).
        selection: optional ``(S_f^c, S_v^c)`` replacing the unit-column matrices.
        description: one line saying what the task is.
        dim: 6 (full space) or 2 (planar position space).
    """

    def __init__(
        self,
        name: str,
        natural: Sequence[str],
        *,
        frame: ConstraintFrame | None = None,
        references: Mapping[str, float] | None = None,
        force_weight: Any = None,
        velocity_weight: Any = None,
        selection: tuple[Any, Any] | None = None,
        description: str = "",
        dim: int = 6,
    ) -> None:
        if dim not in DOFS:
            raise DimensionError(f"dim must be 6 (full space) or 2 (planar); got {dim!r}")
        self.name = str(name)
        self.dim = int(dim)
        self.description = description
        vk, fk = VELOCITY_KEYS[dim], FORCE_KEYS[dim]
        valid = set(vk) | set(fk)
        natural = tuple(natural)
        bad = [k for k in natural if k not in valid]
        if bad:
            raise ParameterError(f"natural constraints must be keys among {sorted(valid)}; got unknown {bad}")
        force_dofs: list[int] = []
        velocity_dofs: list[int] = []
        for i, dof in enumerate(DOFS[dim]):
            has_v, has_f = vk[i] in natural, fk[i] in natural
            if has_v and has_f:
                raise ParameterError(
                    f"natural constraints must be complementary, one per DOF; got both {vk[i]} and {fk[i]} "
                    f"for DOF {dof} (then neither can be an artificial constraint)"
                )
            if not (has_v or has_f):
                raise ParameterError(
                    f"natural constraints must name one quantity per DOF; got none for DOF {dof} "
                    f"(expected {vk[i]} or {fk[i]})"
                )
            (force_dofs if has_v else velocity_dofs).append(i)
        if len(set(natural)) != len(natural):
            raise ParameterError(f"natural constraints must not repeat a key; got {list(natural)}")
        self.natural = natural
        self.force_dofs = tuple(force_dofs)
        self.velocity_dofs = tuple(velocity_dofs)
        self.artificial = tuple(
            (fk[i] if i in force_dofs else vk[i]) for i in range(dim)
        )
        space = 3 if dim == 6 else 2
        self.frame = frame if frame is not None else ConstraintFrame(dim=space)
        if self.frame.dim != space:
            raise DimensionError(f"frame must be {space}-dimensional for a {dim}-D task; got {self.frame.dim}")
        refs = dict(references or {})
        for key, value in refs.items():
            if key not in valid:
                raise ParameterError(f"references must be keyed by quantities among {sorted(valid)}; got {key!r}")
            if key in natural and float(value) != 0.0:
                raise ParameterError(
                    f"references conflict with the natural constraints: {key} = {float(value):g} was given, "
                    f"but the environment imposes the natural constraint {SYMBOLS[key]} = 0; "
                    f"the artificial constraints are {list(self.artificial)}"
                )
        self.references = {k: float(v) for k, v in refs.items()}
        if selection is None:
            E = np.eye(dim)
            S_f, S_v = E[:, force_dofs], E[:, velocity_dofs]
        else:
            S_f, S_v = selection
        self._sel_c = SelectionMatrices(
            S_f, S_v, force_weight=force_weight, velocity_weight=velocity_weight, frame="constraint"
        )
        if selection is not None:
            # one column per DOF the table leaves to force (S_f) or velocity (S_v) control
            S_f_c, S_v_c = self._sel_c.force_selection, self._sel_c.velocity_selection
            for name_, S, allowed, what in (
                ("selection[0] (S_f)", S_f_c, force_dofs, "force"),
                ("selection[1] (S_v)", S_v_c, velocity_dofs, "velocity"),
            ):
                if S.shape[1] != len(allowed):
                    raise DimensionError(
                        f"{name_} must have {len(allowed)} columns, one per {what} controlled DOF; got shape {S.shape}"
                    )

    # -- selection matrices
    @property
    def m(self) -> int:
        """Dimension of the force controlled subspace."""
        return self._sel_c.m

    def _wrench_map(self, R: np.ndarray) -> np.ndarray:
        return wrench_rotation(R, self.dim)

    def selection(
        self,
        frame: FrameName = "base",
        t: float = 0.0,
        end_effector_rotation: Any = None,
    ) -> SelectionMatrices:
        """S_f, S_v (and weights, pseudo-inverses, projections) expressed in a frame at time t.

        Args:
            frame: ``"constraint"`` (constant for every task), ``"base"`` (``S = R_c S^c``) or
                ``"end-effector"`` (``S^e = R_eᵀ R_c S^c``).
            t: time [s] (matters for a moving constraint frame).
            end_effector_rotation: R_e, needed for ``"end-effector"``.
        """
        if frame == "constraint":
            return self._sel_c
        R_c = self.frame.rotation(t)
        if frame == "base":
            return self._sel_c.rotated(R_c, frame="base")
        if frame == "end-effector":
            if end_effector_rotation is None:
                raise FrameError(
                    "end_effector_rotation must be given to express the task in the end-effector frame; got None"
                )
            R_e = _rotation("end_effector_rotation", end_effector_rotation, (R_c.shape[0],))
            return self._sel_c.rotated(R_e.T @ R_c, frame="end-effector")
        raise FrameError(f"frame must be 'constraint', 'base' or 'end-effector'; got {frame!r}")

    def selection_rate(self, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Ṡ_f, Ṡ_v in the base frame: ``D(Ṙ_c) S^c`` (zero for a fixed constraint frame)."""
        Rd = self.frame.rotation_rate(t)
        D = scipy.linalg.block_diag(Rd, Rd) if self.dim == 6 else Rd
        return D @ self._sel_c.force_selection, D @ self._sel_c.velocity_selection

    def stiffness(
        self, compliance: Any, frame: FrameName = "constraint", t: float = 0.0, end_effector_rotation: Any = None
    ) -> np.ndarray:
        """K′ (9.70) in ``frame``; ``compliance`` C is given in that same frame."""
        return self.selection(frame, t, end_effector_rotation).stiffness(compliance)

    def compliance(
        self, compliance: Any, frame: FrameName = "constraint", t: float = 0.0, end_effector_rotation: Any = None
    ) -> np.ndarray:
        """C′ (9.72) in ``frame``; ``compliance`` C is given in that same frame."""
        return self.selection(frame, t, end_effector_rotation).compliance(compliance)

    # -- references
    def desired_force(self) -> np.ndarray:
        """λ_d: the artificial force references of the force controlled DOFs, (m,)."""
        fk = FORCE_KEYS[self.dim]
        return np.array([self.references.get(fk[i], 0.0) for i in self.force_dofs])

    def desired_velocity(self) -> np.ndarray:
        """ν_d: the artificial velocity references of the velocity controlled DOFs, (d − m,)."""
        vk = VELOCITY_KEYS[self.dim]
        return np.array([self.references.get(vk[i], 0.0) for i in self.velocity_dofs])

    def desired_wrench(self, frame: FrameName = "base", t: float = 0.0) -> np.ndarray:
        """h_d = S_f λ_d (Sect. 9.6) in ``frame``; valid only with the default unit columns."""
        return self.selection(frame, t).force_selection @ self.desired_force()

    def desired_twist(self, frame: FrameName = "base", t: float = 0.0) -> np.ndarray:
        """v_d = S_v ν_d (Sect. 9.6) in ``frame``."""
        return self.selection(frame, t).velocity_selection @ self.desired_velocity()

    # -- presentation
    def table(self) -> list[tuple[str, str]]:
        """(natural, artificial) rows like Tables 9.1–9.3: velocity naturals first, then force."""
        vk, fk = VELOCITY_KEYS[self.dim], FORCE_KEYS[self.dim]
        rows = [(SYMBOLS[vk[i]], SYMBOLS[fk[i]]) for i in self.force_dofs]
        rows += [(SYMBOLS[fk[i]], SYMBOLS[vk[i]]) for i in self.velocity_dofs]
        return rows

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "dim": self.dim,
            "natural": list(self.natural),
            "artificial": list(self.artificial),
            "references": dict(self.references),
            "frame": self.frame.describe(),
            **self._sel_c.matrices(),
        }

    def __repr__(self) -> str:
        return f"Task({self.name!r}, natural={list(self.natural)}, dim={self.dim})"


# ---------------------------------------------------------------------------------- the chapter's tasks


def sliding_on_plane(rotation: Any = None, origin: Any = None, references: Mapping[str, float] | None = None) -> Task:
    """Sliding a prismatic object on a planar surface, Table 9.1 (z_c normal to the plane)."""
    return Task(
        "sliding-on-plane", ("vz", "wx", "wy", "fx", "fy", "mz"),
        frame=ConstraintFrame(np.eye(3) if rotation is None else rotation, origin),
        references=references,
        description="sliding a prismatic object on a planar surface (Table 9.1, Fig. 9.12)",
    )


def peg_in_hole(rotation: Any = None, origin: Any = None, references: Mapping[str, float] | None = None) -> Task:
    """Inserting a cylindrical peg in a hole, Table 9.2 (z_c along the hole's axis)."""
    return Task(
        "peg-in-hole", ("vx", "vy", "wx", "wy", "fz", "mz"),
        frame=ConstraintFrame(np.eye(3) if rotation is None else rotation, origin),
        references=references,
        description="insertion of a cylindrical peg in a hole (Table 9.2, Fig. 9.13)",
    )


def turning_crank(
    center: Any = (0.0, 0.0, 0.0),
    radius: float = 0.2,
    angle: Callable[[float], float] | float = 0.0,
    angular_rate: float = 0.0,
    references: Mapping[str, float] | None = None,
) -> Task:
    """Turning a crank, Table 9.3: a moving constraint frame.

    x_c along the crank lever (radial), z_c along the idle handle (parallel to the crank axis,
    the base z axis), y_c tangent to the handle's circle. The frame turns with the crank angle
    ``θ(t) = angle + angular_rate t`` (or ``angle(t)`` if a function), with origin on the handle
    ``center + radius [cos θ, sin θ, 0]``.
    """
    c = as_vector("center", center, 3)
    r = float(radius)
    if callable(angle):
        theta = angle
    else:
        a0, w = float(angle), float(angular_rate)

        def theta(t: float) -> float:
            return a0 + w * t

    frame = ConstraintFrame(
        lambda t: _rot_z(theta(t)),
        lambda t: c + r * np.array([math.cos(theta(t)), math.sin(theta(t)), 0.0]),
        dim=3,
    )
    return Task(
        "turning-crank", ("vx", "vz", "wx", "wy", "fy", "mz"), frame=frame, references=references,
        description="turning a crank (Table 9.3, Fig. 9.14); the constraint frame turns with the lever",
    )


def driving_screw(
    pitch: float = 0.0, rotation: Any = None, origin: Any = None, references: Mapping[str, float] | None = None
) -> Task:
    """Driving a screw in a hole, Problem 9.7 (Fig. 9.17); z_c along the screw's axis.

    With the screwdriver's blade seated in the slot and the screw in its hole, the environment
    forbids translation along x_c, y_c (the hole) and rotation about x_c, y_c (blade in the slot,
    screw in the hole); the thread ties the advance to the turn, ``ȯ_z = p ω_z / (2π)``, which
    for a negligible pitch is the natural constraint ``ȯ_z^c = 0``; the frictionless screw turns
    freely, ``μ_z^c = 0``. The controller specifies the push ``f_z^c`` (negative: into the
    hole), zero ``f_x^c, f_y^c, μ_x^c, μ_y^c`` and the turning rate ``ω_z^c``.

    Args:
        pitch: the thread's pitch p [m/turn]; with p > 0 the velocity controlled direction is
            the screw motion ``[0, 0, p/2π, 0, 0, 1]`` and its reciprocal force direction
            ``[0, 0, 1, 0, 0, −p/2π]`` replaces the pure push.
    """
    k = float(pitch) / (2.0 * math.pi)
    E = np.eye(6)
    S_f = E[:, [0, 1, 2, 3, 4]].copy()
    S_f[5, 2] = -k
    S_v = np.zeros((6, 1))
    S_v[2, 0], S_v[5, 0] = k, 1.0
    return Task(
        "driving-screw", ("vx", "vy", "vz", "wx", "wy", "mz"),
        frame=ConstraintFrame(np.eye(3) if rotation is None else rotation, origin),
        references=references, selection=(S_f, S_v),
        description="driving a screw in a hole (Problem 9.7, Fig. 9.17)",
    )


def inclined_plane(
    angle: float = math.pi / 4,
    through: Any = (1.0, 0.0),
    references: Mapping[str, float] | None = None,
) -> Task:
    """The planar contact of Example 9.4: a plane at ``angle`` to x0 through ``through``.

    Constraint frame: x_c along the plane, y_c normal, out of the environment, R_c (9.85);
    natural constraints ``ȯ_y^c = 0`` and ``f_x^c = 0``; artificial ``f_y^c`` (λ) and ``ȯ_x^c``
    (ν). ``S_f^c = [0, 1]ᵀ``, ``S_v^c = [1, 0]ᵀ``; in the base frame ``S_f = [−1/√2, 1/√2]ᵀ``,
    ``S_v = [1/√2, 1/√2]ᵀ`` for π/4. Problem 9.10 pushes with ``{"fy": -50.0}``.
    """
    return Task(
        "example-9.4", ("vy", "fx"), frame=ConstraintFrame(planar_rotation(angle), through),
        references=references, dim=2,
        description=f"planar tip on a plane at {math.degrees(angle):.6g}° to x0 through {list(through)} (Example 9.4, Fig. 9.16)",
    )


def _problem_9_10() -> Task:
    task = inclined_plane(references={"fy": -50.0})
    task.name = "problem-9.10"
    task.description = "Example 9.4's plane, pushing 50 N into it (λ_d = f_y^c = −50 N), motion along x_c (Problem 9.10)"
    return task


#: the named tasks, built with default parameters (the crank turning at 1 rad/s).
TASKS: dict[str, Callable[[], Task]] = {
    "sliding-on-plane": sliding_on_plane,
    "peg-in-hole": peg_in_hole,
    "turning-crank": lambda: turning_crank(angular_rate=1.0),
    "driving-screw": driving_screw,
    "example-9.4": inclined_plane,
    "problem-9.10": _problem_9_10,
}


def named_task(name: str) -> Task:
    """One of :data:`TASKS` by name."""
    try:
        return TASKS[name]()
    except KeyError:
        raise ParameterError(f"task must be one of {sorted(TASKS)}; got {name!r}") from None
