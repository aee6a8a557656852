"""Scenario parts: the vendor and ROS controllers, from their own configuration files (issue 30).

``[controller] type = "ros2-admittance" | "fzi-compliance" | "fzi-force" | "ur-force-mode" |
"franka-cartesian-impedance"`` with ``config = "path"`` (the project's own file, read unmodified;
relative to the scenario file, else to the working folder, else one of the shipped examples in
``scenarios/configs``) and/or the parameters under the library's names (they override the
file's). The position-interface controllers run the arm through its joint servo (the
``[robot.servo]`` table; the file's ``update_rate`` is compared with the servo's rate). Every
note of the reader (keys not read, mapped frames,
defaults) is said on stderr (a warning) and kept in the run's metadata (``config_notes``).
"""

from __future__ import annotations

import warnings
from importlib import resources
from pathlib import Path
from typing import Any

from ..errors import ScenarioError
from .schema import Field, register_controller

#: g [m/s²] of the simulated arms (Pinocchio's models): a configured weight [N] is this times a mass [kg]
STANDARD_GRAVITY = 9.81

__all__ = ["VENDOR_TYPES", "resolve_config_path", "vendor_controller"]

_COMMON = {
    "config": Field("str", doc="the controller's own configuration file (YAML, .cfg or URScript), read unmodified"),
    "section": Field("str", doc="the controller's section in a YAML file holding several (default: the first)"),
}
_V = "vector"
#: the scenario types: (controller class name, fields beyond the common ones)
VENDOR_TYPES: dict[str, tuple[str, dict[str, Field]]] = {
    "ros2-admittance": ("Ros2AdmittanceController", {
        "mass": Field(_V, doc="admittance.mass per axis [kg, kg m^2]"),
        "damping_ratio": Field(_V, doc="admittance.damping_ratio per axis"),
        "stiffness": Field(_V, doc="admittance.stiffness per axis [N/m, N m/rad]"),
        "selected_axes": Field("boollist", doc="admittance.selected_axes: six true/false, where the admittance acts "
                                              "(the other axes hold the reference pose)"),
        "joint_damping": Field("number", low=0.0, doc="admittance.joint_damping [1/s]"),
        "filter_coefficient": Field("number", low=0.0, high=1.0, doc="ft_sensor.filter_coefficient"),
        "kinematics_alpha": Field("number", low=0.0, doc="kinematics.alpha"),
        "payload_weight": Field("number", doc="gravity_compensation.CoG.force [N]"),
        "payload_cog": Field(_V, doc="gravity_compensation.CoG.pos [m]"),
        "control_frame": Field("str", choices=("tool", "base"), doc="the frame K, D, M are diagonal in"),
        "payload_frame": Field("str", choices=("tool", "base"), doc="the frame CoG.pos is given in"),
    }),
    "fzi-compliance": ("FziComplianceController", {
        "stiffness": Field(_V, doc="stiffness.trans_x ... rot_z [N/m, N m/rad]"),
        "p": Field(_V, doc="pd_gains.<axis>.p"), "d": Field(_V, doc="pd_gains.<axis>.d"),
        "error_scale": Field("number", low=0.0, doc="solver.error_scale"),
        "iterations": Field("int", low=1, high=1000, doc="solver.iterations"),
        "solver": Field("str", choices=("accumulating", "instantaneous"),
                        doc="accumulating (since Dec 2021) or instantaneous (the 2021 solver)"),
        "virtual_mass": Field("number", low=0.0, doc="end-effector mass of the virtual model [kg] (1.3)"),
        "compliance_frame": Field("str", choices=("tool", "base"), doc="the frame the stiffness is diagonal in"),
    }),
    "fzi-force": ("FziForceController", {
        "p": Field(_V, doc="pd_gains.<axis>.p"), "d": Field(_V, doc="pd_gains.<axis>.d"),
        "error_scale": Field("number", low=0.0, doc="solver.error_scale"),
        "solver": Field("str", choices=("accumulating", "instantaneous"), doc="solver semantics"),
        "virtual_mass": Field("number", low=0.0, doc="end-effector mass of the virtual model [kg] (1.3)"),
    }),
    "ur-force-mode": ("UrForceModeController", {
        "task_frame": Field(_V, doc="p[x, y, z, rx, ry, rz] of the force frame in the base [m, rad]"),
        "selection_vector": Field(_V, doc="six 0/1 (1: compliant)"),
        "wrench": Field(_V, doc="the wrench applied to the environment on compliant axes [N, N m]"),
        "limits": Field(_V, doc="speed limits (compliant) / deviation limits (others) [m/s, rad/s; m, rad]"),
        "damping": Field("number", low=0.0, high=1.0, doc="force_mode_set_damping"),
        "gain_scaling": Field("number", low=0.0, high=2.0, doc="force_mode_set_gain_scaling"),
        "gain": Field("number", low=0.0, doc="internal admittance gain G [1/kg] (INFERRED, nominal 0.05)"),
    }),
    "franka-cartesian-impedance": ("FrankaCartesianImpedanceController", {
        "translational_stiffness": Field("number", low=0.0, doc="[N/m] (cfg default 200)"),
        "rotational_stiffness": Field("number", low=0.0, doc="[N m/rad] (cfg default 10)"),
        "nullspace_stiffness": Field("number", low=0.0, doc="(cfg default 0.5)"),
        "soft_start": Field("bool", default=True, doc="stiffness ramps up from 0 (the project's behaviour)"),
    }),
}
_NOT_PARAMS = ("type", "config", "section")


