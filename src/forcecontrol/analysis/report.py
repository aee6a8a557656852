"""Analyse a scenario without simulating it: the linear predictions of every case.

For each case the scenario's parts are built (robot, environment, controller, reference) and
every analysis registered with :func:`forcecontrol.scenarios.register_analysis` that applies is
evaluated: equilibria (9.22)–(9.23), impedance ω_n and ζ (Example 9.2), and for the direct force
control schemes poles, zero, ω_n, ζ, the equilibrium (9.44)/(9.49) and the sampled-data
stability limit. Expected ``analysis.*`` values of the scenario are checked against them.
This is what ``forcecontrol analyze NAME|FILE [--json]`` prints.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

__all__ = ["analyze_scenario"]


def _plain(v: Any) -> Any:
    """JSON-safe value: floats stay floats, inf and nan become None."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        return v
    return f if math.isfinite(f) else None


def analyze_scenario(source: str | Path | dict[str, Any]) -> dict[str, Any]:
    """The analytic predictions of every case of a scenario (nothing is simulated).

    Args:
        source: a built-in scenario name, a TOML path or a scenario dict.

    Returns:
        ``{"scenario", "title", "source", "cases": [{"label", "controller", "analysis",
        "checks"}], "all_checks_pass"}``; ``analysis`` maps names (``pole_re_x``,
        ``stability_limit_x`` [N/m], ``omega_n_x`` [rad/s], ...) to numbers, with None for an
        infinite or undefined value; ``checks`` compares the scenario's ``analysis.*`` expected
        values (the other expected values need a simulation: ``forcecontrol run``).

    Raises:
        ScenarioError: the scenario cannot be loaded or built.
    """
    from ..scenarios.core import _ANALYSES, _check, build_case, load_scenario

    scn = load_scenario(source)
    cases = []
    for i, case in enumerate(scn.cases):
        parts = build_case(case, where=f"{scn.source}: [[case]] #{i + 1}")
        analysis: dict[str, Any] = {}
        for applies, fn in _ANALYSES:
            if applies(parts):
                analysis.update(fn(parts))
        checks = []
        for key, spec in case.expected.items():
            if not key.startswith("analysis."):
                continue
            sub = key.split(".", 1)[1]
            if sub in analysis:
                checks.append(_check(key, float(analysis[sub]), spec, parts["tolerance"]))
            else:
                want = spec["value"] if isinstance(spec, dict) else spec
                checks.append({"metric": key, "value": None, "expected": _plain(want),
                               "tolerance": None, "relative_error": None, "ok": False})
        cases.append({
            "label": case.label,
            "controller": type(parts["controller"]).__name__,
            "environment": parts["environment"].describe(),
            "analysis": {k: _plain(v) for k, v in analysis.items()},
            "checks": [{k: _plain(v) if k != "metric" and k != "ok" else v for k, v in c.items()} for c in checks],
        })
    return {
        "scenario": scn.name,
        "title": scn.title,
        "source": scn.source,
        "cases": cases,
        "all_checks_pass": all(c["ok"] for case in cases for c in case["checks"]),
    }
