"""References: set-points and straight-line paths with a trapezoidal velocity profile.

A reference signal answers ``at(t)`` with a :class:`~forcecontrol.controllers.base.Reference`
and ``sample(times)`` with the packed rows the compiled loop reads (same numbers).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from ._axes import axis_names
from ._validate import as_vector, nonnegative_scalar, positive_scalar
from .controllers.base import REFERENCE_FIELDS, Reference
from .errors import DimensionError, ParameterError

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


#: interpolation kinds of :class:`SampledReference`.
INTERPOLATIONS: tuple[str, ...] = ("linear", "cubic")


class SampledReference(ReferenceSignal):
    """A reference given by samples (a recorded or designed trajectory), interpolated in time.

    Position (and optionally force) samples at increasing times; velocities, accelerations, force
    rates and force accelerations come from the interpolant: ``"cubic"`` is a C² cubic spline
    with zero end slopes (``scipy.interpolate.CubicSpline``, ``bc_type="clamped"``), so x_d,
    ẋ_d and ẍ_d are continuous; ``"linear"`` joins the samples by straight lines (ẋ_d piecewise
    constant, ẍ_d = 0). Before the first sample and after the last the first/last values hold
    with zero derivatives.

    Args:
        times: sample times (N,) [s], strictly increasing, N >= 2.
        position: x_d samples (N, m) [m].
        force: f_d samples (N, m) [N], or None (zero).
        interpolation: ``"linear"`` or ``"cubic"``.
        velocity, acceleration: ẋ_d, ẍ_d samples (N, m), when the source has them (a saved run,
            a planner): then they are interpolated linearly instead of differentiated.

    Raises:
        ParameterError: non-finite values, times not strictly increasing, an unknown interpolation.
        DimensionError: shapes that do not match.
    """

    def __init__(self, times: Any, position: Any, force: Any = None, *, interpolation: str = "cubic",
                 velocity: Any = None, acceleration: Any = None) -> None:
        t = np.asarray(times, dtype=np.float64)
        if t.ndim != 1 or t.shape[0] < 2:
            raise DimensionError(f"times must be a vector of at least 2 samples; got shape {t.shape}")
        if not np.all(np.isfinite(t)):
            raise ParameterError("times must be finite; got NaN or inf")
        steps = np.diff(t)
        if np.any(steps <= 0.0):
            i = int(np.argmax(steps <= 0.0))
            raise ParameterError(
                f"times must be strictly increasing; got t[{i}] = {t[i]:.6g} s followed by t[{i + 1}] = {t[i + 1]:.6g} s"
            )
        X = np.asarray(position, dtype=np.float64)
        if X.ndim == 1:
            X = X[:, None]
        if X.ndim != 2 or X.shape[0] != t.shape[0]:
            raise DimensionError(f"position must have shape ({t.shape[0]}, m) like times; got shape {X.shape}")
        if not np.all(np.isfinite(X)):
            raise ParameterError("position samples must be finite; got NaN or inf")
        m = X.shape[1]
        F = np.zeros_like(X) if force is None else np.asarray(force, dtype=np.float64)
        if F.ndim == 1:
            F = F[:, None]
        if F.shape != X.shape:
            raise DimensionError(f"force must have shape {X.shape} like position; got shape {F.shape}")
        if not np.all(np.isfinite(F)):
            raise ParameterError("force samples must be finite; got NaN or inf")
        if interpolation not in INTERPOLATIONS:
            raise ParameterError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}; got {interpolation!r}")
        extra = {}
        for name, v in (("velocity", velocity), ("acceleration", acceleration)):
            if v is None:
                continue
            V = np.asarray(v, dtype=np.float64)
            V = V[:, None] if V.ndim == 1 else V
            if V.shape != X.shape:
                raise DimensionError(f"{name} must have shape {X.shape} like position; got shape {V.shape}")
            if not np.all(np.isfinite(V)):
                raise ParameterError(f"{name} samples must be finite; got NaN or inf")
            extra[name] = V
        self._given = extra
        self.times, self.position_samples, self.force_samples = t, X, F
        self.dim = int(m)
        self.interpolation = interpolation
        self._has_force = force is not None
        if interpolation == "cubic":
            from scipy.interpolate import CubicSpline  # type: ignore[import-untyped]

            self._x = CubicSpline(t, X, bc_type="clamped")
            self._f = CubicSpline(t, F, bc_type="clamped")

    def _eval(self, tq: np.ndarray, Y: np.ndarray, spline: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        tc = np.clip(tq, self.times[0], self.times[-1])
        inside = ((tq >= self.times[0]) & (tq <= self.times[-1]))[:, None]
        if self.interpolation == "cubic":
            y, yd, ydd = spline(tc), spline(tc, 1), spline(tc, 2)
        else:
            idx = np.clip(np.searchsorted(self.times, tc, side="right") - 1, 0, self.times.shape[0] - 2)
            t0, t1 = self.times[idx], self.times[idx + 1]
            w = ((tc - t0) / (t1 - t0))[:, None]
            y = (1.0 - w) * Y[idx] + w * Y[idx + 1]
            yd = (Y[idx + 1] - Y[idx]) / (t1 - t0)[:, None]
            ydd = np.zeros_like(y)
        return y, np.where(inside, yd, 0.0), np.where(inside, ydd, 0.0)

    def sample(self, times: np.ndarray) -> np.ndarray:
        tq = np.asarray(times, dtype=np.float64).reshape(-1)
        m = self.dim
        out = np.zeros((tq.shape[0], 6 * m))
        x, xd, xdd = self._eval(tq, self.position_samples, getattr(self, "_x", None))
        inside = ((tq >= self.times[0]) & (tq <= self.times[-1]))[:, None]
        for name, V in self._given.items():  # given derivatives: interpolated linearly, zero outside
            tc = np.clip(tq, self.times[0], self.times[-1])
            vi = np.column_stack([np.interp(tc, self.times, V[:, j]) for j in range(m)])
            vi = np.where(inside, vi, 0.0)
            if name == "velocity":
                xd = vi
            else:
                xdd = vi
        out[:, 0:m], out[:, m : 2 * m], out[:, 2 * m : 3 * m] = x, xd, xdd
        if self._has_force:
            f, fd, fdd = self._eval(tq, self.force_samples, getattr(self, "_f", None))
            out[:, 3 * m : 4 * m], out[:, 4 * m : 5 * m], out[:, 5 * m : 6 * m] = f, fd, fdd
        return out

    @classmethod
    def from_file(cls, path: Any, *, dim: int | None = None, interpolation: str = "cubic") -> SampledReference:
        """Read samples from a CSV (header row) or Parquet file.

        Columns: ``t`` [s]; the position per axis, ``x y [z]`` (or ``x0 x1 ...``), or the
        simulator's own log names ``ref_position_x ...`` (preferred when both are present) (so a saved run can be replayed as a
        reference); optionally the force ``fx fy [fz]`` or ``ref_force_x ...``. ``dim`` picks
        the task dimension (default: as many position axes as the file has).

        Raises:
            ParameterError: unreadable file, no ``t`` column, no position columns (the message
                lists the columns found).
        """
        from pathlib import Path

        p = Path(path)
        try:
            if p.suffix.lower() == ".parquet":
                import pyarrow.parquet as pq  # type: ignore[import-untyped]

                table = pq.read_table(p)
                cols = {name: np.asarray(table.column(name).to_numpy(), dtype=np.float64) for name in table.column_names}
            else:
                data = np.genfromtxt(p, delimiter=",", names=True, dtype=np.float64, encoding="utf-8")
                cols = {name: np.atleast_1d(np.asarray(data[name], dtype=np.float64)) for name in data.dtype.names or ()}
        except (OSError, ValueError, UnicodeDecodeError) as exc:
            raise ParameterError(f"cannot read reference samples from {str(p)!r}: {exc}") from exc
        except ImportError as exc:  # pragma: no cover - pyarrow is in the data extra
            raise ParameterError(f"reading {str(p)!r} needs pyarrow (pip install 'forcecontrol[data]')") from exc
        if "t" not in cols:
            raise ParameterError(f"{str(p)!r} has no column 't'; columns found: {sorted(cols)}")

        def pick(names: list[str], prefixes: tuple[str, str]) -> list[np.ndarray] | None:
            out = []
            for a in names:
                for pre in prefixes:
                    key = f"{pre}{a}"
                    if key in cols:
                        out.append(cols[key])
                        break
                else:
                    return None
            return out

        candidates = [dim] if dim is not None else [6, 3, 2, 1]
        for m in candidates:
            pos = pick(axis_names(m)[0], ("ref_position_", ""))  # a saved run's x, y are the tip, not the reference
            if pos is not None:
                break
        else:
            raise ParameterError(
                f"{str(p)!r} has no position columns for {'dim = ' + str(dim) if dim else 'any dimension'} "
                f"(expected e.g. x, y or ref_position_x, ref_position_y); columns found: {sorted(cols)}"
            )
        names, _, wrench = axis_names(m)
        force = pick(names, ("ref_force_",)) or pick(wrench, ("",))
        vel = pick(names, ("ref_velocity_",))
        acc = pick(names, ("ref_acceleration_",))
        return cls(cols["t"], np.column_stack(pos), None if force is None else np.column_stack(force),
                   interpolation=interpolation, velocity=None if vel is None else np.column_stack(vel),
                   acceleration=None if acc is None else np.column_stack(acc))

    def describe(self) -> dict[str, Any]:
        return {"type": "sampled", "samples": int(self.times.shape[0]), "t_start": float(self.times[0]),
                "t_end": float(self.times[-1]), "interpolation": self.interpolation, "force": self._has_force}
