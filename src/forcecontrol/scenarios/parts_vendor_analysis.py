"""The analysis of the vendor and ROS controllers on a position-interface arm (issue 30, item 4).

For a case whose controller is FZI's compliance or force controller, ros2_controllers' admittance
controller or UR's force mode (:mod:`.parts_vendor`) on a position-interface robot, against a
plane (or a spring stiff along one direction), ``forcecontrol analyze`` reports the sampled loop
that limits: the controller's law along the contact normal, the joint servo (the slowest joint's
ω, ζ) and its transport delay, the contact a spring k_e (:mod:`forcecontrol.analysis.vendor_fzi`,
:mod:`forcecontrol.analysis.vendor_loops`). Quantities: the loop's spectral radius at the
environment's stiffness, the stability limit in environment stiffness [N/m], the margin
(limit / k_e), the verdict (``settles`` below the limit, ``bounces`` beyond it) and the equilibrium
contact force (closed form; an unstable loop does not reach it).

The axis gains are projected on the normal (``νᵀ R diag(g) Rᵀ ν`` with R the tool's rotation at q0
for gains given in the tool frame), which is exact when the translational gains are equal.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["VENDOR_LOOP_KINDS", "vendor_loop", "loop_radius", "loop_limit", "loop_summary", "equilibrium_force"]

#: the controller classes this analysis reads, by scenario type
VENDOR_LOOP_KINDS = {"FziComplianceController": "fzi-compliance", "FziForceController": "fzi-force",
                     "Ros2AdmittanceController": "ros2-admittance", "UrForceModeController": "ur-force-mode"}


def _servo_of(robot: Any) -> tuple[float, float, float, int]:
    """(rate, ω, ζ, n_d) of a position-interface robot's servo: the slowest joint's ω and its ζ."""
    s = robot.servo
    w = np.broadcast_to(np.asarray(s.bandwidth, dtype=float), (int(robot.nq),))
    z = np.broadcast_to(np.asarray(s.damping, dtype=float), (int(robot.nq),))
    j = int(np.argmin(w))
    return float(s.rate), float(w[j]), float(z[j]), int(s.delay)


def vendor_loop(kind: str, params: dict[str, Any], servo: tuple[float, float, float, int], direction: Any = None,
                pd_direction: Any = None) -> Any:
    """The 1-DOF sampled loop of a controller's parameters (library names, per-axis vectors or numbers) with the servo
    ``(rate [Hz], ω [rad/s], ζ, delay [cycles])``, along ``direction`` (a unit 3-vector in the gains' frame; default z).

    FZI's controllers apply their PD gains ``p``, ``d`` per axis of the base frame (their ``SpatialPDController`` on the
    base-frame error) and only the stiffness in ``compliance_ref_link``: ``pd_direction`` is the direction in the base
    frame for p and d (default: ``direction``, the same when the compliance frame is the base)."""
    from ..analysis.vendor_fzi import FdccLoop
    from ..analysis.vendor_loops import Ros2AdmittanceLoop, UrForceModeLoop

    nu = np.array([0.0, 0.0, 1.0]) if direction is None else np.asarray(direction, dtype=float)
    nu_pd = nu if pd_direction is None else np.asarray(pd_direction, dtype=float)

    def along(value: Any, default: float, d: np.ndarray = nu) -> float:
        v = np.asarray(default if value is None else value, dtype=float)
        if v.ndim == 0:
            return float(v)
        return float(d @ (v[:3] * d))

    rate, w, z, nd = servo
    if kind in ("fzi-compliance", "fzi-force"):
        return FdccLoop(p=along(params.get("p"), 0.0, nu_pd), d=along(params.get("d"), 0.0, nu_pd),
                        error_scale=float(params.get("error_scale", 1.0)),
                        stiffness=along(params.get("stiffness"), 500.0) if kind == "fzi-compliance" else 0.0,
                        iterations=int(params.get("iterations", 1)) if kind == "fzi-compliance" else 1,
                        rate=rate, bandwidth=w, damping=z, delay=nd, virtual_mass=float(params.get("virtual_mass", 1.3)),
                        solver=str(params.get("solver", "accumulating")),
                        internal_period=float(params.get("internal_period", 0.02)))
    if kind == "ros2-admittance":
        return Ros2AdmittanceLoop(mass=along(params.get("mass"), 1.0), damping_ratio=along(params.get("damping_ratio"), 1.0),
                                  stiffness=along(params.get("stiffness"), 0.0), rate=rate, bandwidth=w, damping=z, delay=nd,
                                  joint_damping=float(params.get("joint_damping", 5.0)),
                                  filter_coefficient=float(params.get("filter_coefficient", 0.05)),
                                  kinematics_alpha=float(params.get("kinematics_alpha", 0.01)))
    if kind == "ur-force-mode":
        return UrForceModeLoop(gain=float(params.get("gain", 0.05)), gain_scaling=float(params.get("gain_scaling", 1.0)),
                               damping_force_mode=float(params.get("damping", 0.005)), rate=rate, bandwidth=w, damping=z,
                               delay=nd)
    raise ValueError(f"no sampled loop for {kind!r}")


#: where each vendor controller says which axes it makes compliant (1/true: compliant; the rest hold the reference pose)
SELECTION_KEYS = {"ros2-admittance": "selected_axes", "ur-force-mode": "selection_vector"}


def unselected_reason(kind: str, params: dict[str, Any], direction: Any) -> str | None:
    """Why the sampled loop along ``direction`` (a unit 3-vector in the gains' frame) is not the controller's: the
    direction lies, wholly or in part (more than 0.1 % of its weight, 1.8°), on translational axes its selection leaves
    out (ros2_controllers' ``selected_axes``, UR's ``selection_vector``), along which the arm holds the reference pose;
    None when it is on selected axes (or the controller has no selection)."""
    key = SELECTION_KEYS.get(kind)
    if key is None or params.get(key) is None:
        return None
    sel = np.broadcast_to(np.asarray(params[key], dtype=float), (6,))[:3]
    d = np.asarray(direction, dtype=float)[:3]
    if float(d @ (sel * d)) >= 1.0 - 1e-3:  # at most 0.1 % of the normal's weight (1.8°) on held axes: the loop is the
        return None                         # controller's to that accuracy
    off = ", ".join(n for n, s, di in zip("xyz", sel, d) if not s and di * di > 1e-6)  # the held axes it lies on
    return (f"the contact normal {np.round(d, 6).tolist()} (in the gains' frame) is on axes {key} leaves out ({off}): "
            "along them the arm holds the reference pose, a position-controlled contact outside this loop's model")


def compliant_axis(selection: Any, wrench: Any = None) -> int | None:
    """The translational axis (0, 1, 2) a force mode is analysed or placed along: the first compliant one of z, x, y
    (with a non-zero ``wrench`` on it, when given), or None."""
    if selection is None:
        return None
    return next((i for i in (2, 0, 1) if selection[i] and (wrench is None or wrench[i] != 0.0)), None)


def loop_radius(loop: Any, k_e: float) -> float:
    """The loop's spectral radius at environment stiffness ``k_e`` [N/m]."""
    from ..analysis.vendor_fzi import FdccLoop, fdcc_spectral_radius
    from ..analysis.vendor_loops import spectral_radius

    return fdcc_spectral_radius(loop, k_e) if isinstance(loop, FdccLoop) else spectral_radius(loop, k_e)


def loop_limit(loop: Any) -> float:
    """The loop's stability limit in environment stiffness [N/m] (``inf``: none found below 1e9 N/m)."""
    from ..analysis.vendor_fzi import FdccLoop, fdcc_stability_limit
    from ..analysis.vendor_loops import stability_limit

    return fdcc_stability_limit(loop) if isinstance(loop, FdccLoop) else stability_limit(loop)


def loop_summary(kind: str, loop: Any) -> str:
    """The loop in words (which loop limits)."""
    servo = (f"the joint servo (ω {loop.bandwidth:.4g} rad/s, ζ {loop.damping:.3g}, {loop.delay} cycle(s) of delay) "
             f"at {loop.rate:g} Hz, the contact a spring along the normal")
    if kind.startswith("fzi"):
        law = (f"FZI's forward-dynamics solver ({loop.solver}, {loop.iterations} iteration(s), p {loop.p:g}, d {loop.d:g}, "
               f"error_scale {loop.error_scale:g}" + (f", stiffness {loop.stiffness:g} N/m" if kind == "fzi-compliance" else "")
               + ")")
    elif kind == "ros2-admittance":
        law = (f"the admittance rule (mass {loop.mass:g} kg, damping_ratio {loop.damping_ratio:g}, stiffness "
               f"{loop.stiffness:g} N/m, joint_damping {loop.joint_damping:g}, filter {loop.filter_coefficient:g})")
    else:
        law = (f"force mode's admittance (gain {loop.gain:g} 1/kg, gain_scaling {loop.gain_scaling:g}, "
               f"damping {loop.damping_force_mode:g})")
    return f"{law} through {servo}"


def loop_quantities(loop: Any, k_e: float) -> dict[str, Any]:
    """Spectral radius, limit, margin and verdict of a loop at ``k_e`` (the analyze/design quantities)."""
    rho = loop_radius(loop, k_e)
    limit = loop_limit(loop)
    return {"environment_stiffness": float(k_e), "vendor_loop_spectral_radius": rho, "vendor_loop_stability_limit": limit,
            "vendor_loop_margin": limit / k_e if k_e > 0 else math.inf,
            "vendor_loop_verdict": "settles" if rho < 1.0 else "bounces"}


def equilibrium_force(kind: str, params: dict[str, Any], nu: np.ndarray, k_e: float, depth: float, f_d: np.ndarray,
                      direction: np.ndarray) -> float:
    """The contact force along the outward normal ν at rest [N] (negative: pressing): compliance with K along the
    normal, ``h = k_e (K δ_t + f_d·ν) / (K + k_e)`` (δ_t: the target's depth below the surface); force controller
    ``f_d·ν``; force mode the wrench along ν; 0 when that would pull (one-sided contact)."""
    fn = float(nu @ f_d[:3])
    if kind in ("fzi-compliance", "ros2-admittance"):
        K = vendor_loop(kind, params, (1.0, 1.0, 1.0, 0), direction).stiffness
        h = k_e * (-K * depth + fn) / (K + k_e)
    else:
        h = fn
    return min(h, 0.0)


def _applies(parts: dict[str, Any]) -> bool:
    from ..robots.servo import PositionInterfaceRobot
    from .parts_servo import _normal_stiffness

    return (type(parts["controller"]).__name__ in VENDOR_LOOP_KINDS and isinstance(parts["robot"], PositionInterfaceRobot)
            and _normal_stiffness(parts["environment"]) is not None)


def _analysis(parts: dict[str, Any]) -> dict[str, Any]:
    from .parts_servo import _normal_stiffness

    ctl, robot = parts["controller"], parts["robot"]
    kind = VENDOR_LOOP_KINDS[type(ctl).__name__]
    nu, k_e = _normal_stiffness(parts["environment"])  # type: ignore[misc]
    nu = np.asarray(nu, dtype=float)[:3]
    q0 = np.asarray(parts["q0"], dtype=float)
    frame = getattr(ctl, "compliance_frame", getattr(ctl, "control_frame", "base"))
    if kind == "ur-force-mode":
        from scipy.spatial.transform import Rotation

        R = Rotation.from_rotvec(np.asarray(ctl.task_frame, dtype=float)[3:6]).as_matrix()
    elif frame == "tool":
        R = np.asarray(robot.frame_pose(q0)[0], dtype=float)[:3, :3]
    else:
        R = np.eye(3)
    direction = R.T @ nu
    params = {k: getattr(ctl, k) for k in ("p", "d", "error_scale", "stiffness", "iterations", "solver", "virtual_mass",
                                           "internal_period", "mass", "damping_ratio", "joint_damping", "filter_coefficient",
                                           "kinematics_alpha", "gain", "gain_scaling", "damping",
                                           *SELECTION_KEYS.values()) if hasattr(ctl, k)}
    skipped = unselected_reason(kind, params, direction)
    if skipped is not None:  # no verdict and no steady force from a loop the controller does not close (said)
        return {"vendor_loop": "not analysed", "vendor_loop_skipped": skipped}
    loop = vendor_loop(kind, params, _servo_of(robot), direction, pd_direction=nu)  # FZI's p, d: per base axis
    out: dict[str, Any] = {"vendor_loop": loop_summary(kind, loop), **loop_quantities(loop, k_e)}
    payload = getattr(getattr(robot, "torque_robot", robot), "payload", None)
    if payload is not None:  # what this verdict does not cover (said next to it, on the table and in --json)
        out["vendor_loop_note"] = (
            f"the verdict leaves out the {payload.mass:g} kg payload after the sensor: its inertial wrench, fed back "
            "through the sensor, can make the loop oscillate in free space (FZI #177; analysis.vendor_fzi."
            "fdcc_error_scale_limit bounds one axis of it): check with `forcecontrol run`")
    ref = parts["reference"].at(float(parts["duration"]))
    env = parts["environment"]
    point = np.asarray(getattr(env, "point", getattr(env, "rest_position", np.zeros(3))), dtype=float)[:3]
    depth = float(nu @ (point - np.asarray(ref.position, dtype=float)[:3]))
    f_d = np.asarray(getattr(ref, "force", np.zeros(6)), dtype=float)
    if kind == "ur-force-mode":
        sel = np.asarray(ctl.selection_vector, dtype=float)[:3]  # the wrench the arm applies to the environment, base frame
        f_d = np.concatenate([R @ (np.asarray(ctl.wrench, dtype=float)[:3] * sel), np.zeros(3)])
    h = equilibrium_force(kind, params, nu, k_e, depth, f_d, direction)
    from ..core.axes import axis_names

    names = axis_names(int(robot.task_dim))[2]
    out.update({f"steady_{names[i]}": float(nu[i] * h) + 0.0 for i in range(3)})
    return out


def _register_analyses() -> None:
    from .checks import register_once

    register_once(_applies, _analysis)
