"""The sampled-loop verdict of the impedance and compliance cases, and of every case's spectral radius.

For a planar case under impedance control (9.30)–(9.31), or (9.28) without force measurement, or
active compliance (8.110) on a linear elastic environment (a plane, a spring), ``analyze`` reports
the loop as the simulator runs it: the law held over each sample on the arm, whose mobility
``J B⁻¹ Jᵀ`` takes the force change within the sample, against the environment's stiffness and
damping (:func:`~forcecontrol.analysis.impedance_loop`, :func:`~forcecontrol.analysis.compliance.compliance_loop`;
the same model as the contact-force transient of ``analyze --verify``). Per base axis ``a``
(:mod:`forcecontrol.analysis.sampled_contact`: each axis gets the radius of the group of axes it
is coupled with):

* ``spectral_radius_a``: at the start pose q0 (the transient's model);
* ``end_spectral_radius_a``: at the pose where the case is predicted to end (the rest of the same
  loop for the reference's final position, (9.32), (9.22)–(9.23) or (9.29); the one-sided plane
  left when it would pull), where the arm's mobility differs: Example 9.2's tip moves 0.1 m along
  the plane, which lowers the limit from 2.59e6 to 2.23e6 N/m;
* ``stability_limit_a``, on an elastic plane, for the axes in contact: the plane's stiffness [N/m]
  up to which the loop is stable at both poses (the end pose that of the case's own stiffness).
  A spring's stiffness is a matrix, with no one number to scale: it gets no limit.

The loop is taken in contact at both poses (what it does once it touches). :func:`sampled_loop_warnings`
turns any ``spectral_radius_a`` or ``end_spectral_radius_a`` >= 1 (the direct force schemes' too)
into a ``sampled-unstable`` warning; :func:`sampled_loop_skip_reason` says why a case whose analysis
gives a continuous ω_n and ζ has no sampled verdict.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..controllers import ImpedanceController, OperationalSpacePD
from ..environments import ElasticPlane

__all__ = ["sampled_loop_warnings", "sampled_loop_skip_reason", "SAMPLED_UNSTABLE"]

#: the ``kind`` of the warning a case gets when its sampled loop is unstable
SAMPLED_UNSTABLE = "sampled-unstable"

_AXES = ("x", "y", "z")
_RADIUS = re.compile(r"^(end_)?spectral_radius_(x|y|z)$")
#: analysis quantities of a settled loop: the steady state, and the continuous model's ω_n and ζ
_STEADY = re.compile(r"^(steady_|pose_error_)")
_DYNAMICS = re.compile(r"(^|_)(omega_n|zeta)(_|$)")


def _scheduled(ctl: Any) -> bool:
    from ..controllers.variable import VariableImpedanceController

    return isinstance(ctl, VariableImpedanceController)


def _linear_environment(env: Any, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray] | None:
    """(K, x_r, one-sided normal or None, D_e) of a linear elastic environment of the task's size, or None."""
    from .parts import _environment_matrix

    got = _environment_matrix(env)
    if got is None:
        return None
    K, rest, normal, De = got
    K = np.asarray(K, dtype=float)
    if K.shape != (m, m):
        return None
    De = np.zeros((m, m)) if De is None else np.asarray(De, dtype=float)
    return K, np.asarray(rest, dtype=float)[:m], None if normal is None else np.asarray(normal, dtype=float)[:m], De


def _applies(parts: dict[str, Any]) -> bool:
    ctl = parts["controller"]
    if not isinstance(ctl, (ImpedanceController, OperationalSpacePD)) or _scheduled(ctl) or parts.get("q0") is None:
        return False
    return _linear_environment(parts["environment"], int(ctl.m)) is not None


def _loop(ctl: Any, K: np.ndarray, De: np.ndarray, mobility: np.ndarray) -> Any:
    from ..analysis import impedance_loop
    from ..analysis.compliance import compliance_loop

    if isinstance(ctl, ImpedanceController):
        return impedance_loop(ctl.inertia, ctl.damping, ctl.stiffness, K, mobility, environment_damping=De,
                              force_measurement=ctl.force_measurement)
    return compliance_loop(ctl.stiffness, ctl.damping, K, mobility, environment_damping=De)


def _mobility(robot: Any, q: np.ndarray) -> np.ndarray:
    from ..sim.contact import contact_mobility

    return np.asarray(contact_mobility(robot, q), dtype=float)


