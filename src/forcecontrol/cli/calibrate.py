"""``forcecontrol calibrate DATA`` and ``forcecontrol calibrate-plan ROBOT N``: F/T sensor calibration.

``calibrate`` reads static free-space readings (CSV or Parquet: an orientation per row as a
quaternion ``qx, qy, qz, qw``, a rotation matrix ``r11 … r33`` or a planar ``angle``, and
``fx, fy, fz`` [, ``tx, ty, tz``]; or, with ``--robot NAME``, joint positions ``q1 … qn`` as
``calibrate-plan --out`` writes them, turned into orientations by the robot's forward kinematics)
and prints the identified tool mass, centre of mass and sensor biases with their standard
uncertainties and the condition number of the poses
(:func:`forcecontrol.realarm.calibration.calibrate`). ``calibrate-plan`` prints (or writes as CSV) joint
configurations that make a well-conditioned calibration for a robot
(:func:`forcecontrol.realarm.calibration.plan_calibration_poses`).
"""

from __future__ import annotations

import sys
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer

from .app import _fail, comma_numbers, print_json

__all__ = ["calibrate_command", "calibrate_plan_command", "calibration_report"]


def sensor_rpy_option(text: str | None) -> Any:
    """``--sensor-rpy roll,pitch,yaw`` [rad] (URDF's rpy: R = Rz(yaw) Ry(pitch) Rx(roll)) → the (3, 3) rotation, or None."""
    import numpy as np

    from ..errors import ParameterError

    if text is None:
        return None
    v = comma_numbers("--sensor-rpy", text, "3 numbers roll,pitch,yaw [rad]")
    if v.size != 3 or not np.all(np.isfinite(v)):
        raise ParameterError(f"--sensor-rpy must be 3 finite numbers roll,pitch,yaw [rad]; got {v.size}: {text!r}")
    from scipy.spatial.transform import Rotation  # type: ignore[import-untyped]

    return Rotation.from_euler("xyz", v).as_matrix()


def _planar(Res: Any, text: str | None) -> Any:
    """A sensor rotation for planar data: about the plane's normal only (roll = pitch = 0), as its 2x2 block."""
    import numpy as np

    from ..errors import ParameterError

    if abs(Res[2, 2] - 1.0) > 1e-12:
        raise ParameterError(f"--sensor-rpy {text}: a planar sensor turns only about the plane's normal; give 0,0,yaw")
    return np.array(Res[:2, :2])


def calibration_report(
    path: Path, gravity: float = 9.81, max_condition: float | None = None, degrees: bool = False, robot: str | None = None,
    sensor_rpy: str | None = None,
) -> dict[str, Any]:
    """The calibration of a data file as plain data (the ``--json`` output).

    With ``robot``, the sensor orientations come from the joint columns through the robot's
    forward kinematics (:func:`forcecontrol.realarm.calibration.read_joint_calibration_data`).
    With ``sensor_rpy`` (``"roll,pitch,yaw"`` [rad]), the sensor frame is turned by that rotation from the frame the
    orientations are of (the robot's controlled frame, or the file's orientation columns): ``R_S = R R_es``.
    """
    from ..realarm.calibration import (
        MAX_CONDITION,
        calibrate,
        calibration_robot,
        read_calibration_data,
        read_joint_calibration_data,
    )

    orientation = "from the file's orientation columns"
    Res = sensor_rpy_option(sensor_rpy)
    if robot is None:
        R, F, T = read_calibration_data(path, degrees=degrees)
        if Res is not None:
            R = R @ (_planar(Res, sensor_rpy) if R.shape[1] == 2 else Res)
    else:
        if degrees:
            from ..errors import ParameterError

            raise ParameterError("--degrees applies to a planar 'angle' column; with --robot the orientations come from the "
                                 "joint positions [rad]")
        model = calibration_robot(robot)
        if Res is not None and int(getattr(model, "task_dim", 3)) == 2:
            Res = _planar(Res, sensor_rpy)
        R, F, T, _, layout = read_joint_calibration_data(path, model, sensor_rotation=Res)
        orientation = f"from the joint positions ({layout}) through {robot}'s forward kinematics (frame {_frame(model)})"
    if Res is not None:
        orientation += f", the sensor turned by rpy = {sensor_rpy} rad on that frame"
    limit = MAX_CONDITION if max_condition is None else max_condition
    res = calibrate(R, F, T, gravity=gravity, max_condition=limit)
    return {"file": str(path), "robot": robot, "orientation": orientation, "max_condition": limit,
            "sensor_rotation": None if Res is None else Res.tolist(), **res.as_dict()}


def _frame(model: Any) -> str:
    frame = getattr(model, "frame", None)
    return frame if isinstance(frame, str) else "the tip, φ = Σ q"


class RobotChoice(str, Enum):
    chapter_arm = "chapter-arm"
    panda = "panda"
    ur5 = "ur5"


def _fmt(v: float, s: float) -> tuple[str, str]:
    import math

    if not math.isfinite(v):
        return "undefined", ""
    return f"{v:.6g}", f"{s:.2g}"


