"""References: set-points and straight-line paths with a trapezoidal velocity profile.

A reference signal answers ``at(t)`` with a :class:`~forcecontrol.controllers.base.Reference`
and ``sample(times)`` with the packed rows the compiled loop reads (same numbers).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from ..controllers.base import REFERENCE_FIELDS, Reference
from ..core.validate import as_vector, nonnegative_scalar, positive_scalar
from ..errors import DimensionError, ParameterError

__all__ = ["ReferenceSignal", "Setpoint", "LinearPath", "trapezoidal_profile", "force_profile", "FORCE_SHAPES"]


class ReferenceSignal(ABC):
    """A reference as a function of time."""

    dim: int

    @abstractmethod
    def sample(self, times: np.ndarray) -> np.ndarray:
        """Packed reference rows, (len(times), 6 m), blocks as in ``REFERENCE_FIELDS``."""

    def at(self, t: float) -> Reference:
        """The reference at time t [s]."""
        row = self.sample(np.array([float(t)]))[0]
        m = self.dim
        return Reference(*(row[i * m : (i + 1) * m] for i in range(len(REFERENCE_FIELDS))))

    def describe(self) -> dict[str, Any]:
        return {"type": type(self).__name__}


def _force(force: Any, dim: int) -> np.ndarray:
    if force is None:
        z = np.zeros(dim)
        z.flags.writeable = False
        return z
    return as_vector("force", force, dim)


FORCE_SHAPES = ("linear", "smooth")


def force_profile(t: np.ndarray, start: float, ramp: float, shape: str = "linear") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normalised force time law σ(t), σ̇, σ̈ in [0, 1]: 0 before ``start``, 1 from ``start + ramp`` on.

    ``ramp = 0`` is a step at ``start`` (a sample at ``start`` holds the stepped value, like
    every breakpoint here); ``"linear"`` ramps at 1/ramp (σ̈ = 0: the corners are impulses);
    ``"smooth"`` is the quintic ``10τ³ − 15τ⁴ + 6τ⁵`` (τ = (t − start)/ramp), with continuous
    σ̇ and σ̈, so f_d, ḟ_d and f̈_d are all defined for the force laws (9.81).
    """
    t = np.asarray(t, dtype=np.float64)
    eps = _BREAK_TOL * max(1.0, abs(start) + ramp)
    if ramp <= 0.0:
        on = (t >= start - eps).astype(np.float64)
        return on, np.zeros_like(t), np.zeros_like(t)
    tau = np.clip((t - start) / ramp, 0.0, 1.0)
    moving = (t >= start - eps) & (t < start + ramp - eps)
    if shape == "linear":
        return tau, np.where(moving, 1.0 / ramp, 0.0), np.zeros_like(t)
    s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
    sd = 30.0 * tau**2 * (1.0 - tau) ** 2 / ramp
    sdd = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau) / ramp**2
    return s, np.where(moving, sd, 0.0), np.where(moving, sdd, 0.0)


class Setpoint(ReferenceSignal):
    """A constant position x_d and a force f_d, stepped at t = 0 or applied later by a time law.

    Args:
        position: x_d, (m,) [m].
        force: f_d, (m,) [N]; zero by default.
        force_start: when the force reference starts [s] (0: with the position step).
        force_ramp: how long it takes to reach f_d [s] (0: a step at ``force_start``).
        force_shape: ``"linear"`` or ``"smooth"`` (quintic: f_d, ḟ_d, f̈_d continuous); see
            :func:`force_profile`.
    """

    #: describe() says everything that shapes the samples (a sweep may reuse them; not inherited).
    describe_complete: ClassVar[bool] = True

    def __init__(
        self, position: Any, force: Any = None, *, force_start: float = 0.0, force_ramp: float = 0.0,
        force_shape: str = "linear",
    ) -> None:
        self.position = as_vector("position", position)
        self.dim = int(self.position.shape[0])
        self.force = _force(force, self.dim)
        self.force_start = nonnegative_scalar("force_start", force_start)
        self.force_ramp = nonnegative_scalar("force_ramp", force_ramp)
        if force_shape not in FORCE_SHAPES:
            raise ParameterError(f"force_shape must be one of {', '.join(FORCE_SHAPES)}; got {force_shape!r}")
        self.force_shape = force_shape

    @property
    def has_force_profile(self) -> bool:
        """True when f_d does not simply step at t = 0."""
        return self.force_start > 0.0 or self.force_ramp > 0.0

    def sample(self, times: np.ndarray) -> np.ndarray:
        n = len(times)
        m = self.dim
        out = np.zeros((n, 6 * m))
        out[:, 0:m] = self.position
        if not self.has_force_profile:
            out[:, 3 * m : 4 * m] = self.force
            return out
        s, sd, sdd = force_profile(np.asarray(times, dtype=np.float64), self.force_start, self.force_ramp, self.force_shape)
        out[:, 3 * m : 4 * m] = s[:, None] * self.force
        out[:, 4 * m : 5 * m] = sd[:, None] * self.force
        out[:, 5 * m : 6 * m] = sdd[:, None] * self.force
        return out

    def at(self, t: float) -> Reference:
        """The reference at t (the constant one is the same read-only arrays every call: no work per sample)."""
        if self.has_force_profile:
            return ReferenceSignal.at(self, t)
        ref = getattr(self, "_ref", None)
        if ref is None:
            z = np.zeros(self.dim)
            z.flags.writeable = False
            ref = Reference(self.position, z, z, self.force, z, z)
            self._ref = ref
        return ref

    def describe(self) -> dict[str, Any]:
        out: dict[str, Any] = {"type": "setpoint", "position": self.position.tolist(), "force": self.force.tolist()}
        if self.has_force_profile:
            out.update(force_start=self.force_start, force_ramp=self.force_ramp, force_shape=self.force_shape)
        return out


