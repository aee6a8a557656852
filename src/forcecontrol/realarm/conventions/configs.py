"""The vendor and ROS controllers' own configuration files: read unmodified, written back in place (issue 30).

Formats (detected from the keys, or named with ``kind``):

* ``ros2-admittance``: a ros2_controllers parameter file (``<controller>: ros__parameters:`` with
  ``admittance:`` and ``kinematics:``; parameter names of ``admittance_controller_parameters.yaml``);
* ``fzi-compliance`` / ``fzi-force``: FZI cartesian_controllers files, ROS 2 (``ros__parameters``,
  optional ``controller_manager`` section with ``update_rate``) or ROS 1 (flat, with ``type:``);
* ``franka-cartesian-impedance``: franka_ros's YAML (``type``, ``arm_id``, ``joint_names``; the
  gains ``translational_stiffness``, ``rotational_stiffness``, ``nullspace_stiffness`` where the
  example's dynamic_reconfigure server reads them, under ``dynamic_reconfigure_compliance_param_node``
  in the controller's section, clamped to the ``.cfg`` ranges as that server does; else the defaults
  of ``compliance_param.cfg``) or that ``.cfg`` file itself (``gen.add(...)`` lines);
* ``ur-force-mode``: URScript lines (:mod:`.ur_script`).

:func:`read_config` returns a :class:`VendorConfig`: the controller's parameters under the
library's names (:mod:`forcecontrol.controllers.vendor`), the rate when the file gives it, and
``notes``: every key that is not read or is mapped (frames, interfaces), said in words, so
nothing is ignored silently. :meth:`VendorConfig.write` rewrites changed values in place
(:mod:`.config_text`; ruamel.yaml for the structure and positions): everything else, comments
included, stays byte for byte.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...errors import ParameterError
from .config_text import Edit, apply_edits, format_number, plain_scalar_end
from .ur_script import read_ur_script, write_ur_script

__all__ = ["KINDS", "VendorConfig", "read_config", "detect_kind"]

#: the formats, with the project they come from.
KINDS = {
    "ros2-admittance": "ros2_controllers admittance_controller",
    "fzi-compliance": "FZI cartesian_compliance_controller",
    "fzi-force": "FZI cartesian_force_controller",
    "franka-cartesian-impedance": "franka_ros cartesian_impedance_example_controller",
    "ur-force-mode": "URScript force_mode",
}
_AX = ("trans_x", "trans_y", "trans_z", "rot_x", "rot_y", "rot_z")
_REQ = object()  # a required key (no default)

# library parameter -> [(path in the controller's parameters, default)]
#: franka_ros's cartesian_impedance_example_controller reads its gains from a dynamic_reconfigure server in this
#: namespace of the controller (``<controller>/dynamic_reconfigure_compliance_param_node/translational_stiffness``)
_FRANKA_NODE = "dynamic_reconfigure_compliance_param_node"
#: the gains' ranges in franka_example_controllers/cfg/compliance_param.cfg: the server clamps a value to them
_FRANKA_RANGES = {"translational_stiffness": (0.0, 400.0), "rotational_stiffness": (0.0, 30.0),
                  "nullspace_stiffness": (0.0, 100.0)}

#: FZI's ROS 1 dynamic_reconfigure ranges (cartesian_controllers, branch ros1: ComplianceController.cfg, PDGains.cfg,
#: CartesianController.cfg), one per value of the slot: the server clamps what the parameter server holds to them
_FZI_ROS1_RANGES = {"stiffness": [(100.0, 5000.0)] * 3 + [(5.0, 200.0)] * 3, "p": [(0.0, 10.0)] * 6,
                    "d": [(0.0, 10.0)] * 6, "error_scale": [(0.0, 10.0)], "iterations": [(1, 100)]}

_SLOTS: dict[str, dict[str, list[tuple[tuple[Any, ...], Any]]]] = {
    "ros2-admittance": {
        "mass": [(("admittance", "mass", i), _REQ) for i in range(6)],
        "damping_ratio": [(("admittance", "damping_ratio", i), _REQ) for i in range(6)],
        "stiffness": [(("admittance", "stiffness", i), _REQ) for i in range(6)],
        "selected_axes": [(("admittance", "selected_axes", i), _REQ) for i in range(6)],
        "joint_damping": [(("admittance", "joint_damping"), 5.0)],
        "filter_coefficient": [(("ft_sensor", "filter_coefficient"), 0.05)],
        "kinematics_alpha": [(("kinematics", "alpha"), 0.01)],
        "payload_weight": [(("gravity_compensation", "CoG", "force"), 0.0)],
        "payload_cog": [(("gravity_compensation", "CoG", "pos", i), _REQ) for i in range(3)],
    },
    "fzi-compliance": {
        "stiffness": [(("stiffness", a), 500.0 if i < 3 else 50.0) for i, a in enumerate(_AX)],
        "p": [(("pd_gains", a, "p"), 0.0) for a in _AX],
        "d": [(("pd_gains", a, "d"), 0.0) for a in _AX],
        "error_scale": [(("solver", "error_scale"), 1.0)],
        "iterations": [(("solver", "iterations"), 1)],
    },
    "fzi-force": {
        "p": [(("pd_gains", a, "p"), 0.0) for a in _AX],
        "d": [(("pd_gains", a, "d"), 0.0) for a in _AX],
        "error_scale": [(("solver", "error_scale"), 1.0)],
    },
    "franka-cartesian-impedance": {  # where the example's dynamic_reconfigure server reads them
        "translational_stiffness": [((_FRANKA_NODE, "translational_stiffness"), 200.0)],
        "rotational_stiffness": [((_FRANKA_NODE, "rotational_stiffness"), 10.0)],
        "nullspace_stiffness": [((_FRANKA_NODE, "nullspace_stiffness"), 0.5)],
    },
}

_NOT_NEEDED = "not needed in simulation (kept in the file)"
# keys read for frames/interfaces or not modelled: each named in the notes with what happens to it
_KNOWN: dict[str, dict[str, str]] = {
    "ros2-admittance": {
        **{k: _NOT_NEEDED for k in (
            "joints", "command_joints", "state_interfaces", "chainable_command_interfaces", "kinematics.plugin_name",
            "kinematics.plugin_package", "kinematics.group_name", "ft_sensor.name", "ft_sensor.frame.external",
            "control.frame.external", "fixed_world_frame.frame.external", "gravity_compensation.frame.external",
            "robot_description")},
        "command_interfaces": "the arm is simulated through its position interface (the servo model)",
        "enable_parameter_update_without_reactivation": "parameters are constant during a simulation",
        "kinematics.base": "the robot's base", "kinematics.tip": "the robot's controlled frame",
        "ft_sensor.frame.id": "the robot's controlled frame (the sensor is taken at the tool)",
        "control.frame.id": "'base' when it names kinematics.base (or fixed_world_frame.frame.id), 'tool' for kinematics.tip",
        "fixed_world_frame.frame.id": "the robot's base (gravity along -z)",
        "gravity_compensation.frame.id": "'base' when it names kinematics.base (or fixed_world_frame.frame.id), 'tool' "
                                         "for kinematics.tip",
    },
    "fzi": {
        **{k: _NOT_NEEDED for k in (
            "joints", "type", "target_frame_topic", "robot_description", "solver.publish_state_feedback")},
        "command_interfaces": "the arm is simulated through its position interface (the servo model)",
        "robot_base_link": "the robot's base", "end_effector_link": "the robot's controlled frame",
        "ft_sensor_ref_link": "the robot's controlled frame (the sensor is taken at the tool)",
        "compliance_ref_link": "'base' when it names robot_base_link, else the robot's controlled frame",
        "hand_frame_control": "the target wrench (reference force) is taken in the base frame",
        "ik_solver": "only forward_dynamics is modelled",
        "solver.forward_dynamics.link_mass": "not read: the virtual model is the measured end-effector inertia "
                                             "(virtual_mass 1.3 kg, virtual_inertia 1 kg m^2)",
    },
    "franka-cartesian-impedance": {
        **{k: _NOT_NEEDED for k in ("type", "arm_id", "joint_names")},
        **{k: f"not read by franka_ros here (its dynamic_reconfigure server reads {_FRANKA_NODE}.{k}): not used"
           for k in _FRANKA_RANGES},
    },
}


@dataclass
class VendorConfig:
    """A controller's configuration as read from its own file.

    Attributes:
        kind: one of :data:`KINDS`. source: the file (or ``<text>``). text: the file's text.
        section: the controller's section in a YAML file (None for a script or .cfg).
        parameters: the controller's keyword arguments (library names), defaults filled in.
        rate: the controller's update rate [Hz] when the file gives it, else None.
        notes: keys not read, mapped or defaulted, in words (printed on stderr and in --json).
        layout: ``"ros2"``, ``"ros1"``, ``"cfg"`` or ``"urscript"``.
    """

    kind: str
    source: str
    text: str
    section: str | None
    parameters: dict[str, Any]
    rate: float | None
    notes: list[str] = field(default_factory=list)
    layout: str = "ros2"
    _node: Any = None
    _spans: Any = None
    _root: Any = None  # a YAML file's whole document (to see which values its anchors share)

    def write(self, **changes: Any) -> str:
        """The file's text with these parameters (library names) changed in place; every other byte kept.

        Raises:
            ParameterError: a name that is not one of the file's parameters, a value of the wrong
                length or (Franka's gains) outside its .cfg range, or a key whose parent table is
                missing (the message names it).
        """
        unknown = sorted(k for k in changes if k not in self.parameters or k not in self.writable())
        if unknown:
            raise ParameterError(f"cannot write {unknown[0]!r} to a {self.kind} file; writable: {', '.join(self.writable())}")
        if self.layout == "urscript":
            return write_ur_script(self.text, self._spans, self.parameters, changes)
        if self.layout == "cfg":
            return _write_cfg(self.text, self._spans, self.parameters, changes)
        if self.kind == "franka-cartesian-impedance":  # what dynamic_reconfigure would clamp is refused, as in a .cfg
            for name, v in changes.items():
                lo, hi = _FRANKA_RANGES[name]
                if not (isinstance(v, int | float) and lo <= v <= hi):
                    raise ParameterError(f"{name} must be within the .cfg range [{lo:g}, {hi:g}]; got {v!r}")
        return _write_yaml(self.text, self._node, _SLOTS[self.kind], self.parameters, changes, self._root)

    def writable(self) -> list[str]:
        """The parameters :meth:`write` can change in this file's format."""
        if self.layout == "urscript":
            return ["task_frame", "selection_vector", "wrench", "limits", "damping", "gain_scaling"]
        return list(_SLOTS[self.kind])


#: the controller classes this reads, by the last part of their plugin name (``<package>/<Class>``; FZI's ROS 1 plugins
#: are ``position_controllers/`` or ``velocity_controllers/Cartesian*Controller``)
_CLASSES = {"CartesianComplianceController": "fzi-compliance", "CartesianForceController": "fzi-force",
            "CartesianMotionController": "fzi-motion", "CartesianImpedanceExampleController": "franka-cartesian-impedance",
            "AdmittanceController": "ros2-admittance"}


def detect_kind(params: Any, type_name: str | None = None) -> str | None:
    """The format of one controller's parameter table (None: not a controller this reads).

    From its plugin type when there is one (the section's ``type``, or ``type_name``: a ROS 2 file gives it in the
    ``controller_manager`` block), by the class name alone: a type naming any other controller (franka_ros's
    ``CartesianPoseExampleController``, ``DualArmCartesianImpedanceExampleController``, FZI's
    ``MotionControlHandle``) is not read. Without a type, from the keys: ``admittance`` and ``kinematics`` (ros2
    admittance), ``translational_stiffness`` or the dynamic_reconfigure node (Franka), ``pd_gains``/``solver`` (FZI:
    compliance with ``stiffness`` or ``compliance_ref_link``, force with ``ft_sensor_ref_link``, else FZI's motion
    controller, which has neither).
    """
    if not isinstance(params, dict):
        return None
    typ = str(params.get("type") or type_name or "").strip()
    if typ:
        return _CLASSES.get(typ.rsplit("/", 1)[-1].strip())
    keys = {str(k).split(".", 1)[0] for k in params}  # "solver.error_scale: 0.2" is ROS 2's "solver: {error_scale: 0.2}"
    if "admittance" in keys and "kinematics" in keys:
        return "ros2-admittance"
    if "translational_stiffness" in keys or _FRANKA_NODE in keys:
        return "franka-cartesian-impedance"
    if "pd_gains" in keys or "solver" in keys:
        if "stiffness" in keys or "compliance_ref_link" in keys:
            return "fzi-compliance"
        if "ft_sensor_ref_link" in keys:
            return "fzi-force"
        return "fzi-motion"
    return None


def read_config(
    source: str | Path, kind: str | None = None, section: str | None = None, *, text: str | None = None
) -> VendorConfig:
    """Read a controller's configuration file (or ``text``) unmodified.

    Args:
        source: the file's path (or a label when ``text`` is given).
        kind: one of :data:`KINDS` (default: detected from the keys).
        section: the controller's section of a YAML file holding several (default: the first of the kind).

    Raises:
        ParameterError: unreadable file, unknown format or kind, a missing required key, a value
            that is not a number (each message names the file, the key and what was given).
    """
    where = str(source)
    if kind is not None and kind not in KINDS:
        raise ParameterError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    if text is None:
        try:
            text = Path(source).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ParameterError(f"{where}: cannot be read as UTF-8 text: {exc}") from exc
    if not text.strip():
        raise ParameterError(f"{where}: the file is empty (expected a controller's configuration: YAML, .cfg or URScript)")
    if Path(where).suffix.lower() == ".toml":  # a scenario, not a controller's own file
        raise ParameterError(f"{where}: a .toml file is a scenario, not a controller's own configuration (ROS YAML, "
                             f"dynamic_reconfigure .cfg, URScript): run it with `forcecontrol run {Path(where).name}`")
    if kind == "ur-force-mode" or (kind is None and re.search(r"^\s*force_mode\s*\(", text, re.M)):
        params, notes, spans = read_ur_script(text, where)
        return VendorConfig("ur-force-mode", where, text, None, params, None, notes, "urscript", None, spans)
    if re.search(r"^\s*gen\.add\s*\(", text, re.M):
        return _read_cfg(where, text, kind)
    return _read_yaml(where, text, kind, section)


#: the fastest controller update rate a file may give [Hz] (ros2_control loops run at up to a few kHz)
MAX_UPDATE_RATE = 1e6


def _rate(where: str, key: str, value: Any) -> float:
    """A file's update rate [Hz]: a finite number in (0, MAX_UPDATE_RATE], else a ParameterError naming the key (true,
    a string, a list, NaN and inf were a traceback or read as 1 Hz)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not (0.0 < float(value) <= MAX_UPDATE_RATE):
        raise ParameterError(f"{where}: key '{key}' must be a positive number of Hz, at most {MAX_UPDATE_RATE:g}; "
                             f"got {value!r}")
    return float(value)


def _load_yaml(where: str, text: str) -> Any:
    try:
        from ruamel.yaml import YAML
        from ruamel.yaml.error import YAMLError
    except ImportError as exc:  # pragma: no cover - the extra is installed in the tests
        raise ParameterError("reading ROS parameter files needs ruamel.yaml: pip install 'forcecontrol[ros]'") from exc
    try:
        doc = YAML(typ="rt").load(text)
    except YAMLError as exc:
        raise ParameterError(f"{where}: not valid YAML: {exc}") from exc
    _check_size(where, doc)
    return doc


#: the most values a parameter file may hold once its aliases are expanded (a controller's file has hundreds)
MAX_YAML_VALUES = 100_000


def _check_size(where: str, doc: Any) -> None:
    """Refuse a document that expands to more than :data:`MAX_YAML_VALUES` values (a YAML alias bomb of 12 lines ran
    past 2 minutes and 1.7 GB); the walk stops at the limit."""
    count, stack = 0, [doc]
    while stack:
        node = stack.pop()
        count += 1
        if count > MAX_YAML_VALUES:
            raise ParameterError(f"{where}: the file expands to more than {MAX_YAML_VALUES:,} values (YAML aliases "
                                 "repeat what they name); a controller's parameters are far fewer")
        if isinstance(node, dict):
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)


def _read_yaml(where: str, text: str, kind: str | None, section: str | None) -> VendorConfig:
    doc = _load_yaml(where, text)
    if not isinstance(doc, dict):
        raise ParameterError(f"{where}: expected a YAML mapping of controller sections; got {type(doc).__name__}")
    rate = None
    cm = doc.get("controller_manager")
    cm_params = cm.get("ros__parameters") if isinstance(cm, dict) else None
    types: dict[str, str] = {}  # ROS 2: each controller's plugin type, declared in the controller_manager block
    if isinstance(cm_params, dict):
        if "update_rate" in cm_params:
            rate = _rate(where, "controller_manager.ros__parameters.update_rate", cm_params["update_rate"])
        types = {str(n): str(v["type"]) for n, v in cm_params.items() if isinstance(v, dict) and v.get("type")}
    found: list[tuple[str, str, Any, str]] = []
    skipped: list[str] = []
    for name, sec in doc.items():
        if name == "controller_manager" or not isinstance(sec, dict):
            continue
        layout = "ros2" if isinstance(sec.get("ros__parameters"), dict) else "ros1"
        params = sec["ros__parameters"] if layout == "ros2" else sec
        k = detect_kind(params, types.get(str(name)))
        if k is not None:
            found.append((str(name), k, params, layout))
        elif params.get("type") or types.get(str(name)):
            skipped.append(f"{name} ({params.get('type') or types.get(str(name))})")
    if section is not None:
        found = [f for f in found if f[0] == section]
        if not found:
            raise ParameterError(f"{where}: no controller section {section!r}; sections: {', '.join(map(str, doc))}")
    if kind is not None:
        found = [f for f in found if f[1] == kind or (kind.startswith("fzi") and f[1].startswith("fzi"))]
    if section is None:  # FZI's motion controller beside the one a user tunes: passed over, named in the notes
        motion = [f for f in found if f[1] == "fzi-motion"]
        if len(motion) < len(found):
            found = [f for f in found if f[1] != "fzi-motion"]
            skipped += [f"{f[0]} (cartesian_motion_controller)" for f in motion]
    if not found:
        raise ParameterError(
            f"{where}: no controller configuration found (expected a section with admittance+kinematics, pd_gains/solver, "
            f"or translational_stiffness{'' if kind is None else ' of kind ' + kind}); top-level keys: {', '.join(map(str, doc))}"
            + (f"; sections of other controllers: {', '.join(skipped)}" if skipped else "")
        )
    name, k, params, layout = found[0]
    if k == "fzi-motion":
        raise ParameterError(f"{where}: section {name!r} is a cartesian_motion_controller: not one of {', '.join(KINDS)}"
                             " (it tracks a target pose; it has no force or compliance law)")
    k = kind or k
    notes = [f"section {o[0]!r} ({o[1]}) not read (use --section)" for o in found[1:]]
    notes += [f"section {s_!r} is not a controller this reads: not read" for s_ in skipped]
    values = _read_slots(where, params, _SLOTS[k], notes)
    if k == "ros2-admittance":  # generate_parameter_library's double arrays (FZI's own ROS 2 examples write integers)
        _say_integral_doubles(params, _SLOTS[k], notes)
    if k == "fzi-compliance" and layout == "ros1" and _get(params, ("solver", "iterations")) is _MISSING:
        values["iterations"] = 10
        notes[:] = [n for n in notes if not n.startswith("solver.iterations not set")]  # not the project's default 1
        notes.append("solver.iterations not set: the ROS 1 dynamic_reconfigure default 10 is used")
    if k.startswith("fzi") and layout == "ros1":  # ROS 1: dynamic_reconfigure servers clamp each value to its .cfg range
        _clamp_to_ranges(values, _SLOTS[k], _FZI_ROS1_RANGES, "ROS 1 dynamic_reconfigure range", notes)
    if k.startswith("fzi"):
        if str(params.get("ik_solver", "forward_dynamics")) != "forward_dynamics":
            raise ParameterError(f"{where}: ik_solver {params['ik_solver']!r} is not modelled (only forward_dynamics)")
        base = params.get("robot_base_link")
        if k == "fzi-compliance":
            ref = params.get("compliance_ref_link")
            values["compliance_frame"] = "base" if base is not None and ref == base else "tool"
            if ref is None:
                notes.append("compliance_ref_link not set: the stiffness is taken in the end-effector (tool) frame "
                             "(set it: the controller applies the stiffness in that frame)")
    if k == "ros2-admittance":
        values["control_frame"] = _admittance_frame(where, params, ("control", "frame", "id"), notes)
        values["payload_frame"] = _admittance_frame(where, params, ("gravity_compensation", "frame", "id"), notes)
        values["selected_axes"] = [bool(v) for v in values["selected_axes"]]
    if k == "franka-cartesian-impedance":
        if not any(str(key).split(".", 1)[0] == _FRANKA_NODE for key in params):
            notes.append(f"no {_FRANKA_NODE} table in the file: the defaults of franka_example_controllers/cfg/"
                         "compliance_param.cfg are used (translational 200 N/m, rotational 10 N m/rad, nullspace 0.5)")
        # dynamic_reconfigure clamps a parameter to its .cfg range
        _clamp_to_ranges(values, _SLOTS[k], {g: [r] for g, r in _FRANKA_RANGES.items()}, ".cfg range", notes)
    known = _KNOWN["fzi" if k.startswith("fzi") else k]
    read = {".".join(str(x) for x in path if not isinstance(x, int)) for slots in _SLOTS[k].values() for path, _ in slots}
    grouped: dict[str, list[str]] = {}
    own_rate = _get(params, ("update_rate",))
    if own_rate is not _MISSING:  # ros2_control: a controller's own update_rate comes before the controller manager's
        own_rate = _rate(where, "update_rate", own_rate)
        if rate is not None and float(own_rate) != rate:
            notes.append(f"update_rate {float(own_rate):g} Hz of the controller's own parameters is used (the "
                         f"controller_manager's is {rate:g} Hz)")
        rate = float(own_rate)
        read.add("update_rate")
    if k.startswith("fzi") and str(params.get("type", "")).startswith("velocity_controllers/"):
        notes.append(f"type {params['type']}: the velocity-interface variant; the arm is simulated through its position "
                     "interface (the servo model)")
    if k in ("fzi-force", "fzi-compliance") and _get(params, ("hand_frame_control",)) is _MISSING:
        notes.append("hand_frame_control not set: upstream's default true takes the target wrench in end_effector_link; "
                     "the simulation takes the reference force in the base frame")
    for key in _leaves(params):
        if key in read:
            continue
        if key in known:
            shown = key if known[key] == _NOT_NEEDED else f"{key} = {_short(_get(params, tuple(key.split('.'))))}"
            grouped.setdefault(known[key], []).append(shown)
        elif not (k.startswith("fzi") and key.split(".")[0] in ("gravity", "tool")):
            notes.append(f"{key}: unsupported key, not read")
        else:
            notes.append(f"{key}: ROS 1 gravity compensation of the force controllers is not modelled (not read)")
    notes += [f"{', '.join(keys)}: {reason}" for reason, keys in grouped.items()]
    if rate is None:
        notes.append("no update_rate in the file (controller_manager's or the controller's): the rate comes from the "
                     "scenario")
    return VendorConfig(k, where, text, name, values, rate, notes, layout, params, None, doc)


_MISSING = object()


def _clamp_to_ranges(values: dict[str, Any], slots: dict[str, list[tuple[tuple[Any, ...], Any]]],
                     ranges: dict[str, list[tuple[float, float]]], what: str, notes: list[str]) -> None:
    """Clamp each value read to its range (one per value of the slot), as a dynamic_reconfigure server does with what
    the parameter server holds; each clamped value said in ``notes`` with its key."""
    for gain, bounds in ranges.items():
        if gain not in values:
            continue
        vals = values[gain] if isinstance(values[gain], list) else [values[gain]]
        keys = [".".join(str(x) for x in path) for path, _ in slots[gain]]
        for i, (v, (lo, hi), key) in enumerate(zip(vals, bounds, keys)):
            if not lo <= v <= hi:
                vals[i] = type(v)(min(hi, max(lo, v)))
                notes.append(f"{key} = {v!r} is outside its {what} [{lo:g}, {hi:g}]: dynamic_reconfigure clamps it "
                             f"to {vals[i]:g}")
        values[gain] = vals if isinstance(values[gain], list) else vals[0]


def _admittance_frame(where: str, params: Any, path: tuple[str, ...], notes: list[str]) -> str:
    """The simulated frame ('base' or 'tool') of a ros2 admittance frame id. admittance_rule_impl.hpp rotates K, D, M,
    the selected axes (control.frame.id) and the CoG (gravity_compensation.frame.id) into that frame at the current
    joints: kinematics.base is the base, kinematics.tip the tool; fixed_world_frame.frame.id is taken as the base
    and ft_sensor.frame.id as the tool (said); any other name is refused: a fixed frame turned from the base, or a
    link between base and tip, is not modelled, and reading it as the tool would turn the gains with the arm."""
    key = ".".join(path)
    fid = _get(params, path)
    base, tip = _get(params, ("kinematics", "base")), _get(params, ("kinematics", "tip"))
    world = _get(params, ("fixed_world_frame", "frame", "id"))
    if fid is _MISSING:
        notes.append(f"{key} not set: taken as kinematics.tip, the tool (set it: the controller takes its gains and "
                     "selected axes in that frame)")
        return "tool"
    if fid == base:
        return "base"
    if fid == tip:
        return "tool"
    sensor = _get(params, ("ft_sensor", "frame", "id"))
    if fid == sensor:  # the sensor is simulated at the tool (ft_sensor.frame.id's own note)
        notes.append(f"{key} = {fid!r} is ft_sensor.frame.id: taken as the tool, where the sensor is simulated (a "
                     "rotation between the sensor's frame and kinematics.tip is not modelled)")
        return "tool"
    if fid == world:
        notes.append(f"{key} = {fid!r} is fixed_world_frame.frame.id: taken as the robot's base (kinematics.base "
                     f"{base!r}), i.e. the two are assumed to coincide")
        return "base"
    raise ParameterError(f"{where}: {key} {fid!r} is neither kinematics.base {base!r}, kinematics.tip {tip!r}, "
                         f"ft_sensor.frame.id {sensor if sensor is not _MISSING else None!r} nor "
                         f"fixed_world_frame.frame.id {world if world is not _MISSING else None!r}: the simulation does not "
                         "know where that frame is (a fixed frame turned from the base, or a link of the arm); name one "
                         "of those frames")


def _locate(node: Any, path: tuple[Any, ...]) -> list[tuple[Any, Any]]:
    """Every (mapping or list, key) that holds ``path``'s value. ROS 2 reads a nested map and dotted names as the same
    parameters (``solver: {error_scale: 0.2}`` is ``solver.error_scale: 0.2``), so each run of names may be one dotted
    key or several nested ones."""
    if not path:
        return []
    head = path[0]
    if isinstance(head, int):
        if not isinstance(node, list) or head >= len(node):
            return []
        return [(node, head)] if len(path) == 1 else _locate(node[head], path[1:])
    if not isinstance(node, dict):
        return []
    names = []
    for x in path:
        if isinstance(x, int):
            break
        names.append(str(x))
    out: list[tuple[Any, Any]] = []
    for i in range(1, len(names) + 1):
        key = ".".join(names[:i])
        if key in node:
            out += [(node, key)] if i == len(path) else _locate(node[key], path[i:])
    return out


def _get(node: Any, path: tuple[Any, ...]) -> Any:
    """The value at ``path`` (nested or dotted keys, :func:`_locate`), or ``_MISSING``.

    Raises:
        ParameterError: the parameter is given twice (nested and dotted): ROS 2 keeps one of them.
    """
    found = _locate(node, path)
    if len(found) > 1:
        dotted = ".".join(str(x) for x in path if not isinstance(x, int))
        raise ParameterError(f"key {dotted!r} is given more than once (as nested and as dotted keys): ROS 2 reads them "
                             "as one parameter; keep one")
    if not found:
        return _MISSING
    parent, key = found[0]
    return parent[key]


def _read_slots(where: str, params: Any, slots: dict[str, list[tuple[tuple[Any, ...], Any]]], notes: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, entries in slots.items():
        _check_array(where, params, entries)
        vals = []
        missing = []
        for path, default in entries:
            v = _get(params, path)
            dotted = ".".join(str(x) for x in path if not isinstance(x, int))
            if v is _MISSING:
                if default is _REQ:
                    raise ParameterError(f"{where}: key {dotted!r} is required ({len(entries)} values); not found")
                v = default
                missing.append((dotted, default))
            elif isinstance(v, bool) != (name == "selected_axes") or not isinstance(v, int | float):
                what = "true/false" if name == "selected_axes" else "a number"
                raise ParameterError(f"{where}: key {dotted!r} must be {what}; got {v!r}")
            elif name == "iterations" and not (isinstance(v, int) or float(v).is_integer()):
                raise ParameterError(f"{where}: key {dotted!r} must be an integer; got {v!r}")
            vals.append(v if isinstance(v, bool) else (int(v) if name == "iterations" else float(v)))
        if missing:
            keys = ", ".join(m[0] for m in missing)
            defaults = sorted({m[1] for m in missing})
            notes.append(f"{keys} not set: the project's default {' / '.join(map(repr, defaults))} is used")
        out[name] = vals[0] if len(entries) == 1 else vals
    return out


def _say_integral_doubles(params: Any, slots: dict[str, list[tuple[tuple[Any, ...], Any]]], notes: list[str]) -> None:
    """Note the double parameters a ros2_controllers file writes as integers (``mass: [5, 6, ...]``): a parameter
    declared as a double (array) does not take an integer when the robot loads the file; read here as the numbers they
    are."""
    keys: dict[str, int] = {}
    for name, entries in slots.items():
        if name in ("iterations", "selected_axes"):  # an integer and booleans
            continue
        for path, _ in entries:
            v = _get(params, path)
            if isinstance(v, int) and not isinstance(v, bool):
                dotted = ".".join(str(x) for x in path if not isinstance(x, int))
                keys[dotted] = keys.get(dotted, 0) + 1
    if keys:
        said = ", ".join(k if n == 1 else f"{k} ({n} values)" for k, n in keys.items())
        notes.append(f"{said}: written as integers; the controller declares them as doubles, which do not take an "
                     "integer when the robot loads the file (write 5.0, not 5); read here as numbers")


def _check_array(where: str, params: Any, entries: list[tuple[tuple[Any, ...], Any]]) -> None:
    """A slot read element by element from one array (``admittance.mass[0]`` ... ``[5]``, ROS 2's double arrays): the
    array, when given, must be a list of exactly that many values (a longer one was cut, a scalar reported as missing).

    Raises:
        ParameterError: naming the key, the length expected and what was given.
    """
    parents = {path[:-1] for path, _ in entries}
    if len(parents) != 1 or not all(isinstance(path[-1], int) for path, _ in entries):
        return
    parent = next(iter(parents))
    value = _get(params, parent)
    if value is _MISSING:
        return
    dotted = ".".join(str(x) for x in parent if not isinstance(x, int))
    n = len(entries)
    if not isinstance(value, list):
        raise ParameterError(f"{where}: key {dotted!r} must be a list of {n} values (one per axis); got {_short(value)}")
    if len(value) != n:
        raise ParameterError(f"{where}: key {dotted!r} must have {n} values (one per axis); got {len(value)}: "
                             f"{_short(value)}")


def _leaves(node: Any, prefix: str = "") -> list[str]:
    if isinstance(node, dict):
        out = []
        for k, v in node.items():
            out += _leaves(v, f"{prefix}{k}.") if isinstance(v, dict) else [f"{prefix}{k}"]
        return out
    return [prefix.rstrip(".")]


def _short(v: Any) -> str:
    s = repr(list(v) if isinstance(v, list) else v)
    return s if len(s) < 60 else s[:57] + "..."


def _paths_to(root: Any) -> tuple[dict[int, int], dict[int, set[str]]]:
    """How many paths from the document's root reach each mapping, list and anchored scalar (by ``id``): more than one
    when a YAML alias (``*name``) or merge key (``<<``) repeats it; and the anchors (``&name``) of the blocks that hold
    it, its own included. The walk follows each alias once per path (a recursive alias is cut where it recurs);
    :func:`_check_size` has bounded the expanded document."""
    counts: dict[int, int] = {}
    anchors: dict[int, set[str]] = {}
    stack: list[tuple[Any, frozenset[int], tuple[str, ...]]] = [(root, frozenset(), ())]
    while stack:
        node, above, names = stack.pop()
        name = _anchor(node)
        container = isinstance(node, dict | list)
        if (not container and not name) or id(node) in above:
            continue
        names = (*names, name) if name else names
        counts[id(node)] = counts.get(id(node), 0) + 1
        anchors.setdefault(id(node), set()).update(names)
        if container:
            children = node.values() if isinstance(node, dict) else node
            stack += [(c, above | {id(node)}, names) for c in children]
    return counts, anchors


def _anchor(node: Any) -> str | None:
    a = getattr(node, "anchor", None)
    return getattr(a, "value", None) if a is not None else None


def _own_keys(mapping: Any) -> list[Any]:
    """The keys written in this mapping itself (not inherited through a merge key ``<<``)."""
    data = mapping.lc.data or {}
    return [k for k in mapping if k in data]


def _target(parent: Any, key: Any) -> tuple[int, Any]:
    """Where a value stands in the file: an anchored scalar by itself (its aliases are the same object), any other
    value by its mapping or list and key."""
    value = parent[key]
    return (id(value), None) if _anchor(value) else (id(parent), key)


def _shared(parent: Any, key: Any, path: tuple[Any, ...], counts: dict[int, int], anchors: dict[int, set[str]],
            writers: dict[tuple[int, Any], list[Any]]) -> str | None:
    """Why the value at ``path`` (``parent[key]``) cannot be written where it stands, or None.

    Refused: a value inherited through a merge key (it stands in the merged block), and a value that more paths of the
    document reach (an alias or merge key repeats it, or the block holding it) than this write's own slots, or that
    this write's slots would set to different values. Allowed: aliases inside the section that this write sets
    alike (FZI's ``trans_y: *tr`` given the same gains as ``trans_x: &tr``).
    """
    if isinstance(parent, dict):
        if key not in _own_keys(parent):
            return f"its value comes from a merge key ('<<: *...') in {'.'.join(str(x) for x in path[:-1]) or 'the section'}"
    target = _target(parent, key)
    paths = counts.get(target[0], 1)
    values = writers.get(target, [])
    if paths <= 1 or (paths == len(values) and all(v == values[0] for v in values)):
        return None
    names = sorted(anchors.get(target[0], ()))
    if target[1] is None:
        return f"its value carries the anchor '&{names[-1]}', which an alias ('*{names[-1]}') uses elsewhere"
    return ("it lies in " + (f"the anchored block '&{names[-1]}'" if names else "a block")
            + " that an alias or a merge key repeats elsewhere in the file")


def _write_yaml(text: str, params: Any, slots: dict[str, list[tuple[tuple[Any, ...], Any]]], old: dict[str, Any],
                new: dict[str, Any], root: Any = None) -> str:
    """The text with the changed values written where they stand.

    Raises:
        ParameterError: a value whose parent key is missing, a list too short, or a value the file shares through a
            YAML anchor, alias or merge key beyond this write (written in place it would change the keys that share it:
            the message names the key and says how the file shares it).
    """
    lines = text.splitlines(keepends=True)
    edits: list[Edit] = []
    counts, anchors = _paths_to(root) if root is not None else ({}, {})
    writers: dict[tuple[int, Any], list[Any]] = {}  # where each slot of the file stands -> the values this write gives
    for name, entries in slots.items():
        if name not in old:
            continue
        given = new.get(name, old[name])
        vals = list(given) if isinstance(given, list | tuple) else [given]
        for (path, _), v in zip(entries, vals):
            held = _locate(params, path)
            if len(held) == 1:
                writers.setdefault(_target(*held[0]), []).append(v)
    written: set[tuple[int, Any]] = set()
    for name, value in new.items():
        entries = slots[name]
        vals = list(value) if isinstance(value, list | tuple) else [value]
        olds = old[name] if isinstance(old[name], list) else [old[name]]
        if len(vals) != len(entries):
            raise ParameterError(f"{name} must have {len(entries)} values; got {len(vals)}")
        for (path, _), v, o in zip(entries, vals, olds):
            if v == o:
                continue
            if name == "iterations" and (isinstance(v, bool) or not isinstance(v, int | float) or not float(v).is_integer()):
                raise ParameterError(f"iterations must be an integer; got {v!r}")
            v = bool(v) if name == "selected_axes" else (int(v) if name == "iterations" else float(v))
            cur = _get(params, path)
            held = _locate(params, path)  # where the value is written (a nested or a dotted key)
            parent, key = (held[0] if held else (_get(params, path[:-1]), path[-1]))
            dotted = ".".join(str(x) for x in path)
            if parent is _MISSING or parent is None:
                raise ParameterError(f"cannot write {dotted}: its parent key is not in the file; add it by hand")
            if cur is not _MISSING:
                why = _shared(parent, key, path, counts, anchors, writers)
                if why:
                    raise ParameterError(f"cannot write {dotted}: {why}; written there it would change every key that "
                                         "shares it. Give this controller its own value in its section (or, for keys "
                                         "of this controller that share it, the same value to each), or edit the file "
                                         "by hand")
                if _target(parent, key) in written:  # an alias this write sets alike: written once
                    continue
                written.add(_target(parent, key))
                line, col = parent.lc.item(key) if isinstance(key, int) else parent.lc.value(key)
                anchor = re.match(r"&[^\s,\]}]+\s+", lines[line][col:])  # the value's anchor is kept
                col += anchor.end() if anchor else 0
                end = plain_scalar_end(lines[line], col)
                edits.append((line, col, end, format_number(v, lines[line][col:end])))
                continue
            if isinstance(key, int):
                raise ParameterError(f"cannot write {dotted}: the list in the file is shorter; fix its length by hand")
            own = _own_keys(parent)
            if counts.get(id(parent), 1) > 1 or not own:
                how = ("its mapping holds only keys from a merge key ('<<: *...')" if not own else
                       "its mapping is one that an alias or a merge key repeats elsewhere in the file")
                raise ParameterError(f"cannot add {dotted}: {how}; add it to this controller's section by hand")
            if parent.fa.flow_style():
                line, col = parent.lc.value(own[-1])
                edits.append((line, plain_scalar_end(lines[line], col), None, f", {key}: {format_number(v)}"))
            else:
                line, col = parent.lc.key(own[0])
                edits.append((line, -1, None, f"{' ' * col}{key}: {format_number(v)}\n"))
    return apply_edits(text, edits)


_CFG = re.compile(r'gen\.add\(\s*"(\w+)"\s*,\s*\w+\s*,\s*[^,]+,\s*"[^"]*"\s*,\s*([^,]+?)\s*,\s*([^,]+?)\s*,\s*([^)]+?)\s*\)')


def _read_cfg(where: str, text: str, kind: str | None) -> VendorConfig:
    """franka_ros's ``compliance_param.cfg``: ``gen.add("name", double_t, level, "doc", default, min, max)``."""
    if kind not in (None, "franka-cartesian-impedance"):
        raise ParameterError(f"{where}: a dynamic_reconfigure .cfg is read as franka-cartesian-impedance; got kind {kind!r}")
    values: dict[str, Any] = {}
    spans: dict[str, Any] = {}
    notes: list[str] = []
    for i, line in enumerate(text.splitlines()):
        m = _CFG.search(line)
        if not m:
            continue
        name = m.group(1)
        try:
            default, lo, hi = float(m.group(2)), float(m.group(3)), float(m.group(4))
        except ValueError as exc:
            raise ParameterError(f"{where}: line {i + 1}: gen.add({name!r}, ...) needs literal default, min, max") from exc
        if name in _SLOTS["franka-cartesian-impedance"]:
            values[name] = default
            spans[name] = (i, m.start(2), m.end(2), lo, hi)
        else:
            notes.append(f"line {i + 1}: parameter {name!r} not read (not a gain of the Cartesian impedance example)")
    for name, slots in _SLOTS["franka-cartesian-impedance"].items():
        if name not in values:
            values[name] = slots[0][1]
            notes.append(f"{name} not in the file: the project's default {slots[0][1]!r} is used")
    notes.append("no rate in a .cfg file: the Franka's 1 kHz is used")
    return VendorConfig("franka-cartesian-impedance", where, text, None, values, 1000.0, notes, "cfg", None, spans)


def _write_cfg(text: str, spans: dict[str, Any], old: dict[str, Any], new: dict[str, Any]) -> str:
    edits: list[Edit] = []
    for name, v in new.items():
        if name not in spans:
            raise ParameterError(f"cannot write {name}: it has no gen.add line in the .cfg file; add it by hand")
        line, a, b, lo, hi = spans[name]
        if not lo <= float(v) <= hi:
            raise ParameterError(f"{name} must be within the .cfg range [{lo:g}, {hi:g}]; got {v!r}")
        if float(v) != float(old[name]):
            edits.append((line, a, b, format_number(float(v))))
    return apply_edits(text, edits)
