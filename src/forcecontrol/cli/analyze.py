"""The ``forcecontrol analyze`` command (registered in :mod:`forcecontrol.cli`).

Kept apart from the analysis package so that the CLI starts without importing python-control;
the work is done by :func:`forcecontrol.scenarios.report.analyze_scenario`.
"""

from __future__ import annotations

import json
import sys
from typing import Annotated, Any

import typer

from .app import (
    ForceOverwrite,
    JsonOut,
    OutFolder,
    _fail,
    _slug,
    compile_notice,
    err_console,
    prepare_output,
    print_json,
    say_note,
)
from .busy import busy
from .overrides import SetOption, apply_sets, parse_sets

__all__ = ["analyze_command"]


def analyze_command(
    ctx: typer.Context,
    scenario: Annotated[str, typer.Argument(help="built-in name (see 'forcecontrol list') or a .toml file")],
    json_out: JsonOut = False,
    check: Annotated[bool, typer.Option(help="exit with code 1 if an expected analysis value is missed")] = False,
    figures: Annotated[
        bool, typer.Option(help="also simulate and write one figure per controller type, with the linearised model's "
                                "force where it applies (the direct force schemes; a note says where it does not)")
    ] = False,
    out: OutFolder = None,
    force: ForceOverwrite = False,
    verify: Annotated[
        bool, typer.Option(help="also simulate each case and report how well the predicted equilibrium agrees")
    ] = False,
    set_: SetOption = None,
) -> None:
    """Analyse a scenario without simulating: poles, ω_n, ζ, equilibria, sampled stability limit.

    With ``--figures`` the scenario is also simulated and one figure per controller type is
    written (like the chapter's Figs. 9.9–9.11), the linearised contact force overlaid for the
    direct force schemes (a note names each figure drawn without it), in ``--out``/NAME as ``run``
    writes its files: never over earlier files (the next NAME-2, ... by default, said in a note;
    ``--force`` overwrites).
    """
    from ..errors import ForceControlError

    try:
        from ..scenarios import load_scenario
        from ..scenarios.report import analyze_scenario

        if verify:
            compile_notice()
        sets = parse_sets(set_)
        scn, set_notes = apply_sets(load_scenario(scenario), sets)
        if not figures:  # else the figures' run says them (plot_scheme_figures' notes)
            from ..scenarios.model import unused_key_notes

            set_notes = [*set_notes, *(text for _, text, _ in unused_key_notes(scn.cases, scn.source))]
        with busy(f"analysing {scn.name}" + (f": simulating its {len(scn.cases)} case(s) to verify (compiling on a first "
                                             "run)" if verify else ""), quiet=json_out or not verify):
            report = analyze_scenario(scn, verify=verify)
        report["set"] = sets  # the keys --set changed (in every case), {} when none
        if figures:
            from ..scenarios.report import plot_scheme_figures

            compile_notice()

            folder, folder_note = prepare_output(out, _slug(report["scenario"]), force, ctx)
            figure_notes: list[str] = [folder_note] if folder_note else []
            with busy(f"simulating {scn.name} for its figures", quiet=json_out):
                report["files"] = [str(p) for p in plot_scheme_figures(scn, folder, notes=figure_notes)]
            set_notes = [*set_notes, *figure_notes]
        elif out is not None or force:
            set_notes = [*set_notes, f"{'--out' if out is not None else '--force'} is for the figures' files: "
                                     "nothing is written without --figures"]
    except ForceControlError as exc:
        _fail(exc)
    for text in set_notes:
        say_note(text)  # one line each, however long (a pipe or a file has no width to wrap at)
    if set_notes:
        report["notes"] = set_notes
    for line in skip_notes(report):  # what was not analysed or verified, on stderr whatever the output
        say_note(line)
    for line in sampled_warnings(report):  # a sampled loop that cannot settle, on stderr whatever the output
        say_warning(line)
    if json_out:
        print_json(report)
    else:
        _print_tables(report)
    if check and not report["all_checks_pass"]:
        raise typer.Exit(code=1)


def format_value(v: Any) -> str:
    """A table cell of an analysis quantity: a number to 6 significant digits, a vector (a mode's
    direction) as ``[a, b, …]`` of those, a boolean as yes/no, None as ``-``."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(format_value(x) for x in v) + "]"
    if isinstance(v, (int, float)):
        return f"{v:.6g}"
    return str(v)


def say_warning(text: str) -> None:
    """Print ``warning: ...`` on stderr, one line however long (as :func:`say_note`)."""
    from .safe import escape

    err_console.print(f"[yellow]warning:[/] {escape(text)}", highlight=False, soft_wrap=True)


def sampled_warnings(report: dict[str, Any]) -> list[str]:
    """The text of each case's ``sampled-unstable`` warning (a sampled loop with a spectral radius >= 1)."""
    return [w["text"] for case in report["cases"] for w in case.get("warnings", []) if w.get("kind") == "sampled-unstable"]


