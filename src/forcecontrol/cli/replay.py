"""``forcecontrol replay SCENARIO DATA``: a scenario's controller run over a recorded log."""

from __future__ import annotations

from collections.abc import Sequence
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer

from .app import (
    ForceOverwrite,
    JsonOut,
    OutFolder,
    _fail,
    _slug,
    comma_numbers,
    compile_notice,
    console,
    prepare_output,
    print_json,
    say_note,
)
from .busy import busy
from .overrides import SetOption, apply_sets, parse_sets
from .safe import terminal_safe

__all__ = ["replay_command", "RecordFormat", "SenseChoice", "read_log", "is_ros_log", "pick_case", "sensor_pose_option"]

#: options shared by the commands that read a recorded log (replay, compare-trace).
JointTopic = Annotated[str, typer.Option(help="bags/MCAP: sensor_msgs/JointState topic")]
WrenchTopic = Annotated[str, typer.Option(help="bags/MCAP: geometry_msgs/WrenchStamped topic ('' for none)")]
Stamps = Annotated[str, typer.Option(
    "--stamps", help="bags/MCAP: time from the messages' header stamps ('header') or the recorder's receive times "
    "('receive': for drivers that leave header.stamp empty)")]
JointNames = Annotated[str | None, typer.Option(
    "--joint-names", help="bags/MCAP: the joints to read, comma-separated (default: the topic's largest set of joints; "
    "a gripper's JointStates on the same topic are passed over)")]
WrenchSense = Annotated[str, typer.Option(help="what the log's wrench is: by-end-effector (h_e) or on-end-effector")]
RecordedLog = Annotated[Path, typer.Argument(help="recorded log: .csv, .parquet, a ROS 2 bag folder or an .mcap file")]
CaseLabel = Annotated[str | None, typer.Option(help="the scenario's case (label; the first by default)")]


def time_option(bound: str = "") -> Any:
    """A callback checking a time option [s]: finite (click's float type lets nan and inf through) and, with ``bound``
    ``">= 0"`` or ``"> 0"``, at least or above zero; None (an option not given) passes."""
    import math

    def check(value: float | None) -> float | None:
        ok = value is None or (math.isfinite(value) and (value >= 0.0 if bound == ">= 0" else value > 0.0 if bound else True))
        if not ok:
            raise typer.BadParameter(f"must be a finite time{' ' + bound if bound else ''} [s]; got {value!r}")
        return value

    return check


MaxGap = Annotated[float | None, typer.Option(
    "--max-gap", callback=time_option("> 0"), help="largest gap between two logged samples bridged by interpolation [s] "
    "(default: 10 periods); a larger one inside the window is refused")]
Start = Annotated[float | None, typer.Option(
    "--start", callback=time_option(), help="replay from this time of the log [s] (its time column; bags/MCAP: from the "
    "first message) (default: where every stream has data)")]
End = Annotated[float | None, typer.Option(
    "--end", callback=time_option(), help="replay up to this time of the log [s] (default: where a stream ends)")]


#: units of replay's JSON fields and metrics (the force error's norm takes moments' N m as N in 6-D)
REPLAY_UNITS = {"period": "s", "window": "s", "max_gap": "s",
                "torque_difference_rms": "N m", "torque_difference_max": "N m", "force_error_rms": "N",
                "force_error_max": "N"}


class RecordFormat(str, Enum):
    auto = "auto"
    csv = "csv"
    parquet = "parquet"
    bag = "bag"
    mcap = "mcap"
    ur_rtde = "ur-rtde"
    franka = "franka"


class SenseChoice(str, Enum):
    on_robot = "on-robot"
    by_robot = "by-robot"


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


#: the topics a ROS bag or MCAP file is read from unless --joint-topic / --wrench-topic say otherwise
DEFAULT_JOINT_TOPIC = "/joint_states"
DEFAULT_WRENCH_TOPIC = "/force_torque_sensor_broadcaster/wrench"


def is_ros_log(path: Path, fmt: RecordFormat) -> bool:
    """A ROS 2 bag or an MCAP file (by --format, else by the path): what the topic, joint and stamp options read."""
    if fmt is not RecordFormat.auto:
        return fmt.value in ("bag", "mcap")
    return path.suffix.lower() in (".mcap", ".db3") or path.is_dir()


