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

The package is split by concept: :mod:`.projections` (weighted pseudo-inverses, projections, K′,
C′, frame maps), :mod:`.selection` (:class:`SelectionMatrices`), :mod:`.frame`
(:class:`ConstraintFrame`), :mod:`.spec` (:class:`Task`) and :mod:`.named` (the chapter's tasks).
"""

from __future__ import annotations

from .frame import ConstraintFrame, planar_rotation
from .named import TASKS, driving_screw, inclined_plane, named_task, peg_in_hole, sliding_on_plane, turning_crank
from .projections import (
    DOFS,
    FORCE_KEYS,
    SYMBOLS,
    VELOCITY_KEYS,
    force_selection_from_constraint,
    partial_compliance,
    partial_stiffness,
    velocity_selection_from_parametrisation,
    weighted_pseudo_inverse,
    wrench_rotation,
)
from .selection import SelectionMatrices
from .spec import Task

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
    "DOFS",
    "VELOCITY_KEYS",
    "FORCE_KEYS",
    "SYMBOLS",
]
