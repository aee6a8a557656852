"""Registrations of curved surfaces, friction and an arc reference (issue 31).

Environments ``elastic-sphere`` (a circle for the planar arm), ``elastic-cylinder``, ``height-field``,
``mesh`` (STL/OBJ/PLY, its ``file`` relative to the scenario file) and ``frictional-plane``; each takes
the friction keys ``static``, ``kinetic``, ``viscous``,
``stick_stiffness``, ``stick_damping``, ``stick_speed`` (friction is on when ``static`` or ``kinetic``
is given: :class:`~forcecontrol.environments.friction.FrictionalContact`). Reference ``arc``: x_d along
a circular arc at a constant tangential speed (for tracing a contour).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..environments import ElasticCylinder, ElasticMesh, ElasticPlane, ElasticSphere, FrictionalContact, HeightField
from ..errors import ParameterError
from ..trajectories import SampledReference
from .schema import Field, register_controller, register_environment, register_reference

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
        for key in ("viscous", "stick_speed"):  # a value other than the default would be ignored: refused, as above
            if p[key] != FRICTION_FIELDS[key].default:
                raise ParameterError(f"{key} needs friction: give static (and kinetic) too; got {key} = {p[key]!r} "
                                     "on a frictionless surface")
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
    "mesh",
    {
        "file": Field("str", True, doc="STL, OBJ or PLY triangle mesh; relative to the scenario file"),
        "scale": Field("number", default=1.0, low=0.0, high=1e3, doc="vertex coordinates times this [m per file unit]"),
        "offset": Field("vector", low=-100.0, high=100.0, doc="added to the vertices after scale [m] (default 0)"),
        **_ELASTIC,
        **FRICTION_FIELDS,
    },
    lambda p, ctx: _with_friction(ElasticMesh.from_file(p["file"], p["stiffness"], p["damping"], scale=p["scale"],
                                                        offset=p["offset"], task_dim=_task_dim(ctx)), p),
    "one-sided elastic triangle mesh (closest point, normal = the distance's gradient), optional friction",
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


def _arc_basis(dim: int, axis: Any, first: Any) -> tuple[np.ndarray, np.ndarray]:
    """(e1, e2): the arc's θ = 0 direction and its quarter turn; planar: x and y; 3-D: e1 = ``first`` made
    normal to ``axis``, e2 = axis × e1 (θ grows counter-clockwise about the axis)."""
    if dim == 2:
        return np.array([1.0, 0.0]), np.array([0.0, 1.0])
    n = np.asarray(axis if axis is not None else [0.0, 0.0, 1.0], dtype=np.float64)
    f = np.asarray(first if first is not None else [1.0, 0.0, 0.0], dtype=np.float64)
    if n.shape != (3,) or f.shape != (3,) or not np.linalg.norm(n) > 0:
        raise ParameterError(f"axis and first must be non-zero 3-vectors for a 3-D arc; got {n.tolist()}, {f.tolist()}")
    n = n / np.linalg.norm(n)
    e1 = f - float(f @ n) * n
    if not np.linalg.norm(e1) > 1e-9:
        raise ParameterError(f"first must not be parallel to axis; got first = {f.tolist()}, axis = {n.tolist()}")
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


def arc_reference(center: Any, radius: float, start_angle: float, end_angle: float, speed: float,
                  start_time: float = 0.0, accel_time: float = 0.5, *, axis: Any = None, first: Any = None,
                  orientation: Any = None, normal_force: float | None = None, force_time: float = 0.5) -> SampledReference:
    """x_d on the arc ``c + r (cos θ e1 + sin θ e2)`` from ``start_angle`` to ``end_angle`` [deg] at the tangential
    ``speed`` [m/s], with a linear speed ramp over ``accel_time`` at both ends; held before and after.

    Planar (c of 2 components): e1, e2 = x, y. 3-D: the arc lies in the plane normal to ``axis`` (default z),
    θ from ``first`` (default x, made normal to the axis). ``orientation`` (3 XYZ Euler angles [rad]) makes it a
    pose reference ``[o_d; φ_d]`` with that orientation held (6-D robots).

    ``normal_force``: λ_d [N] in a frame provider's coordinates (the force reference's first component, e.g.
    along the estimated normal of :class:`~forcecontrol.controllers.spatial_hybrid.SpatialHybridController`
    with ``frame=``), ramped linearly from 0 over ``force_time`` [s] from t = 0; the other components zero.
    """
    c = np.asarray(center, dtype=np.float64)
    if c.shape not in ((2,), (3,)):
        raise ParameterError(f"center must have 2 (planar) or 3 components; got shape {c.shape}")
    if not (radius > 0 and speed > 0 and accel_time > 0):
        raise ParameterError(f"radius, speed and accel_time must be positive; got {radius!r}, {speed!r}, {accel_time!r}")
    e1, e2 = _arc_basis(c.shape[0], axis, first)
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
    dds = np.where(t < accel_time, v / accel_time, 0.0) - np.where(t > total - accel_time, v / accel_time, 0.0)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(t))])
    scale = length / s[-1]
    sign = math.copysign(1.0, a1 - a0)
    theta = a0 + sign * s * scale / radius
    w, wd = sign * ds * scale / radius, sign * dds * scale / radius  # θ̇, θ̈
    radial = np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2
    tangent = -np.sin(theta)[:, None] * e1 + np.cos(theta)[:, None] * e2
    pos = c + radius * radial
    vel = radius * w[:, None] * tangent
    acc = radius * (wd[:, None] * tangent - (w * w)[:, None] * radial)
    if orientation is not None:
        pos = np.hstack([pos, np.broadcast_to(np.asarray(orientation, dtype=np.float64), (pos.shape[0], 3))])
        vel, acc = (np.hstack([a, np.zeros((a.shape[0], 3))]) for a in (vel, acc))
    times = t + start_time
    if start_time > 0.0:  # held at rest before: zero rate up to 1 ms before the start (where the speed ramp's step is)
        hold = [0.0] if start_time <= 0.002 else [0.0, start_time - 0.001]
        if normal_force is not None and force_time < start_time - 0.001:  # the force ramp's corner, sampled
            hold = sorted({*hold, force_time})
        times = np.concatenate([hold, times])
        pos = np.vstack([np.repeat(pos[:1], len(hold), axis=0), pos])
        vel, acc = (np.vstack([np.zeros((len(hold), a.shape[1])), a]) for a in (vel, acc))
    force = None
    if normal_force is not None:
        if not force_time > 0:
            raise ParameterError(f"force_time must be positive; got {force_time!r}")
        force = np.zeros_like(pos)
        force[:, 0] = normal_force * np.clip(times / force_time, 0.0, 1.0)
    # exact rates, interpolated linearly between 5 ms samples: local (a global spline would ring ahead of the motion)
    return SampledReference(times, pos, force, interpolation="linear", velocity=vel, acceleration=acc)


def _arc(p: dict[str, Any], ctx: dict[str, Any]) -> SampledReference:
    robot = ctx["robot"]
    orientation = None
    if int(robot.task_dim) == 6:  # a pose task: the start orientation held
        from ..spatial.closed_form import rotation_to_euler_xyz

        R0, _ = robot.frame_pose(ctx["q0"])
        orientation = rotation_to_euler_xyz(R0)
    elif len(p["center"]) != int(robot.task_dim):
        raise ParameterError(f"center must have {int(robot.task_dim)} components for this robot; got {len(p['center'])}")
    return arc_reference(p["center"], p["radius"], p["start_angle"], p["end_angle"], p["speed"], p["start_time"],
                         p["accel_time"], axis=p["axis"], first=p["first"], orientation=orientation,
                         normal_force=p["normal_force"], force_time=p["force_time"])


register_reference(
    "arc",
    {
        "center": Field("vector", True, low=-100.0, high=100.0, doc="the arc's centre [m] (2 components planar, 3 in 3-D)"),
        "radius": Field("number", True, low=0.0, high=100.0, doc="its radius [m]"),
        "start_angle": Field("number", True, low=-720.0, high=720.0, doc="θ at the start [deg]"),
        "end_angle": Field("number", True, low=-720.0, high=720.0, doc="θ at the end [deg]"),
        "speed": Field("number", True, low=0.0, high=10.0, doc="tangential speed of x_d [m/s]"),
        "start_time": Field("number", default=0.0, low=0.0, high=1e5, doc="when x_d starts moving [s]"),
        "accel_time": Field("number", default=0.5, low=0.0, high=1e5, doc="speed ramp at both ends [s]"),
        "axis": Field("vector", low=-1e6, high=1e6, doc="3-D: the normal of the arc's plane (default z)"),
        "first": Field("vector", low=-1e6, high=1e6, doc="3-D: the direction of θ = 0 (default x)"),
        "normal_force": Field("number", low=0.0, high=1e5,
                              doc="λ_d along a frame provider's normal [N] (spatial-hybrid-estimated); none by default"),
        "force_time": Field("number", default=0.5, low=0.0, high=1e5, doc="the normal force's ramp from 0 at t = 0 [s]"),
    },
    _arc,
    "x_d along a circular arc at a constant tangential speed (planar or 3-D; a 6-D robot holds its start orientation)",
)

# ----------------------------------------------------------------------------- surface following, frame estimated


def _true_normal(env: Any) -> Any:
    """``x -> −ν(x)`` (into the surface) of a curved surface, for the estimator's logs only; None otherwise."""
    surface = getattr(env, "surface", env)
    if not hasattr(surface, "geometry"):
        return None
    space = int(getattr(surface, "space", 2))
    return lambda x: -surface.geometry(np.asarray(x, dtype=np.float64)[:space])[2]


