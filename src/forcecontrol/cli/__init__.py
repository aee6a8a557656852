"""The ``forcecontrol`` command line: one module per command, the only importer of typer and rich.

``forcecontrol.cli.app`` is the typer application (the console script); each command module
registers its command on it when imported here.
"""

from __future__ import annotations

from . import analyze, calibrate, compare, compare_trace, convert, design, replay, report, sweep, task, tune
from .app import app, main

app.command("analyze")(analyze.analyze_command)
app.command("task")(task.task_command)
app.command("sweep")(sweep.sweep_command)
app.command("compare")(compare.compare_command)
app.command("calibrate")(calibrate.calibrate_command)
app.command("calibrate-plan")(calibrate.calibrate_plan_command)
app.command("replay")(replay.replay_command)
app.command("compare-trace")(compare_trace.compare_trace_command)
app.command("convert")(convert.convert_command)
app.command("design")(design.design_command)
app.command("tune")(tune.tune_command)
app.command("report")(report.report_command)

__all__ = ["app", "main"]
