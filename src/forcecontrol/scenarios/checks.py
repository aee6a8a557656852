"""What a scenario run reports and checks: the registered metrics and analyses, the expected values."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import ScenarioError
from ..sim.simulation import SimulationResult

__all__ = ["METRICS", "register_metric", "register_analysis", "register_once", "case_analysis", "register_response",
           "register_analysis_warnings", "case_analysis_warnings",
           "case_response", "check_expected", "check_no_empty_tables"]


#: name -> fn(result, parts, window) giving a settled value; parts has robot, environment,...
METRICS: dict[str, Callable[[SimulationResult, dict[str, Any], float], float]] = {}


#: list of (predicate(parts), fn(parts) -> dict) giving analytic predictions for a case.
_ANALYSES: list[tuple[Callable[[dict[str, Any]], bool], Callable[[dict[str, Any]], dict[str, Any]]]] = []


#: fn(parts, analysis, label) -> warnings: what a case's analysis warns of (a sampled loop that cannot settle, ...)
_ANALYSIS_WARNINGS: list[Callable[[dict[str, Any], dict[str, Any], str], list[dict[str, Any]]]] = []


def register_analysis_warnings(fn: Callable[[dict[str, Any], dict[str, Any], str], list[dict[str, Any]]]) -> None:
    """Add a source of a case's analysis warnings (``{"kind", "t", "text", ...}``), said by ``run`` and ``analyze``
    alike; once per function."""
    if not any(known is fn for known in _ANALYSIS_WARNINGS):
        _ANALYSIS_WARNINGS.append(fn)


def case_analysis_warnings(parts: dict[str, Any], analysis: dict[str, Any], label: str) -> list[dict[str, Any]]:
    """Every registered source's warnings for a built case and its :func:`case_analysis` (``label``: the case's)."""
    return [w for fn in _ANALYSIS_WARNINGS for w in fn(parts, analysis, label)]


def register_metric(name: str, fn: Callable[[SimulationResult, dict[str, Any], float], float]) -> None:
    """Add a settled metric usable in ``expected`` tables."""
    METRICS[name] = fn


def register_analysis(applies: Callable[[dict[str, Any]], bool], fn: Callable[[dict[str, Any]], dict[str, Any]]) -> None:
    """Add an analytic prediction shown beside the simulation (and usable in ``expected``)."""
    _ANALYSES.append((applies, fn))


def register_once(applies: Callable[[dict[str, Any]], bool], fn: Callable[[dict[str, Any]], dict[str, Any]]) -> bool:
    """:func:`register_analysis` unless ``fn`` is already registered (a module's hook may run more than once,
    e.g. after a reload); True when it was added."""
    if any(known is fn for _, known in _ANALYSES):
        return False
    register_analysis(applies, fn)
    return True


#: list of (predicate(parts), fn(parts, times) -> predicted h_e (N, m) or None): linear transients.
_RESPONSES: list[tuple[Callable[[dict[str, Any]], bool], Callable[[dict[str, Any], np.ndarray], Any]]] = []


def register_response(applies: Callable[[dict[str, Any]], bool], fn: Callable[[dict[str, Any], np.ndarray], Any]) -> None:
    """Add a linear model's contact-force transient for the cases ``applies`` accepts.

    ``fn(parts, times)`` returns the predicted h_e at ``times`` (N, m) [N], from the same
    parameters and conventions as the case's analysis, or None when the case is outside the
    model (e.g. the contact would be lost).
    """
    _RESPONSES.append((applies, fn))


def case_response(parts: dict[str, Any], times: Any) -> np.ndarray | None:
    """The first registered linear transient that applies to a built case, at ``times`` (or None).

    None too when the linear model cannot be formed (a singular inertia matrix at q0: the
    sampled-loop models need the arm's mobility ``J B⁻¹ Jᵀ``).
    """
    t = np.asarray(times, dtype=np.float64)
    for applies, fn in _RESPONSES:
        if applies(parts):
            try:
                out = fn(parts, t)
            except np.linalg.LinAlgError:
                continue
            if out is not None:
                return np.asarray(out, dtype=np.float64)
    return None


def case_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Every registered analytic prediction that applies to a built case (see :func:`build_case`)."""
    out: dict[str, Any] = {}
    for applies, fn in _ANALYSES:
        if applies(parts):
            out.update(fn(parts))
    return out


def check_expected(name: str, value: float, spec: Any, rel_tol: float) -> dict[str, Any]:
    """Compare a value with an expected ``spec`` (a number, or ``{value, tol}``).

    Returns:
        ``{"metric", "value", "expected", "tolerance", "relative_error", "ok"}``; the tolerance
        is ``tol`` when given, else ``rel_tol · |expected|``.
    """
    return _check(name, value, spec, rel_tol)


def _column_metric(col: str):
    def fn(res: SimulationResult, parts: dict[str, Any], window: float) -> float:
        cols = res.columns()
        sel = res.t >= res.t[-1] - window - 1e-12
        if col not in cols:
            raise ScenarioError(f"metric {col!r} is not logged for a {res.m}-dimensional task space")
        return float(np.mean(cols[col][sel]))

    return fn


def _penetration(res: SimulationResult, parts: dict[str, Any], window: float) -> float:
    env = parts["environment"]
    if not hasattr(env, "penetration"):
        raise ScenarioError("metric 'penetration' needs an elastic plane")
    sel = res.t >= res.t[-1] - window - 1e-12
    return float(np.mean([env.penetration(x) for x in res.x[sel]]))


def _check_expected_specs(where: str, expected: Any) -> None:
    """Each expected value is a finite number or a table ``{value, tol}`` (finite, tol >= 0), checked before running."""
    if not isinstance(expected, dict):
        raise ScenarioError(f"{where}: [expected] must be a table of metric = value; got {expected!r}")
    for key, spec in expected.items():
        if isinstance(spec, dict):
            extra = sorted(set(spec) - {"value", "tol"})
            if extra or "value" not in spec:
                raise ScenarioError(
                    f"{where}: [expected] key '{key}' must be a number or a table {{value, tol}}; "
                    f"got {spec!r} ({'unknown key ' + repr(extra[0]) if extra else 'no value'})"
                )
            items = [("value", spec["value"])] + ([("tol", spec["tol"])] if "tol" in spec else [])
        else:
            items = [("value", spec)]
        for part, v in items:
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) < 1e308 and (part == "value" or v >= 0)
            if not ok:
                what = "a finite number" if part == "value" else "a finite non-negative number"
                raise ScenarioError(f"{where}: [expected] key '{key}': {part} must be {what}; got {v!r}")


def check_no_empty_tables(where: str, table: dict[str, Any], prefix: str = "") -> None:
    """Refuse an empty table as a value in a ``[[case]]`` (``controller.stiffness = {}``): it would override nothing.

    Raises:
        ScenarioError: naming the case (``where``) and the dotted key.
    """
    for k, v in table.items():
        if isinstance(v, dict):
            if not v:
                raise ScenarioError(
                    f"{where}: key '{prefix}{k}' is an empty table {{}}; a case overrides a key with a value "
                    "(give the value, or remove the key to keep the scenario's)"
                )
            if k != "expected":
                check_no_empty_tables(where, v, f"{prefix}{k}.")


def _check(name: str, value: float, spec: Any, rel_tol: float) -> dict[str, Any]:
    if isinstance(spec, dict):
        want, tol = float(spec["value"]), float(spec.get("tol", rel_tol * abs(float(spec["value"]))))
    else:
        want, tol = float(spec), rel_tol * abs(float(spec))
    tol = max(tol, 1e-12)
    err = value - want
    return {
        "metric": name, "value": value, "expected": want, "tolerance": tol,
        "relative_error": err / want if want else err, "ok": bool(abs(err) <= tol),
    }