def _hybrid_estimated(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    from ..controllers.hybrid import HybridCompliantController
    from ..task import SelectionMatrices
    from ..task.estimation import ConstraintFrameEstimator

    robot = ctx["robot"]
    if int(robot.task_dim) != 2:
        raise ParameterError(f"hybrid-estimated is planar (the chapter's arm); got a {int(robot.task_dim)}-dimensional task")
    Ts = ctx["sample_time"]
    est = ConstraintFrameEstimator(p["first_normal"], p["time_constant"], Ts, min_force=p["min_force"],
                                   min_speed=p["min_speed"], truth=_true_normal(ctx.get("environment")))
    S_f, S_v = est.selection()
    return HybridCompliantController(
        robot, SelectionMatrices(S_f, S_v), 1.0 / p["stiffness_estimate"], p["velocity_gain"], p["velocity_integral_gain"],
        p["force_gain"], p["force_rate_gain"], Ts, frame=est,
    )


_ESTIMATOR_FIELDS = {
    "first_normal": Field("vector", True, low=-1e6, high=1e6,
                          doc="the first guess of the contact normal, along the force on the surface (into it)"),
    "time_constant": Field("number", default=0.05, low=0.0, high=100.0, doc="τ of the normal's first-order filter [s]"),
    "min_force": Field("number", default=1.0, low=0.0, high=1e6, doc="below this force the estimate is held [N]"),
    "min_speed": Field("number", default=1e-3, low=0.0, high=10.0, doc="below this speed friction is not removed [m/s]"),
}

register_controller(
    "hybrid-estimated",
    {
        **_ESTIMATOR_FIELDS,
        "stiffness_estimate": Field("number", True, low=1e-3, high=MAX_STIFFNESS, doc="k̂ = 1/ĉ along the normal [N/m] (> 0)"),
        "velocity_gain": Field("gain", True, doc="K_Pν of (9.80) [1/s]"),
        "velocity_integral_gain": Field("gain", True, doc="K_Iν of (9.80) [1/s²]"),
        "force_gain": Field("gain", True, doc="K_Pλ of (9.81) [1/s²]"),
        "force_rate_gain": Field("gain", True, doc="K_Dλ of (9.81) [1/s]"),
    },
    _hybrid_estimated,
    "hybrid force/velocity control (9.77)-(9.82) in the constraint frame estimated online from force and velocity",
)


def _parallel_estimated(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    from ..controllers.force import ParallelForcePositionController
    from ..task.estimation import ConstraintFrameEstimator

    robot = ctx["robot"]
    if int(robot.task_dim) != 2:
        raise ParameterError(f"parallel-estimated is planar (the chapter's arm); got a {int(robot.task_dim)}-dimensional task")
    Ts = ctx["sample_time"]
    est = ConstraintFrameEstimator(p["first_normal"], p["time_constant"], Ts, min_force=p["min_force"],
                                   min_speed=p["min_speed"], truth=_true_normal(ctx.get("environment")))
    return ParallelForcePositionController(
        robot, p["inertia"], p["damping"], p["stiffness"], [p["force_gain"], 0.0], [p["integral_gain"], 0.0],
        sample_time=Ts, frame=est,
    )


register_controller(
    "parallel-estimated",
    {
        **{key: _ESTIMATOR_FIELDS[key] for key in ("first_normal", "time_constant", "min_force", "min_speed")},
        "inertia": Field("gain", True, doc="M_d of (9.48) [kg]"),
        "damping": Field("gain", True, doc="K_D of (9.48) [N s/m]"),
        "stiffness": Field("gain", True, doc="K_P of (9.48) [N/m]"),
        "force_gain": Field("number", True, low=0.0, high=1e3, doc="k_F of C_F along the estimated normal [m/N]"),
        "integral_gain": Field("number", default=0.0, low=0.0, high=1e3, doc="k_I of C_F along the normal [m/(N s)]"),
    },
    _parallel_estimated,
    "parallel force/position control (9.48), PI C_F (9.43), in the constraint frame estimated online",
)


def surface_following_reference(dim: int, speed: float, normal_force: float, start_time: float = 0.5,
                                accel_time: float = 0.5, force_time: float = 0.5) -> SampledReference:
    """The reference of a frame provider's hybrid, in the frame's coordinates: ν_d = ``speed`` along the
    estimated tangent (ramped linearly over ``accel_time`` from ``start_time``), λ_d = ``normal_force``
    along the estimated normal (ramped over ``force_time`` from 0); ν̇_d = 0 (the velocity loop follows the
    ramp); position unused."""
    if not (accel_time > 0 and force_time > 0 and start_time >= 0):
        raise ParameterError(f"accel_time and force_time must be positive, start_time >= 0; got {accel_time!r}, "
                             f"{force_time!r}, {start_time!r}")
    end = max(force_time, start_time + accel_time) + 1e5  # held after: constant speed and force
    t = np.unique(np.array([0.0, force_time, start_time, start_time + accel_time, end]))
    v = speed * np.clip((t - start_time) / accel_time, 0.0, 1.0)
    f = normal_force * np.clip(t / force_time, 0.0, 1.0)
    z = np.zeros((t.shape[0], dim))
    vel, force = z.copy(), z.copy()
    vel[:, 0], force[:, 0] = v, f
    return SampledReference(t, z, force, interpolation="linear", velocity=vel, acceleration=z)


register_reference(
    "surface-following",
    {
        "speed": Field("number", True, low=-10.0, high=10.0, doc="ν_d along the estimated tangent [m/s] (sign: direction)"),
        "normal_force": Field("number", True, low=0.0, high=1e5, doc="λ_d along the estimated normal [N]"),
        "start_time": Field("number", default=0.5, low=0.0, high=1e5, doc="when the motion starts [s]"),
        "accel_time": Field("number", default=0.5, low=0.0, high=1e5, doc="the speed ramp [s]"),
        "force_time": Field("number", default=0.5, low=0.0, high=1e5, doc="the force ramp from 0 [s]"),
    },
    lambda p, ctx: surface_following_reference(int(ctx["robot"].task_dim), p["speed"], p["normal_force"], p["start_time"],
                                               p["accel_time"], p["force_time"]),
    "tangential speed and normal force in the estimated constraint frame's coordinates (for hybrid-estimated)",
)


def _spatial_hybrid_estimated(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    from ..controllers.redundant import NullSpacePosture
    from ..controllers.spatial_hybrid import SpatialHybridController
    from ..task.estimation import ConstraintFrameEstimator

    robot = ctx["robot"]
    if int(robot.task_dim) != 6:
        raise ParameterError(f"spatial-hybrid-estimated is 6-D (e.g. the Panda); got a {int(robot.task_dim)}-dimensional task")
    if len(p["first_normal"]) != 3:
        raise ParameterError(f"first_normal must have 3 components for a 6-D robot; got {len(p['first_normal'])}")
    Ts = ctx["sample_time"]
    est = ConstraintFrameEstimator(p["first_normal"], p["time_constant"], Ts, min_force=p["min_force"],
                                   min_speed=p["min_speed"], truth=_true_normal(ctx.get("environment")))
    posture = NullSpacePosture(ctx["q0"], p["posture_stiffness"], p["posture_damping"]) if robot.nq > 6 else None
    return SpatialHybridController(
        robot, [0.0, 0.0, 1.0, 0.0, 0.0, 0.0], 1.0 / p["stiffness_estimate"], p["stiffness"], p["damping"], p["force_gain"],
        p["force_rate_gain"], orientation=p["orientation"], posture=posture, sample_time=Ts, frame=est,
    )


register_controller(
    "spatial-hybrid-estimated",
    {
        **_ESTIMATOR_FIELDS,
        "stiffness_estimate": Field("number", True, low=1e-3, high=MAX_STIFFNESS, doc="k̂ = 1/ĉ along the normal [N/m] (> 0)"),
        "stiffness": Field("gain", True, doc="K_P of the pose servo (9.95) along S_v (6, 6) [1/s²]"),
        "damping": Field("gain", True, doc="K_D of the pose servo (9.95) along S_v (6, 6) [1/s]"),
        "force_gain": Field("number", True, low=0.0, high=1e12, doc="K_Pλ of (9.82) [1/s²]"),
        "force_rate_gain": Field("number", True, low=0.0, high=1e12, doc="K_Dλ of (9.82) [1/s]"),
        "posture_stiffness": Field("number", default=25.0, low=0.0, high=1e12, doc="null-space posture K_n [1/s²] (n > 6)"),
        "posture_damping": Field("number", default=10.0, low=0.0, high=1e12, doc="null-space posture D_n [1/s]"),
        "orientation": Field("str", default="euler", choices=("euler", "rotvec"), doc="orientation error"),
    },
    _spatial_hybrid_estimated,
    "6-D hybrid force/motion control (9.77)-(9.84) on the desired frame, S_f along the normal estimated online "
    "(the pose reference's normal component not servoed; λ_d = the arc reference's normal_force)",
)
