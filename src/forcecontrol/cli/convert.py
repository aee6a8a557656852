"""``forcecontrol convert DATA --from CONVENTION --to CONVENTION``: a recorded wrench in another convention.

Reads a recording (CSV, Parquet, ROS 2 bag, MCAP; :func:`forcecontrol.realarm.io.read_recording`),
converts its wrench between the library's convention and a vendor's
(:data:`forcecontrol.realarm.conventions.CONVENTIONS`) and writes a CSV or Parquet table with the
converted columns and a JSON file beside it that records the convention. Conversions between
base-frame conventions need nothing more; those to or from end-effector axes (``franka-K``,
``mujoco``, ``ros-on``, ``ros-by``) or with a flange offset need the end-effector's orientation
at every sample: from a robot model's forward kinematics at the recorded joint positions
(``--robot``), or from the table's ``qx qy qz qw`` columns (the end-effector's orientation in the
base frame, ROS order x, y, z, w).
"""

from __future__ import annotations

from dataclasses import replace
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer

from .app import _fail, console, print_json, say_note
from .replay import RecordedLog, RecordFormat
from .safe import terminal_safe

__all__ = ["convert_command", "convert_report", "RobotName"]

QUATERNION_COLUMNS = ("qx", "qy", "qz", "qw")


class RobotName(str, Enum):
    """Robot models whose forward kinematics give the end-effector's orientation (``none``: use the table's columns)."""

    none = "none"
    chapter_arm = "chapter-arm"
    panda = "panda"
    ur5 = "ur5"


def _parse_offset(text: str | None) -> Any:
    from ..errors import ParameterError

    if text is None:
        return None
    try:
        values = [float(x) for x in text.replace(",", " ").split()]
    except ValueError as exc:
        raise ParameterError(f"--flange-offset must be three numbers 'x,y,z' [m]; got {text!r}") from exc
    if len(values) != 3:
        raise ParameterError(f"--flange-offset must be three numbers 'x,y,z' [m]; got {text!r}")
    return values


def _robot(name: RobotName) -> Any:
    if name is RobotName.chapter_arm:
        from ..robots import CHAPTER_ARM

        return CHAPTER_ARM
    from ..robots import pinocchio as pm

    return pm.panda() if name is RobotName.panda else pm.ur5()


def _table_orientation(path: Path, rows: int) -> Any:
    """The ``qx qy qz qw`` columns of a CSV/Parquet file as rotation matrices, or None without them."""
    import numpy as np
    import pandas as pd

    from ..errors import DimensionError, ParameterError

    suffix = path.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        return None
    df = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
    df.columns = [str(c).strip() for c in df.columns]
    if not all(c in df.columns for c in QUATERNION_COLUMNS):
        return None
    quat = df[list(QUATERNION_COLUMNS)].to_numpy(dtype=np.float64)
    if quat.shape[0] != rows:
        raise DimensionError(f"{path}: {quat.shape[0]} orientation rows for {rows} samples")
    if not np.all(np.isfinite(quat)):
        raise ParameterError(f"{path}: the columns qx qy qz qw contain NaN or inf")
    norms = np.linalg.norm(quat, axis=1)
    if np.abs(norms - 1.0).max() > 1e-6:
        i = int(np.argmax(np.abs(norms - 1.0)))
        raise ParameterError(f"{path}: qx qy qz qw must be unit quaternions; data row {i + 1} has norm {norms[i]:.9g}")
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(quat).as_matrix(), quat


