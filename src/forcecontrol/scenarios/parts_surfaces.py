"""Registrations of curved surfaces, friction and an arc reference (issue 31).

Environments ``elastic-sphere`` (a circle for the planar arm), ``elastic-cylinder``, ``height-field``
and ``frictional-plane``; each takes the friction keys ``static``, ``kinetic``, ``viscous``,
``stick_stiffness``, ``stick_damping``, ``stick_speed`` (friction is on when ``static`` or ``kinetic``
is given: :class:`~forcecontrol.environments.friction.FrictionalContact`). Reference ``arc``: x_d along
a circular arc at a constant tangential speed (for tracing a contour).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..environments import ElasticCylinder, ElasticPlane, ElasticSphere, FrictionalContact, HeightField
from ..errors import ParameterError
from ..trajectories import SampledReference
from .schema import Field, register_environment, register_reference

__all__: list[str] = []

#: the largest stiffness of a surface or a bristle [N/m] (far beyond any tool; keeps RK4's step finite).
MAX_STIFFNESS = 1e9

_ELASTIC = {
    "stiffness": Field("number", True, low=0.0, high=MAX_STIFFNESS, doc="k along the local normal [N/m], > 0"),
    "damping": Field("number", default=0.0, low=0.0, high=1e7, doc="c along the local normal [N s/m]"),
}

FRICTION_FIELDS = {
    "static": Field("number", low=0.0, high=10.0, doc="μ_s, the static friction coefficient (friction on when given)"),
    "kinetic": Field("number", low=0.0, high=10.0, doc="μ_k <= μ_s, the kinetic coefficient (default: μ_s)"),
    "viscous": Field("number", default=0.0, low=0.0, high=1e7, doc="b, tangential viscous friction [N s/m]"),
    "stick_stiffness": Field("number", low=0.0, high=MAX_STIFFNESS,
                             doc="σ₀ of the sticking bristle [N/m] (default: the surface's stiffness)"),
    "stick_damping": Field("number", low=0.0, high=1e7, doc="σ₁ of the bristle [N s/m] (default: the surface's damping)"),
    "stick_speed": Field("number", default=1e-4, low=0.0, high=1.0,
                         doc="below this tangential speed a sliding tool sticks [m/s]"),
}


def _with_friction(surface: Any, p: dict[str, Any]) -> Any:
    """The surface, inside a FrictionalContact when ``static`` or ``kinetic`` is given."""
    if p["static"] is None and p["kinetic"] is None:
        for key in ("stick_stiffness", "stick_damping"):
            if p[key] is not None:
                raise ParameterError(f"{key} needs friction: give static (and kinetic) too")
        return surface
    mu_s = p["static"] if p["static"] is not None else p["kinetic"]
    mu_k = p["kinetic"] if p["kinetic"] is not None else mu_s
    return FrictionalContact(surface, mu_s, mu_k, p["viscous"], stick_stiffness=p["stick_stiffness"],
                             stick_damping=p["stick_damping"], stick_speed=p["stick_speed"])


def _task_dim(ctx: dict[str, Any]) -> int:
    return int(ctx["robot"].task_dim)


def _sphere(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    td = _task_dim(ctx)
    return _with_friction(ElasticSphere(p["center"], p["radius"], p["stiffness"], p["damping"],
                                        task_dim=td if td == 6 else None), p)


def _cylinder(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    return _with_friction(ElasticCylinder(p["point"], p["axis"], p["radius"], p["stiffness"], p["damping"],
                                          task_dim=_task_dim(ctx)), p)


def _height_field(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    if (p["file"] is None) == (p["heights"] is None):
        raise ParameterError("give exactly one of file and heights for a height field")
    td = _task_dim(ctx)
    if p["file"] is not None:
        hf = HeightField.from_file(p["file"], p["origin"], p["spacing"], p["stiffness"], p["damping"],
                                   height_scale=p["height_scale"], task_dim=td if td == 6 else None)
    else:
        hf = HeightField(p["heights"], p["origin"], p["spacing"], p["stiffness"], p["damping"], task_dim=td if td == 6 else None)
    return _with_friction(hf, p)


register_environment(
    "elastic-sphere",
    {
        "center": Field("vector", True, low=-100.0, high=100.0, doc="c [m] (2 components: a circle for the planar arm)"),
        "radius": Field("number", True, low=0.0, high=100.0, doc="R [m], > 0"),
        **_ELASTIC,
        **FRICTION_FIELDS,
    },
    _sphere,
    "one-sided elastic ball (a circle in 2-D), optional Coulomb friction with stiction",
)

register_environment(
    "elastic-cylinder",
    {
        "point": Field("vector", True, low=-100.0, high=100.0, doc="a point of the axis [m] (3-D)"),
        "axis": Field("vector", True, low=-1e6, high=1e6, doc="the axis direction (normalised)"),
        "radius": Field("number", True, low=0.0, high=100.0, doc="R [m], > 0"),
        **_ELASTIC,
        **FRICTION_FIELDS,
    },
    _cylinder,
    "one-sided elastic cylinder of infinite length, any axis (3-D), optional friction",
)

register_environment(
    "height-field",
    {
        "file": Field("str", doc="CSV (rows along x) or grey PNG of heights; relative to the working folder"),
        "heights": Field("gain", doc="alternative to file: h on the grid, a list (2-D) or a list of rows (3-D) [m]"),
        "origin": Field("vector", True, low=-100.0, high=100.0, doc="the grid's first point: x (2-D) or x, y (3-D) [m]"),
        "spacing": Field("gain", True, low=0.0, high=100.0, doc="grid step(s) [m], > 0"),
        "height_scale": Field("number", default=1.0, low=0.0, high=100.0, doc="PNG: height of a white pixel [m]"),
        **_ELASTIC,
        **FRICTION_FIELDS,
    },
    _height_field,
    "one-sided elastic height field (cubic spline over a grid), optional friction",
)

register_environment(
    "frictional-plane",
    {
        "point": Field("vector", True, low=-100.0, high=100.0, doc="a point of the undeformed surface [m]"),
        "normal": Field("vector", True, low=-1e6, high=1e6, doc="outward normal"),
        **_ELASTIC,
        **FRICTION_FIELDS,
    },
    lambda p, ctx: _with_friction(ElasticPlane(p["point"], p["normal"], p["stiffness"], p["damping"]), p),
    "one-sided elastic plane with Coulomb friction and stiction (static, kinetic) and viscous friction",
)

# ----------------------------------------------------------------------------- references


def arc_reference(center: Any, radius: float, start_angle: float, end_angle: float, speed: float,
                  start_time: float = 0.0, accel_time: float = 0.5) -> SampledReference:
    """x_d on the arc ``c + r (cos θ, sin θ)`` from ``start_angle`` to ``end_angle`` [deg] at the tangential
    ``speed`` [m/s], with a linear speed ramp over ``accel_time`` at both ends; held before and after."""
    c = np.asarray(center, dtype=np.float64)
    if c.shape != (2,):
        raise ParameterError(f"center must have 2 components (the planar arm's arc); got shape {c.shape}")
    if not (radius > 0 and speed > 0 and accel_time > 0):
        raise ParameterError(f"radius, speed and accel_time must be positive; got {radius!r}, {speed!r}, {accel_time!r}")
    a0, a1 = math.radians(start_angle), math.radians(end_angle)
    length = abs(a1 - a0) * radius
    if length == 0.0:
        raise ParameterError("start_angle and end_angle must differ")
    cruise = max(length / speed - accel_time, 0.0)  # time at full speed (the ramps cover speed·accel_time)
    v = speed if cruise > 0.0 else length / accel_time
    total = cruise + 2.0 * accel_time
    t = np.linspace(0.0, total, max(int(total / 0.005), 50) + 1)
    up = np.clip(t / accel_time, 0.0, 1.0)
    down = np.clip((total - t) / accel_time, 0.0, 1.0)
    ds = v * np.minimum(up, down)  # the trapezoidal speed, integrated below (trapezoid rule: exact for linear pieces)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(t))])
    s *= length / s[-1]
    theta = a0 + math.copysign(1.0, a1 - a0) * s / radius
    pos = c + radius * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    times = t + start_time
    if start_time > 0.0:
        times, pos = np.concatenate([[0.0], times]), np.vstack([pos[:1], pos])
    return SampledReference(times, pos, interpolation="cubic")


register_reference(
    "arc",
    {
        "center": Field("vector", True, low=-100.0, high=100.0, doc="the arc's centre [m] (planar)"),
        "radius": Field("number", True, low=0.0, high=100.0, doc="its radius [m]"),
        "start_angle": Field("number", True, low=-720.0, high=720.0, doc="θ at the start [deg]"),
        "end_angle": Field("number", True, low=-720.0, high=720.0, doc="θ at the end [deg]"),
        "speed": Field("number", True, low=0.0, high=10.0, doc="tangential speed of x_d [m/s]"),
        "start_time": Field("number", default=0.0, low=0.0, high=1e5, doc="when x_d starts moving [s]"),
        "accel_time": Field("number", default=0.5, low=0.0, high=1e5, doc="speed ramp at both ends [s]"),
    },
    lambda p, ctx: arc_reference(p["center"], p["radius"], p["start_angle"], p["end_angle"], p["speed"],
                                 p["start_time"], p["accel_time"]),
    "x_d along a circular arc at a constant tangential speed (planar), speed ramped at both ends",
)
