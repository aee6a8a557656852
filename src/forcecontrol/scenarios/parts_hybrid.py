"""Registrations of hybrid force/motion control (Sect. 9.7), the rigid plane and task-frame paths.

Controller types ``hybrid-compliant`` ((9.77), (9.80)–(9.82), estimated compliance (9.84)) and
``hybrid-rigid`` ((9.91) with (9.92)/(9.93)/(9.94), (9.80) or (9.95)); environment type
``rigid-plane`` (constrained dynamics (9.87)–(9.88)); reference type ``path-on-plane`` (a
trapezoidal segment with the desired force given as λ_d along the plane's y_c); metrics
``normal_force``, ``tangential_speed_error``, ``constraint_violation`` and ``contact_separation``; closed-loop predictions
for the hybrid schemes on a plane.

The task of these scenarios is the planar contact of Example 9.4 (x_c along the plane, y_c its
outward normal), built from the plane's ``angle``, or any reciprocal ``force_selection`` /
``velocity_selection`` pair given in the base frame.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from ..controllers.hybrid import HybridCompliantController, HybridRigidController
from ..controllers.impedance import ImpedanceController
from ..environments.elastic import ElasticPlane
from ..environments.rigid import PlaneConstraint, RigidEnvironment
from ..errors import ParameterError, ScenarioError
from ..sim.limits import MAX_ANGLE_DEG
from ..task import SelectionMatrices, inclined_plane
from ..trajectories import LinearPath
from .schema import TRAPEZOID_FIELDS, Field, force_law_fields, register_controller, register_environment, register_reference

# ----------------------------------------------------------------------------- helpers


def _plane_normal(env: Any) -> np.ndarray | None:
    """The outward normal y_c of a planar contact (elastic or rigid), else None."""
    if isinstance(env, ElasticPlane):
        return np.asarray(env.normal)
    if isinstance(env, RigidEnvironment) and isinstance(env.constraint, PlaneConstraint):
        return np.asarray(env.constraint.normal)
    return None


def _selection(p: dict[str, Any], ctx: dict[str, Any]) -> SelectionMatrices:
    given = (p["force_selection"] is not None, p["velocity_selection"] is not None)
    if any(given):
        if not all(given):
            raise ParameterError("force_selection and velocity_selection must be given together; got only one")
        if p["angle"] is not None:
            raise ParameterError("give either angle or force_selection/velocity_selection, not both")
        return SelectionMatrices(p["force_selection"], p["velocity_selection"])
    angle = 45.0 if p["angle"] is None else p["angle"]
    return inclined_plane(math.radians(angle)).selection("base")


_TASK_FIELDS = {
    "angle": Field("number", low=-MAX_ANGLE_DEG, high=MAX_ANGLE_DEG,
                   doc="the plane's angle to x0 [deg] (Example 9.4 task; 45 by default)"),
    "force_selection": Field("gain", doc="alternative: S_f in the base frame, rows [[...], ...]"),
    "velocity_selection": Field("gain", doc="alternative: S_v in the base frame, reciprocal to S_f"),
}


class TaskPath(LinearPath):
    """A trapezoidal segment whose force reference is ``h_d = S_f λ_d`` on a planar contact.

    Its acceleration reference is zero while the path rests, for ``t < start_time`` and
    ``t ≥ start_time + duration`` (the sample at t_f holds its torque over [t_f, t_f + Ts], when
    the path is at rest); this overrides ``LinearPath.sample``, which in this tree returns the first
    and last phases' ``±s̈`` there (reported). Without it the feedforward ẍ_d after t_f is
    ``−s̈_c (p_f − p_i)``, which leaves a hybrid run 0.7 mm short and an impedance run
    ``M_d s̈_c |p_f − p_i| / K_P`` (7 cm for Problem 9.3's gains) off the end point.
    """

    describe_complete: ClassVar[bool] = True  # see LinearPath

    def __init__(self, start: Any, end: Any, duration: float | None, accel_time: float | None = None,
                 start_time: float = 0.0, angle: float = 45.0, normal_force: float = 0.0, *,
                 speed: float | None = None) -> None:
        a = math.radians(angle)
        self.normal = np.array([-math.sin(a), math.cos(a)])
        self.normal_force = float(normal_force)
        self.angle = float(angle)
        super().__init__(start, end, duration, accel_time, start_time, self.normal_force * self.normal, speed=speed)

    def sample(self, times: np.ndarray) -> np.ndarray:
        out = super().sample(times)
        t = np.asarray(times, dtype=np.float64) - self.start_time
        rest = (t < 0.0) | (t >= self.duration)  # the sample at t_f holds [t_f, t_f + Ts]: at rest
        out[rest, 2 * self.dim : 3 * self.dim] = 0.0
        return out

    def describe(self) -> dict[str, Any]:
        return {**super().describe(), "type": "path-on-plane", "angle": self.angle, "normal_force": self.normal_force}


# ----------------------------------------------------------------------------- environment


def _rigid_plane(p: dict[str, Any], ctx: dict[str, Any]) -> RigidEnvironment:
    if (p["angle"] is None) == (p["normal"] is None):
        raise ParameterError("give exactly one of normal or angle for a rigid plane")
    if p["angle"] is not None:
        constraint = PlaneConstraint.inclined(math.radians(p["angle"]), p["point"])
    else:
        constraint = PlaneConstraint(p["point"], p["normal"])
    return RigidEnvironment(
        constraint, unilateral=p["unilateral"], stabilisation_frequency=p["stabilisation_frequency"]
    )


register_environment(
    "rigid-plane",
    {
        "point": Field("vector", True, doc="a point of the surface [m]"),
        "normal": Field("vector", doc="outward normal, from the environment into free space"),
        "angle": Field("number", low=-MAX_ANGLE_DEG, high=MAX_ANGLE_DEG,
                       doc="planar alternative to normal: the plane's angle to x0 [deg]"),
        "unilateral": Field("bool", default=True, doc="pushes only (lets go instead of pulling)"),
        "stabilisation_frequency": Field("number", default=100.0, doc="Baumgarte ω_b [rad/s]"),
    },
    _rigid_plane,
    "rigid frictionless plane: holonomic constraint, constrained dynamics (9.87)-(9.88)",
)

# ----------------------------------------------------------------------------- controllers


def _hybrid_compliant(p: dict[str, Any], ctx: dict[str, Any]) -> HybridCompliantController:
    sel = _selection(p, ctx)
    C = p["compliance"]
    if C is None:
        env = ctx.get("environment")
        if not isinstance(env, ElasticPlane):
            raise ParameterError("compliance must be given unless the environment is an elastic plane")
        C = np.eye(sel.dim) / env.stiffness  # C′ only sees the normal compliance 1/k
    return HybridCompliantController(
        ctx["robot"], sel, C, p["velocity_gain"], p["velocity_integral_gain"], p["force_gain"],
        p["force_rate_gain"], ctx["sample_time"],
    )


register_controller(
    "hybrid-compliant",
    {
        **_TASK_FIELDS,
        "compliance": Field("gain", doc="Ĉ [m/N], base frame; by default I/k of the elastic plane (exact)"),
        "velocity_gain": Field("gain", True, doc="K_Pν of (9.80) [1/s]"),
        "velocity_integral_gain": Field("gain", True, doc="K_Iν of (9.80) [1/s²]"),
        "force_gain": Field("gain", True, doc="K_Pλ of (9.81) [1/s²]"),
        "force_rate_gain": Field("gain", True, doc="K_Dλ of (9.81) [1/s]"),
    },
    _hybrid_compliant,
    "hybrid force/velocity control, compliant environment (9.77), (9.80)-(9.82), (9.84)",
)


def _hybrid_rigid(p: dict[str, Any], ctx: dict[str, Any]) -> HybridRigidController:
    """Gains that the chosen laws do not use are not passed on (so that a [[case]] can switch law
    without deleting keys; the controller itself refuses them); the scenario says so (``Field.used_when``)."""
    velocity = p["motion"] == "velocity"
    law = p["force_law"]
    return HybridRigidController(
        ctx["robot"], _selection(p, ctx), motion=p["motion"], velocity_gain=p["velocity_gain"],
        velocity_integral_gain=p["velocity_integral_gain"] if velocity else None,
        position_gain=None if velocity else p["position_gain"],
        force_law=law, force_gain=p["force_gain"] if law == "proportional" else None,
        force_integral_gain=p["force_integral_gain"] if law == "integral" else None,
        sample_time=ctx["sample_time"],
    )


register_controller(
    "hybrid-rigid",
    {
        **_TASK_FIELDS,
        "motion": Field("str", default="velocity", choices=("velocity", "position"), doc="(9.80) or (9.95)"),
        "velocity_gain": Field("gain", True, doc="K_Pν (9.80) or K_Dr (9.95) [1/s]"),
        "velocity_integral_gain": Field("gain", doc="K_Iν (9.80) [1/s²] (motion = velocity)",
                                        used_when=("motion", ("velocity",))),
        "position_gain": Field("gain", doc="K_Pr (9.95) [1/s²] (motion = position)", used_when=("motion", ("position",))),
        **force_law_fields("integral"),
    },
    _hybrid_rigid,
    "hybrid force/velocity or force/position control, rigid environment (9.91)-(9.95)",
)

# ----------------------------------------------------------------------------- reference

register_reference(
    "path-on-plane",
    {
        **TRAPEZOID_FIELDS,
        "angle": Field("number", low=-MAX_ANGLE_DEG, high=MAX_ANGLE_DEG, default=45.0,
                       doc="the plane's angle to x0 [deg]: y_c = [−sin a, cos a]"),
        "normal_force": Field("number", default=0.0, doc="λ_d along y_c [N] (negative: into the plane)"),
    },
    lambda p, ctx: TaskPath(p["start"], p["end"], p["duration"], p["accel_time"], p["start_time"],
                            p["angle"], p["normal_force"], speed=p["speed"]),
    "trapezoidal segment with h_d = λ_d y_c (Problems 9.3, 9.10)",
)

# ----------------------------------------------------------------------------- metrics


def _normal(parts: dict[str, Any], metric: str) -> np.ndarray:
    n = _plane_normal(parts["environment"])
    if n is None:
        raise ScenarioError(f"metric '{metric}' needs a planar contact (elastic-plane or rigid-plane)")
    return n


def _normal_force(res, parts, window) -> float:
    """Settled λ = y_cᵀ h_e [N] (the force on the plane along its outward normal; −50 pushes 50 N in)."""
    n = _normal(parts, "normal_force")
    sel = res.t >= res.t[-1] - window - 1e-12
    return float(np.mean(res.wrench[sel] @ n))


def _tangential_speed_error(res, parts, window) -> float:
    """max_k |x_cᵀ (ẋ_e − ẋ_d)| over the run [m/s]."""
    n = _normal(parts, "tangential_speed_error")
    t = np.array([n[1], -n[0]])
    return float(np.max(np.abs((res.xd - res.reference_block("velocity")) @ t)))


def _phi(res, parts, metric: str) -> np.ndarray:
    env = parts["environment"]
    if not isinstance(env, RigidEnvironment):
        raise ScenarioError(f"metric '{metric}' needs a rigid environment")
    return np.array([env.violation(parts["robot"], q) for q in res.q])


def _constraint_violation(res, parts, window) -> float:
    """max_k of the violation [m]: |φ| for a bilateral constraint, the penetration max(0, −φ) for
    a unilateral one (leaving the surface is allowed there; see ``contact_separation``)."""
    phi = _phi(res, parts, "constraint_violation")
    if parts["environment"].unilateral:
        return float(np.maximum(0.0, -phi).max())
    return float(np.abs(phi).max())


def _contact_separation(res, parts, window) -> float:
    """max_k φ(q_k) [m]: how far a unilateral contact was left during the run."""
    return float(max(0.0, _phi(res, parts, "contact_separation").max()))


# ----------------------------------------------------------------------------- analyses


def _hybrid_compliant_applies(parts: dict[str, Any]) -> bool:
    ctl = parts["controller"]
    return isinstance(ctl, HybridCompliantController) and ctl.selection.m == 1 and isinstance(
        parts["environment"], ElasticPlane
    )


def _hybrid_compliant_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Closed loops (9.78), (9.79) and, with Ĉ ≠ C, (9.84): λ̈ + K_Dλ λ̇ + L_f K_Pλ λ = L_f K_Pλ λ_d.

    ``L_f = (S_fᵀ C S_f)⁻¹ S_fᵀ Ĉ S_f`` with the plane's compliance 1/k along its normal.
    """
    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    S_f = ctl.selection.force_selection[:, 0]
    c_true = float((S_f @ env.normal) ** 2) / env.stiffness
    L_f = float(S_f @ ctl.compliance @ S_f) / c_true
    kp, kd = float(ctl.force_gain[0, 0]), float(ctl.force_rate_gain[0, 0])
    wn = math.sqrt(L_f * kp)
    out = {"L_f": L_f, "force_omega_n": wn, "force_zeta": kd / (2.0 * wn)}
    if ctl.selection.dim - ctl.selection.m == 1:
        ki, kv = float(ctl.velocity_integral_gain[0, 0]), float(ctl.velocity_gain[0, 0])
        out["velocity_omega_n"] = math.sqrt(ki)
        out["velocity_zeta"] = kv / (2.0 * math.sqrt(ki))
    if hasattr(ref, "force"):
        out["steady_normal_force"] = float(ctl.selection.force_pinv[0] @ ref.force)
        out["steady_penetration"] = -out["steady_normal_force"] / env.stiffness
    return out


def _hybrid_rigid_applies(parts: dict[str, Any]) -> bool:
    return isinstance(parts["controller"], HybridRigidController) and parts["controller"].selection.m == 1


def _hybrid_rigid_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """The sampled force loop: the reaction is read one sample late, so (9.93) gives the pole −K_Pλ
    and (9.94) the pole ``1 − K_Iλ Ts`` (λ = f_λ of the previous sample); stable inside the unit circle."""
    ctl, ref = parts["controller"], parts["reference"]
    Ts = ctl.sample_time
    pole = {"feedforward": 0.0, "proportional": -float(ctl.force_gain[0, 0]),
            "integral": 1.0 - float(ctl.force_integral_gain[0, 0]) * Ts}[ctl.force_law]
    out: dict[str, Any] = {"force_sample_pole": pole}
    if hasattr(ref, "force"):
        out["steady_normal_force"] = float(ctl.selection.force_pinv[0] @ ref.force)
    return out


def _impedance_on_plane_applies(parts: dict[str, Any]) -> bool:
    return (
        isinstance(parts["controller"], ImpedanceController)
        and parts["controller"].force_measurement
        and isinstance(parts["environment"], ElasticPlane)
        and isinstance(parts["reference"], TaskPath)
    )


def _impedance_on_plane_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Impedance (9.32) against the plane at the path's end, along the normal n (an eigenvector of
    M_d, K_D, K_P): ``m ÿ + k_D ẏ + (k_P + k) y = …``, contact force ``λ = −k k_P/(k_P + k) δ_d``
    with δ_d the reference's depth below the surface; ω_n, ζ of that axis."""
    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    n = np.asarray(env.normal)
    m, kd, kp = (float(n @ M @ n) for M in (ctl.inertia, ctl.damping, ctl.stiffness))
    k = env.stiffness
    depth = env.penetration(ref.end)
    wn = math.sqrt((kp + k) / m)
    return {
        "steady_normal_force": -k * kp / (kp + k) * depth,
        "steady_penetration": kp / (kp + k) * depth,
        "normal_omega_n": wn,
        "normal_zeta": kd / (2.0 * math.sqrt(m * (kp + k))),
    }


def _register_analyses() -> None:
    from .core import register_analysis, register_metric

    register_metric("normal_force", _normal_force)
    register_metric("tangential_speed_error", _tangential_speed_error)
    register_metric("constraint_violation", _constraint_violation)
    register_metric("contact_separation", _contact_separation)
    register_analysis(_hybrid_compliant_applies, _hybrid_compliant_analysis)
    register_analysis(_hybrid_rigid_applies, _hybrid_rigid_analysis)
    register_analysis(_impedance_on_plane_applies, _impedance_on_plane_analysis)