def calibrate_command(
    data: Annotated[Path, typer.Argument(help="CSV or Parquet: qx,qy,qz,qw | r11..r33 | angle, and fx,fy,fz[,tx,ty,tz]")],
    gravity: Annotated[float, typer.Option("--gravity", help="|g| [m/s²], along −z (3-D) or −y (planar)")] = 9.81,
    max_condition: Annotated[
        float | None, typer.Option("--max-condition", help="refuse poses whose normalised regressor is worse (default 100)")
    ] = None,
    json_out: Annotated[bool, typer.Option("--json", help="print one JSON object instead of a table")] = False,
    degrees: Annotated[bool, typer.Option("--degrees", help="the planar 'angle' column is in degrees (default radians)")] = False,
    robot: Annotated[
        RobotChoice | None,
        typer.Option("--robot", help="orientations from joint columns q1..qn (calibrate-plan --out) through this robot's FK"),
    ] = None,
    sensor_rpy: Annotated[
        str | None,
        typer.Option("--sensor-rpy", help="the sensor's rotation roll,pitch,yaw [rad] (URDF rpy) on the frame the "
                     "orientations are of (--robot's frame, or the file's columns)"),
    ] = None,
) -> None:
    """Identify a tool's mass, centre of mass and the F/T sensor's biases, with their uncertainty.

    The force readings are also checked against the model in the orientations given: when they fit a turned sensor
    frame much better (a sensor mounted turned on the flange), a warning gives that rotation for --sensor-rpy."""
    from rich.console import Console
    from rich.table import Table

    from ..errors import ForceControlError

    try:
        report = calibration_report(data, gravity, max_condition, degrees, None if robot is None else robot.value, sensor_rpy)
    except (ForceControlError, ImportError) as exc:
        _fail(exc)
    if json_out:
        print_json(report)
        return
    console = Console(width=None if sys.stdout.isatty() else 132)
    kind = "planar" if report["dim"] == 2 else "3-D"
    t = Table(title=f"{data.name}: {kind} F/T sensor, {report['n_readings']} readings", title_justify="left",
              caption="sensor frame; ± one standard uncertainty", caption_justify="left")
    for col in ("parameter", "value", "± std", "unit"):
        t.add_column(col, justify="left" if col in ("parameter", "unit") else "right")
    for row in report["parameters"]:
        v, s = _fmt(row["value"], row["std"])
        t.add_row(row["name"], v, s, row["unit"])
    console.print(t)
    console.print(f"orientations: {report['orientation']}", markup=False, highlight=False)
    console.print(f"condition number of the poses: {report['condition_number']:.3g} (1 is ideal; refused above "
                  f"{report['max_condition']:g})")
    line = f"residual RMS: forces {report['force_residual_rms']:.3g} N"
    if report["torque_residual_rms"] is not None:
        line += f", moments {report['torque_residual_rms']:.3g} N m"
    console.print(line)
    for note in report["notes"]:
        console.print(f"note: {note}")


def plan_report(robot: str, n_poses: int, seed: int = 0, torques: bool = True) -> dict[str, Any]:
    """A calibration plan for a named robot as plain data."""
    from ..realarm.calibration import calibration_robot, plan_calibration_poses

    model = calibration_robot(robot)  # the same model calibrate --robot turns the joints into orientations with
    plan = plan_calibration_poses(model, n_poses, seed=seed, torques=torques)
    return {"robot": robot, "n_poses": n_poses, "seed": seed, "condition_number": plan.condition_number,
            "joint_positions": plan.joint_positions.tolist(), "rotations": plan.rotations.tolist()}


def calibrate_plan_command(
    robot: Annotated[RobotChoice, typer.Argument(help="the robot model")],
    n_poses: Annotated[int, typer.Argument(help="number of poses (>= 3; planar with moments >= 4)")],
    seed: Annotated[int, typer.Option("--seed", help="seed of the random candidates")] = 0,
    forces_only: Annotated[bool, typer.Option("--forces-only", help="plan for mass and force bias only")] = False,
    out: Annotated[Path | None, typer.Option("--out", help="write the poses as CSV (q1..qn)")] = None,
    json_out: Annotated[bool, typer.Option("--json", help="print one JSON object instead of a table")] = False,
    force: Annotated[bool, typer.Option("--force", help="overwrite an --out file forcecontrol did not write")] = False,
) -> None:
    """Plan well-conditioned calibration poses within a robot's joint limits."""
    from rich.console import Console
    from rich.table import Table

    from ..errors import ForceControlError

    try:
        report = plan_report(robot.value, n_poses, seed, not forces_only)
    except (ForceControlError, ImportError) as exc:
        _fail(exc)
    if out is not None:
        import csv

        from .owned import claim_output, mark_output

        try:  # never over a file forcecontrol did not write, unless --force (then said on stderr and in --json)
            report["notes"] = claim_output(out, "calibrate-plan", force)
        except ForceControlError as exc:
            _fail(exc)
        for note in report["notes"]:
            print(f"note: {note}", file=sys.stderr)
        try:
            with out.open("w", newline="", encoding="utf-8") as fh:
                w = csv.writer(fh)
                nq = len(report["joint_positions"][0])
                w.writerow([f"q{i + 1}" for i in range(nq)])
                w.writerows([[repr(float(v)) for v in q] for q in report["joint_positions"]])
            mark_output(out, "calibrate-plan")
        except OSError as exc:
            from ..errors import OutputError

            _fail(OutputError(f"cannot write {str(out)!r}: {exc.strerror or exc}"))
    if json_out:
        print_json(report)
        return
    console = Console(width=None if sys.stdout.isatty() else 132)
    nq = len(report["joint_positions"][0])
    t = Table(title=f"{report['robot']}: {n_poses} calibration poses (rad)", title_justify="left")
    t.add_column("pose", justify="right")
    for i in range(nq):
        t.add_column(f"q{i + 1}", justify="right")
    for k, q in enumerate(report["joint_positions"]):
        t.add_row(str(k + 1), *(f"{v:.4f}" for v in q))
    console.print(t)
    console.print(f"condition number of the poses: {report['condition_number']:.3g} (1 is ideal)")
    if out is not None:
        console.print(f"written: {out}")