def resolve_config_path(value: str, where: str) -> Path:
    """A configuration path: absolute, or relative to the scenario file's folder, the working folder,
    or the shipped examples (``scenarios/configs``), the first that exists (:func:`from_shipped_examples` tells
    the last)."""
    p = Path(value)
    if p.is_absolute():
        return p
    scenario_file = Path(where.split(": [[case]]")[0])
    candidates = ([scenario_file.parent / p] if scenario_file.is_file() else []) + [Path.cwd() / p, _SHIPPED / "configs" / p]
    for c in candidates:
        if c.is_file():
            return c
    raise ScenarioError(f"{where}: [controller]: key 'config' names no file: {value!r} (looked in: "
                        f"{', '.join(str(c.parent) for c in candidates)})")


_SHIPPED = Path(str(resources.files("forcecontrol.scenarios")))


def from_shipped_examples(path: Path, value: str, where: str) -> bool:
    """Whether :func:`resolve_config_path` found ``value`` only among the shipped examples, for a scenario that is
    not itself one of the library's (a built-in or a shipped example)."""
    scenario_dir = Path(where.split(": [[case]]")[0].removesuffix(" (edited)")).parent.resolve()
    own = scenario_dir in (_SHIPPED.resolve(), (_SHIPPED / "configs").resolve())
    return path.parent == _SHIPPED / "configs" and not Path(value).is_absolute() and not own


def vendor_controller(kind: str, p: dict[str, Any], ctx: dict[str, Any]) -> Any:
    """Build the controller of ``kind`` from its checked table (``p``) and the case's context."""
    from ..controllers import vendor
    from ..robots.servo import PositionInterfaceRobot

    where = str(ctx.get("where", "<scenario>"))
    params: dict[str, Any] = {}
    notes: list[str] = []
    rate = None
    source = None
    if p.get("config"):
        from ..errors import ForceControlError
        from ..realarm.conventions.configs import read_config

        path = resolve_config_path(p["config"], where)
        try:
            cfg = read_config(path, kind if not kind.startswith("fzi") else None, p.get("section"))
        except ForceControlError as exc:
            raise ScenarioError(f"{where}: [controller] config: {exc}") from exc
        if cfg.kind != kind:
            raise ScenarioError(f"{where}: [controller]: {path} is a {cfg.kind} configuration; the table's type is {kind!r}")
        params.update(cfg.parameters)
        notes = list(cfg.notes)
        if from_shipped_examples(path, p["config"], where):
            notes.insert(0, f"config {p['config']!r} is neither next to the scenario nor in the working folder: the "
                            f"library's shipped example {path} is used")
        rate = rate if rate is not None else cfg.rate
        source = str(path)
    given = {k: v for k, v in p.items() if k not in _NOT_PARAMS and v is not None}
    params.update(given)
    robot = ctx["robot"]
    cls = getattr(vendor, VENDOR_TYPES[kind][0])
    if kind != "franka-cartesian-impedance":
        if not isinstance(robot, PositionInterfaceRobot):
            raise ScenarioError(f"{where}: [controller] type {kind!r} runs a position-interface arm: add a [robot.servo] "
                                "table (e.g. preset = 'ur-e-series')")
        if rate is not None and abs(float(rate) - robot.servo.rate) > 1e-9 * rate:
            notes.append(f"the file's update_rate {float(rate):g} Hz differs from the servo's rate {robot.servo.rate:g} Hz "
                         "([robot.servo] rate): the controller runs at the servo's rate")
    elif isinstance(robot, PositionInterfaceRobot):
        raise ScenarioError(f"{where}: [controller] type {kind!r} is a torque controller: remove the [robot.servo] table")
    elif abs(float(ctx["sample_time"]) - 1e-3) > 1e-12:
        # franka_ros's gain/equilibrium filter (filter_params 0.005) and torque-rate limit (delta_tau_max 1 N m) act per
        # cycle of libfranka's 1 kHz loop: at another period the soft start and the rate limit are not Franka's
        notes.append(f"sample_time {float(ctx['sample_time']):g} s is not the FCI's 1 ms: the example's per-cycle filter "
                     "(0.005) and torque-rate limit (delta_tau_max) act per sample here, so its soft start and rate "
                     "limit run at another speed than on the robot")
    ctl = cls(robot, sample_time=ctx["sample_time"], **params)
    ctl.config_source = source
    ctl.config_notes = notes
    ctl.GAINS = (*type(ctl).GAINS, "config_source", "config_notes")
    scenario_file = where.split(": [[case]]")[0].removesuffix(" (edited)")  # Scenario.with_ (--set) builds "<file> (edited)"
    said = (scenario_file, Path(source or "").name, tuple(notes))  # the path is relative on load, absolute after --set
    if notes and said not in _SAID:  # once per scenario file and configuration (a load, --set and the run build it again)
        _SAID.add(said)
        head = f"{Path(scenario_file).name}: [controller] {kind} from {Path(source or '').name}"
        for n in notes:  # one warning (one stderr line) per note
            warnings.warn(ConfigNote(f"{head}: {n}"), stacklevel=2)
    return ctl


