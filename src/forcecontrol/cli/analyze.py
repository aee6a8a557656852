"""The ``forcecontrol analyze`` command (registered in :mod:`forcecontrol.cli`).

Kept apart from the analysis package so that the CLI starts without importing python-control;
the work is done by :func:`forcecontrol.analysis.report.analyze_scenario`.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from .app import JsonOut, _fail, compile_notice, print_json

__all__ = ["analyze_command"]


def analyze_command(
    scenario: Annotated[str, typer.Argument(help="built-in name (see 'forcecontrol list') or a .toml file")],
    json_out: JsonOut = False,
    check: Annotated[bool, typer.Option(help="exit with code 1 if an expected analysis value is missed")] = False,
    figures: Annotated[
        bool, typer.Option(help="also simulate and write one figure per controller type with the linearised model")
    ] = False,
    out: Annotated[Path, typer.Option(help="folder for the figures")] = Path("forcecontrol-out"),
    verify: Annotated[
        bool, typer.Option(help="also simulate each case and report how well the predicted equilibrium agrees")
    ] = False,
) -> None:
    """Analyse a scenario without simulating: poles, ω_n, ζ, equilibria, sampled stability limit.

    With ``--figures`` the scenario is also simulated and one figure per controller type is
    written (like the chapter's Figs. 9.9–9.11), the linearised contact force overlaid.
    """
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from ..errors import ForceControlError

    try:
        from ..analysis.report import analyze_scenario

        if verify:
            compile_notice()
        report = analyze_scenario(scenario, verify=verify)
        if figures:
            from ..analysis.report import plot_scheme_figures

            compile_notice()

            folder = out / "".join(ch if ch.isalnum() or ch == "." else "-" for ch in report["scenario"]).lower()
            report["files"] = [str(p) for p in plot_scheme_figures(scenario, folder)]
    except ForceControlError as exc:
        _fail(exc)
    if json_out:
        print_json(report)
    else:
        console = Console(width=None if sys.stdout.isatty() else 132)
        console.print(f"[bold]{report['title'] or report['scenario']}[/]")
        for case in report["cases"]:
            expected = {c["metric"].split(".", 1)[1]: c for c in case["checks"]}
            t = Table(title=f"{case['label']} ({case['controller']})", title_justify="left")
            for col in ("quantity", "predicted", "expected", "tolerance", ""):
                t.add_column(col, justify="left" if col == "quantity" else "right")
            for k, v in case["analysis"].items():
                c = expected.get(k)
                t.add_row(
                    k, "-" if v is None else f"{v:.6g}",
                    "" if c is None else f"{c['expected']:.6g}",
                    "" if c is None or c["tolerance"] is None else f"±{c['tolerance']:.3g}",
                    "" if c is None else ("[green]ok[/]" if c["ok"] else "[red]MISSED[/]"),
                )
            if not case["analysis"]:
                t.add_row("(no analysis applies to this case)", "", "", "", "")
            console.print(t)
            ver = case.get("verification")
            if ver is not None and (ver["quantities"] or ver.get("transient") is not None):
                vt = Table(title="predicted equilibrium against a simulation of the case", title_justify="left")
                for col in ("quantity", "predicted", "simulated", "difference", ""):
                    vt.add_column(col, justify="left" if col == "quantity" else "right")
                for k, v in ver["quantities"].items():
                    vt.add_row(k, f"{v['predicted']:.6g}", f"{v['simulated']:.6g}", f"{100 * v['relative_difference']:.3f} %",
                               "[green]agrees[/]" if v["agrees"] else "[red]differs[/]")
                tr = ver.get("transient")
                if tr is not None:
                    vt.add_row(f"contact force at {len(tr['times'])} times ≤ {tr['times'][-1]:g} s", "linear model",
                               "", f"{100 * tr['difference_over_peak']:.3f} % of peak",
                               "[green]agrees[/]" if tr["agrees"] else "[red]differs[/]")
                console.print(vt)
                if ver["warning"]:
                    console.print(f"[yellow]warning:[/] {escape(ver['warning'])}", highlight=False)
        for f in report.get("files", []):
            console.print(f"figure: {f}")
    if check and not report["all_checks_pass"]:
        raise typer.Exit(code=1)