def _pose(robot: Any, q0: np.ndarray, x: np.ndarray, m: int) -> np.ndarray | None:
    """Joint angles putting the tip at x, by Newton's method from q0 (the least-norm step of a redundant arm),
    or None when it does not converge to 1e-9 m (out of reach, or through a singularity)."""
    q = q0.copy()
    for _ in range(50):
        e = x - np.asarray(robot.forward_kinematics(q), dtype=float)[:m]
        if not np.all(np.isfinite(e)):
            return None
        if float(np.max(np.abs(e))) < 1e-9:
            return q
        J = np.asarray(robot.jacobian(q), dtype=float)[:m]
        try:
            q = q + np.linalg.lstsq(J, e, rcond=None)[0]
        except np.linalg.LinAlgError:  # pragma: no cover - an SVD that does not converge
            return None
    return None


@dataclass(frozen=True)
class _Model:
    """The case's held loop at the start pose and (when found) at the end pose."""

    start: Any
    end: Any | None
    end_skipped: str | None
    contact_axes: list[int]
    K: np.ndarray
    De: np.ndarray
    mobility_start: np.ndarray
    mobility_end: np.ndarray | None


def _end_position(loop: Any, x_d: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """Where the held loop rests for a constant x_d: the acceleration rows of ``(A + B F) z + B g = 0`` at ẋ = 0."""
    m = loop.m
    return np.linalg.solve(-loop.continuous()[m:, :m], loop.input(x_d, rest))


def _end_rest(ctl: Any, robot: Any, q0: np.ndarray, start: Any, K: np.ndarray, De: np.ndarray, rest: np.ndarray,
              normal: np.ndarray | None, x_d: np.ndarray, mob0: np.ndarray) -> np.ndarray:
    """Where the case is predicted to end: the rest of its held loop for the final x_d; the free rest when that would
    not press on a one-sided plane; for (9.29), whose rest depends on the mobility there, three fixed-point steps."""
    m = start.m
    x_end = _end_position(start, x_d, rest)
    if normal is not None and float((x_end - rest) @ normal) > 0.0:  # no penetration: the plane is left
        return _end_position(_loop(ctl, np.zeros((m, m)), np.zeros((m, m)), mob0), x_d, rest)
    for _ in range(3):  # (9.28) rests where the mobility of its own pose says (the others do not depend on it)
        q = _pose(robot, q0, x_end, m)
        if q is None:
            break
        x_end = _end_position(_loop(ctl, K, De, _mobility(robot, q)), x_d, rest)
    return x_end


def _model(parts: dict[str, Any]) -> _Model:
    """The held loops of a case the verdict applies to. Raises ``numpy.linalg.LinAlgError`` when the arm's
    inertia is singular at q0."""
    ctl, robot = parts["controller"], parts["robot"]
    m = int(ctl.m)
    K, rest, normal, De = _linear_environment(parts["environment"], m)  # type: ignore[misc]
    q0 = np.asarray(parts["q0"], dtype=float)
    mob0 = _mobility(robot, q0)
    start = _loop(ctl, K, De, mob0)
    contact = [i for i in range(m) if K[i, i] > 0.0]
    if parts.get("duration") is None:
        return _Model(start, None, "the case has no duration (no final reference)", contact, K, De, mob0, None)
    x_d = np.asarray(parts["reference"].at(float(parts["duration"])).position, dtype=float)[:m]
    end, skipped, mob = None, None, None
    try:
        x_end = _end_rest(ctl, robot, q0, start, K, De, rest, normal, x_d, mob0)
    except np.linalg.LinAlgError:
        x_end = None
        skipped = ("the held loop has no single rest position for the final reference (its stiffness through the "
                   "arm's mobility is singular)")
    q_end = None if x_end is None else _pose(robot, q0, x_end, m)
    if x_end is not None and q_end is None:
        skipped = f"the predicted end position {np.round(x_end, 6).tolist()} m is not reached from q0 by the arm's kinematics"
    elif q_end is not None:
        try:
            mob = _mobility(robot, q_end)
            end = _loop(ctl, K, De, mob)
        except np.linalg.LinAlgError:
            skipped = "the arm's inertia matrix is singular at the end pose"
    return _Model(start, end, skipped, contact, K, De, mob0, mob)


def _sampled_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """``spectral_radius_<a>``, ``end_spectral_radius_<a>`` and (on a plane) ``stability_limit_<a>`` (module text)."""
    from ..analysis.sampled_contact import axis_spectral_radii, stiffness_limit

    ctl, env = parts["controller"], parts["environment"]
    Ts = float(ctl.sample_time)
    try:
        md = _model(parts)
    except np.linalg.LinAlgError:
        return {}  # singular inertia at q0: said by sampled_loop_skip_reason
    axes = "xyz"[: ctl.m]
    rho = axis_spectral_radii(md.start, Ts)
    out: dict[str, Any] = {f"spectral_radius_{a}": float(rho[i]) for i, a in enumerate(axes)}
    if md.end is not None:
        rho_end = axis_spectral_radii(md.end, Ts)
        out.update({f"end_spectral_radius_{a}": float(rho_end[i]) for i, a in enumerate(axes)})
    if isinstance(env, ElasticPlane) and md.contact_axes:
        k0 = float(env.stiffness)
        mobilities = [md.mobility_start] + ([md.mobility_end] if md.mobility_end is not None else [])

        def radius(k: float) -> float:
            worst = 0.0
            for mob in mobilities:
                r = axis_spectral_radii(_loop(ctl, md.K * (k / k0), md.De, mob), Ts)
                worst = max(worst, float(np.max(r[md.contact_axes])))
            return worst

        limit = stiffness_limit(radius)
        out.update({f"stability_limit_{axes[i]}": limit for i in md.contact_axes})
    return out


def _groups_and_speed(parts: dict[str, Any]) -> tuple[list[list[int]], np.ndarray] | None:
    """The coupled axis groups of a case's held loop and each axis' ω_n [rad/s] (the start pose's; the
    groups are the same at the end pose), or None outside this module's cases."""
    from ..analysis.sampled_contact import axis_frequencies, axis_groups

    if not _applies(parts):
        return None
    try:
        md = _model(parts)
    except np.linalg.LinAlgError:
        return None
    return axis_groups(md.start), axis_frequencies(md.start)


def _settled_quantities(analysis: dict[str, Any], unstable: list[str]) -> list[str]:
    """The analysis' keys of a settled loop a case with unstable axes does not reach: every steady value
    (``steady_*``, ``pose_error_*``), and each ω_n and ζ but those named after an axis that is stable."""
    out = []
    for k in analysis:
        if _STEADY.match(k):
            out.append(k)
        elif _DYNAMICS.search(k):
            axis = k.rsplit("_", 1)[-1]
            if axis not in _AXES or axis in unstable:
                out.append(k)
    return out


def sampled_loop_warnings(parts: dict[str, Any], analysis: dict[str, Any], label: str) -> list[dict[str, Any]]:
    """One ``sampled-unstable`` warning per group of coupled axes whose sampled loop has a spectral radius >= 1.

    Reads ``spectral_radius_<a>`` (at the start pose: this module's, and the direct force schemes')
    and ``end_spectral_radius_<a>`` of the analysis. ω_n is that of the held loop's continuous limit
    on the axes' group (this module's cases) or ``omega_n_<a>`` (the direct force schemes).

    Returns:
        ``[{"kind": "sampled-unstable", "t": None, "text", "axes", "spectral_radius" (the start pose's),
        "end_spectral_radius" (or None), "omega_n_T" (or None), "quantities"}]``; ``quantities`` are the
        analysis' keys of a settled loop that the case does not reach (:func:`_settled_quantities`).
    """
    Ts = float(parts["controller"].sample_time)
    out: list[dict[str, Any]] = _whole_loop_warnings(analysis, label)
    rho: dict[str, dict[str, float]] = {"start": {}, "end": {}}
    for key, v in analysis.items():
        mt = _RADIUS.match(key)
        if mt and isinstance(v, (int, float)) and math.isfinite(v):
            rho["end" if mt.group(1) else "start"][mt.group(2)] = float(v)
    bad = sorted({a for pose in rho.values() for a, v in pose.items() if v >= 1.0}, key=_AXES.index)
    if not bad:
        return out
    model = _groups_and_speed(parts)
    if model is not None:
        groups = [[_AXES[i] for i in g] for g in model[0]]
        wn = {_AXES[i]: float(w) for i, w in enumerate(model[1])}
    else:  # the direct force schemes: one loop per axis
        groups = [[a] for a in bad]
        wn = {a: float(analysis[f"omega_n_{a}"]) for a in bad if isinstance(analysis.get(f"omega_n_{a}"), (int, float))}
    for group in groups:
        hit = [a for a in group if a in bad]
        if not hit:
            continue
        r0 = max(rho["start"].get(a, 0.0) for a in hit)
        r1 = max((rho["end"][a] for a in hit if a in rho["end"]), default=None)
        w = max((wn[a] for a in hit if a in wn), default=None)
        along = f"axes {', '.join(hit)} (coupled)" if len(hit) > 1 else f"axis {hit[0]}"
        where = f"ρ = {r0:.6g} at the start pose q0" + ("" if r1 is None else f", {r1:.6g} at the predicted end pose")
        speed = "" if w is None else f", ω_n·T = {w * Ts:.4g}"
        text = (f"{label}: the sampled loop is unstable along {along} ({where}{speed}, T = {Ts:g} s): it does not "
                "settle (expect bouncing or divergence); its continuous ω_n, ζ and steady values are not reached")
        out.append({"kind": SAMPLED_UNSTABLE, "t": None, "text": text, "axes": hit, "spectral_radius": r0,
                    "end_spectral_radius": r1, "omega_n_T": None if w is None else w * Ts,
                    "quantities": _settled_quantities(analysis, hit)})
    return out


#: the loops whose analysis is one spectral radius for the whole loop (not per axis): the name in the key, and the text
_WHOLE_LOOPS = {"servo_loop": "the loop through the position servo", "vendor_loop": "the vendor controller's contact loop"}


def _whole_loop_warnings(analysis: dict[str, Any], label: str) -> list[dict[str, Any]]:
    """A ``sampled-unstable`` warning for a ``servo_loop_spectral_radius`` or ``vendor_loop_spectral_radius`` >= 1
    (the position-interface servo loop, the vendor controllers' loops): as the per-axis one, without axes; the
    quantities not reached are every steady value and the loop's own damping and frequency."""
    out = []
    for name, what in _WHOLE_LOOPS.items():
        v = analysis.get(f"{name}_spectral_radius")
        if not isinstance(v, (int, float)) or not math.isfinite(v) or v < 1.0:
            continue
        limit = analysis.get(f"{name}_stability_limit")
        beyond = (f", the environment's stiffness beyond its stability limit {limit:.6g} N/m"
                  if isinstance(limit, (int, float)) and math.isfinite(limit) else "")
        text = (f"{label}: {what} is unstable (ρ = {v:.6g}{beyond}): it does not settle (expect bouncing or "
                "divergence); its steady values are not reached")
        quantities = [k for k in analysis if _STEADY.match(k) or (k.startswith(name) and _DYNAMICS.search(k))]
        out.append({"kind": SAMPLED_UNSTABLE, "t": None, "text": text, "axes": [], "spectral_radius": float(v),
                    "end_spectral_radius": None, "omega_n_T": None, "quantities": quantities})
    return out


def sampled_loop_skip_reason(parts: dict[str, Any], analysis: dict[str, Any]) -> str | None:
    """Why a case has no (or only a partial) sampled-loop verdict although its analysis gives a loop's
    dynamics (ω_n, ζ), or None when it has one or gives no dynamics."""
    from ..controllers.admittance import AdmittanceController
    from ..controllers.hybrid import HybridCompliantController
    from ..controllers.spatial import SpatialImpedanceController

    ctl = parts["controller"]
    if analysis.get("vendor_loop_skipped"):  # a vendor loop the controller does not close along the contact normal
        return f"the vendor controller's contact loop is not analysed: {analysis['vendor_loop_skipped']}"
    if _applies(parts):
        if not any(_RADIUS.match(k) for k in analysis):
            return "the arm's inertia matrix is singular at q0: no mobility J B⁻¹ Jᵀ to take the held force"
        if not any(k.startswith("end_spectral_radius_") for k in analysis):
            try:
                skipped = _model(parts).end_skipped
            except np.linalg.LinAlgError:  # pragma: no cover - said above
                skipped = None
            return None if skipped is None else f"at the end pose: {skipped} (the verdict is the start pose's)"
        return None
    if any(_RADIUS.match(k) or "spectral_radius" in k or k == "force_sample_pole" for k in analysis):
        return None
    if not any(_DYNAMICS.search(k) for k in analysis):
        return None
    name = type(ctl).__name__
    if _scheduled(ctl) or getattr(ctl, "stiffness_schedule", None) is not None \
            or getattr(ctl, "damping_schedule", None) is not None:
        return (f"no sampled-loop stability verdict for this {name} case (its gains follow a schedule over the run, "
                "which a loop at frozen gains does not cover); its steady state, ω_n and ζ are the continuous model's "
                "at the gains of t = 0, which hold only until the schedule changes them")
    elif isinstance(ctl, (SpatialImpedanceController, AdmittanceController)) or int(getattr(ctl, "m", 0)) == 6:
        why = "a 6-D case: its sampled model serves the contact-force transient of --verify only"
    elif isinstance(ctl, HybridCompliantController):
        why = "the hybrid force loop's sampled margins are `forcecontrol design`'s (scheme hybrid)"
    else:
        why = "no sampled-loop model of it here"
    return f"no sampled-loop stability verdict for this {name} case ({why}); its ω_n and ζ are the continuous model's"


def _register_analyses() -> None:
    from .checks import register_analysis_warnings, register_once

    register_once(_applies, _sampled_analysis)
    register_analysis_warnings(sampled_loop_warnings)
