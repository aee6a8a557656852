"""Registrations of the direct force control schemes (Sect. 9.4) and their analysis.

Controller types: ``inner-position`` (Fig. 9.6, (9.39) + PI (9.43)), ``inner-velocity``
(Fig. 9.7, (9.45)–(9.46)) and ``parallel`` (Fig. 9.8, (9.48) + PI). The environment's stiffness
matrix is handed to the controller so that a force reference outside R(K) is reported with a
:class:`~forcecontrol.errors.DriftWarning` when the case starts.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..controllers.force import (
    InnerPositionForceController,
    InnerVelocityForceController,
    ParallelForcePositionController,
)
from ..sim.limits import MAX_ANGLE_DEG
from ..trajectories import Setpoint
from .schema import Field, register_controller

_MOTION = {
    "inertia": Field("gain", True, doc="M_d [kg]"),
    "damping": Field("gain", True, doc="K_D [N s/m]"),
    "stiffness": Field("gain", True, doc="K_P [N/m]"),
    "force_gain": Field("gain", True, doc="K_F, diagonal of C_F [m/N] (in the task frame)"),
    "task_frame_angle": Field("number", low=-MAX_ANGLE_DEG, high=MAX_ANGLE_DEG,
                              doc="planar task frame: its x axis at this angle to x0 [deg]; "
                                  "C_F is diagonal there, its origin is the start tip (the inner position "
                                  "loop holds the start along axes without C_F) (default: the base frame)"),
}


def _frame(p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    if p["task_frame_angle"] is None:
        return None
    if int(ctx["robot"].task_dim) != 2:
        from ..errors import ParameterError

        raise ParameterError(f"task_frame_angle is for a planar task (m = 2); this robot's task has m = {ctx['robot'].task_dim}")
    import math

    from ..task import planar_rotation

    return planar_rotation(math.radians(p["task_frame_angle"]))
_PI = {
    **_MOTION,
    "integral_gain": Field("gain", default=0.0, doc="K_I, diagonal of C_F's integral action [m/(N s)]"),
    "integral_limit": Field("gain", doc="anti-windup bound on the integral action [m]"),
}


def _env_stiffness(ctx: dict[str, Any]) -> Any:
    env = ctx.get("environment")
    return env.stiffness_matrix() if env is not None and hasattr(env, "stiffness_matrix") else None


def _pi_builder(cls):
    def build(p: dict[str, Any], ctx: dict[str, Any]):
        return cls(
            ctx["robot"], p["inertia"], p["damping"], p["stiffness"], p["force_gain"], p["integral_gain"],
            integral_limit=p["integral_limit"], integrator_start=p["integrator_start"],
            environment_stiffness=_env_stiffness(ctx), sample_time=ctx["sample_time"], task_frame=_frame(p, ctx),
        )

    return build


register_controller(
    "inner-position",
    {**_PI, "integrator_start": Field("str", default="hold", choices=("hold", "tip", "zero"),
                                      doc="'hold' (default): x_F = tip before the force step, every step of f_d (at t = 0 or "
                                          "later) acts on the whole PI: the book's step response (9.42)-(9.43), Fig. 9.9; "
                                          "'tip': bumpless, x_F(0) = tip with f_d(0) applied and no proportional kick at any "
                                          "change of f_d; 'zero': ξ₀ = 0")},
    _pi_builder(InnerPositionForceController),
    "force control with inner position loop (9.39), PI C_F (9.43)",
)

register_controller(
    "inner-velocity",
    dict(_MOTION),
    lambda p, ctx: InnerVelocityForceController(
        ctx["robot"], p["inertia"], p["damping"], p["stiffness"], p["force_gain"],
        environment_stiffness=_env_stiffness(ctx), sample_time=ctx["sample_time"], task_frame=_frame(p, ctx),
    ),
    "force control with inner velocity loop (9.45)-(9.46)",
)

register_controller(
    "parallel",
    {**_PI, "integrator_start": Field("str", default="zero", choices=("tip", "hold", "zero"),
                                      doc="'zero' (default): ξ₀ = 0, x_d and f_d step at t = 0 on the whole PI (the book's "
                                          "Fig. 9.11); 'hold': x_d + x_F = tip before the force step; 'tip': x_d + x_F(0) = "
                                          "tip with f_d(0) applied, bumpless at later changes of f_d")},
    _pi_builder(ParallelForcePositionController),
    "parallel force/position control (9.48), PI C_F (9.43)",
)

_FORCE_TYPES = (InnerPositionForceController, InnerVelocityForceController, ParallelForcePositionController)


def _force_applies(parts: dict[str, Any]) -> bool:
    env = parts["environment"]
    if not (isinstance(parts["controller"], _FORCE_TYPES) and hasattr(env, "stiffness_matrix")):
        return False
    K = env.stiffness_matrix()
    ctl = parts["controller"]
    diag = all(
        np.allclose(M, np.diag(np.diag(M)))
        for M in (K, ctl.inertia, ctl.damping, ctl.stiffness)
    )
    return diag


def force_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Per base axis: poles, zero, ω_n, ζ, equilibrium (9.44)/(9.49), sampled stability limit.

    Keys (``a`` = x, y, ...): ``pole_re_a``, ``pole_im_a`` (the complex pair, imaginary part
    positive), ``real_pole_a`` (the third pole of the PI schemes), ``zero_a`` (of f_e/f_d; none with
    ``integrator_start = "tip"``, whose bumpless PI has no zero),
    ``omega_n_a``, ``zeta_a`` (of the complex pair, or of the slowest pole), ``steady_a``,
    ``steady_fa``, ``spectral_radius_a`` (sampled loop at Ts) and ``stability_limit_a`` (largest
    environment stiffness [N/m] keeping the sampled loop stable, with the arm's operational mass
    at q0 along the axis); only axes in contact (k > 0) get the last two.
    """
    import math

    from ..analysis.force_design import force_loop_axes, operational_mass, sampled_stability_limit

    ctl, env, ref, robot = parts["controller"], parts["environment"], parts["reference"], parts["robot"]
    K = env.stiffness_matrix()
    rest = env.point if hasattr(env, "point") else env.rest_position
    axes = force_loop_axes(ctl, K)
    out: dict[str, Any] = {}
    Ts = ctl.sample_time
    import warnings

    for i, (a, ax) in enumerate(zip("xyz", axes)):
        poles = ax.poles()
        cplx = [p for p in poles if p.imag > 1e-9]
        real = [p.real for p in poles if abs(p.imag) <= 1e-9]
        if cplx:
            out[f"pole_re_{a}"] = float(cplx[0].real)
            out[f"pole_im_{a}"] = float(cplx[0].imag)
        if real and ax.has_integral:
            out[f"real_pole_{a}"] = float(max(real))
        z = ax.zeros()
        if z.size == 1 and ax.force_gain > 0 and ax.environment_stiffness > 0 and not (ax.has_integral and ax.start == "tip"):
            out[f"zero_{a}"] = float(np.real(z[0]))
        wn, zeta, p = ax.damping_table()
        j = int(np.argmax(np.abs(np.imag(p)))) if np.any(np.abs(np.imag(p)) > 1e-9) else int(np.argmin(wn))
        if wn[j] > 0.0:
            out[f"omega_n_{a}"] = float(wn[j])
            out[f"zeta_{a}"] = float(zeta[j])
        if isinstance(ref, Setpoint):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the controller's reset reports drift once
                x, f = ax.equilibrium(float(ref.force[i]), float(ref.position[i]), float(rest[i]))
            if not math.isnan(x):
                out[f"steady_{a}"] = x
                out[f"steady_f{a}"] = f
        if ax.environment_stiffness > 0:
            nu = np.zeros(ctl.m)
            nu[i] = 1.0
            mx = operational_mass(robot, parts["q0"], nu)
            out[f"spectral_radius_{a}"] = ax.spectral_radius(Ts, mx)
            out[f"stability_limit_{a}"] = sampled_stability_limit(ax, Ts, arm_inertia=mx)
    return out


