"""``forcecontrol compare NAME``: a scenario on the built-in simulator and on MuJoCo, side by side."""

from __future__ import annotations

import sys
from typing import Annotated, Any

import typer

from .app import JsonOut, _fail, compile_notice, print_json

__all__ = ["compare_command", "compare_scenario", "COMPARE_UNITS"]

#: units of each engine's contact-force metrics and of the differences in --json
COMPARE_UNITS = {"steady": "N", "peak": "N", "peak_time": "s", "overshoot_percent": "%", "settling_time_2pc": "s",
                 "steady_force_difference_percent": "%", "max_force_difference_over_peak_percent": "%"}


def compare_scenario(name: str) -> dict[str, Any]:
    """Run every case of a scenario on both engines and compare the contact force (see ``compare_engines``)."""
    from ..engines.compare import compare_engines
    from ..scenarios import load_scenario, run_scenario

    scn = load_scenario(name)
    builtin = run_scenario(scn, engine="auto")
    mujoco = run_scenario(scn, engine="mujoco")
    cases = []
    for a, b in zip(builtin.cases, mujoco.cases):
        rep = compare_engines(a.result, b.result)
        rep["label"] = a.label
        rep["engines"] = [a.result.metadata.get("engine"), "mujoco"]
        cases.append(rep)
    return {"scenario": scn.name, "cases": cases}


def compare_command(
    scenario: Annotated[str, typer.Argument(help="built-in name (see 'forcecontrol list') or a .toml file")],
    json_out: JsonOut = False,
) -> None:
    """Run a scenario on the built-in simulator and on MuJoCo; report both and why they differ."""
    from rich.console import Console
    from rich.table import Table

    from ..errors import ForceControlError
    from .safe import escape

    compile_notice()
    try:
        report = compare_scenario(scenario)
    except (ForceControlError, ImportError) as exc:
        _fail(exc)
    if json_out:
        print_json({**report, "units": COMPARE_UNITS})
        return
    console = Console(width=None if sys.stdout.isatty() else 132)  # piped: as the other commands (80 cut the numbers)
    t = Table(title=f"{report['scenario']}: contact force, built-in simulator vs MuJoCo", title_justify="left")
    for col in ("case", "axis", "engine", "steady [N]", "peak [N]", "peak time [s]", "overshoot [%]", "settling [s]"):
        t.add_column(escape(col), justify="left" if col in ("case", "engine") else "right")  # '[s]' is a unit, not markup
    for c in report["cases"]:
        for eng, key in ((c["engines"][0], "builtin"), ("mujoco", "mujoco")):
            m = c[key]
            t.add_row(
                c["label"], str(c["axis"]), str(eng), f"{m['steady']:.4f}", f"{m['peak']:.4f}", f"{m['peak_time']:.3f}",
                f"{m['overshoot_percent']:.2f}", f"{m['settling_time_2pc']:.3f}",
            )
        t.add_row(
            c["label"], "", "difference", f"{c['steady_force_difference_percent']:.3f} %", "",
            "", "", f"max |Δf|/peak {c['max_force_difference_over_peak_percent']:.2f} %",
        )
    console.print(t)
    console.print("[bold]Where the engines differ, and why:[/]")
    for why in report["cases"][0]["why_they_differ"] if report["cases"] else ():
        console.print(f"  • {why}")