#: relative tolerance (of t_f) within which a sample time counts as being on a breakpoint.
_BREAK_TOL = 1e-9


def trapezoidal_profile(t: np.ndarray, duration: float, accel_time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normalised trapezoidal velocity timing law s(t) in [0, 1] (Sect. 4.2.1 of the book).

    Args:
        t: times since the start [s]; before 0 the profile rests at s = 0, from t_f on at
            s = 1, with zero velocity and acceleration.
        duration: t_f [s].
        accel_time: t_c [s], 0 < t_c <= t_f / 2.

    Returns:
        s, ṡ, s̈ at each time.
    """
    tf, tc = duration, accel_time
    sdd_c = 1.0 / (tc * (tf - tc))
    t = np.asarray(t, dtype=np.float64)
    s = np.empty_like(t)
    sd = np.empty_like(t)
    sdd = np.empty_like(t)
    # A sample at a breakpoint holds the interval that starts there (zero-order hold): t = 0
    # the first accelerating one, t_c the cruise, t_f − t_c the deceleration, t_f the rest.
    # Breakpoints are compared with a tolerance of 1e-9 t_f, so that k Ts lands on the
    # breakpoint it means despite round-off (0.8 may be 0.7999999999999999).
    eps = _BREAK_TOL * tf
    before = t < -eps
    after = t >= tf - eps
    s[before], sd[before], sdd[before] = 0.0, 0.0, 0.0
    s[after], sd[after], sdd[after] = 1.0, 0.0, 0.0
    moving = ~(before | after)
    a = moving & (t < tc - eps)
    c = moving & (t >= tc - eps) & (t < tf - tc - eps)
    d = moving & (t >= tf - tc - eps)
    s[a] = 0.5 * sdd_c * t[a] ** 2
    sd[a] = sdd_c * t[a]
    sdd[a] = sdd_c
    s[c] = sdd_c * tc * (t[c] - 0.5 * tc)
    sd[c] = sdd_c * tc
    sdd[c] = 0.0
    r = tf - t[d]
    s[d] = 1.0 - 0.5 * sdd_c * r**2
    sd[d] = sdd_c * r
    sdd[d] = -sdd_c
    return s, sd, sdd


def _trapezoid_scalar(t: float, tf: float, tc: float) -> tuple[float, float, float]:
    """:func:`trapezoidal_profile` at one time, with plain floats (the hot path of ``at``)."""
    eps = _BREAK_TOL * tf
    if t < -eps:
        return 0.0, 0.0, 0.0
    if t >= tf - eps:
        return 1.0, 0.0, 0.0
    sdd_c = 1.0 / (tc * (tf - tc))
    if t < tc - eps:
        return 0.5 * sdd_c * t * t, sdd_c * t, sdd_c
    if t < tf - tc - eps:
        return sdd_c * tc * (t - 0.5 * tc), sdd_c * tc, 0.0
    r = tf - t
    return 1.0 - 0.5 * sdd_c * r * r, sdd_c * r, -sdd_c


class LinearPath(ReferenceSignal):
    """A straight segment from ``start`` to ``end`` with a trapezoidal velocity profile.

    Before ``start_time`` the reference rests at ``start``; after ``start_time + duration`` at
    ``end``. Velocity and acceleration references are the exact derivatives.

    Args:
        start: p_i, (m,) [m]; end: p_f, (m,) [m].
        duration: t_f [s]; or give ``speed`` instead.
        accel_time: t_c [s], acceleration (and deceleration) time, 0 < t_c <= t_f/2;
            t_f/5 by default.
        speed: the cruise (top) speed along the path [m/s], instead of ``duration``: then
            ``t_f = L / speed + t_c`` (with the default ``t_c = t_f / 5``: ``t_f = 1.25 L / speed``).
        start_time: when the motion starts [s].
        force: constant f_d, (m,) [N].
    """

    #: describe() says everything that shapes the samples (a sweep may reuse them; not inherited).
    describe_complete: ClassVar[bool] = True

    def __init__(
        self,
        start: Any,
        end: Any,
        duration: float | None = None,
        accel_time: float | None = None,
        start_time: float = 0.0,
        force: Any = None,
        *,
        speed: float | None = None,
    ) -> None:
        self.start = as_vector("start", start)
        self.dim = int(self.start.shape[0])
        self.end = as_vector("end", end, self.dim)
        if (duration is None) == (speed is None):
            raise ParameterError(f"give exactly one of duration and speed; got duration={duration!r}, speed={speed!r}")
        if speed is not None:
            v = positive_scalar("speed", speed)
            L = float(np.linalg.norm(self.end - self.start))
            if L == 0.0:
                raise ParameterError("speed needs start and end to differ (a zero-length path has no duration)")
            duration = L / v + positive_scalar("accel_time", accel_time) if accel_time is not None else 1.25 * L / v
        self.duration = positive_scalar("duration", duration)
        self.accel_time = self.duration / 5.0 if accel_time is None else positive_scalar("accel_time", accel_time)
        if self.accel_time > 0.5 * self.duration + 1e-15:
            raise ParameterError(
                f"accel_time must be at most duration/2 = {0.5 * self.duration:.6g} s; got {self.accel_time:.6g} s"
            )
        if not math.isfinite(1.0 / max(self.accel_time * (self.duration - self.accel_time), 1e-320)):
            # the profile's peak acceleration 1/(t_c (t_f - t_c)) (Sect. 4.2.1) overflows: 1e-300 s, say
            raise ParameterError(
                f"duration {self.duration:.6g} s with accel_time {self.accel_time:.6g} s is too short: "
                "the path's acceleration 1/(t_c (t_f - t_c)) is not finite"
            )
        self.start_time = nonnegative_scalar("start_time", start_time)
        self.force = _force(force, self.dim)

    @property
    def cruise_speed(self) -> float:
        """Speed along the path during the constant-velocity phase [m/s]."""
        L = float(np.linalg.norm(self.end - self.start))
        return L / (self.duration - self.accel_time)

    def sample(self, times: np.ndarray) -> np.ndarray:
        times = np.asarray(times, dtype=np.float64)
        if times.ndim != 1:
            raise DimensionError(f"times must be a vector; got shape {times.shape}")
        s, sd, sdd = trapezoidal_profile(times - self.start_time, self.duration, self.accel_time)
        d = self.end - self.start
        m = self.dim
        out = np.zeros((len(times), 6 * m))
        out[:, 0:m] = self.start + s[:, None] * d
        out[:, m : 2 * m] = sd[:, None] * d
        out[:, 2 * m : 3 * m] = sdd[:, None] * d
        out[:, 3 * m : 4 * m] = self.force
        return out

    def at(self, t: float) -> Reference:
        """The reference at time t [s], evaluated with scalars (same numbers as ``sample``)."""
        s, sd, sdd = _trapezoid_scalar(float(t) - self.start_time, self.duration, self.accel_time)
        d = self.end - self.start
        z = np.zeros(self.dim)
        return Reference(self.start + s * d, sd * d, sdd * d, self.force, z, z)

    def describe(self) -> dict[str, Any]:
        return {
            "type": "linear-path",
            "start": self.start.tolist(),
            "end": self.end.tolist(),
            "duration": self.duration,
            "accel_time": self.accel_time,
            "start_time": self.start_time,
            "force": self.force.tolist(),
            "length": float(math.dist(self.start, self.end)),
        }
