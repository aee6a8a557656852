"""Registrations of the surface tasks users do (issue 31, item 4): wiping a bump field, a spiral search for a hole.

Environment ``bump-field``: a :class:`~forcecontrol.environments.surfaces.HeightField` sampled from a
formula, ``h(x, y) = base + A cos(2π(x − x_c)/L) cos(2π(y − y_c)/L) − Σ d_i exp(−|p − p_i|²/(2 w_i²))``
(an egg-crate of bumps with a crest at ``crest``, and Gaussian dips: the holes of a search). Reference
``spiral``: x_d along an Archimedean spiral ``r = pitch θ / 2π`` in the plane normal to ``axis`` at a
constant speed along the curve. Controller ``spatial-hybrid-search``: the 6-D hybrid with S_f along the
known normal and the hole detector of :class:`~forcecontrol.controllers.search.SpiralSearchController`.
Metrics ``hole_found`` (1 or 0), ``hole_time`` [s], ``hole_x``, ``hole_y``, ``hole_z`` [m] (NaN when not
found) read the run's ``hole found`` event.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError, ScenarioError
from ..trajectories import SampledReference
from .parts_surfaces import FRICTION_FIELDS, MAX_STIFFNESS, _with_friction
from .schema import Field, register_controller, register_environment, register_reference

__all__ = ["spiral_reference", "wipe_line_reference"]

#: the longest spiral or line [s] (its samples every few ms stay in memory).
MAX_PATH_TIME = 1e4


def _bump_field(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    from ..environments.heightfield_extra import BumpField

    td = int(ctx["robot"].task_dim)
    if td not in (3, 6):
        raise ParameterError(f"bump-field is a 3-D surface (a 3-D or 6-D task); got a {td}-dimensional task")
    size = np.asarray(p["size"], dtype=np.float64)
    if size.shape != (2,) or np.any(size <= 0):
        raise ParameterError(f"size must be the grid's positive extent (x, y) [m]; got {p['size']!r}")
    if not p["spacing"] > 0 or np.any(size / p["spacing"] > 2000):
        raise ParameterError(f"spacing must be positive and give at most 2001 samples per side; got {p['spacing']!r} for size "
                             f"{size.tolist()}")
    shape = [max(int(math.ceil(v / p["spacing"] - 1e-9)) + 1, 4) for v in size]  # samples covering the size
    field = BumpField(p["origin"], p["spacing"], shape, p["base"], p["amplitude"], p["wavelength"], p["crest"],
                      p["dips"], stiffness=p["stiffness"], damping=p["damping"], task_dim=td if td == 6 else None)
    return _with_friction(field, p)


register_environment(
    "bump-field",
    {
        "origin": Field("vector", True, low=-100.0, high=100.0, doc="the grid's first point (x, y) [m]"),
        "spacing": Field("number", True, low=0.0, high=100.0, doc="the grid step along x and y [m], > 0"),
        "size": Field("vector", True, low=0.0, high=100.0,
                      doc="the grid's extent (x, y) [m] (the contact uses the formula; the grid samples it)"),
        "base": Field("number", True, low=-100.0, high=100.0, doc="the mean height [m]"),
        "amplitude": Field("number", default=0.0, low=-1.0, high=1.0, doc="A of the bumps [m]"),
        "wavelength": Field("number", default=1.0, low=0.0, high=100.0, doc="L of the bumps [m]"),
        "crest": Field("vector", low=-100.0, high=100.0, doc="(x, y) of a crest of the bumps [m] (default: origin)"),
        "dips": Field("gain", low=-100.0, high=100.0, doc="Gaussian dips (holes), rows [x, y, depth, width] [m]"),
        "stiffness": Field("number", True, low=0.0, high=MAX_STIFFNESS, doc="k along the local normal [N/m], > 0"),
        "damping": Field("number", default=0.0, low=0.0, high=1e7, doc="c along the local normal [N s/m]"),
        **FRICTION_FIELDS,
    },
    _bump_field,
    "height field of bumps A cos·cos and Gaussian dips (holes), sampled on a grid (3-D), optional friction",
)

# ----------------------------------------------------------------------------- spiral


def spiral_reference(center: Any, pitch: float, radius: float, speed: float, start_time: float = 0.0,
                     accel_time: float = 0.1, *, axis: Any = None, first: Any = None, orientation: Any = None,
                     force: Any = None) -> SampledReference:
    """x_d on the Archimedean spiral ``c + r(θ)(cos θ e1 + sin θ e2)``, ``r = b θ``, ``b = pitch/2π``, from the
    centre out to ``radius`` [m] at ``speed`` [m/s] along the curve (ramped linearly over ``accel_time`` at both
    ends), starting at ``start_time``; e1, e2 as for :func:`~forcecontrol.scenarios.parts_surfaces.arc_reference`
    (the plane normal to ``axis``, default z). ``orientation`` (XYZ Euler [rad]) makes it a pose reference held
    at that orientation; ``force`` a constant h_d (the reference's width) [N].

    Rates exact: with g(θ) = |dp/dθ| = b √(1 + θ²), θ̇ = ṡ/g and θ̈ = (s̈ − g′ θ̇²)/g.
    """
    from .parts_surfaces import _arc_basis

    c = np.asarray(center, dtype=np.float64)
    if c.shape != (3,):
        raise ParameterError(f"center must have 3 components; got shape {c.shape}")
    if not (pitch > 0 and radius > 0 and speed > 0 and accel_time > 0):
        raise ParameterError(f"pitch, radius, speed and accel_time must be positive; got {pitch!r}, {radius!r}, "
                             f"{speed!r}, {accel_time!r}")
    e1, e2 = _arc_basis(3, axis, first)
    b = pitch / (2.0 * math.pi)
    th_end = radius / b

    def arc_length(th: np.ndarray) -> np.ndarray:
        return 0.5 * b * (th * np.sqrt(1.0 + th * th) + np.arcsinh(th))

    length = float(arc_length(np.array(th_end)))
    cruise = max(length / speed - accel_time, 0.0)
    v = speed if cruise > 0.0 else length / accel_time
    total = cruise + 2.0 * accel_time
    if not total <= MAX_PATH_TIME:
        raise ParameterError(f"the spiral ({length:.4g} m at {speed:.4g} m/s) takes {total:.4g} s; at most {MAX_PATH_TIME:g} s")
    t = np.linspace(0.0, total, max(int(total / 0.002), 100) + 1)
    up, down = np.clip(t / accel_time, 0.0, 1.0), np.clip((total - t) / accel_time, 0.0, 1.0)
    ds = v * np.minimum(up, down)
    dds = np.where(t < accel_time, v / accel_time, 0.0) - np.where(t > total - accel_time, v / accel_time, 0.0)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(t))])
    scale = length / s[-1]
    s, ds, dds = s * scale, ds * scale, dds * scale
    grid = np.linspace(0.0, th_end, 20001)
    th = np.interp(s, arc_length(grid), grid)
    g = b * np.sqrt(1.0 + th * th)
    gp = b * th / np.sqrt(1.0 + th * th)
    w = ds / g
    wd = (dds - gp * w * w) / g
    cs, sn = np.cos(th)[:, None], np.sin(th)[:, None]
    radial, tangent = cs * e1 + sn * e2, -sn * e1 + cs * e2
    r = (b * th)[:, None]
    pos = c + r * radial
    dp = b * radial + r * tangent  # dp/dθ
    ddp = 2.0 * b * tangent - r * radial  # d²p/dθ²
    vel = dp * w[:, None]
    acc = ddp * (w * w)[:, None] + dp * wd[:, None]
    if orientation is not None:
        pos = np.hstack([pos, np.broadcast_to(np.asarray(orientation, dtype=np.float64), (pos.shape[0], 3))])
        vel, acc = (np.hstack([a, np.zeros((a.shape[0], 3))]) for a in (vel, acc))
    times = t + start_time
    if start_time > 0.0:
        hold = [0.0] if start_time <= 0.002 else [0.0, start_time - 0.001]
        times = np.concatenate([hold, times])
        pos = np.vstack([np.repeat(pos[:1], len(hold), axis=0), pos])
        vel, acc = (np.vstack([np.zeros((len(hold), a.shape[1])), a]) for a in (vel, acc))
    h = None
    if force is not None:
        f = np.asarray(force, dtype=np.float64)
        if f.shape != (pos.shape[1],):
            raise ParameterError(f"force must have {pos.shape[1]} components; got {f.shape[0] if f.ndim else 1}")
        h = np.broadcast_to(f, pos.shape).copy()
    ref = SampledReference(times, pos, h, interpolation="linear", velocity=vel, acceleration=acc)
    ref.spiral_path = {"center": c.copy(), "pitch": float(pitch), "radius": float(radius)}
    return ref


def _spiral(p: dict[str, Any], ctx: dict[str, Any]) -> SampledReference:
    from ..spatial.closed_form import rotation_to_euler_xyz

    robot = ctx["robot"]
    if int(robot.task_dim) != 6:
        raise ParameterError(f"the spiral reference is for 6-D robots (the Panda); got a {int(robot.task_dim)}-dimensional task")
    R0, p0 = robot.frame_pose(ctx["q0"])
    offset = np.zeros(3) if p["center_offset"] is None else np.asarray(p["center_offset"], dtype=np.float64)
    if offset.shape != (3,):
        raise ParameterError(f"center_offset must have 3 components; got {offset.shape[0]}")
    return spiral_reference(p0 + offset, p["pitch"], p["radius"], p["speed"], p["start_time"], p["accel_time"],
                            axis=p["axis"], first=p["first"], orientation=rotation_to_euler_xyz(R0), force=p["force"])


register_reference(
    "spiral",
    {
        "center_offset": Field("vector", low=-100.0, high=100.0, doc="the centre − o_e(q0) [m] (default: the start tip)"),
        "pitch": Field("number", True, low=0.0, high=100.0, doc="the growth of r per turn [m]"),
        "radius": Field("number", True, low=0.0, high=100.0, doc="the last turn's radius [m]: the search's reach"),
        "speed": Field("number", True, low=0.0, high=10.0, doc="speed of x_d along the spiral [m/s]"),
        "start_time": Field("number", default=0.0, low=0.0, high=1e5, doc="when x_d starts moving [s]"),
        "accel_time": Field("number", default=0.1, low=0.0, high=1e5, doc="speed ramp at both ends [s]"),
        "axis": Field("vector", low=-1e6, high=1e6, doc="the normal of the spiral's plane (default z)"),
        "first": Field("vector", low=-1e6, high=1e6, doc="the direction of θ = 0 (default x)"),
        "force": Field("vector", low=-1e5, high=1e5, doc="h_d = [f; μ] on the environment, base frame [N, N m]"),
    },
    _spiral,
    "x_d along an Archimedean spiral in a plane at a constant speed (6-D robots, start orientation held): a hole search",
)

# ----------------------------------------------------------------------------- wipe line


def wipe_line_reference(start: Any, end: Any, speed: float, start_time: float = 0.0, accel_time: float = 0.2, *,
                        normal_force: float = 0.0) -> SampledReference:
    """x_d (6,) from the pose ``start`` to ``end`` (same orientation) along a straight line at ``speed`` [m/s]
    (linear ramps over ``accel_time`` at both ends), from ``start_time``; λ_d = ``normal_force`` [N] (the
    force reference's first component, for a frame provider's normal), constant.

    **No rates**: ẋ_d = ẍ_d = 0 are given to the controller. This was chosen when the 6-D hybrid read (9.82)'s λ̇
    from the twist error, k̂ n̂ᵀ(ẋ − ẋ_d), so that a line at the angle β to the surface's tangent shifted the regulated
    force by k̂ K_Dλ v sin β / K_Pλ; the hybrid now reads the tip's own velocity, λ̇ = k̂ n̂ᵀ ẋ, and rates would no
    longer do that. Without rates, the pose servo follows x_d along the estimated tangent with the steady lag v K_D/K_P.
    """
    a, b = (np.asarray(v, dtype=np.float64) for v in (start, end))
    if a.shape != (6,) or b.shape != (6,):
        raise ParameterError(f"start and end must be poses (6,); got shapes {a.shape} and {b.shape}")
    if not (speed > 0 and accel_time > 0):
        raise ParameterError(f"speed and accel_time must be positive; got {speed!r}, {accel_time!r}")
    length = float(np.linalg.norm(b[:3] - a[:3]))
    if length == 0.0:
        raise ParameterError("end must differ from start")
    cruise = max(length / speed - accel_time, 0.0)
    v = speed if cruise > 0.0 else length / accel_time
    total = cruise + 2.0 * accel_time
    if not total <= MAX_PATH_TIME:
        raise ParameterError(f"the line ({length:.4g} m at {speed:.4g} m/s) takes {total:.4g} s; at most {MAX_PATH_TIME:g} s")
    t = np.linspace(0.0, total, max(int(total / 0.005), 50) + 1)
    ds = v * np.minimum(np.clip(t / accel_time, 0.0, 1.0), np.clip((total - t) / accel_time, 0.0, 1.0))
    s = np.concatenate([[0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(t))])
    pos = a + (s / s[-1])[:, None] * (b - a)
    times = t + start_time
    if start_time > 0.0:
        times = np.concatenate([[0.0], times])
        pos = np.vstack([pos[:1], pos])
    force = np.zeros_like(pos)
    force[:, 0] = normal_force
    zero = np.zeros_like(pos)
    ref = SampledReference(times, pos, force, interpolation="linear", velocity=zero, acceleration=zero)
    ref.wipe_path = {"start": a[:3].copy(), "end": b[:3].copy(), "speed": float(speed), "normal_force": float(normal_force)}
    return ref


def _wipe_line(p: dict[str, Any], ctx: dict[str, Any]) -> SampledReference:
    from ..spatial.closed_form import rotation_to_euler_xyz

    robot = ctx["robot"]
    if int(robot.task_dim) != 6:
        raise ParameterError(f"wipe-line is for 6-D robots (e.g. the Panda); got a {int(robot.task_dim)}-dimensional task")
    R0, p0 = robot.frame_pose(ctx["q0"])
    end = np.asarray(p["end_offset"], dtype=np.float64)
    if end.shape != (3,):
        raise ParameterError(f"end_offset must have 3 components; got {end.shape[0]}")
    phi = rotation_to_euler_xyz(R0)
    return wipe_line_reference(np.concatenate([p0, phi]), np.concatenate([p0 + end, phi]), p["speed"], p["start_time"],
                               p["accel_time"], normal_force=p["normal_force"])


register_reference(
    "wipe-line",
    {
        "end_offset": Field("vector", True, low=-100.0, high=100.0, doc="the line's end − o_e(q0), base frame [m]"),
        "speed": Field("number", True, low=0.0, high=10.0, doc="speed of x_d along the line [m/s]"),
        "start_time": Field("number", default=0.0, low=0.0, high=1e5, doc="when x_d starts moving [s]"),
        "accel_time": Field("number", default=0.2, low=0.0, high=1e5, doc="speed ramp at both ends [s]"),
        "normal_force": Field("number", default=0.0, low=0.0, high=1e5,
                              doc="λ_d along a frame provider's normal [N] (spatial-hybrid-estimated)"),
    },
    _wipe_line,
    "x_d along a straight line from the start pose, no rates given (for a surface the controller does not know)",
)

# ----------------------------------------------------------------------------- search controller


def _search(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    from ..controllers.redundant import NullSpacePosture
    from ..controllers.search import SpiralSearchController

    robot = ctx["robot"]
    if int(robot.task_dim) != 6:
        raise ParameterError(f"spatial-hybrid-search is 6-D (e.g. the Panda); got a {int(robot.task_dim)}-dimensional task")
    n = np.asarray(p["normal"], dtype=np.float64)
    if n.shape != (3,) or not np.linalg.norm(n) > 0:
        raise ParameterError(f"normal must be a non-zero 3-vector (into the surface, base frame); got {p['normal']!r}")
    R0, _ = robot.frame_pose(ctx["q0"])
    direction = np.concatenate([R0.T @ (n / np.linalg.norm(n)), np.zeros(3)])  # S_f on the desired frame (held orientation)
    posture = NullSpacePosture(ctx["q0"], p["posture_stiffness"], p["posture_damping"]) if robot.nq > 6 else None
    return SpiralSearchController(
        robot, direction, 1.0 / p["stiffness_estimate"], p["stiffness"], p["damping"], p["force_gain"], p["force_rate_gain"],
        orientation=p["orientation"], posture=posture, sample_time=ctx["sample_time"], normal=n, threshold=p["threshold"],
        start_time=p["start_time"],
    )


register_controller(
    "spatial-hybrid-search",
    {
        "normal": Field("vector", True, low=-1e6, high=1e6, doc="the surface's normal into it, base frame (S_f; the drop)"),
        "threshold": Field("number", True, low=0.0, high=1.0, doc="the drop along the normal that finds the hole [m]"),
        "start_time": Field("number", default=0.0, low=0.0, high=1e5, doc="when the search starts (its reference height) [s]"),
        "stiffness_estimate": Field("number", True, low=1e-3, high=MAX_STIFFNESS, doc="k̂ = 1/ĉ along the normal [N/m] (> 0)"),
        "stiffness": Field("gain", True, doc="K_P of the pose servo (9.95) along S_v (6, 6) [1/s²]"),
        "damping": Field("gain", True, doc="K_D of the pose servo (9.95) along S_v (6, 6) [1/s]"),
        "force_gain": Field("number", True, low=0.0, high=1e12, doc="K_Pλ of (9.82) [1/s²]"),
        "force_rate_gain": Field("number", True, low=0.0, high=1e12, doc="K_Dλ of (9.82) [1/s]"),
        "posture_stiffness": Field("number", default=25.0, low=0.0, high=1e12, doc="null-space posture K_n [1/s²] (n > 6)"),
        "posture_damping": Field("number", default=10.0, low=0.0, high=1e12, doc="null-space posture D_n [1/s]"),
        "orientation": Field("str", default="euler", choices=("euler", "rotvec"), doc="orientation error"),
    },
    _search,
    "6-D hybrid (9.77)-(9.84), S_f along the surface's normal, with a hole detector (the tip's drop along it): a search",
)

# ----------------------------------------------------------------------------- metrics


def _hole_event(res: Any) -> dict[str, Any] | None:
    for e in res.events or ():
        if e.get("event") == "hole found":
            return e
    return None


def _hole_metric(key: str):
    def fn(res: Any, parts: dict[str, Any], window: float) -> float:
        if not hasattr(parts["controller"], "search_normal"):
            raise ScenarioError(f"metric {key!r} needs the spatial-hybrid-search controller (a hole search)")
        e = _hole_event(res)
        if key == "hole_found":
            return 1.0 if e is not None else 0.0
        if e is None:
            return float("nan")
        return float(e["t"]) if key == "hole_time" else float(e["position"]["xyz".index(key[-1])])

    return fn


# ----------------------------------------------------------------------------- analyses


def _wipe_applies(parts: dict[str, Any]) -> bool:
    env = parts["environment"]
    return (hasattr(getattr(env, "surface", env), "path_curvature") and hasattr(parts["reference"], "wipe_path")
            and getattr(parts["controller"], "frame", None) is not None)


def _wipe_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """The first-order bound of analysis/surface_following.py at the largest normal curvature of the bump field
    under the wiped line (sampled every mm), at the line's speed, with the controller's gains and filter."""
    from ..analysis.surface_following import path_following_bound

    env, ctl, ref = parts["environment"], parts["controller"], parts["reference"]
    field = getattr(env, "surface", env)
    path = ref.wipe_path
    a, b = path["start"], path["end"]
    direction = (b - a)[:2]
    n = max(int(np.linalg.norm(b - a) / 1e-3), 2) + 1
    kappa = [field.path_curvature(p[0], p[1], direction) for p in np.linspace(a, b, n)]
    est = ctl.frame
    out = path_following_bound(path["normal_force"], path["speed"], kappa, field.stiffness, float(ctl.force_stiffness[0, 0]),
                               float(ctl.force_damping[0, 0]), est.time_constant,
                               stiffness_estimate=1.0 / float(ctl.compliance[0, 0]), sample_time=est.sample_time)
    # at rest after the line (the estimate converged, λ = λ_d exactly): the tip where x_d's offset lies along the
    # normal (the S_v servo's error zero), i.e. on the normal through the foot of x_d, pressing λ_d along it
    nu = field.geometry(np.asarray(b, dtype=np.float64))[2]
    steady = {f"steady_{axis}": float(-path["normal_force"] * nu[i]) for i, axis in enumerate(("fx", "fy", "fz"))}
    return {"path_curvature_max": float(np.max(np.abs(kappa))), "estimate_lag": out.lag, "normal_force_bound": out.bound,
            "curvature_error": out.curvature_error, "lag_error": out.lag_error, **steady}


def _search_applies(parts: dict[str, Any]) -> bool:
    env = parts["environment"]
    return hasattr(parts["controller"], "search_normal") and hasattr(getattr(env, "surface", env), "dips")


def _search_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Where the nearest dip is felt: within w √(2 ln(d/threshold)) of its centre (a drop of the surface larger than
    the threshold, the tool following it under force control); its distance from the search's start; with a spiral
    reference, whether the spiral passes within that radius (its reach and its pitch: a first-order statement,
    the tool's lag behind x_d ignored)."""
    env, ctl = parts["environment"], parts["controller"]
    field = getattr(env, "surface", env)
    if not len(field.dips):
        return {}
    start = parts["robot"].frame_pose(parts["q0"])[1]
    rows = field.dips
    dist = np.hypot(rows[:, 0] - start[0], rows[:, 1] - start[1])
    i = int(np.argmin(dist))
    depth, width = float(rows[i, 2]), float(rows[i, 3])
    felt = width * math.sqrt(2.0 * math.log(depth / ctl.threshold)) if depth > ctl.threshold else 0.0
    out: dict[str, Any] = {"hole_distance": float(dist[i]), "hole_detection_radius": felt}
    # at rest (held where the hole was found, or at the spiral's end): λ = λ_d exactly along the fixed normal; the
    # lateral force (a dip's slope) is not predicted, so only a normal along z gives a settled axis to compare
    n = ctl.search_normal
    if abs(abs(float(n[2])) - 1.0) < 1e-12:
        h_d = np.asarray(parts["reference"].at(0.0).force, dtype=np.float64)[:3]
        out["steady_fz"] = float(n[2] * (n @ h_d))
    spiral = getattr(parts["reference"], "spiral_path", None)
    if spiral is not None:  # found for sure when the felt disc is within the spiral's reach and wider than its pitch
        r = float(np.hypot(rows[i, 0] - spiral["center"][0], rows[i, 1] - spiral["center"][1]))
        out["hole_in_reach"] = bool(r - felt <= spiral["radius"] and spiral["pitch"] <= 2.0 * felt)
    return out


def _register() -> None:
    from .checks import register_analysis, register_metric

    for key in ("hole_found", "hole_time", "hole_x", "hole_y", "hole_z"):
        register_metric(key, _hole_metric(key))
    register_analysis(_wipe_applies, _wipe_analysis)
    register_analysis(_search_applies, _search_analysis)


_register()
