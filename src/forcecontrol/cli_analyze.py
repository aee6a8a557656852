"""The ``forcecontrol analyze`` command (registered in :mod:`forcecontrol.cli`).

Kept apart from the analysis package so that the CLI starts without importing python-control;
the work is done by :func:`forcecontrol.analysis.report.analyze_scenario`.
"""

from __future__ import annotations

import json
import sys
from typing import Annotated

import typer

__all__ = ["analyze_command"]


def analyze_command(
    scenario: Annotated[str, typer.Argument(help="built-in name (see 'forcecontrol list') or a .toml file")],
    json_out: Annotated[bool, typer.Option("--json", help="print one JSON object instead of tables")] = False,
    check: Annotated[bool, typer.Option(help="exit with code 1 if an expected analysis value is missed")] = False,
) -> None:
    """Analyse a scenario without simulating: poles, ω_n, ζ, equilibria, sampled stability limit."""
    from rich.console import Console
    from rich.table import Table

    from .errors import ForceControlError

    try:
        from .analysis.report import analyze_scenario

        report = analyze_scenario(scenario)
    except ForceControlError as exc:
        Console(stderr=True).print(f"[bold red]error:[/] {exc}")
        raise typer.Exit(code=2) from None
    if json_out:
        sys.stdout.write(json.dumps(report, indent=2) + "\n")
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
    if check and not report["all_checks_pass"]:
        raise typer.Exit(code=1)
