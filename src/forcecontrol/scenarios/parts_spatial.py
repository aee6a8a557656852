"""Scenario parts for 6-D robots (Pinocchio models): poses relative to the start, tables, springs, 6-D controllers.

Pose references and environments are given relative to the end-effector's start pose (from the
case's q0), so that scenarios do not hard-code a robot's forward kinematics:

* offsets of the position are in the base frame [m];
* rotations are XYZ Euler angles [deg] applied in the start frame (``R_d = R_0 R(φ)``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..core.validate import as_matrix, as_vector
from ..errors import DimensionError, ScenarioError
from ..spatial.closed_form import euler_xyz_to_rotation, rotation_to_euler_xyz  # no SciPy import (0.15 s per process)
from .schema import TIMING_FIELDS, Field, force_law_fields, register_controller, register_environment, register_reference

# ----------------------------------------------------------------------------- robots


def pinocchio_robot(where: str, rt: dict[str, Any]):
    """The ``[robot]`` table's Pinocchio model (``panda``, ``ur5`` or ``urdf``)."""
    try:
        from ..robots import pinocchio as pm
    except ImportError as exc:  # pragma: no cover - depends on the installation
        msg = f"{where}: [robot]: model '{rt['model']}' needs Pinocchio: pip install 'forcecontrol[pinocchio]'"
        raise ScenarioError(msg) from exc
    from ..errors import ForceControlError

    try:
        if rt["model"] == "panda":
            return pm.panda(rt["frame"] or "panda_hand_tcp")
        if rt["model"] in ("ur5", "ur10"):  # with the payload, if any (issue 30, FZI #177)
            pay = rt.get("payload_mass")
            if rt.get("payload_com") is not None and not pay:
                raise ScenarioError(f"{where}: [robot]: key 'payload_com' needs a payload_mass > 0; got {pay!r}")
            make = pm.ur5 if rt["model"] == "ur5" else pm.ur10
            return make(rt["frame"] or "tool0", payload=pm.Payload(pay, rt.get("payload_com") or (0, 0, 0)) if pay else None)
        if not rt["urdf"] or not rt["frame"]:
            raise ScenarioError(f"{where}: [robot]: model 'urdf' needs keys 'urdf' and 'frame'")
        return pm.PinocchioRobot.from_urdf(Path(rt["urdf"]), rt["frame"], locked_joints=tuple(rt["locked_joints"] or ()),
                                           frame_type=rt.get("frame_type"))
    except ForceControlError as exc:
        if isinstance(exc, ScenarioError):
            raise
        raise ScenarioError(f"{where}: [robot]: {exc}") from exc


