"""``forcecontrol replay SCENARIO DATA``: a scenario's controller run over a recorded log."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer

from .app import ForceOverwrite, JsonOut, OutFolder, _fail, _slug, compile_notice, console, prepare_output, print_json, say_note
from .busy import busy
from .overrides import SetOption, apply_sets, parse_sets
from .safe import terminal_safe

__all__ = ["replay_command", "RecordFormat", "read_log", "pick_case"]

#: options shared by the commands that read a recorded log (replay, compare-trace).
JointTopic = Annotated[str, typer.Option(help="bags/MCAP: sensor_msgs/JointState topic")]
WrenchTopic = Annotated[str, typer.Option(help="bags/MCAP: geometry_msgs/WrenchStamped topic ('' for none)")]
WrenchSense = Annotated[str, typer.Option(help="what the log's wrench is: by-end-effector (h_e) or on-end-effector")]
RecordedLog = Annotated[Path, typer.Argument(help="recorded log: .csv, .parquet, a ROS 2 bag folder or an .mcap file")]
CaseLabel = Annotated[str | None, typer.Option(help="the scenario's case (label; the first by default)")]


#: units of replay's JSON fields and metrics (the force error's norm takes moments' N m as N in 6-D)
REPLAY_UNITS = {"period": "s", "torque_difference_rms": "N m", "torque_difference_max": "N m", "force_error_rms": "N",
                "force_error_max": "N"}


class RecordFormat(str, Enum):
    auto = "auto"
    csv = "csv"
    parquet = "parquet"
    bag = "bag"
    mcap = "mcap"


def pick_case(scn: Any, label: str | None) -> tuple[Any, dict[str, Any]]:
    """The scenario's case named ``label`` (the first by default) and its built parts."""
    from ..errors import ScenarioError
    from ..scenarios import build_case

    labels = [c.label for c in scn.cases]
    if label is None:
        case = scn.cases[0]
    elif label in labels:
        case = scn.cases[labels.index(label)]
    else:
        raise ScenarioError(f"scenario {scn.name!r} has no case {label!r}; its cases are {labels}")
    return case, build_case(case, where=f"{scn.source}: case {case.label!r}")


def read_log(path: Path, fmt: RecordFormat, m: int, joint_topic: str, wrench_topic: str, wrench_sense: str) -> Any:
    """Read a recorded log in any format; bags and MCAP keep the task space's m wrench components."""
    from ..realarm.io import read_recording

    format_ = None if fmt is RecordFormat.auto else fmt.value
    kwargs: dict[str, Any] = {"wrench_sense": wrench_sense}
    suffix = path.suffix.lower()
    is_ros = format_ in ("bag", "mcap") or (format_ is None and (suffix in (".mcap", ".db3") or path.is_dir()))
    if is_ros:
        kwargs.update(joint_topic=joint_topic, wrench_topic=wrench_topic or None, wrench_components=m)
    return read_recording(path, format_, **kwargs)


def replay_command(
    scenario: Annotated[str, typer.Argument(help="built-in name or .toml file: its controller, robot and reference")],
    data: RecordedLog,
    format: Annotated[RecordFormat, typer.Option("--format", help="format of DATA (default: from the path)")] = RecordFormat.auto,
    case: CaseLabel = None,
    out: OutFolder = None,
    joint_topic: JointTopic = "/joint_states",
    wrench_topic: WrenchTopic = "/force_torque_sensor_broadcaster/wrench",
    wrench_sense: WrenchSense = "by-end-effector",
    json_out: JsonOut = False,
    force: ForceOverwrite = False,
    set_: SetOption = None,
) -> None:
    """Run a scenario's controller over a recorded log: the torques and force errors it would have produced."""
    from rich.table import Table

    from ..errors import ForceControlError
    from ..realarm.replay import replay
    from ..scenarios import load_scenario

    compile_notice()
    try:
        with busy(f"loading {scenario}", quiet=json_out) as step:  # a long log takes seconds at each step
            sets = parse_sets(set_)
            scn, set_notes = apply_sets(load_scenario(scenario), sets)
            spec, parts = pick_case(scn, case)
            robot = parts["robot"]
            step(f"reading {data}")
            rec = read_log(data, format, int(robot.task_dim), joint_topic, wrench_topic, wrench_sense)
            step(f"replaying {len(rec.t)} samples (compiling the controller's law on a first run)")
            result = replay(parts["controller"], rec, parts["reference"], robot)
            folder, note = prepare_output(out, _slug(f"{scn.name}-replay"), force)
            step(f"writing the table and the figure of {len(rec.t)} samples")
            stem = _slug(spec.label)
            table = folder / f"{stem}.csv"
            result.to_pandas().to_csv(table, index=False)
            figure = result.plot(folder / f"{stem}.png")
        for text in [*set_notes, note]:
            say_note(text)
    except (ForceControlError, ImportError) as exc:
        _fail(exc)
        return
    report = {"scenario": scn.name, "case": spec.label, "data": str(data), "samples": int(result.t.size),
              "period": result.metadata["period"], "metrics": result.metrics(),
              "files": {"table": str(table), "figure": str(figure)}, "units": REPLAY_UNITS, "set": sets}
    if note or set_notes:
        report["notes"] = [*set_notes, *([note] if note else [])]
    if json_out:
        print_json(report)
        return
    t = Table(title=f"{scn.name} ({spec.label}) replayed over {data}", title_justify="left")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_column("unit")
    t.add_row("samples", f"{result.t.size} at Ts = {result.metadata['period']:.6g} s", "")
    for k, v in report["metrics"].items():
        t.add_row(k, f"{v:.6g}", REPLAY_UNITS.get(k, ""))
    console.print(t)
    for k, v in report["files"].items():
        console.print(terminal_safe(f"{k}: {v}"), markup=False, highlight=False)
