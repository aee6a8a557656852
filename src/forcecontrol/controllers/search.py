"""A spiral search for a hole under force control: the search phase of peg-in-hole (issue 31, item 4).

The tool slides over a nominally flat surface pressed along its normal (the 6-D hybrid scheme
(9.77)–(9.84) of :class:`~forcecontrol.controllers.spatial_hybrid.SpatialHybridController`, S_f along the
surface's normal) while x_d runs along a spiral in the tangent plane. Where the surface opens (a hole,
a depression), the force loop pushes the tool in: the tip drops along the normal. The search watches
that drop, ``d(t) = n̂ᵀ(o_e(t) − o_e(t_0))`` with n̂ the known normal (into the surface) and t_0 the
search's start, and declares the hole found at the first sample where ``d > threshold``; from then on
x_d is held where the tip was (the spiral stops, as a real search does before the insertion).

Events (the run's ``events``, ``run --json``): ``hole found`` at the detection (time, tip position,
drop), or, when the run ends without one, ``hole not found`` (how far the spiral got). Both are said on
stderr too (a warning): a search that did not find its hole is not silent.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import ParameterError
from .base import Reference
from .spatial_hybrid import SpatialHybridController

__all__ = ["SpiralSearchController", "SearchNote"]


class SearchNote(UserWarning):
    """What a hole search found (or did not): said on stderr and logged in the run's events."""


class SpiralSearchController(SpatialHybridController):
    """:class:`~forcecontrol.controllers.spatial_hybrid.SpatialHybridController` with a hole detector.

    Law, inputs and outputs: those of the 6-D hybrid (force along S_f, pose along S_v). In addition:

    Args:
        normal: n̂, the surface's normal into it, base frame (3,), normalised: the drop is measured along it.
        threshold: the drop along n̂ [m] (> 0) that declares the hole.
        start_time: t_0 [s] (>= 0), when the search starts (the reference tip height is taken there).
        *args, **kwargs: those of :class:`SpatialHybridController`.

    After :meth:`reset`, :attr:`found` is None until the hole is found, then ``(t, o_e)``.
    """

    def __init__(self, *args: Any, normal: Any, threshold: float, start_time: float = 0.0, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        n = np.asarray(normal, dtype=np.float64)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.linalg.norm(n) > 1e-12:
            raise ParameterError(f"normal must be a non-zero finite 3-vector (into the surface); got {n.tolist()}")
        self.search_normal = n / np.linalg.norm(n)
        self.threshold = positive_scalar("threshold", threshold, "m")
        self.search_start = nonnegative_scalar("start_time", start_time, "s")
        self._compiled = False  # the detector runs each sample: the Python loop
        self._clear()

    def _clear(self) -> None:
        self.found: tuple[float, np.ndarray] | None = None
        self._origin: np.ndarray | None = None
        self._hold: np.ndarray | None = None
        self._t = 0.0
        self._now = 0.0
        self._max_drop = 0.0
        self._reach = 0.0
        self._warned = False

    def reset(self, measurement: Any = None, reference: Any = None) -> None:
        """As every controller; the search back to not found."""
        super().reset(measurement, reference)
        self._clear()

    def _frame_step(self, err: Any, o_e: np.ndarray, v_e: np.ndarray, h: np.ndarray, reference: Reference) -> Reference:
        reference = super()._frame_step(err, o_e, v_e, h, reference)
        t = self._now
        self._t = max(self._t, t)
        if self._hold is not None:
            return reference
        if t + 0.5 * self.sample_time < self.search_start:
            return reference
        if self._origin is None:
            self._origin = np.array(o_e[:3], dtype=np.float64)
            self._start_xd = np.array(np.asarray(reference.position, dtype=np.float64)[:3])
        drop = float(self.search_normal @ (o_e[:3] - self._origin))
        self._max_drop = max(self._max_drop, drop)
        xd = np.asarray(reference.position, dtype=np.float64)
        self._reach = max(self._reach, float(np.linalg.norm(xd[:3] - self._start_xd)))
        if drop > self.threshold:
            self.found = (t, np.array(o_e[:3], dtype=np.float64))
            hold = xd.copy()
            hold[:3] = o_e[:3]
            self._hold = hold
            text = (f"hole found at t = {t:.4f} s, tip at [{o_e[0]:.5f}, {o_e[1]:.5f}, {o_e[2]:.5f}] m "
                    f"(dropped {1e3 * drop:.2f} mm > {1e3 * self.threshold:.2f} mm along the normal); the spiral stops there")
            warnings.warn(f"{type(self).__name__}: {text}", SearchNote, stacklevel=2)
        return reference

    def step(self, t: float, measurement: Any, reference: Reference) -> np.ndarray:
        """The hybrid's torques for this sample (the detector runs inside, on the tip's position)."""
        self._now = float(t)
        if self._hold is not None:  # found: x_d held where the tip was (the pose error is formed from it)
            zero = np.zeros_like(np.asarray(reference.velocity, dtype=np.float64))
            reference = Reference(self._hold.copy(), zero, zero, reference.force, reference.force_rate, reference.force_accel)
        return super().step(t, measurement, reference)

    @property
    def events(self) -> list[dict[str, Any]]:
        """``hole found`` (t, detail with the tip position) or, after a run without it, ``hole not found``."""
        if self.found is not None:
            t, p = self.found
            return [{"t": float(t), "event": "hole found", "position": [float(v) for v in p],
                     "detail": f"tip at [{p[0]:.5f}, {p[1]:.5f}, {p[2]:.5f}] m dropped more than {1e3 * self.threshold:.2f} mm"}]
        if self._t <= 0.0:
            return []
        if self._origin is None:
            text = (f"hole not found: the run ended at t = {self._t:.4f} s, before the search's start at "
                    f"{self.search_start:.4g} s")
        else:
            text = (f"hole not found: no drop of more than {1e3 * self.threshold:.2f} mm along the normal by t = "
                    f"{self._t:.4f} s (largest {1e3 * self._max_drop:.2f} mm; x_d went {1e3 * self._reach:.1f} mm from "
                    "the search's start)")
        if not self._warned:
            self._warned = True
            warnings.warn(f"{type(self).__name__}: {text}", SearchNote, stacklevel=2)
        return [{"t": float(self._t), "event": "hole not found", "detail": text}]

    def gains(self) -> dict[str, Any]:
        return {**super().gains(), "search_normal": self.search_normal.tolist(), "threshold": self.threshold,
                "search_start": self.search_start}