def _start(ctx: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    robot = ctx["robot"]
    if not hasattr(robot, "frame_pose"):
        raise ScenarioError("6-D parts need a 6-D robot: [robot] model = 'panda', 'ur5' or 'urdf'")
    return robot.frame_pose(ctx["q0"])


def _offset(key: str, value: Any) -> np.ndarray:
    """A 3-vector key (offset [m] or XYZ Euler angles [deg]): three finite numbers, or zeros when absent."""
    return as_vector(key, value if value is not None else [0.0, 0.0, 0.0], 3)


def _pose(ctx: dict[str, Any], offset: Any, rotation_deg: Any, keys: tuple[str, str] = ("offset", "rotation")) -> np.ndarray:
    R0, p0 = _start(ctx)
    p = p0 + _offset(keys[0], offset)
    rot = np.radians(_offset(keys[1], rotation_deg))
    return np.concatenate([p, rotation_to_euler_xyz(R0 @ euler_xyz_to_rotation(rot))])


def _posture(p: dict[str, Any], ctx: dict[str, Any]):
    from ..controllers.redundant import NullSpacePosture

    if ctx["robot"].nq <= 6:
        return None
    return NullSpacePosture(ctx["q0"], p["posture_stiffness"], p["posture_damping"])


_POSTURE_FIELDS = {
    "posture_stiffness": Field("number", default=25.0, doc="null-space posture K_n [1/s²] (n > 6; posture = q0)"),
    "posture_damping": Field("number", default=10.0, doc="null-space posture D_n [1/s]"),
    "orientation": Field("str", default="euler", choices=("euler", "rotvec"), doc="orientation error"),
}

# ----------------------------------------------------------------------------- references


def _pose_setpoint(p: dict[str, Any], ctx: dict[str, Any]):
    from ..trajectories import Setpoint

    return Setpoint(_pose(ctx, p["offset"], p["rotation"]), p["force"])


register_reference(
    "pose-setpoint",
    {
        "offset": Field("vector", doc="o_d − o_e(q0), base frame [m]"),
        "rotation": Field("vector", doc="XYZ Euler angles of R_0ᵀ R_d [deg]"),
        "force": Field("vector", doc="h_d = [f; μ] on the environment, base frame [N, N m]"),
    },
    _pose_setpoint,
    "constant desired frame relative to the start pose (6-D robots)",
)


def _pose_line(p: dict[str, Any], ctx: dict[str, Any]):
    from ..trajectories import LinearPath

    start = _pose(ctx, p["start_offset"], p["rotation"], ("start_offset", "rotation"))
    end = _pose(ctx, p["end_offset"], p["rotation"], ("end_offset", "rotation"))
    return LinearPath(start, end, p["duration"], p["accel_time"], p["start_time"], p["force"], speed=p["speed"])


register_reference(
    "pose-line",
    {
        "start_offset": Field("vector", doc="start of the line − o_e(q0), base frame [m]"),
        "end_offset": Field("vector", True, doc="end of the line − o_e(q0), base frame [m]"),
        "rotation": Field("vector", doc="constant orientation: XYZ Euler angles of R_0ᵀ R_d [deg]"),
        **TIMING_FIELDS,
        "force": Field("vector", doc="h_d = [f; μ] on the environment, base frame [N, N m]"),
    },
    _pose_line,
    "straight line of the desired frame's origin, trapezoidal speed, constant orientation (6-D robots)",
)

# ----------------------------------------------------------------------------- environments


def _table(p: dict[str, Any], ctx: dict[str, Any]):
    from ..environments.spatial import Table

    _R0, p0 = _start(ctx)
    point = p0 + _offset("offset", p["offset"])
    return Table(point, p["normal"], p["stiffness"], p["damping"])


register_environment(
    "table",
    {
        "offset": Field("vector", doc="a surface point − o_e(q0), base frame [m] (default: the start tip)"),
        "normal": Field("vector", default=[0.0, 0.0, 1.0], doc="outward normal"),
        "stiffness": Field("number", True, doc="k [N/m]"),
        "damping": Field("number", default=0.0, doc="c [N s/m]"),
    },
    _table,
    "one-sided elastic table, point contact at the end-effector origin (6-D robots)",
)


def _rigid_table(p: dict[str, Any], ctx: dict[str, Any]):
    from ..environments.rigid import PlaneConstraint, RigidEnvironment

    _R0, p0 = _start(ctx)
    point = p0 + _offset("offset", p["offset"])
    normal = as_vector("normal", p["normal"], 3)
    # the constraint on the 6-D pose x = [o_e; φ_e] acts on the position only
    plane = PlaneConstraint(np.concatenate([point, np.zeros(3)]), np.concatenate([normal, np.zeros(3)]))
    return RigidEnvironment(plane, unilateral=p["unilateral"])


register_environment(
    "rigid-table",
    {
        "offset": Field("vector", doc="a surface point − o_e(q0), base frame [m] (default: the start tip)"),
        "normal": Field("vector", default=[0.0, 0.0, 1.0], doc="outward normal"),
        "unilateral": Field("bool", default=True, doc="the table only pushes (contact can be lost)"),
    },
    _rigid_table,
    "rigid frictionless table, constrained dynamics (9.87)-(9.88), point contact at the end-effector (6-D robots)",
)


def _spring(p: dict[str, Any], ctx: dict[str, Any]):
    from ..environments.spatial import SpatialSpring

    rest = _pose(ctx, p["offset"], p["rotation"])
    return SpatialSpring(p["stiffness"], rest[:3], euler_xyz_to_rotation(rest[3:]), p["damping"])


register_environment(
    "spatial-spring",
    {
        "stiffness": Field("gain", True, doc="K (6, 6) symmetric PSD in the rest frame [N/m, N m/rad]"),
        "damping": Field("gain", default=0.0, doc="D (6, 6) symmetric PSD"),
        "offset": Field("vector", doc="rest origin − o_e(q0), base frame [m]"),
        "rotation": Field("vector", doc="XYZ Euler angles of R_0ᵀ R_r [deg]"),
    },
    _spring,
    "general 6-D spring (9.21) between the end-effector and a rest frame (6-D robots)",
)

# ----------------------------------------------------------------------------- controllers


def _impedance(p: dict[str, Any], ctx: dict[str, Any]):
    from ..controllers.spatial import SpatialImpedanceController

    return SpatialImpedanceController(
        ctx["robot"], p["inertia"], p["damping"], p["stiffness"], orientation=p["orientation"],
        posture=_posture(p, ctx), sample_time=ctx["sample_time"], frame=p["frame"],
    )


register_controller(
    "spatial-impedance",
    {
        "inertia": Field("gain", True, doc="M_d (6, 6) [kg, kg m²]"),
        "damping": Field("gain", True, doc="K_D (6, 6)"),
        "stiffness": Field("gain", True, doc="K_P (6, 6)"),
        "frame": Field("str", default="desired", choices=("desired", "base"),
                       doc="'desired': error on the desired frame (9.35); "
                           "'base': x = [o_e; XYZ angles of R_e], J_A, T_A (9.28)-(9.31)"),
        **_POSTURE_FIELDS,
    },
    _impedance,
    "impedance on the desired frame (9.30), (9.35): configuration-independent (9.36); or in the base frame (9.31)",
)


def _compliance(p: dict[str, Any], ctx: dict[str, Any]):
    from ..controllers.spatial import SpatialComplianceController

    return SpatialComplianceController(
        ctx["robot"], p["stiffness"], p["damping"], orientation=p["orientation"], posture=_posture(p, ctx),
        sample_time=ctx["sample_time"],
    )


register_controller(
    "spatial-compliance",
    {"stiffness": Field("gain", True, doc="K_P (6, 6)"), "damping": Field("gain", True, doc="K_D (6, 6)"), **_POSTURE_FIELDS},
    _compliance,
    "PD with gravity compensation on the desired frame (9.15): active compliance",
)


def _admittance(p: dict[str, Any], ctx: dict[str, Any]):
    from ..controllers.admittance import AdmittanceController

    return AdmittanceController(
        ctx["robot"], p["inertia"], p["damping"], p["stiffness"], motion_stiffness=p["motion_stiffness"],
        motion_damping=p["motion_damping"], environment_stiffness=p["environment_stiffness"],
        orientation=p["orientation"], posture=_posture(p, ctx), sample_time=ctx["sample_time"],
    )


register_controller(
    "admittance",
    {
        "inertia": Field("gain", True, doc="M_t (6, 6)"),
        "damping": Field("gain", True, doc="K_Dt (6, 6)"),
        "stiffness": Field("gain", True, doc="K_Pt (6, 6)"),
        "motion_stiffness": Field("gain", default=2500.0, doc="K_P of the motion loop [1/s²]"),
        "motion_damping": Field("gain", default=100.0, doc="K_D of the motion loop [1/s]"),
        "environment_stiffness": Field("gain", doc="expected contact stiffness for the bandwidth check"),
        **_POSTURE_FIELDS,
    },
    _admittance,
    "admittance control (9.37): compliant frame tracked by inverse dynamics",
)


def _force_directions(p: dict[str, Any]) -> Any:
    """S_f (6, k) from a 6-D hybrid table's ``task`` or ``force_directions`` (exactly one)."""
    if (p["task"] is None) == (p["force_directions"] is None):
        raise ScenarioError("a 6-D hybrid controller needs exactly one of 'task' (a named task) and 'force_directions'")
    if p["task"] is not None:
        from ..task import named_task

        return named_task(p["task"]).selection().force_selection
    given = p["force_directions"]
    rows = as_matrix("force_directions", given if isinstance(given, list) and isinstance(given[0], list) else [given])
    if rows.shape[1] != 6 or not 1 <= rows.shape[0] <= 6:
        raise DimensionError(
            f"key 'force_directions' must be 1 to 6 rows of 6 numbers (columns of S_f); got shape {rows.shape}"
        )
    return rows.T


_HYBRID_6D_FIELDS = {
    "task": Field("str", doc="a named task of forcecontrol.task (e.g. 'peg-in-hole', Table 9.2)"),
    "force_directions": Field("gain", doc="S_f columns given as rows of 6 numbers (desired frame)"),
    "stiffness": Field("gain", True, doc="K_P of the pose servo (9.95) along S_v (6, 6) [1/s²]"),
    "damping": Field("gain", True, doc="K_D of the pose servo (9.95) along S_v (6, 6) [1/s]"),
}


def _hybrid(p: dict[str, Any], ctx: dict[str, Any]):
    from ..controllers.spatial_hybrid import SpatialHybridController

    sel = _force_directions(p)
    return SpatialHybridController(
        ctx["robot"], sel, p["compliance"], p["stiffness"], p["damping"], p["force_stiffness"], p["force_damping"],
        orientation=p["orientation"], posture=_posture(p, ctx), sample_time=ctx["sample_time"],
    )


register_controller(
    "spatial-hybrid",
    {
        **_HYBRID_6D_FIELDS,
        "compliance": Field("gain", True, doc="C along S_f [m/N, rad/(N m)]"),
        "force_stiffness": Field("gain", True, doc="K_Pλ [1/s²]"),
        "force_damping": Field("gain", True, doc="K_Dλ [1/s]"),
        **_POSTURE_FIELDS,
    },
    _hybrid,
    "hybrid force/motion control on the desired frame, compliant environment ((9.77)-(9.84) in 6-D)",
)


def _hybrid_rigid(p: dict[str, Any], ctx: dict[str, Any]):
    from ..controllers.spatial_hybrid import SpatialHybridRigidController

    return SpatialHybridRigidController(
        ctx["robot"], _force_directions(p), p["stiffness"], p["damping"], force_law=p["force_law"],
        force_gain=p["force_gain"], force_integral_gain=p["force_integral_gain"], orientation=p["orientation"],
        posture=_posture(p, ctx), sample_time=ctx["sample_time"],
    )


register_controller(
    "spatial-hybrid-rigid",
    {
        **_HYBRID_6D_FIELDS,
        **force_law_fields("feedforward"),
        **_POSTURE_FIELDS,
    },
    _hybrid_rigid,
    "hybrid force/motion control on the desired frame, rigid environment ((9.91)-(9.95) in 6-D)",
)
