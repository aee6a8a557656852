"""The ``forcecontrol report`` command (registered in :mod:`forcecontrol.cli`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

__all__ = ["report_command"]


def report_command(
    source: Annotated[Path, typer.Argument(
        help="a run's output folder (what 'forcecontrol run NAME' writes: its logs are kept by default) or a sweep "
             "table / its folder")],
    out: Annotated[Path | None, typer.Option(  # noqa: UP007 - typer needs Optional
        help="the HTML file (default: report.html in the folder, or SWEEP.html beside the table)")] = None,
    force: Annotated[bool, typer.Option("--force", help="overwrite an existing report file")] = False,
) -> None:
    """Write one self-contained interactive HTML report (plotly, no network needed to view it).

    A run folder gives the time responses of every case (and embeds its 3-D views, 'run --view3d'); a sweep
    gives maps of the metrics over the swept parameters with the analytic sampled-loop stability boundary
    where the analysis has one.
    Needs the 'workbench' extra (plotly).
    """
    from ..errors import ForceControlError, OutputError
    from ..workbench import require
    from .app import _fail, console
    from .busy import busy
    from .safe import terminal_safe

    try:
        require("plotly")
    except ImportError as exc:
        _fail(exc)
    from ..workbench.report import default_report_path, write_report

    try:
        path = out or default_report_path(source)
        if path.exists() and not force:
            raise OutputError(f"{str(path)!r} already exists; pass --force to overwrite it, or --out to write elsewhere")
        with busy(f"writing the report of {source} (plotly, every sample of every case)"):
            written = write_report(source, path)
    except ForceControlError as exc:
        _fail(exc)
        return
    console.print(terminal_safe(f"report: {written}"), markup=False, highlight=False)
