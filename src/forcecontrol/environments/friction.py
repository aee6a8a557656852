"""Coulomb friction with stiction on an elastic surface: a stick/slip (reset-integrator) model.

:class:`FrictionalContact` wraps an elastic surface (an :class:`~forcecontrol.environments.elastic.ElasticPlane`
or any :class:`~forcecontrol.environments.surfaces.ElasticSurface`) and adds a tangential force to
its normal force f_n. With ν the surface normal and ``v_t = ẋ − (ν·ẋ) ν`` the tangential velocity,
the tangential part of h_e (the force the tool exerts on the surface, along the motion) is:

* **slip**: ``h_t = μ_k f_n s + b v_t``, s the unit sliding direction (``v_t/|v_t|``): kinetic
  Coulomb plus viscous friction, exact, not smoothed;
* **stick**: the tool is held by a stiff tangential spring to an anchor point a (a bristle):
  ``h_t = σ₀ e_t + σ₁ v_t`` with e_t the tangential part of ``x − a``; the tool cannot creep: it moves by the
  bristle's deflection (the load over σ₀) only.

The mode is a state, updated after every integrator step (:meth:`FrictionalContact.advance`,
called by the simulator's Python loop; within a step the state is held, so the force is smooth for
RK4): stick turns to slip when the bristle's spring carries more than the static limit, ``|σ₀ e_t| > μ_s f_n``
(breakaway; the damper's part ``σ₁ v_t`` is the bristle's transient, not the load it holds); slip turns to stick
when the tangential velocity reverses or drops below ``stick_speed``, with the anchor at the tool (the bristle
unloaded: a tool that stops carries only the load it then feels, at most μ_s f_n, never the kinetic force it
had while sliding, which would push it back). Losing contact clears the state; touching starts in stick when
``|v_t| <= stick_speed``, else in slip. With μ_s = 0 the tool never sticks (the surface is exactly frictionless
but for the viscous b).

The bristle is a spring on the tool's mass m (the arm's, or the apparent mass its controller gives it): a load
stepped onto a stuck tool swings the spring past the load by ``exp(−πζ/√(1−ζ²))`` of it, ζ = σ₁/(2√(σ₀ m)), and
the breakaway test sees that swing (as a real elastic contact would): undamped (σ₁ = 0, the default on a surface
without damping), a load stepped above μ_s f_n/2 breaks away, and a stuck tool oscillates on the bristle for ever.
Give ``stick_damping`` near ``2 √(σ₀ m)`` (critical) for loads that change quickly; a run whose tool broke away from
an undamped bristle says so (:meth:`FrictionalContact.take_projection_note`, a ContactModelWarning). Breakaway
tests the spring's part only, as the LuGre model bounds its bristle's deflection by the static force (Canudas de
Wit et al., 1995); the damper's part is the transient on top.

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
from .base import Environment, xyz
from .elastic import ElasticPlane
from .spatial import Table
from .surfaces import ElasticSurface

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
        stick_damping: σ₁ [N s/m] >= 0 of the bristle (default: the surface's normal damping); see the module's
            docstring for the damping a stuck tool needs.
        stick_speed: below this tangential speed [m/s] a sliding tool sticks (default 1e-4).
    """

    stateful: ClassVar[bool] = True
    #: its wrench reads the first three coordinates of x (o_e) and of ẋ alone, whatever the surface (the surfaces'
    #: ``normal_force_at`` takes a point and a velocity): a 6-D run's integrator stages skip the Euler angles
    reads_orientation: ClassVar[bool] = False
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
        self._undamped_breakaways = 0
        self._log: dict[str, np.ndarray] = {}

    def _clear(self) -> None:
        self.mode = FREE
        self.anchor = np.zeros(self.space)
        self.direction = np.zeros(self.space)

    # -- forces, on scalars (a planar point is (x, y, 0): the same arithmetic as in 2-D, to the bit); the normal force
    # and normal are the surface's own (normal_force_at)
    def _stick_force(self, p0: float, p1: float, p2: float, n0: float, n1: float, n2: float, t0: float, t1: float,
                     t2: float) -> tuple[float, float, float]:
        """The stuck contact's tangential spring and damper: σ0 (the anchor offset in the tangent plane) + σ1 (the
        tangential velocity t)."""
        a0, a1, a2 = xyz(self.anchor, self.space)
        e0 = p0 - a0
        e1 = p1 - a1
        e2 = p2 - a2
        en = n0 * e0 + n1 * e1 + n2 * e2
        k, c = self.sigma0, self.sigma1
        return k * (e0 - en * n0) + c * t0, k * (e1 - en * n1) + c * t1, k * (e2 - en * n2) + c * t2

    def _components(self, p0: float, p1: float, p2: float, v0: float, v1: float,
                    v2: float) -> tuple[float, float, float, float, float, float, float]:
        """(f_n, ν0, ν1, ν2, h_t0, h_t1, h_t2) under the current stick/slip state; h_n = −f_n ν."""
        fn, n0, n1, n2 = self.surface.normal_force_at(p0, p1, p2, v0, v1, v2)
        if fn <= 0.0:
            return 0.0, n0, n1, n2, 0.0, 0.0, 0.0
        vn = n0 * v0 + n1 * v1 + n2 * v2
        t0 = v0 - vn * n0
        t1 = v1 - vn * n1
        t2 = v2 - vn * n2
        if self.mode == STICK:
            h0, h1, h2 = self._stick_force(p0, p1, p2, n0, n1, n2, t0, t1, t2)
        else:  # sliding (or touching in this step: the state follows after it)
            speed = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            if speed > 1e-12:
                s0, s1, s2 = t0 / speed, t1 / speed, t2 / speed
            else:
                d0, d1, d2 = xyz(self.direction, self.space)
                dn = n0 * d0 + n1 * d1 + n2 * d2
                s0, s1, s2 = d0 - dn * n0, d1 - dn * n1, d2 - dn * n2
                ns = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
                s0, s1, s2 = (s0 / ns, s1 / ns, s2 / ns) if ns > 1e-12 else (0.0, 0.0, 0.0)
            f = self.mu_k * fn
            h0, h1, h2 = f * s0, f * s1, f * s2
        b = self.viscous
        return fn, n0, n1, n2, h0 + b * t0, h1 + b * t1, h2 + b * t2

    def _point(self, x: Any) -> tuple[float, float, float]:
        """The first ``space`` coordinates of x as three floats (a planar point gets z = 0)."""
        return xyz(np.asarray(x, dtype=np.float64), self.space)

    def _vector(self, a: float, b: float, c: float) -> np.ndarray:
        return np.array((a, b, c) if self.space == 3 else (a, b))

    def components(self, x: Any, xd: Any) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """(f_n, ν, h_n, h_t) at (x, ẋ) under the current stick/slip state: the normal force [N], the
        normal, and the normal and tangential parts of h_e (space,) [N]."""
        fn, n0, n1, n2, h0, h1, h2 = self._components(*self._point(x), *self._point(xd))
        return fn, self._vector(n0, n1, n2), self._vector(-fn * n0, -fn * n1, -fn * n2), self._vector(h0, h1, h2)

    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        if self.dim == 2:  # the planar arm's hot path
            x0, x1 = np.asarray(x, dtype=np.float64).tolist()
            v0, v1 = np.asarray(xd, dtype=np.float64).tolist()
            fn, n0, n1, _, h0, h1, _ = self._components(x0, x1, 0.0, v0, v1, 0.0)
            return np.array((-fn * n0 + h0, -fn * n1 + h1))
        fn, n0, n1, n2, h0, h1, h2 = self._components(*self._point(x), *self._point(xd))
        out = np.zeros(self.dim)
        out[0], out[1] = -fn * n0 + h0, -fn * n1 + h1
        if self.space == 3:
            out[2] = -fn * n2 + h2
        return out
    def max_stiffness(self) -> float:
        return max(float(self.surface.stiffness), self.sigma0)

    def take_projection_note(self) -> str | None:
        """What the contact model did that a run should say, then forgotten: the surface's
        (:meth:`~forcecontrol.environments.surfaces.ElasticSurface.take_projection_note`) and breakaways from an
        undamped bristle (which a load above μ_s f_n/2 stepped onto a stuck tool reaches); None when neither."""
        take = getattr(self.surface, "take_projection_note", None)
        notes = [take() if take is not None else None]
        if self._undamped_breakaways:
            notes.append(
                f"the tool broke away {self._undamped_breakaways} time(s) from an undamped bristle (stick_damping = 0, "
                f"stick_stiffness = {self.sigma0:g} N/m): a stuck tool swings on it, to twice a load stepped onto it, "
                "so a load between μ_s f_n/2 and μ_s f_n may have broken away; give stick_damping near 2 √(σ₀ m) "
                "(critical for the tool's apparent mass m) for loads that change quickly")
            self._undamped_breakaways = 0
        said = [n for n in notes if n]
        return "; ".join(said) if said else None

    # -- the stick/slip state (the simulator calls start, advance, log_sample, signals)
    def _update(self, x: np.ndarray, xd: np.ndarray) -> None:
        p0, p1, p2 = self._point(x)
        v0, v1, v2 = self._point(xd)
        fn, n0, n1, n2 = self.surface.normal_force_at(p0, p1, p2, v0, v1, v2)
        if fn <= 0.0:
            self.mode = FREE
            return
        vn = n0 * v0 + n1 * v1 + n2 * v2
        t0 = v0 - vn * n0
        t1 = v1 - vn * n1
        t2 = v2 - vn * n2
        speed = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        if self.mu_s == 0.0:  # frictionless but for the viscous part: never stuck
            self.mode = SLIP
            if speed > 1e-12:
                self.direction = self._vector(t0 / speed, t1 / speed, t2 / speed)
            return
        if self.mode == FREE:
            if speed > self.stick_speed:
                self.mode, self.direction = SLIP, self._vector(t0 / speed, t1 / speed, t2 / speed)
            else:
                self.mode, self.anchor = STICK, self._vector(p0, p1, p2)
            return
        if self.mode == STICK:
            f0, f1, f2 = self._stick_force(p0, p1, p2, n0, n1, n2, 0.0, 0.0, 0.0)  # the spring's load, not its damper
            fmag = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
            if fmag > self.mu_s * fn:  # breakaway
                self.mode = SLIP
                self._undamped_breakaways += self.sigma1 == 0.0
                if speed > 1e-12:
                    self.direction = self._vector(t0 / speed, t1 / speed, t2 / speed)
                else:
                    self.direction = self._vector(f0 / fmag, f1 / fmag, f2 / fmag)
            return
        # sliding: stop on a reversal or below the sticking speed, the bristle unloaded at the tool
        d0, d1, d2 = xyz(self.direction, self.space)
        if speed <= self.stick_speed or t0 * d0 + t1 * d1 + t2 * d2 <= 0.0:
            self.mode, self.anchor = STICK, self._vector(p0, p1, p2)
        else:
            self.direction = self._vector(t0 / speed, t1 / speed, t2 / speed)

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
        log = self._log
        if not log:
            return
        v0, v1, v2 = self._point(xd)
        fn, n0, n1, n2, h0, h1, h2 = self._components(*self._point(x), v0, v1, v2)  # on scalars (a planar z is 0)
        row = log["friction"][k]
        row[:] = 0.0
        row[0], row[1] = h0, h1
        if self.space == 3:
            row[2] = h2
        log["normal_force"][k] = fn
        log["friction_force"][k] = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        vn = n0 * v0 + n1 * v1 + n2 * v2  # |v - (ν·v) ν|: the speed along the surface
        t0, t1, t2 = v0 - vn * n0, v1 - vn * n1, v2 - vn * n2
        log["tangential_speed"][k] = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        log["stick"][k] = 1.0 if self.mode == STICK else 0.0

    def signals(self) -> dict[str, np.ndarray]:
        """The logged signals of the last run (``friction`` and :attr:`SIGNALS`)."""
        return dict(self._log)

    def describe(self) -> dict[str, Any]:
        return {
            "type": self.describe_type, "surface": self.surface.describe(), "static": self.mu_s, "kinetic": self.mu_k,
            "viscous": self.viscous, "stick_stiffness": self.sigma0, "stick_damping": self.sigma1,
            "stick_speed": self.stick_speed,
        }
