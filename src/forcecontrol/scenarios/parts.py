"""Registrations of the foundation's parts: environments, controllers and references."""

from __future__ import annotations

import math
from typing import Any

from ..controllers import ImpedanceController, JointSpacePD, OperationalSpacePD
from ..environments import ElasticPlane, LinearSpring
from ..sim.limits import MAX_ANGLE_DEG
from ..trajectories import LinearPath, SampledReference, Setpoint
from .schema import TRAPEZOID_FIELDS, Field, register_controller, register_environment, register_reference

# ----------------------------------------------------------------------------- environments


def _plane(p: dict[str, Any], ctx: dict[str, Any]) -> ElasticPlane:
    if p["angle"] is not None:
        if p["normal"] is not None:
            from ..errors import ParameterError

            raise ParameterError("give either normal or angle, not both")
        return ElasticPlane.inclined(math.radians(p["angle"]), p["point"], p["stiffness"], p["damping"])
    if p["normal"] is None:
        from ..errors import ParameterError

        raise ParameterError("normal (or angle) is required for an elastic plane")
    return ElasticPlane(p["point"], p["normal"], p["stiffness"], p["damping"])


register_environment(
    "elastic-plane",
    {
        "point": Field("vector", True, doc="a point of the undeformed surface [m]"),
        "normal": Field("vector", doc="outward normal, from the environment into free space"),
        "angle": Field("number", low=-MAX_ANGLE_DEG, high=MAX_ANGLE_DEG,
                       doc="planar alternative to normal: the plane's angle to x0 [deg]"),
        "stiffness": Field("number", True, doc="stiffness along the normal [N/m]"),
        "damping": Field("number", default=0.0, doc="damping along the normal [N s/m]"),
    },
    _plane,
    "one-sided frictionless elastic plane (line in 2-D)",
)

register_environment(
    "linear-spring",
    {
        "stiffness": Field("gain", True, doc="K, symmetric PSD [N/m]"),
        "rest_position": Field("vector", True, doc="x_r [m]"),
        "damping": Field("gain", default=0.0, doc="D, symmetric PSD [N s/m]"),
    },
    lambda p, ctx: LinearSpring(p["stiffness"], p["rest_position"], p["damping"]),
    "bilateral linear spring h = K (x − x_r) + D ẋ",
)

# ----------------------------------------------------------------------------- controllers

register_controller(
    "impedance",
    {
        "inertia": Field("gain", True, doc="M_d [kg]"),
        "damping": Field("gain", True, doc="K_D [N s/m]"),
        "stiffness": Field("gain", True, doc="K_P [N/m]"),
        "force_measurement": Field("bool", default=True, doc="(9.30)-(9.31) if true, (9.28) if false"),
    },
    lambda p, ctx: ImpedanceController(
        ctx["robot"], p["inertia"], p["damping"], p["stiffness"], p["force_measurement"], ctx["sample_time"]
    ),
    "impedance control by inverse dynamics (9.28) / (9.30)-(9.31)",
)

register_controller(
    "operational-pd",
    {
        "stiffness": Field("gain", True, doc="K_P [N/m]"),
        "damping": Field("gain", True, doc="K_D [N s/m]"),
    },
    lambda p, ctx: OperationalSpacePD(ctx["robot"], p["stiffness"], p["damping"], ctx["sample_time"]),
    "active compliance: operational-space PD with gravity compensation (8.110)",
)


def _joint_pd(p: dict[str, Any], ctx: dict[str, Any]) -> JointSpacePD:
    robot = ctx["robot"]
    qd = p["joint_setpoint"]
    if qd is None:
        if p["setpoint_position"] is None:
            from ..errors import ParameterError

            raise ParameterError("joint_setpoint or setpoint_position is required for joint-pd")
        qd = robot.inverse_kinematics(p["setpoint_position"], elbow=p["elbow"])
    return JointSpacePD(robot, p["stiffness"], p["damping"], qd, ctx["sample_time"])


register_controller(
    "joint-pd",
    {
        "stiffness": Field("gain", True, doc="K_P [N m/rad]"),
        "damping": Field("gain", True, doc="K_D [N m s/rad]"),
        "joint_setpoint": Field("vector", doc="q_d [rad]"),
        "setpoint_position": Field("vector", doc="alternative: tip position whose IK gives q_d [m]"),
        "elbow": Field("str", default="up", choices=("up", "down")),
    },
    _joint_pd,
    "joint-space PD with gravity compensation (8.51), equilibrium (9.24)",
)

# ----------------------------------------------------------------------------- references

register_reference(
    "setpoint",
    {
        "position": Field("vector", True, doc="x_d [m]"),
        "force": Field("vector", doc="f_d [N]"),
        "force_start": Field("number", default=0.0, doc="when f_d starts [s] (0: with the position step)"),
        "force_ramp": Field("number", default=0.0, doc="time to reach f_d [s] (0: a step at force_start)"),
        "force_shape": Field("str", default="linear", choices=("linear", "smooth"),
                             doc="ramp shape: linear, or smooth (quintic: f_d, its rate and acceleration continuous)"),
    },
    lambda p, ctx: Setpoint(p["position"], p["force"], force_start=p["force_start"], force_ramp=p["force_ramp"],
                            force_shape=p["force_shape"]),
    "constant x_d; f_d stepped at t = 0, or at force_start, or ramped over force_ramp",
)

