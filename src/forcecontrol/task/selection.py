"""Selection matrices S_f, S_v of a task with their weights, pseudo-inverses and projections (9.52)–(9.60)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import as_matrix, as_vector, readonly
from ..errors import DimensionError, ParameterError
from .projections import (
    _TOL,
    _full_column_rank,
    _rotation,
    _scipy_linalg,
    _space_dim,
    _weight,
    force_selection_from_constraint,
    partial_stiffness,
    velocity_selection_from_parametrisation,
    wrench_rotation,
)


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
            S_v = _scipy_linalg().null_space(S_f.T)
        else:
            S_v = velocity_selection_from_parametrisation(jacobian, rho_jacobian)
        unknown = set(weights) - {"force_weight", "velocity_weight", "frame"}
        if unknown:
            raise ParameterError(
                f"unknown keyword arguments {sorted(unknown)}; valid: force_weight, velocity_weight, frame"
            )
        return cls(S_f, S_v, **weights)


# ---------------------------------------------------------------------------------- frames