def read_log(
    path: Path, fmt: RecordFormat, m: int, joint_topic: str, wrench_topic: str, wrench_sense: str, sense: str | None = None,
    joint_names: str | None = None, stamps: str = "header", prefer_joints: Sequence[str] | None = None,
) -> Any:
    """Read a recorded log in any format; bags and MCAP keep the task space's m wrench components, and read
    ``prefer_joints`` (the model's joints) when their joint-state topic holds them all and ``joint_names`` is not given.

    A UR RTDE or libfranka recording (``--format ur-rtde|franka``, or told from its columns) is read
    with the vendor's documented wrench sense; ``sense`` (``on-robot``/``by-robot``) overrides it.
    """
    from ..errors import ParameterError
    from ..realarm.io import read_recording

    format_ = None if fmt is RecordFormat.auto else fmt.value
    kwargs: dict[str, Any] = {"wrench_sense": wrench_sense}
    if is_ros_log(path, fmt):
        if sense is not None:
            raise ParameterError("--sense overrides a UR RTDE or libfranka recording's sense; a ROS bag/MCAP wrench's sense is "
                                 "--wrench-sense")
        kwargs.update(joint_topic=joint_topic, wrench_topic=wrench_topic or None, wrench_components=m, stamps=stamps,
                      prefer_joint_names=prefer_joints)
        if joint_names is not None:
            names = [n.strip() for n in joint_names.split(",")]
            if not all(names) or len(set(names)) != len(names):
                raise ParameterError(f"--joint-names must be distinct joint names separated by commas; got {joint_names!r}")
            kwargs["joint_names"] = names
    else:
        if (joint_topic, wrench_topic, joint_names, stamps) != (DEFAULT_JOINT_TOPIC, DEFAULT_WRENCH_TOPIC, None, "header"):
            given = [o for o, v, d in (("--joint-topic", joint_topic, DEFAULT_JOINT_TOPIC),
                                       ("--wrench-topic", wrench_topic, DEFAULT_WRENCH_TOPIC),
                                       ("--joint-names", joint_names, None), ("--stamps", stamps, "header")) if v != d]
            raise ParameterError(f"{' and '.join(given)} {'select' if len(given) > 1 else 'selects'} what is read from a ROS "
                                 f"bag or MCAP file; {path.name} is not one (it would be ignored)")
        if sense is not None:
            kwargs["sense"] = sense
    rec = read_recording(path, format_, **kwargs)
    if rec.wrench is not None and rec.m > m and rec.metadata.get("format") in ("ur-rtde", "franka"):
        from dataclasses import replace

        rec = replace(rec, wrench=rec.wrench[:, :m], metadata={**rec.metadata, "notes": [
            *rec.metadata.get("notes", []), f"the 6-D wrench cut to the task space's first {m} components"]})
    return rec


def sensor_pose_option(text: str | None, parent: str, child: str) -> Any:
    """``--sensor-pose``: 6 numbers ``x,y,z,roll,pitch,yaw`` [m, rad] (R = Rz(yaw) Ry(pitch) Rx(roll), URDF's rpy) or 16
    numbers (a 4x4 homogeneous matrix, row by row) → ``Transform`` of the sensor frame in the end-effector frame."""
    import numpy as np

    from ..errors import ParameterError
    from ..spatial import Transform

    if text is None:
        return None
    v = comma_numbers("--sensor-pose", text, "numbers")
    if v.size == 6 and np.all(np.isfinite(v)):
        from scipy.spatial.transform import Rotation

        return Transform(Rotation.from_euler("xyz", v[3:]).as_matrix(), v[:3], parent=parent, child=child)
    if v.size == 16 and np.all(np.isfinite(v)):
        T = v.reshape(4, 4)
        if np.abs(T[3] - [0, 0, 0, 1]).max() > 1e-9:
            raise ParameterError(f"--sensor-pose as 16 numbers is a 4x4 matrix row by row, last row 0,0,0,1; got {T[3].tolist()}")
        return Transform(T[:3, :3], T[:3, 3], parent=parent, child=child)
    raise ParameterError(f"--sensor-pose must be 6 numbers x,y,z,roll,pitch,yaw [m, rad] or 16 (a 4x4 matrix row by row), "
                         f"finite; got {v.size}: {text!r}")


def _sensor_pose(text: str | None, rec: Any, robot: Any) -> Any:
    """The ``--sensor-pose`` Transform for this log (parent: the robot's end-effector frame, child: the log's wrench frame)."""
    if text is None:
        return None
    from ..errors import ParameterError

    if rec.wrench is None or rec.wrench_frame == "base":
        raise ParameterError(f"--sensor-pose places a wrench recorded in a sensor frame; this log's wrench is "
                             f"{'absent' if rec.wrench is None else 'in the base frame'}, so it would be ignored")
    frame = getattr(robot, "frame", None)
    return sensor_pose_option(text, frame if isinstance(frame, str) else "end-effector", rec.wrench_frame)


