"""Frame-tagged data: poses (Transform), wrenches and twists that carry their frame and point."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..core.validate import as_vector
from ..errors import FrameError, ParameterError
from .rotations import check_rotation

__all__ = ["Transform", "Wrench", "Twist"]


def _name(what: str, v: Any) -> str:
    if not isinstance(v, str) or not v:
        raise ParameterError(f"{what} must be a non-empty frame name; got {v!r}")
    return v


@dataclass(frozen=True)
class Transform:
    """The pose of frame ``child`` in frame ``parent``: ``p_parent = R p_child + t``.

    Attributes:
        rotation: R, (3, 3); translation: t [m], (3,) (the child's origin in the parent frame).
        parent, child: frame names.
    """

    rotation: np.ndarray
    translation: np.ndarray
    parent: str = "world"
    child: str = "body"

    def __post_init__(self) -> None:
        object.__setattr__(self, "rotation", check_rotation("rotation", self.rotation))
        object.__setattr__(self, "translation", as_vector("translation", self.translation, 3))
        _name("parent", self.parent)
        _name("child", self.child)

    def inverse(self) -> Transform:
        """The pose of ``parent`` in ``child``."""
        R = self.rotation
        return Transform(R.T, -(R.T @ self.translation), parent=self.child, child=self.parent)

    def __matmul__(self, other: Transform) -> Transform:
        """Composition ``X_a_b @ X_b_c = X_a_c``; the inner frames must match."""
        if self.child != other.parent:
            raise FrameError(f"cannot compose: {self.parent}<-{self.child} with {other.parent}<-{other.child}")
        return Transform(
            self.rotation @ other.rotation, self.rotation @ other.translation + self.translation, self.parent, other.child
        )


class _FrameTagged:
    """Checks shared by :class:`Wrench` and :class:`Twist`: two 3-vectors and two frame names."""

    _parts: ClassVar[tuple[str, str]]

    def __post_init__(self) -> None:
        for part in self._parts:
            object.__setattr__(self, part, as_vector(part, getattr(self, part), 3))
        _name("frame", self.frame)  # type: ignore[attr-defined]
        _name("point", self.point)  # type: ignore[attr-defined]


@dataclass(frozen=True)
class Wrench(_FrameTagged):
    """A force and a moment, expressed in frame ``frame``, the moment taken about ``point``'s origin.

    Attributes:
        force: f [N], (3,); moment: μ [N m], (3,).
        frame: the frame whose axes the vectors are expressed in.
        point: the frame whose origin the moment is taken about.
    """

    _parts: ClassVar[tuple[str, str]] = ("force", "moment")
    force: np.ndarray
    moment: np.ndarray
    frame: str = "world"
    point: str = "world"


    @classmethod
    def from_vector(cls, h: Any, frame: str = "world", point: str = "world") -> Wrench:
        """From ``[f; μ]`` (6,)."""
        h = as_vector("wrench", h, 6)
        return cls(h[:3], h[3:], frame, point)

    @property
    def vector(self) -> np.ndarray:
        """``[f; μ]``, (6,)."""
        return np.concatenate([self.force, self.moment])

    def _same(self, other: Wrench, op: str) -> None:
        if not isinstance(other, Wrench):
            raise FrameError(f"cannot {op} a Wrench and a {type(other).__name__}")
        if (self.frame, self.point) != (other.frame, other.point):
            raise FrameError(
                f"cannot {op} wrenches in different frames: ({self.frame}, about {self.point}) and "
                f"({other.frame}, about {other.point}); change one with .transformed() first"
            )

    def __add__(self, other: Wrench) -> Wrench:
        self._same(other, "add")
        return Wrench(self.force + other.force, self.moment + other.moment, self.frame, self.point)

    def __sub__(self, other: Wrench) -> Wrench:
        self._same(other, "subtract")
        return Wrench(self.force - other.force, self.moment - other.moment, self.frame, self.point)

    def require(self, frame: str, point: str) -> np.ndarray:
        """``[f; μ]`` after checking it is expressed in ``frame`` about ``point``, else FrameError."""
        if (self.frame, self.point) != (frame, point):
            raise FrameError(
                f"wrench must be expressed in frame {frame!r} about {point!r}; got frame {self.frame!r} about {self.point!r}"
            )
        return self.vector

    def transformed(self, X: Transform) -> Wrench:
        """The same wrench expressed in ``X.parent`` about ``X.parent``'s origin.

        Needs the wrench in ``X.child`` about ``X.child``'s origin: ``f' = R f``,
        ``μ' = R μ + t × (R f)`` (the dual of the twist transformation).
        """
        if (self.frame, self.point) != (X.child, X.child):
            raise FrameError(
                f"transform {X.parent}<-{X.child} needs a wrench in {X.child!r} about {X.child!r}; "
                f"got frame {self.frame!r} about {self.point!r}"
            )
        f = X.rotation @ self.force
        return Wrench(f, X.rotation @ self.moment + np.cross(X.translation, f), X.parent, X.parent)

    def rotated(self, X: Transform) -> Wrench:
        """Re-express the axes in ``X.parent`` (from ``X.child``), keeping the point."""
        if self.frame != X.child:
            raise FrameError(f"rotation {X.parent}<-{X.child} needs a wrench in {X.child!r}; got {self.frame!r}")
        return Wrench(X.rotation @ self.force, X.rotation @ self.moment, X.parent, self.point)

    def shifted(self, point: str, r: Any) -> Wrench:
        """The moment about a new point, ``r`` the vector from the old point to it (in ``frame``)."""
        r = as_vector("r", r, 3)
        return Wrench(self.force, self.moment - np.cross(r, self.force), self.frame, _name("point", point))


@dataclass(frozen=True)
class Twist(_FrameTagged):
    """A linear and an angular velocity in frame ``frame``, the linear one of ``point``'s origin.

    Attributes:
        linear: v [m/s], (3,); angular: ω [rad/s], (3,).
    """

    _parts: ClassVar[tuple[str, str]] = ("linear", "angular")
    linear: np.ndarray
    angular: np.ndarray
    frame: str = "world"
    point: str = "world"


    @property
    def vector(self) -> np.ndarray:
        """``[v; ω]``, (6,)."""
        return np.concatenate([self.linear, self.angular])

    def __add__(self, other: Twist) -> Twist:
        if not isinstance(other, Twist) or (self.frame, self.point) != (other.frame, other.point):
            raise FrameError(
                f"cannot add twists in different frames: ({self.frame}, at {self.point}) and "
                f"({getattr(other, 'frame', '?')}, at {getattr(other, 'point', '?')})"
            )
        return Twist(self.linear + other.linear, self.angular + other.angular, self.frame, self.point)

    def transformed(self, X: Transform) -> Twist:
        """The same twist in ``X.parent`` at ``X.parent``'s origin: ``ω' = R ω``, ``v' = R v + t × ω'``."""
        if (self.frame, self.point) != (X.child, X.child):
            raise FrameError(
                f"transform {X.parent}<-{X.child} needs a twist in {X.child!r} at {X.child!r}; "
                f"got frame {self.frame!r} at {self.point!r}"
            )
        w = X.rotation @ self.angular
        return Twist(X.rotation @ self.linear + np.cross(X.translation, w), w, X.parent, X.parent)

    def power(self, wrench: Wrench) -> float:
        """``hᵀ v`` [W]; both must be in the same frame about the same point."""
        if (self.frame, self.point) != (wrench.frame, wrench.point):
            raise FrameError(
                f"power needs a twist and a wrench in the same frame and point; got ({self.frame}, {self.point}) "
                f"and ({wrench.frame}, {wrench.point})"
            )
        return float(self.linear @ wrench.force + self.angular @ wrench.moment)
