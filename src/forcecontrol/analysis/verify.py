"""Comparing a case's analysis with a simulation of it (``forcecontrol analyze --verify``).

The pieces that need no scenario machinery: the tolerances, the comparison of the predicted
settled values and of the contact-force transient with a :class:`~forcecontrol.sim.result.SimulationResult`,
and the reasons given when something is not compared (silence is a defect: a verification not
done says why). :func:`forcecontrol.scenarios.report.verify_case` runs the simulation and puts
them together.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.axes import axis_names

__all__ = [
    "VERIFY_TOLERANCE",
    "TRANSIENT_TOLERANCE",
    "TRANSIENT_TIMES",
    "compare_steady",
    "compare_transient",
    "no_analysis_reason",
    "no_transient_reason",
]

#: relative difference under which a predicted steady value agrees with the simulation.
VERIFY_TOLERANCE = 0.01
#: difference (of the simulated peak contact force) under which a predicted transient agrees.
TRANSIENT_TOLERANCE = 0.02
#: when the transient is compared [s] (those within the case's duration).
TRANSIENT_TIMES = (0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.8, 1.0, 1.5, 2.0, 3.0)

#: analysis quantities compared with a scenario metric rather than a logged column: name -> group.
DERIVED_GROUPS = {"normal_force": "force", "penetration": "depth"}


def _difference(group: str, a: float, b: float) -> float:
    """a − b; for angles the shortest one (XYZ angles of ±π are one angle)."""
    from ..spatial import wrap_angle

    d = float(a) - float(b)
    return float(wrap_angle(d)) if group == "angle" else d


def compare_steady(analysis: dict[str, Any], res: Any, settled: dict[str, float],
                   derived: dict[str, tuple[float, float]]) -> tuple[dict[str, Any], dict[str, str]]:
    """Each predicted ``steady_<name>`` against the simulation's settled value.

    Args:
        analysis: the case's analysis (name -> value).
        res: the simulation (its start pose and wrench history give the scales).
        settled: the settled logged columns (``x … rz``, ``fx … mz``).
        derived: ``name -> (settled, start)`` of the scenario metrics in :data:`DERIVED_GROUPS`
            (the normal force on a plane, the penetration), for those the case has.

    Returns:
        ``(compared, unverified)``: ``compared[steady_<name>] = {"predicted", "simulated",
        "relative_difference", "agrees"}``; ``unverified[steady_<name>]`` says why a predicted
        settled value was not compared. Four groups, each against its own scale: positions and
        angles (the largest predicted move from the start), forces and moments (the largest
        prediction, or the run's peak when all are zero); a penetration against its own move.
    """
    pose_names, _, wrench_names = axis_names(res.x.shape[1])
    start = dict(zip(pose_names, (float(v) for v in res.x[0])))
    groups: dict[str, dict[str, float]] = {"position": {}, "angle": {}, "force": {}, "moment": {}, "depth": {}}
    simulated: dict[str, float] = dict(settled)
    unverified: dict[str, str] = {}
    for key, predicted in analysis.items():
        if not key.startswith("steady_"):
            continue
        name = key[len("steady_"):]
        if predicted is None or not math.isfinite(float(predicted)):
            unverified[key] = "the prediction is infinite or undefined"
            continue
        if name in pose_names:
            group = "angle" if name.startswith("r") else "position"
        elif name in wrench_names:
            group = "moment" if name.startswith("m") else "force"
        elif name in derived:
            group = DERIVED_GROUPS[name]
            simulated[name], start[name] = derived[name]
        else:
            unverified[key] = f"the simulation gives no settled '{name}' for this case"
            continue
        if name not in simulated:
            unverified[key] = f"the simulation logs no '{name}' for this case"
            continue
        groups[group][name] = float(predicted)
    out: dict[str, Any] = {}
    for group, values in groups.items():
        if group in ("position", "angle"):
            scale = max([abs(_difference(group, v, start[n])) for n, v in values.items()] + [1e-6])
        elif group == "depth":
            scale = max([abs(v - start[n]) for n, v in values.items()] + [1e-6])
        else:  # a wrench predicted zero (a peg aligned in its hole) is measured against the run's peak
            cols = [wrench_names.index(n) for n in values if n in wrench_names]
            peak = float(np.max(np.linalg.norm(res.wrench[:, cols], axis=1))) if cols else 0.0
            peak = max([peak] + [abs(derived[n][0]) for n in values if n in derived])
            scale = max([abs(v) for v in values.values()] + [1e-6])
            if scale <= 1e-6:
                scale = max(peak, 1e-6)
        for name, predicted in values.items():
            diff = abs(_difference(group, simulated[name], predicted)) / scale
            out[f"steady_{name}"] = {"predicted": predicted, "simulated": simulated[name], "relative_difference": diff,
                                     "agrees": diff <= VERIFY_TOLERANCE}
    return out, unverified


def compare_transient(predicted: Any, times: Any, res: Any, sample_time: float) -> dict[str, Any]:
    """The predicted contact force at ``times`` against the simulation's: ``{"times", "predicted",
    "simulated", "difference_over_peak", "agrees"}`` (within :data:`TRANSIENT_TOLERANCE` of the peak)."""
    predicted = np.asarray(predicted, dtype=float)
    times = np.asarray(times, dtype=float)
    simulated = res.wrench[np.rint(times / sample_time).astype(int), : predicted.shape[1]]
    peak = max(float(np.max(np.linalg.norm(res.wrench, axis=1))), 1e-9)
    diff = float(np.max(np.linalg.norm(simulated - predicted, axis=1))) / peak
    return {"times": times.tolist(), "predicted": predicted.tolist(), "simulated": simulated.tolist(),
            "difference_over_peak": diff, "agrees": diff <= TRANSIENT_TOLERANCE}


def _kind(obj: Any) -> str:
    describe = getattr(obj, "describe", None)
    kind = describe().get("type") if callable(describe) else None
    return str(kind or type(obj).__name__)


def no_analysis_reason(parts: dict[str, Any]) -> str:
    """Why no analysis applies to a built case (its controller, environment and reference)."""
    from ..supervision.transitions import ContactSupervisor

    ctl = parts["controller"]
    text = (f"no analysis applies to a {type(ctl).__name__} with environment '{_kind(parts['environment'])}' and "
            f"reference '{_kind(parts['reference'])}'")
    if isinstance(ctl, ContactSupervisor):
        text += " (a contact supervisor switches laws during the run; analyse each law as a case of its own)"
    return text


def no_transient_reason(parts: dict[str, Any]) -> str:
    """Why no linear contact-force transient model applies to a built case (the settled values
    are still compared)."""
    from ..controllers.compliance import OperationalSpacePD
    from ..controllers.hybrid import HybridCompliantController, HybridRigidController
    from ..controllers.impedance import ImpedanceController
    from ..controllers.spatial_hybrid import SpatialHybridController
    from ..trajectories import Setpoint

    ctl, ref = parts["controller"], parts["reference"]
    name = type(ctl).__name__
    if isinstance(ctl, HybridRigidController):
        return ("hybrid control on a rigid environment has no contact-force transient model: the reaction follows "
                "f_λ within a sample (its sampled loop is the pole force_sample_pole, not compared)")
    if isinstance(ctl, SpatialHybridController) and ctl.force_selection.shape[1] != 1:
        return (f"the 6-D hybrid force loop's transient is modelled for one force direction; this case controls "
                f"{ctl.force_selection.shape[1]}")
    if isinstance(ctl, (SpatialHybridController, HybridCompliantController)):
        return (f"the {name} force loop's transient is modelled for a constant λ_d along one force direction "
                "parallel to a plane's normal; this case has another")
    if isinstance(ctl, OperationalSpacePD):
        return "active compliance (9.22)-(9.23) is analysed at its equilibrium only (no transient model)"
    if isinstance(ctl, ImpedanceController) and not isinstance(ref, Setpoint):
        return f"the impedance transient model needs a set-point reference; this case follows '{_kind(ref)}'"
    return (f"no linear transient model for a {name} with environment '{_kind(parts['environment'])}' and "
            f"reference '{_kind(ref)}'")