def convert_report(
    data: Path, source: str, target: str, out: Path, *, fmt: RecordFormat = RecordFormat.auto, robot: RobotName = RobotName.none,
    flange_offset: str | None = None, base_frame: str = "base", end_effector_frame: str = "end-effector",
    joint_topic: str = "/joint_states", wrench_topic: str = "/force_torque_sensor_broadcaster/wrench", force: bool = False,
) -> dict[str, Any]:
    """Convert a recording's wrench and write it; the report as plain data (the ``--json`` output).

    Args:
        data: the recording; source, target: convention names; out: the .csv/.parquet to write.
        fmt, robot, flange_offset, base_frame, end_effector_frame, joint_topic, wrench_topic, force:
            as the command's options.

    Returns:
        ``data``, ``from``, ``to`` (conventions), ``samples``, ``components``, ``orientation``
        (where it came from), ``files`` (table and metadata) and ``notes`` (a file ``force``
        replaced that forcecontrol did not write: its own outputs carry a mark
        ``.<name>.forcecontrol-convert.json``).

    Raises:
        ParameterError: an unknown convention, an existing output without ``force``, an
            orientation needed but not available, a file that cannot be read.
    """
    import numpy as np

    from ..errors import ParameterError
    from ..realarm.conventions import convention
    from ..realarm.io import convert_recording, read_recording, write_recording

    src, dst = convention(source), convention(target)
    offset = _parse_offset(flange_offset)
    if out.suffix.lower() not in (".csv", ".parquet", ".pq"):
        raise ParameterError(f"--out must name a .csv or .parquet file; got {str(out)!r}")
    meta_path = out.with_suffix(".json")
    notes = _claim_outputs((out, meta_path), force)
    format_ = None if fmt is RecordFormat.auto else fmt.value
    suffix = data.suffix.lower()
    is_ros = format_ in ("bag", "mcap") or (format_ is None and (suffix in (".mcap", ".db3") or data.is_dir()))
    kwargs: dict[str, Any] = {"wrench_sense": src.sense}
    if is_ros:
        kwargs.update(joint_topic=joint_topic, wrench_topic=wrench_topic)
    else:
        kwargs.update(wrench_frame=end_effector_frame if src.axes == "end-effector" else base_frame)
    rec = read_recording(data, format_, **kwargs)
    if src.axes == "ur-base" and rec.metadata.get("format") == "ur-rtde":
        src = replace(src, axes="base")
        notes.append(f"{data}: the RTDE reader has rotated actual_TCP_force from the controller's base into base_link "
                     f"already; --from {src.name} is taken in base_link axes")
    file_frame = rec.wrench_frame
    if is_ros and src.axes == "base" and file_frame != base_frame:
        raise ParameterError(
            f"{data}: the wrench messages are in frame {file_frame!r}, but --from {src.name} is in base axes "
            f"(--base-frame {base_frame!r}): pick a convention in end-effector axes, or pass --base-frame {file_frame}"
        )
    if is_ros and src.axes == "end-effector" and file_frame == base_frame:
        raise ParameterError(
            f"{data}: the wrench messages are in the base frame {base_frame!r}, but --from {src.name} is in end-effector axes"
        )
    if rec.wrench is None:
        raise ParameterError(f"{data}: has no wrench to convert")
    if rec.t_wrench is not None and not np.array_equal(rec.t_wrench, rec.t):
        rec = rec.resample(float(np.median(np.diff(rec.t))))
    moves = offset is not None and any(v != 0.0 for v in offset) and (src.point == "flange") != (dst.point == "flange")
    needs = src != dst and (src.needs_orientation or dst.needs_orientation or moves)
    rotations, orientation, extra = None, "not needed", None
    if needs:
        if robot is not RobotName.none:
            from ..realarm.replay import end_effector_rotation

            model = _robot(robot)
            if rec.n != model.nq:
                raise ParameterError(f"{data}: {rec.n} joints, but --robot {robot.value} has {model.nq}")
            rotations = np.array([end_effector_rotation(model, q) for q in rec.q])
            orientation = f"forward kinematics of {robot.value} at the recorded q"
        else:
            found = _table_orientation(data, rec.t.size) if not is_ros else None
            if found is None:
                raise ParameterError(
                    f"converting {src.name} → {dst.name} needs the end-effector's orientation at every sample: pass "
                    "--robot (forward kinematics at the recorded q) or give the table qx qy qz qw columns"
                )
            rotations, quat = found
            extra = {c: quat[:, i] for i, c in enumerate(QUATERNION_COLUMNS)}
            orientation = "the table's qx qy qz qw columns"
    converted = convert_recording(rec, src, dst, rotations=rotations, flange_offset=offset,
                                  base_frame=base_frame, end_effector_frame=end_effector_frame)
    if extra is None and not is_ros:
        found = _table_orientation(data, rec.t.size)
        if found is not None:
            extra = {c: found[1][:, i] for i, c in enumerate(QUATERNION_COLUMNS)}

    converted = replace(converted, metadata={**converted.metadata, "orientation": orientation, "file_wrench_frame": file_frame})
    table, meta = write_recording(converted, out, extra=extra)
    for p in (table, meta):
        _mark(p)
    return {
        "data": str(data), "from": src.describe(), "to": dst.describe(), "samples": int(converted.t.size),
        "components": converted.m, "orientation": orientation, "files": {"table": str(table), "metadata": str(meta)},
        "notes": notes,
    }


