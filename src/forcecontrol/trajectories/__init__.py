"""References: set-points, straight-line paths with a trapezoidal velocity profile, sampled signals.

A reference signal answers ``at(t)`` with a :class:`~forcecontrol.controllers.base.Reference`
and ``sample(times)`` with the packed rows the compiled loop reads (same numbers).
"""

from __future__ import annotations

from .profiles import FORCE_SHAPES, LinearPath, ReferenceSignal, Setpoint, force_profile, trapezoidal_profile
from .sampled import INTERPOLATIONS, SampledReference

__all__ = [
    "ReferenceSignal",
    "Setpoint",
    "LinearPath",
    "SampledReference",
    "trapezoidal_profile",
    "force_profile",
    "FORCE_SHAPES",
    "INTERPOLATIONS",
]
