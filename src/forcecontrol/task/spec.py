"""A task: natural and artificial constraints per degree of freedom, as in Tables 9.1–9.3 (Sect. 9.5)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import DimensionError, FrameError, ParameterError
from .frame import ConstraintFrame, FrameName
from .projections import DOFS, FORCE_KEYS, SYMBOLS, VELOCITY_KEYS, _rotation, _scipy_linalg, wrench_rotation
from .selection import SelectionMatrices


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
        D = _scipy_linalg().block_diag(Rd, Rd) if self.dim == 6 else Rd
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
