"""The names of task-space components, one convention for logs, readers and references."""

from __future__ import annotations

from typing import Any

__all__ = ["axis_names", "joint_columns", "REFERENCE_FIELDS"]

#: the fields of a reference, in the order of a logged reference row (each ``m`` wide).
REFERENCE_FIELDS = ("position", "velocity", "acceleration", "force", "force_rate", "force_accel")


def axis_names(m: int) -> tuple[list[str], list[str], list[str]]:
    """Column names of the pose, twist and wrench components for an m-dimensional task space.

    ``x y (z)`` / ``vx vy (vz)`` / ``fx fy (fz)`` for m <= 3; a 6-D space adds ``rx ry rz`` (XYZ
    angles), ``wx wy wz`` and ``mx my mz``; other m: ``x0 ...``, ``v0 ...``, ``f0 ...``.
    """
    if m <= 3:
        p = list("xyz"[:m])
        return p, [f"v{a}" for a in p], [f"f{a}" for a in p]
    if m == 6:
        return (["x", "y", "z", "rx", "ry", "rz"], ["vx", "vy", "vz", "wx", "wy", "wz"],
                ["fx", "fy", "fz", "mx", "my", "mz"])
    return [f"x{i}" for i in range(m)], [f"v{i}" for i in range(m)], [f"f{i}" for i in range(m)]


def joint_columns(t: Any, q: Any, qd: Any, torque: Any, extra: Any = None, extra_name: str = "") -> dict[str, Any]:
    """The flat columns ``t, q1 qd1 u1 [extra1] q2 ...`` of a log (``extra_name`` formats the
    optional per-joint column, e.g. ``"uc{}"``); the task-space columns are added by the caller."""
    cols: dict[str, Any] = {"t": t}
    for i in range(q.shape[1]):
        cols[f"q{i + 1}"] = q[:, i]
        cols[f"qd{i + 1}"] = qd[:, i]
        cols[f"u{i + 1}"] = torque[:, i]
        if extra is not None:
            cols[extra_name.format(i + 1)] = extra[:, i]
    return cols
