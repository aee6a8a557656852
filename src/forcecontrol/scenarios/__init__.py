"""The chapter's examples and problems as data (TOML), runnable by name, and user scenarios.

Built-in scenarios are the ``*.toml`` files of this folder. Parts (environments, controllers,
references, metrics, analyses) register themselves in modules named ``parts*.py`` here, which
are imported on first use.
"""

from __future__ import annotations

import importlib
import pkgutil

from .core import (
    METRICS,
    CaseResult,
    CaseSpec,
    Scenario,
    ScenarioRun,
    build_case,
    case_analysis,
    case_response,
    check_expected,
    list_scenarios,
    load_scenario,
    register_analysis,
    register_metric,
    register_response,
    run_scenario,
    scenario_source,
)
from .schema import (
    CONTROLLERS,
    ENVIRONMENTS,
    REFERENCES,
    Field,
    register_controller,
    register_environment,
    register_reference,
)

#: ``fc.scenario("example-9.2")``: load a built-in scenario (or a TOML file) as a Scenario, then
#: ``.with_({...})`` to edit it and ``.run()`` to simulate it.
scenario = load_scenario

__all__ = [
    "scenario",
    "Scenario",
    "CaseSpec",
    "CaseResult",
    "ScenarioRun",
    "build_case",
    "case_analysis",
    "case_response",
    "check_expected",
    "list_scenarios",
    "load_scenario",
    "run_scenario",
    "scenario_source",
    "register_metric",
    "register_analysis",
    "register_response",
    "register_controller",
    "register_environment",
    "register_reference",
    "Field",
    "METRICS",
    "CONTROLLERS",
    "ENVIRONMENTS",
    "REFERENCES",
]


def _load_parts() -> None:
    for mod in sorted(m.name for m in pkgutil.iter_modules(__path__) if m.name.startswith("parts")):
        module = importlib.import_module(f"{__name__}.{mod}")
        hook = getattr(module, "_register_analyses", None)
        if hook is not None:
            hook()


_load_parts()