def skip_notes(report: dict[str, Any]) -> list[str]:
    """One line per case for each thing not analysed or not verified, with the reason (as the JSON has it)."""
    out = []
    for case in report["cases"]:
        label = case["label"]
        ver = case.get("verification")
        if case.get("analysis_skipped"):
            out.append(f"{label}: {case['analysis_skipped']}" + ("" if ver is None else " (so nothing is verified)"))
        if case.get("sampled_loop_skipped"):
            out.append(f"{label}: {case['sampled_loop_skipped']}")
        for c in case["checks"]:
            if c.get("reason"):
                out.append(f"{label}: expected '{c['metric']}' not checked: {c['reason']}")
        if ver is None:
            continue
        if ver.get("skipped"):
            if not case.get("analysis_skipped"):  # else said above
                out.append(f"{label}: not verified: {ver['skipped']}")
            continue
        if ver.get("transient_skipped"):
            out.append(f"{label}: transient not verified: {ver['transient_skipped']}")
        for name, reason in ver.get("unverified", {}).items():
            out.append(f"{label}: {name} not verified: {reason}")
    return out


def _print_tables(report: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    from ..scenarios.units import with_unit
    from .safe import escape

    console = Console(width=None if sys.stdout.isatty() else 132)
    console.print(f"[bold]{escape(report['title'] or report['scenario'])}[/]")
    for key, value in report.get("set", {}).items():
        console.print(f"set: {escape(key)} = {escape(json.dumps(value))}", highlight=False)
    for case in report["cases"]:
        expected = {c["metric"].split(".", 1)[1]: c for c in case["checks"]}
        unstable = [w for w in case.get("warnings", []) if w.get("kind") == "sampled-unstable"]
        not_reached = {k for w in unstable for k in w.get("quantities", [])}  # marked † in the table
        title = f"{case['label']} ({case['controller']})" + (" — sampled loop UNSTABLE" if unstable else "")
        t = Table(title=escape(title), title_justify="left")
        for col in ("quantity", "predicted", "expected", "tolerance", ""):
            t.add_column(col, justify="left" if col == "quantity" else "right")
        for k in list(case["analysis"]) + [k for k in expected if k not in case["analysis"]]:
            c = expected.get(k)
            t.add_row(
                escape(with_unit(k)) + (" †" if k in not_reached else ""), format_value(case["analysis"].get(k)),
                "" if c is None else format_value(c["expected"]),
                "" if c is None or c["tolerance"] is None else f"±{c['tolerance']:.3g}",
                "" if c is None else ("[green]ok[/]" if c["ok"] else "[red]MISSED[/]"),
            )
        if not case["analysis"]:
            t.add_row(escape(f"(no analysis: {case.get('analysis_skipped') or 'none applies to this case'})"), "", "", "", "")
        console.print(t)
        for w in unstable:
            along = f" along {', '.join(w['axes'])}" if w["axes"] else ""
            console.print(f"[red]sampled loop unstable{escape(along)}:[/] spectral radius "
                          f"{format_value(max(w['spectral_radius'], w.get('end_spectral_radius') or 0.0))} >= 1; "
                          "† marks the continuous model's values, which it does not reach", highlight=False)
        ver = case.get("verification")
        if ver is not None:
            _print_verification(console, ver)
    for f in report.get("files", []):
        console.print(f"figure: {f}")


def _print_verification(console: Any, ver: dict[str, Any]) -> None:
    from rich.table import Table

    from ..scenarios.units import with_unit
    from .safe import escape

    if ver.get("skipped"):
        console.print(f"[yellow]not verified:[/] {escape(ver['skipped'])}", highlight=False)
        return
    vt = Table(title="predicted equilibrium against a simulation of the case", title_justify="left")
    for col in ("quantity", "predicted", "simulated", "difference", ""):
        vt.add_column(col, justify="left" if col == "quantity" else "right")
    for k, v in ver["quantities"].items():
        vt.add_row(escape(with_unit(k)), format_value(v["predicted"]), format_value(v["simulated"]),
                   f"{100 * v['relative_difference']:.3f} %",
                   "[green]agrees[/]" if v["agrees"] else "[red]differs[/]")
    tr = ver.get("transient")
    if tr is not None:
        vt.add_row(f"contact force at {len(tr['times'])} times ≤ {tr['times'][-1]:g} s", "linear model",
                   "", f"{100 * tr['difference_over_peak']:.3f} % of peak",
                   "[green]agrees[/]" if tr["agrees"] else "[red]differs[/]")
    else:
        vt.add_row("contact-force transient", "-", "-", "", "[yellow]not verified[/]")
    for k in ver.get("unverified", {}):
        vt.add_row(k, "-", "-", "", "[yellow]not verified[/]")
    console.print(vt)
    if ver.get("transient_skipped"):
        console.print(f"[yellow]transient not verified:[/] {escape(ver['transient_skipped'])}", highlight=False)
    for k, reason in ver.get("unverified", {}).items():
        console.print(f"[yellow]{escape(k)} not verified:[/] {escape(reason)}", highlight=False)
    if ver["warning"]:
        console.print(f"[yellow]warning:[/] {escape(ver['warning'])}", highlight=False)