register_reference(
    "linear-path",
    {
        **TRAPEZOID_FIELDS,
        "force": Field("vector", doc="constant f_d [N]"),
    },
    lambda p, ctx: LinearPath(p["start"], p["end"], p["duration"], p["accel_time"], p["start_time"], p["force"],
                              speed=p["speed"]),
    "straight segment with a trapezoidal velocity profile",
)

register_reference(
    "sampled",
    {
        "file": Field("str", True, doc="CSV or Parquet: t, x, y [, z] (or ref_position_*), optional fx, fy (or ref_force_*); "
                                       "a relative path is relative to the scenario file"),
        "interpolation": Field("str", default="cubic", choices=("linear", "cubic"), doc="cubic spline (C²) or linear"),
        "dim": Field("int", doc="task dimension (default: the position columns found)"),
    },
    lambda p, ctx: SampledReference.from_file(p["file"], dim=p["dim"], interpolation=p["interpolation"]),
    "x_d (and f_d) from samples in a file, interpolated; held before the first and after the last sample",
)

# ----------------------------------------------------------------------------- analyses


def _environment_matrix(env: Any) -> Any:
    """(K, x_r, one-sided normal, D_e) of a linear elastic environment in the base frame, or None."""
    if not hasattr(env, "stiffness_matrix"):
        return None
    D = env.damping_matrix() if hasattr(env, "damping_matrix") else None
    if isinstance(env, ElasticPlane):
        return env.stiffness_matrix(), env.point, env.normal, D
    return env.stiffness_matrix(), env.rest_position, None, D


def _impedance_applies(parts: dict[str, Any]) -> bool:
    ctl = parts["controller"]
    return (
        isinstance(ctl, ImpedanceController)
        and ctl.force_measurement
        and isinstance(parts["reference"], Setpoint)
        and _environment_matrix(parts["environment"]) is not None
    )


def _impedance_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Equilibrium, ω_n and ζ of the impedance (9.32) on the environment, for any geometry.

    The modes come from the coupled linear model (``analysis.impedance_modes``): along the base
    axes (``omega_n_x``, ``zeta_x``, ...) when the contact is axis-aligned (Example 9.2), else per
    mode (``omega_n_1``, ``zeta_1``, ``mode_1`` = its direction), ascending.
    """

    from ..analysis import impedance_modes

    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    K, rest, normal, De = _environment_matrix(env)
    md = impedance_modes(ctl.inertia, ctl.damping, ctl.stiffness, K, ref.position, rest, one_sided_normal=normal,
                         environment_damping=De)
    axes = "xyz"[: ctl.m]
    out: dict[str, Any] = {}
    for i, a in enumerate(axes):
        out[f"steady_{a}"] = float(md.position[i])
        out[f"steady_f{a}"] = float(md.contact_force[i])
    out.update(md.named(axes))
    out["in_contact"] = md.in_contact
    return out


def _impedance_response(parts: dict[str, Any], times: Any) -> Any:
    """h_e(t) of the linear model of the impedance analysis, from rest at the start tip; None when it
    leaves a one-sided contact (or starts off it) at one of the times.

    The loop as the simulator runs it, sampled at the controller's Ts with the arm's mobility at
    q0 (:func:`~forcecontrol.analysis.impedance_response` with ``sample_time`` and ``mobility``).
    """
    import numpy as np

    from ..analysis import impedance_response
    from ..sim.simulation import contact_mobility

    ctl, env, ref, robot = parts["controller"], parts["environment"], parts["reference"], parts["robot"]
    K, rest, normal, De = _environment_matrix(env)
    q0 = np.asarray(parts["q0"], dtype=float)
    x0 = np.asarray(robot.forward_kinematics(q0), dtype=float)[: ctl.m]
    x, h = impedance_response(ctl.inertia, ctl.damping, ctl.stiffness, K, ref.position, rest, x0, times,
                              environment_damping=De, sample_time=ctl.sample_time, mobility=contact_mobility(robot, q0))
    if normal is not None and np.any((x - rest) @ normal > 1e-9):  # off the plane: the spring model does not hold
        return None
    return h


def _compliance_applies(parts: dict[str, Any]) -> bool:
    return isinstance(parts["controller"], OperationalSpacePD) and isinstance(parts["reference"], Setpoint) and hasattr(
        parts["environment"], "stiffness_matrix"
    )


def _compliance_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """The equilibrium (9.22)–(9.23) (valid while the contact holds)."""
    from ..analysis import compliance_equilibrium

    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    rest = env.point if isinstance(env, ElasticPlane) else env.rest_position
    eq = compliance_equilibrium(ctl.stiffness, env.stiffness_matrix(), ref.position, rest)
    out: dict[str, Any] = {}
    for i, a in enumerate("xyz"[: ctl.m]):
        out[f"steady_{a}"] = float(eq.position[i])
        out[f"steady_f{a}"] = float(eq.contact_force[i])
        out[f"pose_error_{a}"] = float(eq.pose_error[i])
    return out


def _register_analyses() -> None:
    from .core import register_analysis, register_response

    register_analysis(_impedance_applies, _impedance_analysis)
    register_response(_impedance_applies, _impedance_response)
    register_analysis(_compliance_applies, _compliance_analysis)
