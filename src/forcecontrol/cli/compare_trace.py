"""``forcecontrol compare-trace SIM_OR_SCENARIO RECORDED``: a simulated trace against a recorded one."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from .app import ForceOverwrite, JsonOut, OutFolder, _fail, _slug, compile_notice, console, prepare_output, print_json, say_note
from .replay import (
    DEFAULT_JOINT_TOPIC,
    DEFAULT_WRENCH_TOPIC,
    CaseLabel,
    JointNames,
    JointTopic,
    MaxGap,
    RecordedLog,
    RecordFormat,
    Stamps,
    WrenchSense,
    WrenchTopic,
    is_ros_log,
    pick_case,
    read_log,
    time_option,
)

__all__ = ["compare_trace_command"]

_DATA_SUFFIXES = (".csv", ".parquet", ".pq", ".mcap", ".db3")


def _simulated(
    source: str, case: str | None, fmt: RecordFormat, args: tuple[str, str, str], joint_names: str | None = None,
    stamps: str = "header",
) -> tuple[Any, str, int, str, Any]:
    """The simulated trace: a data file as it is, or a scenario's case simulated now; its name, task dimension, the
    stem of its output folder (the file's stem or the scenario's name; a case label such as 'k = 1e4 N/m' is no path)
    and the scenario's robot (None for a data file)."""
    from ..scenarios import load_scenario
    from ..sim.simulation import simulate

    p = Path(source)
    if p.suffix.lower() in _DATA_SUFFIXES or (p.is_dir() and (p / "metadata.yaml").exists()):
        ros = is_ros_log(p, fmt)  # a table beside a recorded bag takes neither option
        rec = read_log(p, fmt, 6, *args, **({"joint_names": joint_names, "stamps": stamps} if ros else {}))
        return rec, str(p), rec.m, p.stem, None
    scn = load_scenario(source)
    spec, parts = pick_case(scn, case)
    res = simulate(parts["robot"], parts["environment"], parts["controller"], parts["reference"], q0=parts["q0"],
                   qd0=parts["qd0"], duration=parts["duration"], sensor=parts["sensor"], substeps=parts["substeps"],
                   label=spec.label)
    return res, f"{scn.name} ({spec.label})", int(parts["robot"].task_dim), scn.name, parts["robot"]


def compare_trace_command(
    ctx: typer.Context,
    simulated: Annotated[str, typer.Argument(help="a scenario (simulated now) or a data file of a simulated trace")],
    recorded: RecordedLog,
    format: Annotated[RecordFormat, typer.Option("--format", help="format of RECORDED (default: from the path)")] = (
        RecordFormat.auto
    ),
    case: CaseLabel = None,
    max_shift: Annotated[float, typer.Option(callback=time_option(">= 0"),
                                             help="largest time shift searched to align the traces [s], >= 0")] = 0.1,
    out: OutFolder = None,
    joint_topic: JointTopic = DEFAULT_JOINT_TOPIC,
    wrench_topic: WrenchTopic = DEFAULT_WRENCH_TOPIC,
    joint_names: JointNames = None,
    stamps: Stamps = "header",
    wrench_sense: WrenchSense = "by-end-effector",
    max_gap: MaxGap = None,
    json_out: JsonOut = False,
    force: ForceOverwrite = False,
) -> None:
    """Compare a simulated trace with a recorded one: time shift, RMS and max force/position errors, a figure."""
    from rich.table import Table

    from ..errors import ForceControlError
    from ..realarm.io import RecordedRun
    from ..realarm.replay import compare_traces, model_joint_names

    compile_notice()
    args = (joint_topic, wrench_topic, wrench_sense)
    try:
        sim, name, m, stem, robot = _simulated(simulated, case, format, args, joint_names, stamps)
        joints = None if robot is None else model_joint_names(robot)
        rec = read_log(recorded, format, m, *args, joint_names=joint_names, stamps=stamps, prefer_joints=joints)
        if robot is not None:  # a JointState's order need not be the model's
            rec = rec.in_joint_order(joints)
        if isinstance(sim, RecordedRun) and sim.joint_names != rec.joint_names:
            rec = rec.in_joint_order(sim.joint_names)
        cmp = compare_traces(sim, rec, max_shift=max_shift, robot=robot, max_gap=max_gap)
        folder, note = prepare_output(out, _slug(f"{stem}-compare-trace"), force, ctx)
        log_notes = list(rec.metadata.get("notes", []))
        for text in [*log_notes, note]:
            say_note(text)
        figure = cmp.plot(folder / "compare-trace.png")
    except (ForceControlError, ImportError) as exc:
        _fail(exc)
        return
    units = {"shift": "s", "position_error_rms": "rad", "position_error_max": "rad", "force_error_rms": "N",
             "force_error_max": "N"}
    report = {"simulated": name, "recorded": str(recorded), "samples": int(cmp.t.size), "metrics": cmp.metrics,
              "files": {"figure": str(figure)}, "units": {k: u for k, u in units.items() if k in cmp.metrics}}
    if note or log_notes:
        report["notes"] = [*log_notes, *([note] if note else [])]
    if json_out:
        print_json(report)
        return
    t = Table(title=f"{name} against {recorded}", title_justify="left")
    t.add_column("metric")
    t.add_column("value", justify="right")
    for k, v in cmp.metrics.items():
        t.add_row(k, f"{v:.6g} {units.get(k, '')}")
    console.print(t)
    console.print(f"figure: {figure}", markup=False, highlight=False)