def force_response(parts: dict[str, Any], times: Any) -> Any:
    """h_e(t) of the sampled linear loops of the analysis (:meth:`ForceLoopAxis.sampled`, with the arm's
    operational mass at q0), from rest at the start tip with ξ₀ as the controller presets it;
    None when the scenario is outside that model (a rotated task frame, a start off the contact,
    a reference that is not a set-point)."""
    from ..analysis.force_design import force_loop_axes, operational_mass

    ctl, env, ref, robot = parts["controller"], parts["environment"], parts["reference"], parts["robot"]
    if not isinstance(ref, Setpoint) or getattr(ctl, "task_frame", None) is not None:
        return None
    K = env.stiffness_matrix()
    rest = np.asarray(env.point if hasattr(env, "point") else env.rest_position, dtype=float)
    q0 = np.asarray(parts["q0"], dtype=float)
    x0 = np.asarray(robot.forward_kinematics(q0), dtype=float)[: ctl.m]
    Ts = float(ctl.sample_time)
    idx = np.rint(np.asarray(times, dtype=float) / Ts).astype(int)
    n = int(idx.max()) + 1
    refs = [ref.at(k * Ts) for k in range(n)]
    out = np.zeros((idx.size, ctl.m))
    for i, ax in enumerate(force_loop_axes(ctl, K)):
        if ax.environment_stiffness == 0.0:
            continue  # no contact along this axis: h_e = 0
        if abs(x0[i] - rest[i]) > 1e-9:
            return None  # the loop starts off the contact: the approach is not in the linear model
        nu = np.zeros(ctl.m)
        nu[i] = 1.0
        A, B, C, D = ax._sampled_matrices(Ts, operational_mass(robot, q0, nu))
        U = np.array([[r.force[i], r.position[i], rest[i]] for r in refs])
        z = np.zeros(A.shape[0])
        z[0] = rest[i]
        bumpless = ax.has_integral and ax.start == "tip"
        if ax.has_integral:
            z[2] = ax.initial_integral(float(U[0, 0]), float(U[0, 1]), float(rest[i]))
        f = np.empty(n)
        for k in range(n):
            if bumpless and k > 0:  # "tip": a change of f_d moves ξ by −k_F Δf_d (no kick)
                z[2] -= ax.force_gain * (U[k, 0] - U[k - 1, 0])
            f[k] = C[0] @ z + D[0] @ U[k]
            z = A @ z + B @ U[k]
        out[:, i] = f[idx]
    return out


def _register_analyses() -> None:
    from .core import register_analysis, register_response

    register_analysis(_force_applies, force_analysis)
    register_response(_force_applies, force_response)
