"""The ``forcecontrol task NAME`` command (registered in :mod:`forcecontrol.cli`).

Prints a named task like the chapter's Tables 9.1–9.3: the natural and artificial constraints,
then S_f and S_v (and, on request, their pseudo-inverses) in the constraint, base or
end-effector frame.
"""

from __future__ import annotations

import sys
from enum import Enum
from typing import TYPE_CHECKING, Annotated, Any

import typer

from .app import JsonOut, _fail, print_json

if TYPE_CHECKING:
    import numpy as np

__all__ = ["task_command", "format_matrix", "task_report", "MAX_TASK_TIME"]

#: the largest |--time| accepted [s] (about 32 years): a moving frame's angle beyond it means nothing
MAX_TASK_TIME = 1e9


class FrameChoice(str, Enum):
    constraint = "constraint"
    base = "base"


def _num(v: float) -> str:
    if abs(v) < 1e-12:
        return "0"
    r = round(v)
    if abs(v - r) < 1e-12:
        return str(int(r))
    return f"{v:.4g}"


def format_matrix(name: str, M: np.ndarray) -> str:
    """A matrix as the chapter prints it, in brackets, one row per line, with its name."""
    import numpy as np  # not at start-up: `forcecontrol --help` does not need NumPy

    cells = [[_num(float(v)) for v in row] for row in np.atleast_2d(M)]
    width = max((len(c) for row in cells for c in row), default=1)
    lines = ["  ".join(c.rjust(width) for c in row) for row in cells]
    pad = " " * (len(name) + 3)
    out = []
    for i, line in enumerate(lines):
        left = "⎡" if i == 0 else ("⎣" if i == len(lines) - 1 else "⎢")
        right = "⎤" if i == 0 else ("⎦" if i == len(lines) - 1 else "⎥")
        if len(lines) == 1:
            left, right = "[", "]"
        head = f"{name} = " if i == (len(lines) - 1) // 2 else pad
        out.append(f"{head}{left} {line} {right}")
    return "\n".join(out)


def task_report(name: str, frame: str = "constraint", t: float = 0.0, pinv: bool = False) -> dict[str, Any]:
    """The task's table and matrices as plain data (the ``--json`` output)."""
    import math

    from ..errors import ParameterError
    from ..task import SYMBOLS, named_task

    if not isinstance(t, (int, float)) or isinstance(t, bool) or not math.isfinite(t) or abs(t) > MAX_TASK_TIME:
        raise ParameterError(f"time (--time) must be a finite number of seconds of magnitude at most {MAX_TASK_TIME:g}; "
                             f"got {t!r}")
    task = named_task(name)
    sel = task.selection(frame, t)  # type: ignore[arg-type]
    refs = {SYMBOLS[k]: v for k, v in task.references.items()}
    out: dict[str, Any] = {
        "task": task.name,
        "description": task.description,
        "frame": frame,
        "time": t,
        "moving_frame": task.frame.moving,
        "m": task.m,
        "constraints": [{"natural": n, "artificial": a, "reference": refs.get(a)} for n, a in task.table()],
        "S_f": sel.force_selection.tolist(),
        "S_v": sel.velocity_selection.tolist(),
    }
    if pinv:
        out["S_f_pinv"] = sel.force_pinv.tolist()
        out["S_v_pinv"] = sel.velocity_pinv.tolist()
    return out


def task_command(
    name: Annotated[str, typer.Argument(help="task name; 'list' lists them")] = "list",
    frame: Annotated[FrameChoice, typer.Option(help="frame the matrices are expressed in")] = FrameChoice.constraint,
    time: Annotated[float, typer.Option("--time", help="time [s] (for a moving constraint frame)")] = 0.0,
    pinv: Annotated[bool, typer.Option("--pinv", help="also print S_f† and S_v† (9.55), W = I")] = False,
    json_out: JsonOut = False,
) -> None:
    """Print a task's natural and artificial constraints and S_f, S_v, like Tables 9.1–9.3."""
    from rich.console import Console
    from rich.table import Table

    from ..errors import ForceControlError
    from ..task import TASKS, named_task

    console = Console(width=None if sys.stdout.isatty() else 132)
    if name == "list" and (time != time or abs(time) > MAX_TASK_TIME):  # nan, inf, 1e308: refused, as for a task
        from ..errors import ParameterError

        _fail(ParameterError(f"time (--time) must be a finite number of seconds of magnitude at most {MAX_TASK_TIME:g}; "
                             f"got {time!r}"))
    if name == "list":
        table = Table(title="Named tasks (forcecontrol task NAME)")
        table.add_column("name", style="bold")
        table.add_column("description")
        for key in TASKS:
            table.add_row(key, named_task(key).description)
        console.print(table)
        return
    try:
        report = task_report(name, frame.value, time, pinv)
    except ForceControlError as exc:
        _fail(exc)
    if json_out:
        print_json(report)
        return
    console.print(f"[bold]{report['task']}[/]: {report['description']}")
    table = Table(title=f"Natural and artificial constraints (m = {report['m']})", title_justify="left")
    table.add_column("Natural constraints")
    table.add_column("Artificial constraints")
    for row in report["constraints"]:
        art = row["artificial"] + (f" = {row['reference']:g}" if row["reference"] is not None else "")
        table.add_row(row["natural"], art)
    console.print(table)
    where = f"{report['frame']} frame" + (f", t = {time:g} s (moving frame)" if report["moving_frame"] else "")
    console.print(f"Selection matrices, {where}:")
    import numpy as np

    blocks = [format_matrix("S_f", np.array(report["S_f"])), format_matrix("S_v", np.array(report["S_v"]))]
    if pinv:
        blocks += [format_matrix("S_f†", np.array(report["S_f_pinv"])), format_matrix("S_v†", np.array(report["S_v_pinv"]))]
    for b in blocks:
        console.print(b, highlight=False, markup=False)
        console.print()
