"""The names of task-space components, one convention for logs, readers and references."""

from __future__ import annotations

__all__ = ["axis_names"]


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