def replay_command(
    ctx: typer.Context,
    scenario: Annotated[str, typer.Argument(help="built-in name or .toml file: its controller, robot and reference")],
    data: RecordedLog,
    format: Annotated[RecordFormat, typer.Option("--format", help="format of DATA (default: from the path)")] = RecordFormat.auto,
    case: CaseLabel = None,
    out: OutFolder = None,
    joint_topic: JointTopic = DEFAULT_JOINT_TOPIC,
    wrench_topic: WrenchTopic = DEFAULT_WRENCH_TOPIC,
    joint_names: JointNames = None,
    stamps: Stamps = "header",
    wrench_sense: WrenchSense = "by-end-effector",
    sense: Annotated[
        SenseChoice | None,
        typer.Option("--sense", help="UR RTDE/libfranka logs: override the vendor's documented wrench sense"),
    ] = None,
    sensor_pose: Annotated[
        str | None,
        typer.Option("--sensor-pose", help="the wrench frame's pose on the end-effector: x,y,z,roll,pitch,yaw [m, rad] or "
                     "16 numbers (4x4, row by row)"),
    ] = None,
    start: Start = None,
    end: End = None,
    max_gap: MaxGap = None,
    json_out: JsonOut = False,
    force: ForceOverwrite = False,
    set_: SetOption = None,
) -> None:
    """Run a scenario's controller over a recorded log: the torques and force errors it would have produced."""
    from rich.table import Table

    from ..errors import ForceControlError
    from ..realarm.replay import model_joint_names, replay
    from ..scenarios import load_scenario

    compile_notice()
    try:
        with busy(f"loading {scenario}", quiet=json_out) as step:  # a long log takes seconds at each step
            sets = parse_sets(set_)
            scn, set_notes = apply_sets(load_scenario(scenario), sets)
            spec, parts = pick_case(scn, case)
            robot = parts["robot"]
            step(f"reading {data}")
            joints = model_joint_names(robot)
            rec = read_log(data, format, int(robot.task_dim), joint_topic, wrench_topic, wrench_sense,
                           None if sense is None else sense.value, joint_names, stamps, joints)
            rec = rec.in_joint_order(joints)  # a JointState's order need not be the model's
            X = _sensor_pose(sensor_pose, rec, robot)
            step(f"replaying {len(rec.t)} samples (compiling the controller's law on a first run)")
            result = replay(parts["controller"], rec, parts["reference"], robot, sensor_pose=X, max_gap=max_gap, start=start,
                            end=end)
            folder, note = prepare_output(out, _slug(f"{scn.name}-replay"), force, ctx)
            step(f"writing the table and the figure of {len(rec.t)} samples")
            stem = _slug(spec.label)
            table = folder / f"{stem}.csv"
            result.to_pandas().to_csv(table, index=False)
            figure = result.plot(folder / f"{stem}.png")
        log_notes = list(rec.metadata.get("notes", []))
        first = float(result.metadata["time_origin"] - rec.time_origin)  # the window's start in the log's time
        if start is not None and first > float(rec.t[0]) + 0.5 * result.metadata["period"]:
            log_notes.append(f"the controller starts from its reset state at t = {first:.6g} s of the log (--start), not "
                             "from the state it had there in the recorded run: a controller with a state of its own "
                             "(admittance's compliant frame, an integral action) gives other torques at first")
        for text in [*set_notes, *log_notes, note]:
            say_note(text)
    except (ForceControlError, ImportError) as exc:
        _fail(exc)
        return
    report = {"scenario": scn.name, "case": spec.label, "data": str(data), "samples": int(result.t.size),
              "period": result.metadata["period"], "metrics": result.metrics(),
              "window": [first, first + float(result.t[-1])],
              "max_gap": result.metadata["max_gap"],
              "files": {"table": str(table), "figure": str(figure)}, "units": REPLAY_UNITS, "set": sets,
              "recording": {"format": rec.metadata.get("format"), "joint_names": list(rec.joint_names),
                            "wrench_frame": rec.wrench_frame,
                            "wrench_point": rec.wrench_point, "wrench_sense": rec.wrench_sense,
                            "sensor_pose": None if X is None else {"rotation": X.rotation.tolist(),
                                                                   "translation": X.translation.tolist(),
                                                                   "parent": X.parent, "child": X.child}}}
    if note or set_notes or log_notes:
        report["notes"] = [*set_notes, *log_notes, *([note] if note else [])]
    if json_out:
        print_json(report)
        return
    t = Table(title=f"{scn.name} ({spec.label}) replayed over {data}", title_justify="left")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_column("unit")
    t.add_row("samples", f"{result.t.size} at Ts = {result.metadata['period']:.6g} s", "")
    t.add_row("window", f"{report['window'][0]:.6g} to {report['window'][1]:.6g}", "s")
    for k, v in report["metrics"].items():
        t.add_row(k, f"{v:.6g}", REPLAY_UNITS.get(k, ""))
    console.print(t)
    for k, v in report["files"].items():
        console.print(terminal_safe(f"{k}: {v}"), markup=False, highlight=False)
