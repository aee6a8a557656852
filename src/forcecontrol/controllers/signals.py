"""The signals a controller step reads: the measurement and the reference, and the packed reference row."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.axes import REFERENCE_FIELDS
from ..errors import DimensionError

__all__ = ["Measurement", "Reference", "pack_reference", "REFERENCE_FIELDS"]


@dataclass(frozen=True, slots=True)
class Measurement:
    """What a controller reads at one sample.

    Arrays are not copied (this is built once per control cycle); do not mutate them afterwards.

    Attributes:
        q: joint positions, (n,) [rad].
        qd: joint velocities, (n,) [rad/s].
        wrench: measured force the end-effector exerts on the environment, expressed in the
            base frame, (m,) [N] (h_e of (9.1)).
    """

    q: np.ndarray
    qd: np.ndarray
    wrench: np.ndarray


@dataclass(frozen=True, slots=True)
class Reference:
    """Operational-space references at one sample (base frame, SI units).

    Attributes:
        position: desired position x_d, (m,) [m].
        velocity: ẋ_d, (m,) [m/s].
        acceleration: ẍ_d, (m,) [m/s²].
        force: desired contact force f_d (force on the environment), (m,) [N].
        force_rate: ḟ_d, (m,) [N/s].
        force_accel: f̈_d, (m,) [N/s²].
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    force: np.ndarray
    force_rate: np.ndarray
    force_accel: np.ndarray

    @classmethod
    def setpoint(cls, position, force=None) -> Reference:
        """A constant reference: position x_d, zero derivatives, optional constant force f_d."""
        x = np.asarray(position, dtype=np.float64)
        z = np.zeros_like(x)
        f = z if force is None else np.asarray(force, dtype=np.float64)
        if f.shape != x.shape:
            raise DimensionError(f"force must have shape {x.shape}; got shape {f.shape}")
        return cls(x, z, z, f, z, z)


def pack_reference(ref: Reference) -> np.ndarray:
    """Flatten a :class:`Reference` into the row layout of :data:`REFERENCE_FIELDS`."""
    return np.concatenate([np.asarray(getattr(ref, f), dtype=np.float64) for f in REFERENCE_FIELDS])
