"""The constraint frame estimated online from the measured force and velocity (issue 31, item 3).

When the contact geometry is unknown, the task frame of Sect. 9.5 is not given: it is tracked from
what the sensors see, after Bruyninckx & De Schutter, "Specification of force-controlled actions in
the task frame formalism: a synthesis", IEEE T-RA 12(4), 1996 (the task frame's normal "tracked" by
the measured force and its tangent by the measured velocity) and De Schutter, Bruyninckx et al.,
"Estimating first-order geometric parameters and monitoring contact transitions during force-controlled
compliant motion", IJRR 18(12), 1999 (the contact normal from force and velocity, with friction
along the velocity removed by projecting it out):

* the measured force with its component along the measured velocity removed
  (``f_⊥ = f − (f·v̂) v̂`` when ``|v| > min_speed`` and the tool slides, ``|v·n̂| < |v|/2``, i.e. the
  velocity within 60° of the estimated tangent plane; else ``f``: while the tool presses in, along the
  normal, removing the velocity's direction would remove the normal itself): Coulomb friction acts
  along −v̂ on the tool, so on a frictional surface ``f_⊥`` still points along the contact normal;
* low-pass filtered, first order with time constant τ, on the vector's components (exact
  zero-order-hold discretisation, ``a = 1 − exp(−T_s/τ)``): ``n_f ← n_f + a (f_⊥/|f_⊥| − n_f)``;
  the normal estimate is ``n̂ = n_f/|n_f|``; below ``min_force`` (no contact) the estimate is held,
  and so is n̂ (n_f still filtering) while ``|n_f| < MIN_FILTERED`` (1e-9): samples opposite to n_f can
  cancel it (with a = 1/2, one sample ``f_⊥/|f_⊥| = −n_f`` gives ``n_f = 0``), which has no direction;
* the tangent: planar, ``t̂ = n̂`` turned by +90° (``[−n̂_y, n̂_x]``); 3-D, the measured velocity's
  part orthogonal to n̂ (the last one held when slower than ``min_speed``), and ``b̂ = n̂ × t̂``.

Sign: n̂ points along the force the tool exerts on the environment (h_e of the chapter, into the
surface), so ``λ = n̂ᵀ h_e > 0`` is pressing. Selection: ``S_f = n̂`` (d, 1), ``S_v = t̂`` (2-D) or
``[t̂ b̂]`` (3-D), orthonormal, so ``S_f† = S_fᵀ``, ``S_v† = S_vᵀ`` and ``S_fᵀ S_v = O`` (9.58).

Lag on a circle (the closed form the tests check): tracing a circle of radius R at speed v the true
normal turns at ω = v/R, ``n(t) = [cos ωt, sin ωt]``, i.e. the complex exponential e^{jωt}; the
filter ``τ ṅ_f + n_f = n`` answers with ``e^{jωt}/(1 + jωτ)``, so n̂ lags n by ``atan(ωτ) = atan(vτ/R)``
(and the discrete filter by ``arg(1 − (1 − a) e^{−jωT_s})``, equal to it up to O(ωT_s)).

Logged signals (one row per update): ``estimated_normal_angle`` [rad] (atan2 of n̂, 3-D: of its x–z
part; unwrapped), and, when a ``truth`` function is given (for the logs only: the controller never
reads it), ``true_normal_angle`` [rad] (unwrapped) and ``normal_angle_error`` [rad] (estimated − true,
wrapped to ±π): the estimate's lag and noise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.validate import as_vector, positive_scalar
from ..errors import DimensionError, ParameterError

__all__ = ["ConstraintFrameEstimator", "circle_lag"]


def circle_lag(speed: float, radius: float, time_constant: float, sample_time: float | None = None) -> float:
    """The angle [rad] by which the first-order estimate lags the true normal on a circle traced at
    constant ``speed``: ``atan(v τ / R)`` (continuous), or the exact value of the discrete filter when
    ``sample_time`` is given (see the module docstring)."""
    w = speed / radius
    if sample_time is None:
        return math.atan(w * time_constant)
    a = 1.0 - math.exp(-sample_time / time_constant)
    z = 1.0 - (1.0 - a) * complex(math.cos(w * sample_time), -math.sin(w * sample_time))
    return math.atan2(z.imag, z.real)


def _angle(v: np.ndarray) -> float:
    return math.atan2(float(v[1]), float(v[0])) if v.shape[0] == 2 else math.atan2(float(v[2]), float(v[0]))


def _unwrapped(angle: float, previous: list[float]) -> float:
    """``angle`` shifted by a multiple of 2π to within π of the last logged value (continuous curves)."""
    return angle if not previous else previous[-1] + math.remainder(angle - previous[-1], 2.0 * math.pi)


#: below this norm the filtered vector n_f (a mean of unit vectors) gives no direction: n̂ is held.
MIN_FILTERED = 1e-9


def _finite(name: str, values: list[float], unit: str) -> None:
    if not all(map(math.isfinite, values)):
        raise ParameterError(f"{name} must be finite [{unit}]; got {values} (the estimate is left as it was)")


class ConstraintFrameEstimator:
    """The constraint frame's normal and tangent tracked from the measured force and velocity.

    Args:
        first_normal: the first guess of the contact normal (d,), d = 2 (planar) or 3, along the
            force the tool is to exert (into the surface); normalised.
        time_constant: τ [s] of the first-order filter, > 0.
        sample_time: T_s [s] between updates, > 0.
        min_force: below this measured force [N] the estimate is held (no contact), default 1.
        min_speed: below this speed [m/s] the velocity is not used (friction not removed; 3-D: the
            tangent held), default 1e-3; nor is it when it points within 30° of the normal (pressing in).
        first_tangent: 3-D only: the first tangent guess (made orthogonal to the normal); default
            any vector orthogonal to it.
        truth: optional ``x -> true normal (d,)`` (into the surface), used for the logs only.

    Friction is removed only while the tool slides faster than ``min_speed``: while it sticks or
    creeps, the measured force's tangential part f_t stays in, and n̂ tilts from the contact normal
    towards f_t by ``atan(|f_t|/f_n)``, up to ``atan μ_s`` (16.70° at μ_s = 0.3).
    """

    def __init__(self, first_normal: Any, time_constant: float, sample_time: float, *, min_force: float = 1.0,
                 min_speed: float = 1e-3, first_tangent: Any = None,
                 truth: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        n0 = np.asarray(first_normal, dtype=np.float64)
        if n0.shape not in ((2,), (3,)):
            raise DimensionError(f"first_normal must have 2 (planar) or 3 components; got shape {n0.shape}")
        n0 = as_vector("first_normal", n0, n0.shape[0])
        norm = float(np.linalg.norm(n0))
        if not norm > 1e-12:
            raise ParameterError(f"first_normal must be a non-zero vector; got {n0.tolist()}")
        self.dim = int(n0.shape[0])
        self.first_normal = n0 / norm
        self.time_constant = positive_scalar("time_constant", time_constant, "s")
        self.sample_time = positive_scalar("sample_time", sample_time, "s")
        self.min_force = positive_scalar("min_force", min_force, "N")
        self.min_speed = positive_scalar("min_speed", min_speed, "m/s")
        self.first_tangent = self._orthogonal(self.first_normal, first_tangent)
        self.truth = truth
        #: the filter's gain per update, exact zero-order hold of τ ṅ_f + n_f = n.
        self.gain = 1.0 - math.exp(-self.sample_time / self.time_constant)
        self.reset()

    def _orthogonal(self, n: np.ndarray, guess: Any) -> np.ndarray:
        if self.dim == 2:
            if guess is not None:
                raise ParameterError("first_tangent applies to 3-D only; the planar tangent is the normal turned by +90°")
            return np.array([-n[1], n[0]])
        g = np.asarray(guess if guess is not None else (np.eye(3)[int(np.argmin(np.abs(n)))]), dtype=np.float64)
        if g.shape != (3,):
            raise DimensionError(f"first_tangent must have 3 components; got shape {g.shape}")
        t = g - float(g @ n) * n
        if not np.linalg.norm(t) > 1e-9:
            raise ParameterError(f"first_tangent must not be parallel to first_normal; got {g.tolist()}")
        return t / np.linalg.norm(t)

    @property
    def SIGNALS(self) -> tuple[str, ...]:  # noqa: N802 - the name the scenarios read from controllers
        """The names of the logged signals."""
        names = ("estimated_normal_angle",)
        return names + (("true_normal_angle", "normal_angle_error") if self.truth is not None else ())

    def reset(self) -> None:
        """Back to the first guess; logs cleared."""
        self.filtered = self.first_normal.copy()
        self.normal = self.first_normal.copy()
        self.tangent = self.first_tangent.copy()
        self._log: dict[str, list[float]] = {"estimated_normal_angle": []}
        if self.truth is not None:
            self._log.update(true_normal_angle=[], normal_angle_error=[])

    def update(self, force: Any, velocity: Any, x: Any = None) -> np.ndarray:
        """One sample: filter the measured normal direction; returns n̂ (d,). ``force`` and
        ``velocity`` are base-frame (d,) [N], [m/s] (longer vectors are cut to d); ``x`` the tip
        position, for the ``truth`` log only.

        Raises:
            DimensionError: ``force`` or ``velocity`` has fewer than d components.
            ParameterError: a NaN or infinite component of ``force`` or ``velocity`` (nothing changed).
        """
        d = self.dim
        f = np.asarray(force, dtype=np.float64)[:d]
        v = np.asarray(velocity, dtype=np.float64)[:d]
        fl, vl = f.tolist(), v.tolist()
        if len(fl) != d or len(vl) != d:
            raise DimensionError(f"force and velocity must have at least {d} components; got {len(fl)} and {len(vl)}")
        if not math.isfinite(sum(fl) + sum(vl)):  # one test when all is well; then which one
            _finite("force", fl, "N")
            _finite("velocity", vl, "m/s")
        if d == 2:
            return self._update2(*fl, *vl, x)
        speed = math.sqrt(float(v @ v))
        if speed > self.min_speed and abs(float(v @ self.normal)) < 0.5 * speed:
            f = f - float(f @ v) / (speed * speed) * v  # friction along the (sliding) velocity removed
        fn = math.sqrt(float(f @ f))
        if fn > self.min_force:
            self.filtered = self.filtered + self.gain * (f / fn - self.filtered)
            na = float(np.linalg.norm(self.filtered))
            if na >= MIN_FILTERED:  # else no direction: n̂ held
                self.normal = self.filtered / na
        n = self.normal
        t = v - float(v @ n) * n if speed > self.min_speed else self.tangent - float(self.tangent @ n) * n
        tn = float(np.linalg.norm(t))
        self.tangent = t / tn if tn > 1e-12 else self._orthogonal(n, None)
        self._record(x)
        return n

    def _update2(self, f0: float, f1: float, v0: float, v1: float, x: Any) -> np.ndarray:
        """:meth:`update` for a planar frame on scalars: the same arithmetic, without the small arrays."""
        speed = math.sqrt(v0 * v0 + v1 * v1)
        m0, m1 = self.normal.tolist()
        if speed > self.min_speed and abs(v0 * m0 + v1 * m1) < 0.5 * speed:
            c = (f0 * v0 + f1 * v1) / (speed * speed)  # friction along the (sliding) velocity removed
            f0, f1 = f0 - c * v0, f1 - c * v1
        fn = math.sqrt(f0 * f0 + f1 * f1)
        if fn > self.min_force:
            g = self.gain
            a0, a1 = self.filtered.tolist()
            a0, a1 = a0 + g * (f0 / fn - a0), a1 + g * (f1 / fn - a1)
            self.filtered = np.array((a0, a1))
            na = math.sqrt(a0 * a0 + a1 * a1)
            if na >= MIN_FILTERED:  # else no direction: n̂ held
                m0, m1 = a0 / na, a1 / na
                self.normal = np.array((m0, m1))
        self.tangent = np.array((-m1, m0))
        self._record(x)
        return self.normal

    def _record(self, x: Any) -> None:
        log = self._log
        est = _unwrapped(_angle(self.normal), log["estimated_normal_angle"])
        log["estimated_normal_angle"].append(est)
        if self.truth is not None and x is not None:
            true = _angle(np.asarray(self.truth(np.asarray(x, dtype=np.float64)[: self.dim]), dtype=np.float64))
            true = _unwrapped(true, log["true_normal_angle"])
            log["true_normal_angle"].append(true)
            self._log["normal_angle_error"].append(math.remainder(est - true, 2.0 * math.pi))

    def selection(self) -> tuple[np.ndarray, np.ndarray]:
        """(S_f (d, 1), S_v (d, d − 1)) of the current estimate, orthonormal columns."""
        S_f = self.normal[:, None].copy()
        if self.dim == 2:
            return S_f, self.tangent[:, None].copy()
        n0, n1, n2 = self.normal.tolist()
        t0, t1, t2 = self.tangent.tolist()
        # ν × t as np.cross computes it (each product, then the difference), without its 50 µs of overhead per call
        return S_f, np.array(((t0, n1 * t2 - n2 * t1), (t1, n2 * t0 - n0 * t2), (t2, n0 * t1 - n1 * t0)))

    def signals(self) -> dict[str, np.ndarray]:
        """The logged signals, one row per update."""
        return {name: np.asarray(v, dtype=np.float64) for name, v in self._log.items()}

    def describe(self) -> dict[str, Any]:
        return {"type": "constraint-frame-estimator", "first_normal": self.first_normal.tolist(),
                "time_constant": self.time_constant, "min_force": self.min_force, "min_speed": self.min_speed}
