"""Scenario parts for position/velocity-interface arms: the ``admittance-position`` controller and its analysis.

A ``[robot.servo]`` table (:mod:`.servo_robot`) wraps the robot in its joint servo
(:class:`~forcecontrol.robots.servo.PositionInterfaceRobot`); ``[controller] type =
"admittance-position"`` runs admittance control (9.37) through IK on that servo, and the
scenario's analysis then reports the sampled loop (equilibrium, modes, margins, k_e limit:
:mod:`forcecontrol.analysis.servo_loop`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ScenarioError
from .core import register_analysis
from .schema import Field, register_controller

__all__: list[str] = []


def _admittance_position(p: dict[str, Any], ctx: dict[str, Any]):
    from ..controllers.admittance_position import PositionAdmittanceController
    from ..robots.servo import PositionInterfaceRobot

    if not isinstance(ctx["robot"], PositionInterfaceRobot):
        raise ScenarioError("controller 'admittance-position' needs a position-interface robot: add a [robot.servo] table")
    return PositionAdmittanceController(
        ctx["robot"], p["inertia"], p["damping"], p["stiffness"], sample_time=ctx["sample_time"],
        ik_damping=p["ik_damping"], velocity_feedforward=p["velocity_feedforward"],
        joint_limits=None if p["joint_limits"] == "none" else "model",
    )


register_controller(
    "admittance-position",
    {
        "inertia": Field("gain", True, doc="M_t (m, m) [kg, kg m²]"),
        "damping": Field("gain", True, doc="K_Dt (m, m)"),
        "stiffness": Field("gain", True, doc="K_Pt (m, m)"),
        "ik_damping": Field("number", default=1e-3, low=0.0, doc="λ of the damped least-squares IK [m]"),
        "velocity_feedforward": Field("bool", default=False, doc="send the compliant frame's twist as joint velocities"),
        "joint_limits": Field("str", default="model", choices=("model", "none"), doc="URDF joint and speed limits in the IK"),
    },
    _admittance_position,
    "admittance control (9.37) on a position-interface arm: compliant frame, IK, the arm's own servo",
)


# ----------------------------------------------------------------------------- the sampled loop's analysis


def _applies(parts: dict[str, Any]) -> bool:
    from ..controllers.admittance_position import PositionAdmittanceController

    ctl, env = parts["controller"], parts["environment"]
    return (isinstance(ctl, PositionAdmittanceController) and not ctl.velocity_feedforward
            and _normal_stiffness(env) is not None)


def _normal_stiffness(env: Any) -> tuple[np.ndarray, float] | None:
    """(ν, k) of a plane, or of a spring stiff along one translational direction only."""
    if hasattr(env, "normal") and hasattr(env, "stiffness") and np.ndim(env.stiffness) == 0:
        return np.asarray(env.normal, dtype=float), float(env.stiffness)
    if hasattr(env, "stiffness_matrix"):
        K = np.asarray(env.stiffness_matrix(), dtype=float)
        w, V = np.linalg.eigh(K)
        if np.sum(w > 1e-9 * max(w.max(), 1e-300)) == 1:
            nu = V[:, -1]
            m = K.shape[0]
            if m == 6 and np.linalg.norm(nu[3:]) > 1e-9:
                return None
            return nu[: 3 if m == 6 else m], float(w[-1])
    return None


def _analysis(parts: dict[str, Any]) -> dict[str, Any]:
    from ..analysis.servo_loop import admittance_servo_loop

    ctl = parts["controller"]
    nu, k = _normal_stiffness(parts["environment"])  # type: ignore[misc]
    loop = admittance_servo_loop(ctl, parts["q0"], nu)
    rep = loop.report(k, limit=True)
    slow = min(rep.modes, key=lambda m: m[1]) if rep.modes else (math.nan, math.nan)
    out = _steady_force(parts, nu, rep.force)
    return {
        **out,
        "servo_loop_spectral_radius": rep.spectral_radius,
        "servo_loop_stable": rep.stable,
        "servo_loop_stability_limit": rep.stability_limit,
        "servo_loop_gain_margin_db": 20 * math.log10(rep.gain_margin) if rep.gain_margin > 0 else -math.inf,
        "servo_loop_phase_margin": rep.phase_margin,
        "servo_loop_least_damped_omega_n": slow[0],
        "servo_loop_least_damped_zeta": slow[1],
        "servo_loop_force_per_penetration": rep.force,
    }


def _steady_force(parts: dict[str, Any], nu: np.ndarray, per_metre: float) -> dict[str, float]:
    """``steady_f*``: the equilibrium contact force (closed form; an unstable loop does not reach it).

    The desired frame's penetration ``δ_d = ν·(p − x_d)`` (p: the plane's point or the spring's rest
    position) times the series stiffness; the force the arm exerts is ``−ν f`` (none when δ_d ≤ 0
    against a one-sided plane).
    """
    from ..core.axes import axis_names

    env = parts["environment"]
    ref = parts["reference"].at(float(parts["duration"]))
    m = int(parts["robot"].task_dim)
    p = np.asarray(getattr(env, "point", getattr(env, "rest_position", None)), dtype=float)[: nu.size]
    x_d = np.asarray(ref.position, dtype=float)[: nu.size]
    depth = float(nu @ (p - x_d))
    one_sided = hasattr(env, "normal")
    f = per_metre * depth if depth > 0 or not one_sided else 0.0
    names = axis_names(m)[2]
    return {f"steady_{names[i]}": float(-nu[i] * f) + 0.0 for i in range(nu.size)}


register_analysis(_applies, _analysis)
