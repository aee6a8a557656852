"""The chapter's named tasks.

Tables 9.1–9.3 (sliding on a plane, peg in hole, turning a crank, driving a screw), Example 9.4
and Problem 9.10.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..core.validate import as_vector
from ..errors import ParameterError
from .frame import ConstraintFrame, _rot_z, planar_rotation
from .spec import Task


def _fixed_frame_task(name: str, directions: tuple[str, ...], rotation: Any, origin: Any,
                      references: Mapping[str, float] | None, description: str) -> Task:
    """A task of the chapter in a constraint frame fixed in the base (identity rotation by default)."""
    frame = ConstraintFrame(np.eye(3) if rotation is None else rotation, origin)
    return Task(name, directions, frame=frame, references=references, description=description)


def sliding_on_plane(rotation: Any = None, origin: Any = None, references: Mapping[str, float] | None = None) -> Task:
    """Sliding a prismatic object on a planar surface, Table 9.1 (z_c normal to the plane)."""
    return _fixed_frame_task("sliding-on-plane", ("vz", "wx", "wy", "fx", "fy", "mz"), rotation, origin, references,
                             "sliding a prismatic object on a planar surface (Table 9.1, Fig. 9.12)")


def peg_in_hole(rotation: Any = None, origin: Any = None, references: Mapping[str, float] | None = None) -> Task:
    """Inserting a cylindrical peg in a hole, Table 9.2 (z_c along the hole's axis)."""
    return _fixed_frame_task("peg-in-hole", ("vx", "vy", "wx", "wy", "fz", "mz"), rotation, origin, references,
                             "insertion of a cylindrical peg in a hole (Table 9.2, Fig. 9.13)")


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