class ConfigNote(UserWarning):
    """What a configuration file's reader did not read, mapped or defaulted (the notes of ``read_config``).

    A command shows it as one clean ``note: ...`` line on stderr (:mod:`forcecontrol.cli.notices`) and keeps it in
    ``--json``'s ``warnings``."""


_SAID: set[Any] = set()


def _register(kind: str) -> None:
    cls_name, fields = VENDOR_TYPES[kind]
    register_controller(kind, {**_COMMON, **fields}, lambda p, ctx: vendor_controller(kind, p, ctx),
                        f"{cls_name}: the project's controller from its own configuration file (issue 30)")


for _kind in VENDOR_TYPES:
    _register(_kind)


# ----------------------------------------------------------------------------- import-config: the equivalent scenario

_UR5_Q0 = [0.0, -1.57, 1.57, -1.57, -1.57, 0.0]
_PANDA_Q0 = [0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398]


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    s = str(v).replace("\\", "\\\\").replace('"', '\\"')
    return f'"{s}"'


def scenario_toml(cfg: Any, *, inline: bool = False) -> str:
    """A scenario (TOML text) that runs the controller of a :class:`~forcecontrol.realarm.conventions.configs.VendorConfig`.

    The arm is the UR5 through the UR e-Series servo (the Panda, torque interface, for Franka's
    controller) at the file's update rate when it gives one; the tool presses an elastic table
    5 mm below the start (10 N reference force, or a desired pose 2 cm into it for the compliance
    controllers). ``inline``: the parameters are written as keys (no ``config`` key); otherwise
    the scenario names the file and lists the values read as comments.
    """
    import math

    kind = cfg.kind
    lines = [f"# Equivalent to {cfg.source} ({kind}{'' if cfg.section is None else ', section ' + repr(cfg.section)}),"
             " written by 'forcecontrol import-config'", "#"]
    lines += [f"# note: {n}" for n in cfg.notes]
    stem = Path(cfg.source).stem.replace("_", "-") or "imported"
    torque = kind == "franka-cartesian-impedance"
    rate = 1000.0 if torque else (cfg.rate or 500.0)
    period = 1.0 / rate
    Ts = 0.001 if torque else period / math.ceil(period / 5e-4 - 1e-9)
    lines += [f'name = "{stem}"', f'title = {_toml_value(KIND_TITLES[kind] + " from " + Path(cfg.source).name)}',
              "duration = 3.0", f"sample_time = {Ts!r}", "allow_contact_loss = true", "", "[robot]"]
    if torque:
        lines += ['model = "panda"', f"q0 = {_toml_value(_PANDA_Q0)}"]
    else:
        lines += ['model = "ur5"', f"q0 = {_toml_value(_UR5_Q0)}"]
        weight = float(cfg.parameters.get("payload_weight") or 0.0) if kind == "ros2-admittance" else 0.0
        if weight > 0.0 and cfg.parameters.get("payload_frame", "tool") == "tool":
            # the tool whose weight the file's gravity compensation removes: carried by the simulated arm too
            # (without it, the compensation reads as a force lifting the tool)
            lines += [f"payload_mass = {weight / STANDARD_GRAVITY!r}  # gravity_compensation.CoG.force / g",
                      f"payload_com = {_toml_value(list(cfg.parameters.get('payload_cog') or (0.0, 0.0, 0.0)))}",
                      "payload_weight_in_reading = true  # the F/T reading holds the tool's weight; the file removes it"]
        elif weight != 0.0:
            lines.insert(2 + len(cfg.notes), f"# note: the file compensates a {weight:g} N tool that the simulated arm "
                         "does not carry (a tool is simulated for a positive weight with CoG.pos in the tool frame): "
                         "the compensation will read as a force on the tool")
        lines += ["", "[robot.servo]", 'preset = "ur-e-series"']
        if cfg.rate is not None:
            lines.append(f"rate = {float(cfg.rate)!r}")
    push, signals = _force_mode_push(cfg) if kind == "ur-force-mode" else (None, ["z", "fz"])
    if push is None:
        lines += ["", "[environment]", 'type = "table"', "offset = [0.0, 0.0, -0.005]", "stiffness = 5000.0"]
    else:  # the table 5 mm ahead along the force mode's compliant axis, facing the push
        lines += ["", "[environment]", 'type = "table"', f"offset = {_toml_value([0.005 * v for v in push])}",
                  f"normal = {_toml_value([-v + 0.0 for v in push])}", "stiffness = 5000.0",
                  "# the table faces the force mode's push (task frame, selection_vector and wrench of the file)"]
    lines += ["", "[controller]", f'type = "{kind}"']
    fields = VENDOR_TYPES[kind][1]
    params = {k: v for k, v in cfg.parameters.items() if k in fields}
    if inline:
        lines += [f"{k} = {_toml_value(v)}" for k, v in params.items()]
    else:
        lines.append(f"config = {_toml_value(str(Path(cfg.source).resolve()))}")
        if cfg.section is not None:
            lines.append(f"section = {_toml_value(cfg.section)}")
        lines.append("# read from the file (a key here overrides it):")
        lines += [f"# {k} = {_toml_value(v)}" for k, v in params.items()]
    lines += ["", "[reference]", 'type = "pose-setpoint"']
    if kind in ("fzi-compliance", "franka-cartesian-impedance"):
        lines.append("offset = [0.0, 0.0, -0.02]")
    elif kind != "ur-force-mode":
        lines.append("force = [0.0, 0.0, -10.0, 0.0, 0.0, 0.0]")
        if kind == "ros2-admittance":  # upstream's ~/wrench_reference is in the sensor frame, this is the base frame's
            lines.append("# base frame; on the robot, ~/wrench_reference takes it in the ft_sensor frame: R_sensor^T f "
                         "(at q0 the tool's z points down: about (0, 0, 10) there)")
    lines += ["", "[figure]", f"signals = {_toml_value(signals)}", ""]
    return "\n".join(lines)


