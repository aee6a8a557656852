"""The constraint frame O_c–x_c y_c z_c: fixed, or moving with the task (the crank's) (Sect. 9.5)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Literal

import numpy as np

from ..core.validate import as_vector, readonly
from ..errors import DimensionError, ParameterError
from .projections import _rotation


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
