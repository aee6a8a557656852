"""Analyse a scenario without simulating it: the linear predictions of every case.

For each case the scenario's parts are built (robot, environment, controller, reference) and
every analysis registered with :func:`forcecontrol.scenarios.register_analysis` that applies is
evaluated: equilibria (9.22)–(9.23), impedance ω_n and ζ (Example 9.2), the sampled loop's
spectral radius and stability limit of impedance (9.28), (9.30)–(9.31) and compliance (8.110) on a
linear environment, and for the direct force control schemes poles, zero, ω_n, ζ, the equilibrium
(9.44)/(9.49) and the sampled-data stability limit. Expected ``analysis.*`` values of the scenario are checked against them.
This is what ``forcecontrol analyze NAME|FILE [--json]`` prints.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis.verify import (
    DERIVED_GROUPS,
    TRANSIENT_TIMES,
    TRANSIENT_TOLERANCE,
    VERIFY_TOLERANCE,
    compare_steady,
    compare_transient,
    no_analysis_reason,
    no_transient_reason,
)
from ..core.paths import inside, safe_name
from ..errors import ForceControlError

if TYPE_CHECKING:  # pragma: no cover
    from .core import Scenario

__all__ = ["analyze_scenario", "plot_scheme_figures", "verify_case", "VERIFY_TOLERANCE", "TRANSIENT_TOLERANCE"]


def _plain(v: Any) -> Any:
    """JSON-safe value: floats stay floats, inf and nan become None, booleans stay booleans,
    vectors (a mode's direction) become lists of those."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x) for x in v]
    try:
        f = float(v)
    except (TypeError, ValueError):
        return v
    return f if math.isfinite(f) else None


def _is_number(v: Any) -> bool:
    """A scalar an expected value can be checked against (a boolean counts as 0 or 1)."""
    return isinstance(v, (bool, int, float, np.bool_, np.integer, np.floating))


def verify_case(parts: dict[str, Any], analysis: dict[str, Any], engine: str = "auto") -> dict[str, Any]:
    """Check a case's predicted equilibrium (``steady_*``) and transient against a simulation of the same case.

    The case is simulated as the scenario says (``simulate`` on the full nonlinear arm); each
    predicted ``steady_<axis>`` (``x … rz``, ``fx … mz``) is compared with the settled value over the
    scenario's ``settle_window``, and so are ``steady_normal_force`` and ``steady_penetration``
    (the scenario metrics ``normal_force`` and ``penetration``, for the schemes on a plane). A
    relative difference above :data:`VERIFY_TOLERANCE` (of the largest predicted move from the
    start of the case among positions, among angles, or of the largest predicted force, or
    moment — of the run's peak force or moment when the prediction is zero) means the loop is
    outside the linear regime of the analysis (lost contact, saturation, not settled) and is
    reported as such. When the case's analysis has a linear transient model (the sampled loops of
    impedance on a linear environment, of the hybrid force loops and of the direct force
    schemes), its contact force at :data:`TRANSIENT_TIMES` is compared too, within
    :data:`TRANSIENT_TOLERANCE` of the simulated peak. What is not compared says why.

    Returns:
        ``{"quantities": {name: {"predicted", "simulated", "relative_difference", "agrees"}},
        "transient": {...} | None, "transient_skipped": reason | None, "unverified": {name: reason},
        "skipped": reason | None, "agrees": bool | None, "warning": str | None}``; ``skipped`` (and
        ``agrees`` None) when nothing at all could be compared; no simulation is run when the
        case has no analysis.
    """
    if not analysis:
        return _skipped(no_analysis_reason(parts) + ": nothing to verify")

    from ..sim.simulation import simulate
    from .core import METRICS

    res = simulate(
        parts["robot"], parts["environment"], parts["controller"], parts["reference"], q0=parts["q0"],
        qd0=parts["qd0"], duration=parts["duration"], sensor=parts["sensor"], substeps=parts["substeps"],
        engine=engine,  # type: ignore[arg-type]
    )
    window = parts["settle_window"]
    derived = {}
    for name in DERIVED_GROUPS:
        if f"steady_{name}" in analysis and name in METRICS:
            try:
                settled = METRICS[name](res, parts, window)
            except ForceControlError:
                continue  # the metric does not apply to this case: reported as unverified
            env = parts["environment"]  # the start value sets the scale of a penetration (its move)
            start = float(env.penetration(res.x[0])) if name == "penetration" and hasattr(env, "penetration") else 0.0
            derived[name] = (settled, start)
    out, unverified = compare_steady(analysis, res, res.settled_values(window), derived)
    transient, transient_skipped = _verify_transient(parts, res)
    bad = [k for k, v in out.items() if not v["agrees"]]
    if transient is not None and not transient["agrees"]:
        bad.append("the contact-force transient")
    warning = None
    if bad:
        warning = (f"{', '.join(bad)} differ from the simulation by more than {100 * VERIFY_TOLERANCE:g} % "
                   f"({100 * TRANSIENT_TOLERANCE:g} % of the peak for the transient): the loop is outside the "
                   "analysis' linear regime (contact lost, saturation) or has not settled"
                   + ("; a transient alone over its tolerance can also be the arm moving far from its start "
                      "pose (the sampled-loop model is linearised there: the arm's mobility at q0)"
                      if bad == ["the contact-force transient"] else ""))
    skipped = None
    if not out and transient is None:
        names = ", ".join(analysis)
        skipped = (f"none of the analysis' quantities ({names}) is a settled value the simulation gives, and "
                   f"{transient_skipped}")
    return {"quantities": out, "transient": transient, "transient_skipped": transient_skipped, "unverified": unverified,
            "skipped": skipped, "agrees": None if skipped else not bad, "warning": warning}


def _skipped(reason: str) -> dict[str, Any]:
    return {"quantities": {}, "transient": None, "transient_skipped": None, "unverified": {}, "skipped": reason,
            "agrees": None, "warning": None}


def _verify_transient(parts: dict[str, Any], res: Any) -> tuple[dict[str, Any] | None, str | None]:
    """(the comparison of :func:`~.verify.compare_transient`, None) or (None, why not)."""
    from .core import _RESPONSES, case_response

    times = np.array([t for t in TRANSIENT_TIMES if t <= res.t[-1] + 1e-12])
    if times.size == 0:
        return None, (f"the case lasts {res.t[-1]:g} s, less than the first time the transient is compared at "
                      f"({TRANSIENT_TIMES[0]:g} s)")
    if not any(applies(parts) for applies, _ in _RESPONSES):
        return None, no_transient_reason(parts)
    predicted = case_response(parts, times)
    if predicted is None:
        return None, ("the linear transient model leaves (or does not make) the one-sided contact at one of the "
                      "compared times, or the arm's inertia is singular at the start: no transient is claimed")
    return compare_transient(predicted, times, res, float(parts["controller"].sample_time)), None


def analyze_scenario(source: str | Path | dict[str, Any] | Scenario, *, verify: bool = False) -> dict[str, Any]:
    """The analytic predictions of every case of a scenario (nothing is simulated unless ``verify``).

    Args:
        source: a built-in scenario name, a TOML path, a scenario dict or a loaded
            :class:`~forcecontrol.scenarios.Scenario` (e.g. one changed with ``with_``).
        verify: also simulate each case and compare the predicted equilibrium with it
            (:func:`verify_case`); the result goes in each case's ``verification``.

    Returns:
        ``{"scenario", "title", "source", "cases": [{"label", "controller", "analysis",
        "checks"}], "all_checks_pass", "units"}``; ``units`` maps each quantity to its SI unit
        (:func:`forcecontrol.scenarios.units.unit`); ``analysis`` maps names (``pole_re_x``,
        ``stability_limit_x`` [N/m], ``omega_n_x`` [rad/s], ...) to numbers, with None for an
        infinite or undefined value; ``checks`` compares the scenario's ``analysis.*`` expected
        values (the other expected values need a simulation: ``forcecontrol run``). A case's
        ``warnings`` has a ``sampled-unstable`` entry for each group of axes whose sampled loop has
        a spectral radius >= 1 (:func:`~.parts_sampled.sampled_loop_warnings`: its continuous ω_n, ζ
        and steady values are not reached), and ``sampled_loop_skipped`` says why a case whose
        analysis gives a loop's ω_n and ζ has no sampled verdict.

    Raises:
        ScenarioError: the scenario cannot be loaded or built.
    """
    from .checks import case_analysis_warnings
    from .core import Scenario, build_case, case_analysis, check_expected, load_scenario
    from .parts_sampled import sampled_loop_skip_reason
    from .summary import config_warnings

    scn = source if isinstance(source, Scenario) else load_scenario(source)
    cases = []
    for i, case in enumerate(scn.cases):
        parts = build_case(case, where=f"{scn.source}: [[case]] #{i + 1}")
        analysis = case_analysis(parts)
        checks = []
        for key, spec in case.expected.items():
            if not key.startswith("analysis."):
                continue
            sub = key.split(".", 1)[1]
            if sub in analysis and _is_number(analysis[sub]):
                checks.append(check_expected(key, float(analysis[sub]), spec, parts["tolerance"]))
            else:
                want = spec["value"] if isinstance(spec, dict) else spec
                reason = (f"the analysis gives no '{sub}' for this case" if sub not in analysis
                          else f"the analysis' '{sub}' is not a number (a direction or a list)")
                checks.append({"metric": key, "value": None, "expected": _plain(want),
                               "tolerance": None, "relative_error": None, "ok": False, "reason": reason})
        entry = {
            "label": case.label,
            "controller": type(parts["controller"]).__name__,
            "environment": parts["environment"].describe(),
            "analysis": {k: _plain(v) for k, v in analysis.items()},
            "checks": [{k: _plain(v) if k not in ("metric", "ok", "reason") else v for k, v in c.items()} for c in checks],
        }
        entry["warnings"] = config_warnings(getattr(parts["controller"], "config_notes", None))  # as run --json
        # a sampled loop with a spectral radius >= 1 does not settle: said next to its continuous numbers
        entry["warnings"] += case_analysis_warnings(parts, analysis, case.label)
        if not analysis:
            entry["analysis_skipped"] = no_analysis_reason(parts)
        sampled_skipped = sampled_loop_skip_reason(parts, analysis)
        if sampled_skipped:
            entry["sampled_loop_skipped"] = sampled_skipped
        if verify:
            entry["verification"] = verify_case(parts, analysis)
        cases.append(entry)
    from .units import units_map

    names = [k for c in cases for k in c["analysis"]] + [ch["metric"] for c in cases for ch in c["checks"]]
    return {
        "scenario": scn.name,
        "title": scn.title,
        "source": scn.source,
        "cases": cases,
        "all_checks_pass": all(c["ok"] for case in cases for c in case["checks"]),
        "units": units_map(names),
    }


_BOOK_FIGURES = {
    "InnerPositionForceController": "Fig. 9.9: force control with inner position loop",
    "InnerVelocityForceController": "Fig. 9.10: force control with inner velocity loop",
    "ParallelForcePositionController": "Fig. 9.11: parallel force/position control",
}


def _linear_overlay(parts: dict[str, Any], t: Any) -> tuple[int, Any] | None:
    """The linearised f_e(t) along the contact axis for a direct force control case, or None."""
    import numpy as np

    from ..analysis.force_design import force_loop_axes
    from ..controllers.base import Measurement
    from ..controllers.force import (
        InnerPositionForceController,
        InnerVelocityForceController,
        ParallelForcePositionController,
    )
    from ..errors import ForceControlError
    from ..trajectories import Setpoint

    ctl, env, ref, robot = parts["controller"], parts["environment"], parts["reference"], parts["robot"]
    if not isinstance(ctl, (InnerPositionForceController, InnerVelocityForceController, ParallelForcePositionController)):
        return None
    if not isinstance(ref, Setpoint) or not hasattr(env, "stiffness_matrix"):
        return None
    K = env.stiffness_matrix()
    try:
        axes = force_loop_axes(ctl, K)
    except ForceControlError:
        return None
    i = int(np.argmax(np.diag(K)))
    q0 = np.asarray(parts["q0"], dtype=float)
    qd0 = np.zeros(robot.nq) if parts["qd0"] is None else np.asarray(parts["qd0"], dtype=float)
    x0 = robot.forward_kinematics(q0)
    ctl.reset(Measurement(q0, qd0, env.wrench(x0, robot.jacobian(q0) @ qd0)), ref.at(0.0))
    ax = axes[i]
    rest = env.point if hasattr(env, "point") else env.rest_position
    state = [x0[i], float((robot.jacobian(q0) @ qd0)[i])] + ([ctl.state[ctl.m + i]] if ax.has_integral else [])
    f_d = ref.sample(np.asarray(t, dtype=np.float64))[:, 3 * ctl.m + i]  # f_d(t): a step, or a later/ramped force
    resp = ax.response(t, f_d, float(ref.position[i]), float(rest[i]), initial_state=state)
    return i, np.asarray(resp.outputs[0])


def plot_scheme_figures(
    source: str | Path | dict[str, Any] | Scenario, folder: str | Path, *, engine: str = "auto",
    notes: list[str] | None = None,
) -> list[Path]:
    """Simulate a scenario and write one figure per controller type (like Figs. 9.9–9.11).

    Each figure shows x and f_x (the scenario's ``[figure]`` signals) of the cases that share a
    controller type, with the linearised model's contact force (:class:`ForceLoopAxis`, started
    from the simulation's initial state and integrator) overlaid in red.

    Args:
        source: a built-in scenario name, a TOML path or a scenario dict.
        folder: where the PNG files go (created).
        engine: simulator engine.
        notes: when given, a line is appended for each figure drawn without the linearised overlay
            (the linear model is that of the direct force schemes on an elastic environment, set point
            reference), saying why, and one for each key the scenario sets that no case uses
            (:func:`~.model.unused_key_notes`, then not warned as an :class:`~.model.UnusedKeyNote`).

    Returns:
        The written files, one per controller type, in order of first appearance.
    """
    import warnings

    from ..viz.plotting import SIGNAL_LABELS, plot_results
    from .core import Scenario, build_case, load_scenario, run_scenario
    from .model import UnusedKeyNote, unused_key_notes

    scn = source if isinstance(source, Scenario) else load_scenario(source)
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        if notes is not None:  # said in the notes instead
            warnings.filterwarnings("ignore", category=UnusedKeyNote)
            notes.extend(text for _, text, _ in unused_key_notes(scn.cases, scn.source))
        run = run_scenario(scn, engine=engine)
    groups: dict[str, list[int]] = {}
    for i, case in enumerate(run.cases):
        groups.setdefault(case.result.metadata["controller"]["type"], []).append(i)
    fig = scn.figure or {}
    signals = list(fig.get("signals") or ["x", "fx"])
    folder = Path(folder)
    written = []
    for kind, idx in groups.items():
        overlays: dict[str, list[tuple[Any, Any, str]]] = {}
        for i in idx:
            parts = build_case(scn.cases[i], where=f"{scn.source}: [[case]] #{i + 1}")
            r = run.cases[i].result
            lin = _linear_overlay(parts, r.t)
            if lin is not None:
                axis, f = lin
                sig = "f" + "xyz"[axis]
                if sig in SIGNAL_LABELS and sig in signals:
                    overlays.setdefault(sig, []).append((r.t, f, f"linearised, {run.cases[i].label}"))
        if notes is not None and not overlays:
            notes.append(f"figure of {kind}: simulated only, no linearised overlay (the linear model covers the direct "
                         "force schemes on an elastic environment with a set point)")
        title = _BOOK_FIGURES.get(kind, kind)
        stem = safe_name("".join(ch if ch.isalnum() else "-" for ch in f"{scn.name}-{kind}").strip("-").lower())
        path = plot_results(
            [run.cases[i].result for i in idx], signals, title=f"{scn.name}: {title}",
            t_max=fig.get("t_max"), overlays=overlays, path=inside(folder, f"{stem}.png"),
        )
        written.append(Path(path))
    return written