def _mark_path(path: Path) -> Path:
    """The mark beside a file ``convert`` wrote: ``.<name>.forcecontrol-convert.json`` (as the sweep marks its outputs)."""
    return path.with_name(f".{path.name}.forcecontrol-convert.json")


def _mark(path: Path) -> None:
    import json

    _mark_path(path).write_text(json.dumps({"file": path.name}))


def _ours(path: Path) -> bool:
    import json

    try:
        doc = json.loads(_mark_path(path).read_text())
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and doc.get("file") == path.name


def _claim_outputs(paths: tuple[Path, ...], force: bool) -> list[str]:
    """Refuse existing outputs unless ``force``; a folder always. Notes name the files ``force`` replaces that
    forcecontrol did not write (its own earlier outputs carry a mark).

    Raises:
        ParameterError: an output exists (and not ``force``), or is a folder.
    """
    from ..errors import ParameterError

    folders = [p for p in paths if p.is_dir()]
    if folders:
        raise ParameterError(f"{', '.join(map(str, folders))} is an existing folder; expected a file path for the "
                             "converted table and its .json metadata (a folder is never replaced, even with --force)")
    existing = [p for p in paths if p.exists()]
    if existing and not force:
        raise ParameterError(f"{', '.join(map(str, existing))} already exist(s); pass --force to overwrite")
    return [f"--force: {p} was not written by forcecontrol; it is replaced" for p in existing if not _ours(p)]


def convert_command(
    data: RecordedLog,
    source: Annotated[str, typer.Option("--from", help="the file's wrench convention (see --help text)")],
    target: Annotated[str, typer.Option("--to", help="the convention to write")],
    out: Annotated[Path | None, typer.Option(help="output .csv or .parquet (default: DATA's name + '-TO.csv' here)")] = None,
    format: Annotated[RecordFormat, typer.Option("--format", help="format of DATA (default: from the path)")] = RecordFormat.auto,
    robot: Annotated[RobotName, typer.Option(help="forward kinematics for the end-effector's orientation")] = RobotName.none,
    flange_offset: Annotated[
        str | None, typer.Option(help="ur-tcp: the flange's position in the end-effector frame 'x,y,z' [m]")
    ] = None,
    base_frame: Annotated[str, typer.Option(help="the base frame's name (bags: header.frame_id)")] = "base",
    end_effector_frame: Annotated[str, typer.Option(help="the end-effector (sensor) frame's name")] = "end-effector",
    joint_topic: Annotated[str, typer.Option(help="bags/MCAP: sensor_msgs/JointState topic")] = "/joint_states",
    wrench_topic: Annotated[str, typer.Option(help="bags/MCAP: geometry_msgs/WrenchStamped topic")] = (
        "/force_torque_sensor_broadcaster/wrench"
    ),
    force: Annotated[bool, typer.Option("--force", help="overwrite the output files")] = False,
    json_out: Annotated[bool, typer.Option("--json", help="print one JSON object instead of a table")] = False,
) -> None:
    """Convert a recorded wrench between conventions: library (h_e), franka-O, franka-K, ur-tcp, mujoco, ros-on, ros-by."""
    from rich.table import Table

    from ..errors import ForceControlError

    if out is None:
        out = Path(f"{data.stem or data.name}-{target}.csv")
    try:
        report = convert_report(data, source, target, out, fmt=format, robot=robot, flange_offset=flange_offset,
                                base_frame=base_frame, end_effector_frame=end_effector_frame, joint_topic=joint_topic,
                                wrench_topic=wrench_topic, force=force)
    except (ForceControlError, ImportError, OSError) as exc:
        _fail(exc)
    for text in report["notes"]:
        say_note(terminal_safe(text))
    if json_out:
        print_json(report)
        return
    t = Table(title=f"{data}: wrench {report['from']['name']} → {report['to']['name']}", title_justify="left")
    t.add_column("")
    t.add_column("axes")
    t.add_column("point")
    t.add_column("sense")
    for k in ("from", "to"):
        c = report[k]
        t.add_row(f"{k}: {c['name']}", c["axes"], c["point"], c["sense"])
    console.print(t)
    console.print(f"{report['samples']} samples, {report['components']} components; orientation: {report['orientation']}",
                  markup=False, highlight=False)
    for k, v in report["files"].items():
        console.print(terminal_safe(f"{k}: {v}"), markup=False, highlight=False)
