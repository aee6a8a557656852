"""A wrench that carries its frame, reference point and sense; twist helpers for the point and frame."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ...core.validate import as_vector
from ...errors import FrameError, ParameterError
from ...spatial import Transform, Twist, Wrench

__all__ = ["SensedWrench", "BY_END_EFFECTOR", "ON_END_EFFECTOR", "SENSES", "twist_about", "twist_rotated"]

#: the chapter's sense: the wrench the end-effector exerts on the environment (h_e of (9.1)).
BY_END_EFFECTOR = "by-end-effector"
#: the opposite: the wrench the environment exerts on the end-effector (−h_e), what most
#: drivers and wrist sensors report as "external" or "measured" wrench.
ON_END_EFFECTOR = "on-end-effector"
SENSES = (BY_END_EFFECTOR, ON_END_EFFECTOR)


def _sense(value: Any) -> str:
    if value not in SENSES:
        raise ParameterError(
            f"sense must be {BY_END_EFFECTOR!r} (exerted by the end-effector on the environment, the chapter's h_e) "
            f"or {ON_END_EFFECTOR!r} (exerted on the end-effector by the environment); got {value!r}"
        )
    return str(value)


@dataclass(frozen=True)
class SensedWrench:
    """A wrench with its frame, reference point and sense.

    Attributes:
        wrench: force f [N] and moment μ [N m] (:class:`~forcecontrol.spatial.Wrench`): its
            ``frame`` names the axes, its ``point`` the frame whose origin the moment is about.
        sense: :data:`BY_END_EFFECTOR` (the chapter's h_e) or :data:`ON_END_EFFECTOR` (−h_e).
        stamp: time [s] of the measurement, or None.
    """

    wrench: Wrench
    sense: str
    stamp: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.wrench, Wrench):
            raise ParameterError(f"wrench must be a forcecontrol Wrench; got {type(self.wrench).__name__}")
        object.__setattr__(self, "sense", _sense(self.sense))
        if self.stamp is not None:
            object.__setattr__(self, "stamp", float(as_vector("stamp", [self.stamp], 1)[0]))

    @classmethod
    def from_vector(
        cls, h: Any, *, frame: str, point: str | None = None, sense: str, stamp: float | None = None
    ) -> SensedWrench:
        """From ``[f; μ]`` (6,), in ``frame`` about ``point`` (the frame's own origin by default)."""
        return cls(Wrench.from_vector(h, frame, point or frame), sense, stamp)

    @property
    def frame(self) -> str:
        """The frame whose axes the vectors are expressed in."""
        return self.wrench.frame

    @property
    def point(self) -> str:
        """The frame whose origin the moment is taken about."""
        return self.wrench.point

    @property
    def vector(self) -> np.ndarray:
        """``[f; μ]`` (6,) as stored (frame, point and sense as tagged)."""
        return self.wrench.vector

    def _with(self, wrench: Wrench, sense: str | None = None) -> SensedWrench:
        return SensedWrench(wrench, self.sense if sense is None else sense, self.stamp)

    def in_sense(self, sense: str) -> SensedWrench:
        """The same interaction seen from the other body when ``sense`` differs: ``h → −h`` (Newton's third law)."""
        sense = _sense(sense)
        if sense == self.sense:
            return self
        w = self.wrench
        return self._with(Wrench(-w.force, -w.moment, w.frame, w.point), sense)

    def about(self, point: str, r: Any) -> SensedWrench:
        """The moment about another point: ``μ' = μ − r × f``.

        Args:
            point: name of the new reference point's frame.
            r: vector from the current point to the new one [m], expressed in this wrench's frame.
        """
        return self._with(self.wrench.shifted(point, r))

    def rotated(self, X: Transform) -> SensedWrench:
        """Re-express the axes in ``X.parent`` (this wrench must be in ``X.child``); the point is kept."""
        return self._with(self.wrench.rotated(X))

    def transformed(self, X: Transform) -> SensedWrench:
        """Expressed in ``X.parent`` about ``X.parent``'s origin (this wrench: in ``X.child`` about its origin)."""
        return self._with(self.wrench.transformed(X))

    def h_e(self, frame: str, point: str) -> np.ndarray:
        """The chapter's ``h_e = [f; μ]`` (6,), after checking the frame and point; the sense is converted.

        Raises:
            FrameError: the wrench is not expressed in ``frame`` about ``point`` (convert it first).
        """
        return self.in_sense(BY_END_EFFECTOR).wrench.require(frame, point)

    def require(self, frame: str, point: str, sense: str) -> np.ndarray:
        """``[f; μ]`` after checking frame, point and sense (no conversion), else FrameError."""
        if self.sense != _sense(sense):
            raise FrameError(f"wrench must have sense {sense!r}; got {self.sense!r}; convert it with .in_sense()")
        return self.wrench.require(frame, point)


def twist_about(twist: Twist, point: str, r: Any) -> Twist:
    """The same rigid-body twist at another point: ``v' = v + ω × r``.

    Args:
        twist: linear velocity of ``twist.point``'s origin and angular velocity, in ``twist.frame``.
        point: name of the new point; r: vector from the current point to it [m], in ``twist.frame``.
    """
    r = as_vector("r", r, 3)
    return Twist(twist.linear + np.cross(twist.angular, r), twist.angular, twist.frame, point)


def twist_rotated(twist: Twist, X: Transform) -> Twist:
    """Re-express a twist's axes in ``X.parent`` (it must be in ``X.child``); the point is kept."""
    if twist.frame != X.child:
        raise FrameError(f"rotation {X.parent}<-{X.child} needs a twist in {X.child!r}; got {twist.frame!r}")
    return Twist(X.rotation @ twist.linear, X.rotation @ twist.angular, X.parent, twist.point)