def _force_mode_push(cfg: Any) -> tuple[list[float] | None, list[str]]:
    """The unit direction (base frame) a force mode pushes along (its first compliant translational axis, z first, in
    the task frame, signed by the wrench the robot applies on it) and the figure's signals; (None, z) when no
    translational axis is compliant or its wrench is zero (the table stays below the tool)."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from .parts_vendor_analysis import compliant_axis

    p = cfg.parameters
    sel, wrench = p.get("selection_vector") or [0.0] * 6, p.get("wrench") or [0.0] * 6
    axis = compliant_axis(sel, wrench)
    if axis is None:
        return None, ["z", "fz"]
    R = Rotation.from_rotvec(np.asarray((p.get("task_frame") or [0.0] * 6)[3:6], dtype=float)).as_matrix()
    d = np.sign(wrench[axis]) * R[:, axis]
    d = [float(round(v, 12)) + 0.0 for v in d]
    names = [n for n, v in zip("xyz", d) if abs(v) > 0.1]
    return d, [*names, *(f"f{n}" for n in names)]


def check_vendor_parameters(cfg: Any) -> None:
    """Refuse a configuration whose values the library's controller refuses (a negative stiffness, an error_scale
    below 0, ...), before a scenario or a file is written from it: the controller of :func:`scenario_toml`'s
    scenario (parameters inline) is built once.

    Raises:
        ParameterError: naming the file, the parameter, the expected range and the value given.
    """
    import math

    import tomllib

    from ..errors import ForceControlError, ParameterError
    from .build import build_case
    from .core import load_scenario

    for key, v in cfg.parameters.items():  # a non-finite value is refused here by name
        vals = v if isinstance(v, list | tuple) else [v]
        if any(isinstance(x, float) and not math.isfinite(x) for x in vals):
            raise ParameterError(f"{cfg.source}: {key} must be finite; got {v!r}")
    try:
        scn = load_scenario(tomllib.loads(scenario_toml(cfg, inline=True)))
        build_case(scn.cases[0], where=str(cfg.source))
    except ForceControlError as exc:
        said = str(exc).removeprefix("<dict>: ")  # the scenario is the file's: its name is said first
        raise ParameterError(f"{cfg.source}: the {cfg.kind} controller refuses these values: {said}") from exc


KIND_TITLES = {
    "ros2-admittance": "ros2_controllers admittance_controller",
    "fzi-compliance": "FZI cartesian_compliance_controller",
    "fzi-force": "FZI cartesian_force_controller",
    "franka-cartesian-impedance": "franka_ros cartesian_impedance_example_controller",
    "ur-force-mode": "URScript force_mode",
}
