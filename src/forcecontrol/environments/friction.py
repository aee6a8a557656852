"""Coulomb friction with stiction on an elastic surface: a stick/slip (reset-integrator) model.

:class:`FrictionalContact` wraps an elastic surface (an :class:`~forcecontrol.environments.elastic.ElasticPlane`
or any :class:`~forcecontrol.environments.surfaces.ElasticSurface`) and adds a tangential force to
its normal force f_n. With ν the surface normal and ``v_t = ẋ − (ν·ẋ) ν`` the tangential velocity,
the tangential part of h_e (the force the tool exerts on the surface, along the motion) is:

* **slip**: ``h_t = μ_k f_n s + b v_t``, s the unit sliding direction (``v_t/|v_t|``): kinetic
  Coulomb plus viscous friction, exact, not smoothed;
* **stick**: the tool is held by a stiff tangential spring to an anchor point a (a bristle):
  ``h_t = σ₀ e_t + σ₁ v_t`` with e_t the tangential part of ``x − a``; the tool cannot creep:
  its tangential speed decays with the bristle's damped mode to zero.

The mode is a state, updated after every integrator step (:meth:`FrictionalContact.advance`,
called by the simulator's Python loop; within a step the state is held, so the force is smooth for
RK4): stick turns to slip when the bristle force exceeds the static limit, ``|σ₀ e_t + σ₁ v_t| > μ_s f_n``
(breakaway); slip turns to stick when the tangential velocity reverses or drops below
``stick_speed``, with the anchor placed so that the bristle carries the kinetic force at once
(no jump of the friction force). Losing contact clears the state; touching starts in stick when
``|v_t| <= stick_speed``, else in slip.

The run's log gets the signals ``friction`` (the tangential part of h_e, (N+1, m) [N]),
``normal_force`` (f_n >= 0 [N]), ``friction_force`` (|h_t| [N]), ``tangential_speed`` (|v_t| [m/s],
v_t relative to the surface normal at the contact) and ``stick`` (1 while sticking, 0 while slipping or free).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import ParameterError
from .base import Environment
from .elastic import ElasticPlane
from .spatial import Table
from .surfaces import ElasticSphere, ElasticSurface

__all__ = ["FrictionalContact"]

FREE, STICK, SLIP = 0, 1, 2


def _bounded(name: str, value: Any, low: float, high: float, unit: str = "") -> float:
    v = nonnegative_scalar(name, value, unit)
    if not low <= v <= high:
        raise ParameterError(f"{name} must be in [{low:g}, {high:g}]{' ' + unit if unit else ''}; got {v!r}")
    return v


class FrictionalContact(Environment):
    """An elastic surface with Coulomb friction (static μ_s, kinetic μ_k), stiction and viscous friction.

    Args:
        surface: an :class:`~forcecontrol.environments.elastic.ElasticPlane` (2-D/3-D), a
            :class:`~forcecontrol.environments.spatial.Table` (6-D pose task) or an
            :class:`~forcecontrol.environments.surfaces.ElasticSurface`.
        static: μ_s in [0, 10], >= μ_k.
        kinetic: μ_k in [0, 10].
        viscous: b [N s/m] >= 0, the tangential viscous friction.
        stick_stiffness: σ₀ [N/m] > 0 of the sticking bristle (default: the surface's normal stiffness).
        stick_damping: σ₁ [N s/m] >= 0 of the bristle (default: the surface's normal damping).
        stick_speed: below this tangential speed [m/s] a sliding tool sticks (default 1e-4).
    """

    stateful: ClassVar[bool] = True
    #: the scalar signals it logs (plottable columns of the run).
    SIGNALS: ClassVar[tuple[str, ...]] = ("normal_force", "friction_force", "tangential_speed", "stick")
    describe_type: ClassVar[str | None] = "frictional-contact"

    def __init__(self, surface: Environment, static: float, kinetic: float, viscous: float = 0.0, *,
                 stick_stiffness: float | None = None, stick_damping: float | None = None, stick_speed: float = 1e-4) -> None:
        if not isinstance(surface, (ElasticPlane, Table, ElasticSurface)):
            raise ParameterError(f"surface must be an ElasticPlane, a Table or an ElasticSurface; got {type(surface).__name__}")
        if getattr(surface, "stateful", False):
            raise ParameterError("surface must not itself be a FrictionalContact")
        self.surface = surface
        self.dim = surface.dim
        self.space = surface.dim if isinstance(surface, ElasticPlane) else 3 if isinstance(surface, Table) else surface.space
        self.mu_s = _bounded("static", static, 0.0, 10.0)
        self.mu_k = _bounded("kinetic", kinetic, 0.0, 10.0)
        if self.mu_k > self.mu_s:
            raise ParameterError(
                f"kinetic must not exceed static (μ_k <= μ_s); got kinetic = {self.mu_k!r}, static = {self.mu_s!r}"
            )
        self.viscous = nonnegative_scalar("viscous", viscous, "N s/m")
        k, c = float(surface.stiffness), float(surface.damping)
        self.sigma0 = k if stick_stiffness is None else positive_scalar("stick_stiffness", stick_stiffness, "N/m")
        self.sigma1 = c if stick_damping is None else nonnegative_scalar("stick_damping", stick_damping, "N s/m")
        self.stick_speed = positive_scalar("stick_speed", stick_speed, "m/s")
        #: the damping that sets the integration step (the fastest of the normal, bristle and viscous ones).
        self.damping = max(c, self.sigma1 + self.viscous)
        self._clear()
        self._log: dict[str, np.ndarray] = {}

    def _clear(self) -> None:
        self.mode = FREE
        self.anchor = np.zeros(self.space)
        self.direction = np.zeros(self.space)

    # -- geometry and forces
    def _normal(self, x: np.ndarray, xd: np.ndarray) -> tuple[float, np.ndarray]:
        s = self.surface
        if isinstance(s, (ElasticPlane, Table)):
            nu = s.normal
            delta = float(nu @ (s.point - x))
            if delta <= 0.0:
                return 0.0, nu
            return max(0.0, s.stiffness * delta - s.damping * float(nu @ xd)), nu
        fn, nu, _ = s.normal_force(x, xd)
        return fn, nu

    def _stick_force2(self, p0: float, p1: float, n0: float, n1: float, t0: float, t1: float) -> tuple[float, float]:
        """The stuck contact's tangential spring and damper on scalars (planar): σ0 (the anchor offset in the tangent
        plane) + σ1 (the tangential velocity (t0, t1))."""
        a0, a1 = self.anchor.tolist()
        e0 = p0 - a0
        e1 = p1 - a1
        en = n0 * e0 + n1 * e1
        return self.sigma0 * (e0 - en * n0) + self.sigma1 * t0, self.sigma0 * (e1 - en * n1) + self.sigma1 * t1

    def _normal2(self, p0: float, p1: float, v0: float, v1: float) -> tuple[float, float, float]:
        """:meth:`_normal` on scalars for a planar surface: (f_n, ν0, ν1), the same arithmetic."""
        s = self.surface
        if type(s) is ElasticPlane:
            n0, n1 = s.normal.tolist()
            r0, r1 = s.point.tolist()
            delta = n0 * (r0 - p0) + n1 * (r1 - p1)
            if delta <= 0.0:
                return 0.0, n0, n1
            return max(0.0, s.stiffness * delta - s.damping * (n0 * v0 + n1 * v1)), n0, n1
        if type(s) is ElasticSphere:  # ElasticSphere.geometry and ElasticSurface.normal_force
            c0, c1 = s.center.tolist()
            d0 = p0 - c0
            d1 = p1 - c1
            r = math.sqrt(d0 * d0 + d1 * d1)
            n0, n1 = (1.0, 0.0) if r < 1e-12 else (d0 / r, d1 / r)
            phi = r - s.radius
            if phi >= 0.0:
                return 0.0, n0, n1
            return max(0.0, -s.stiffness * phi - s.damping * (n0 * v0 + n1 * v1)), n0, n1
        fn, nu = self._normal(np.array((p0, p1)), np.array((v0, v1)))
        n0, n1 = np.asarray(nu, dtype=np.float64).tolist()
        return fn, n0, n1

    def _components2(self, p0: float, p1: float, v0: float, v1: float) -> tuple[float, float, float, float, float]:
        """:meth:`components` on scalars for a planar surface (the same arithmetic, none of the small
        arrays): (f_n, ν0, ν1, h_t0, h_t1); h_n = −f_n ν."""
        fn, n0, n1 = self._normal2(p0, p1, v0, v1)
        if fn <= 0.0:
            return 0.0, n0, n1, 0.0, 0.0
        vn = n0 * v0 + n1 * v1
        t0 = v0 - vn * n0
        t1 = v1 - vn * n1
        if self.mode == STICK:
            h0, h1 = self._stick_force2(p0, p1, n0, n1, t0, t1)
        else:  # sliding (or touching in this step: the state follows after it)
            speed = math.sqrt(t0 * t0 + t1 * t1)
            if speed > 1e-12:
                s0, s1 = t0 / speed, t1 / speed
            else:
                d0, d1 = self.direction.tolist()
                dn = n0 * d0 + n1 * d1
                s0, s1 = d0 - dn * n0, d1 - dn * n1
                ns = math.sqrt(s0 * s0 + s1 * s1)
                s0, s1 = (s0 / ns, s1 / ns) if ns > 1e-12 else (0.0, 0.0)
            f = self.mu_k * fn
            h0, h1 = f * s0, f * s1
        b = self.viscous
        return fn, n0, n1, h0 + b * t0, h1 + b * t1

    def components(self, x: Any, xd: Any) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """(f_n, ν, h_n, h_t) at (x, ẋ) under the current stick/slip state: the normal force [N], the
        normal, and the normal and tangential parts of h_e (space,) [N]."""
        p = np.asarray(x, dtype=np.float64)[: self.space]
        v = np.asarray(xd, dtype=np.float64)[: self.space]
        if self.space == 2:
            fn, n0, n1, h0, h1 = self._components2(*p.tolist(), *v.tolist())
            return fn, np.array((n0, n1)), np.array((-fn * n0, -fn * n1)), np.array((h0, h1))
        fn, nu = self._normal(p, v)
        zero = np.zeros(self.space)
        if fn <= 0.0:
            return 0.0, nu, zero, zero
        vt = v - float(nu @ v) * nu
        if self.mode == STICK:
            e = p - self.anchor
            ht = self.sigma0 * (e - float(nu @ e) * nu) + self.sigma1 * vt
        else:  # sliding (or touching in this step: the state follows after it)
            speed = math.sqrt(float(vt @ vt))
            if speed > 1e-12:
                s = vt / speed
            else:
                s = self.direction - float(nu @ self.direction) * nu
                ns = float(np.linalg.norm(s))
                s = s / ns if ns > 1e-12 else zero
            ht = self.mu_k * fn * s
        return fn, nu, -fn * nu, ht + self.viscous * vt

    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        if self.space == 2 and self.dim == 2:  # the planar arm's hot path: scalars in, one array out
            x0, x1 = np.asarray(x, dtype=np.float64).tolist()
            v0, v1 = np.asarray(xd, dtype=np.float64).tolist()
            fn, n0, n1, h0, h1 = self._components2(x0, x1, v0, v1)
            return np.array((-fn * n0 + h0, -fn * n1 + h1))
        out = np.zeros(self.dim)
        _, _, hn, ht = self.components(x, xd)
        out[: self.space] = hn + ht
        return out

    def max_stiffness(self) -> float:
        return max(float(self.surface.stiffness), self.sigma0)

    def take_projection_note(self) -> str | None:
        """The surface's (:meth:`~forcecontrol.environments.surfaces.ElasticSurface.take_projection_note`), or None."""
        take = getattr(self.surface, "take_projection_note", None)
        return take() if take is not None else None

    # -- the stick/slip state (the simulator calls start, advance, log_sample, signals)
    def _update(self, x: np.ndarray, xd: np.ndarray) -> None:
        p = np.asarray(x, dtype=np.float64)[: self.space]
        v = np.asarray(xd, dtype=np.float64)[: self.space]
        if self.space == 2:
            self._update2(*p.tolist(), *v.tolist())
            return
        fn, nu = self._normal(p, v)
        if fn <= 0.0:
            self.mode = FREE
            return
        vt = v - float(nu @ v) * nu
        speed = math.sqrt(float(vt @ vt))
        if self.mode == FREE:
            if speed > self.stick_speed:
                self.mode, self.direction = SLIP, vt / speed
            else:
                self.mode, self.anchor = STICK, p.copy()
            return
        if self.mode == STICK:
            e = p - self.anchor
            et = e - float(nu @ e) * nu
            f = self.sigma0 * et + self.sigma1 * vt
            fmag = math.sqrt(float(f @ f))
            if fmag > self.mu_s * fn:  # breakaway
                self.mode = SLIP
                self.direction = vt / speed if speed > 1e-12 else f / fmag
            return
        # sliding: stop on a reversal or below the sticking speed, with the kinetic force carried on
        if speed <= self.stick_speed or float(vt @ self.direction) <= 0.0:
            d = self.direction - float(nu @ self.direction) * nu
            nd = float(np.linalg.norm(d))
            d = d / nd if nd > 1e-12 else np.zeros(self.space)
            self.mode = STICK
            self.anchor = p - (self.mu_k * fn / self.sigma0) * d
        else:
            self.direction = vt / speed

    def _update2(self, p0: float, p1: float, v0: float, v1: float) -> None:
        """:meth:`_update` on scalars for a planar surface (the same arithmetic and transitions)."""
        fn, n0, n1 = self._normal2(p0, p1, v0, v1)
        if fn <= 0.0:
            self.mode = FREE
            return
        vn = n0 * v0 + n1 * v1
        t0 = v0 - vn * n0
        t1 = v1 - vn * n1
        speed = math.sqrt(t0 * t0 + t1 * t1)
        if self.mode == FREE:
            if speed > self.stick_speed:
                self.mode, self.direction = SLIP, np.array((t0 / speed, t1 / speed))
            else:
                self.mode, self.anchor = STICK, np.array((p0, p1))
            return
        if self.mode == STICK:
            f0, f1 = self._stick_force2(p0, p1, n0, n1, t0, t1)
            fmag = math.sqrt(f0 * f0 + f1 * f1)
            if fmag > self.mu_s * fn:  # breakaway
                self.mode = SLIP
                self.direction = np.array((t0 / speed, t1 / speed) if speed > 1e-12 else (f0 / fmag, f1 / fmag))
            return
        # sliding: stop on a reversal or below the sticking speed, with the kinetic force carried on
        d0, d1 = self.direction.tolist()
        if speed <= self.stick_speed or t0 * d0 + t1 * d1 <= 0.0:
            dn = n0 * d0 + n1 * d1
            d0, d1 = d0 - dn * n0, d1 - dn * n1
            nd = math.sqrt(d0 * d0 + d1 * d1)
            d0, d1 = (d0 / nd, d1 / nd) if nd > 1e-12 else (0.0, 0.0)
            self.mode = STICK
            c = self.mu_k * fn / self.sigma0
            self.anchor = np.array((p0 - c * d0, p1 - c * d1))
        else:
            self.direction = np.array((t0 / speed, t1 / speed))

    def _pose(self, robot: Any, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pose_twist = getattr(robot, "pose_twist", None)
        if pose_twist is not None:
            return pose_twist(q, qd)
        T = robot.terms(q, qd)
        return T.x, T.xd

    def start(self, robot: Any, q0: np.ndarray, qd0: np.ndarray, rows: int) -> None:
        """Start a run of ``rows`` samples at (q0, q̇0): the state from the initial contact, logs cleared."""
        self._clear()
        self._update(*self._pose(robot, q0, qd0))
        self._log = {"friction": np.full((rows, self.dim), np.nan)}
        self._log.update({name: np.full(rows, np.nan) for name in self.SIGNALS})

    def advance(self, robot: Any, q: np.ndarray, qd: np.ndarray) -> None:
        """Update the stick/slip state after an integrator step ending at (q, q̇)."""
        self._update(*self._pose(robot, q, qd))

    def log_sample(self, k: int, x: np.ndarray, xd: np.ndarray) -> None:
        """Log sample k's friction force, normal force and mode."""
        if not self._log:
            return
        fn, nu, _, ht = self.components(x, xd)
        v = np.asarray(xd, dtype=np.float64)[: self.space]
        self._log["friction"][k] = 0.0
        self._log["friction"][k, : self.space] = ht
        self._log["normal_force"][k] = fn
        self._log["friction_force"][k] = math.sqrt(float(ht @ ht))
        self._log["tangential_speed"][k] = float(np.linalg.norm(v - float(nu @ v) * nu))
        self._log["stick"][k] = 1.0 if self.mode == STICK else 0.0

    def signals(self) -> dict[str, np.ndarray]:
        """The logged signals of the last run (``friction`` and :attr:`SIGNALS`)."""
        return dict(self._log)

    def describe(self) -> dict[str, Any]:
        return {
            "type": self.describe_type, "surface": self.surface.describe(), "static": self.mu_s, "kinetic": self.mu_k,
            "viscous": self.viscous, "stick_stiffness": self.sigma0, "stick_damping": self.sigma1,
            "stick_speed": self.stick_speed,
        }
