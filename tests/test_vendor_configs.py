"""Reading the vendor/ROS controllers' own configuration files and writing tuned values back in place (issue 30, item 3)."""

from __future__ import annotations

import difflib
from importlib import resources
from pathlib import Path

import pytest

from forcecontrol.errors import ParameterError
from forcecontrol.realarm.conventions.configs import read_config

pytest.importorskip("ruamel.yaml")

CONFIGS = Path(str(resources.files("forcecontrol.scenarios"))) / "configs"
SHIPPED = {
    "ros2_admittance.yaml": "ros2-admittance",
    "fzi_compliance.yaml": "fzi-compliance",
    "fzi_force.yaml": "fzi-force",
    "franka_cartesian_impedance.yaml": "franka-cartesian-impedance",
    "compliance_param.cfg": "franka-cartesian-impedance",
    "ur_force_mode.script": "ur-force-mode",
}

# the layout of the project's own test_params.yaml (flow lists with comments, the '.0' rule), written for this test
ROS2_FLOW = """\
test_admittance_controller:
  # contains minimal needed parameters for kuka_kr6
  ros__parameters:
    joints: [joint1, joint2, joint3, joint4, joint5, joint6]
    command_interfaces: [position]
    kinematics:
      plugin_name: kinematics_interface_kdl/KinematicsInterfaceKDL
      base: base_link # Assumed to be stationary
      tip: tool0
      alpha: 0.0005
    ft_sensor:
      frame:
        id: link_6  # tool0 Wrench measurements are in this frame
      filter_coefficient: 0.005
    control:
      frame:
        id: tool0
    gravity_compensation:
      frame:
        id: tool0
      CoG: # specifies the center of gravity of the end effector
        pos: [0.1, 0.0, 0.0]
        force: 23.0 # mass * 9.81
    admittance:
      selected_axes: [true, true, true, true, true, true]   # x y z rx ry rz
      # Having ".0" at the end is MUST, otherwise there is a loading error
      mass: [5.5, 6.6, 7.7, 8.8, 9.9, 10.10]
      damping_ratio: [2.828427, 2.828427, 2.828427, 2.828427, 2.828427, 2.828427]  # zeta = D / (2 * sqrt( M * S ))
      stiffness: [214.1, 214.2, 214.3, 214.4, 214.5, 214.6]
    my_vendor_extension: {gain: 3}   # a key this library does not know
"""


def _changed_lines(a: str, b: str) -> list[tuple[str, str]]:
    al, bl = a.splitlines(), b.splitlines()
    assert len(al) == len(bl)
    return [(x, y) for x, y in zip(al, bl) if x != y]


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_shipped_examples_read_as_their_kind_and_round_trip_byte_for_byte(name):
    """Each shipped example is detected as its project's format, and writing it back unchanged gives the same bytes."""
    cfg = read_config(CONFIGS / name)
    assert cfg.kind == SHIPPED[name]
    assert cfg.write() == cfg.text
    assert cfg.write(**{k: cfg.parameters[k] for k in cfg.writable()}) == cfg.text


def test_shipped_ros2_example_values_are_the_documented_ones():
    """The admittance example reads as the project's test_params (mass, ζ = 2√2, stiffness, α, CoG), joint_damping 5."""
    p = read_config(CONFIGS / "ros2_admittance.yaml").parameters
    assert p["mass"] == [5.5, 6.6, 7.7, 8.8, 9.9, 10.1]
    assert p["damping_ratio"] == [2.828427] * 6
    assert p["stiffness"] == [214.1, 214.2, 214.3, 214.4, 214.5, 214.6]
    assert (p["filter_coefficient"], p["kinematics_alpha"], p["joint_damping"]) == (0.005, 0.0005, 5.0)
    assert (p["payload_weight"], p["payload_cog"]) == (23.0, [0.1, 0.0, 0.0])


def test_flow_list_value_changes_only_its_token_and_keeps_comments():
    """Tuning mass[2] in a flow list rewrites that number only: the line's other values and its comment stay."""
    cfg = read_config("test_params.yaml", text=ROS2_FLOW)
    mass = list(cfg.parameters["mass"])
    mass[2] = 3.0
    out = cfg.write(mass=mass)
    assert _changed_lines(ROS2_FLOW, out) == [
        ("      mass: [5.5, 6.6, 7.7, 8.8, 9.9, 10.10]", "      mass: [5.5, 6.6, 3.0, 8.8, 9.9, 10.10]")
    ]
    assert read_config("x.yaml", text=out).parameters["mass"] == [5.5, 6.6, 3.0, 8.8, 9.9, 10.1]


def test_integral_double_keeps_its_decimal_point():
    """A tuned value of 300 for a double parameter is written 300.0 (the project fails to load a bare integer)."""
    cfg = read_config("p.yaml", text=ROS2_FLOW)
    out = cfg.write(stiffness=[300, 214.2, 214.3, 214.4, 214.5, 214.6])
    assert "stiffness: [300.0, 214.2," in out


def test_unknown_keys_are_kept_and_named_in_the_notes():
    """A key the library does not know survives a write and is named in the notes (nothing ignored silently)."""
    cfg = read_config("p.yaml", text=ROS2_FLOW)
    assert any(n.startswith("my_vendor_extension.gain: unsupported key") for n in cfg.notes)
    assert any(n.startswith("admittance.joint_damping not set") for n in cfg.notes)
    out = cfg.write(filter_coefficient=0.05)
    assert "    my_vendor_extension: {gain: 3}   # a key this library does not know\n" in out
    assert _changed_lines(ROS2_FLOW, out) == [("      filter_coefficient: 0.005", "      filter_coefficient: 0.05")]


def test_missing_key_is_inserted_beside_its_siblings():
    """joint_damping (absent, default 5) written as 2.0 becomes a new key of 'admittance' with its siblings' indentation."""
    out = read_config("p.yaml", text=ROS2_FLOW).write(joint_damping=2.0)
    diff = [d for d in difflib.ndiff(ROS2_FLOW.splitlines(), out.splitlines()) if d[:1] in "+-"]
    assert diff == ["+       joint_damping: 2.0"]
    assert read_config("p.yaml", text=out).parameters["joint_damping"] == 2.0


def test_fzi_flow_mapping_gets_the_missing_d_gain():
    """pd_gains.rot_x = {p: 1.5} gains ', d: 0.01' inside its braces; the other axes are untouched."""
    cfg = read_config(CONFIGS / "fzi_compliance.yaml")
    d = list(cfg.parameters["d"])
    d[3] = 0.01
    out = cfg.write(d=d, error_scale=0.3)
    assert _changed_lines(cfg.text, out) == [
        ("        error_scale: 0.5", "        error_scale: 0.3"),
        ("        rot_x: {p: 1.5}", "        rot_x: {p: 1.5, d: 0.01}"),
    ]
    assert cfg.rate == 100.0


def test_ur_script_values_rewritten_in_place_and_missing_call_added():
    """force_mode's wrench number changes in place; a missing force_mode_set_damping line is added before force_mode."""
    text = "zero_ftsensor()\n  force_mode(p[0,0,0,0,0,0], [0,0,1,0,0,0], [0,0,-10,0,0,0], 2, [0.1,0.1,0.05,0.2,0.2,0.2])\n"
    cfg = read_config("prog.script", text=text)
    assert cfg.parameters["damping"] == 0.005 and cfg.parameters["gain_scaling"] == 1.0
    assert any("zero_ftsensor" in n for n in cfg.notes)
    out = cfg.write(wrench=[0, 0, -12.5, 0, 0, 0], damping=0.05)
    assert out == ("zero_ftsensor()\n  force_mode_set_damping(0.05)\n"
                   "  force_mode(p[0,0,0,0,0,0], [0,0,1,0,0,0], [0,0,-12.5,0,0,0], 2, [0.1,0.1,0.05,0.2,0.2,0.2])\n")


def test_franka_cfg_default_rewritten_and_range_enforced():
    """The .cfg default of translational_stiffness is rewritten in place; a value outside its [0, 400] range is refused."""
    cfg = read_config(CONFIGS / "compliance_param.cfg")
    out = cfg.write(translational_stiffness=350.0)
    assert len(_changed_lines(cfg.text, out)) == 1 and '"Cartesian translational stiffness", 350.0, 0, 400)' in out
    with pytest.raises(ParameterError, match=r"translational_stiffness must be within the \.cfg range \[0, 400\]; got 500"):
        cfg.write(translational_stiffness=500.0)


def _franka_yaml(extra: str) -> str:
    return (CONFIGS / "franka_cartesian_impedance.yaml").read_text(encoding="utf-8") + extra


def test_franka_gains_are_read_where_franka_ros_reads_them_and_clamped_to_the_cfg_range():
    """The example's gains come from its dynamic_reconfigure server: <controller>/dynamic_reconfigure_compliance_param_node/
    NAME is read (and clamped to compliance_param.cfg's range, as the server does); a gain at the controller's top level,
    which franka_ros does not read, is not used and said so."""
    node = "dynamic_reconfigure_compliance_param_node"
    cfg = read_config("f.yaml", text=_franka_yaml(f"  translational_stiffness: 300\n  {node}:\n    rotational_stiffness: 50\n"
                                                   "    nullspace_stiffness: 2\n"))
    assert cfg.kind == "franka-cartesian-impedance"
    assert cfg.parameters == {"translational_stiffness": 200.0, "rotational_stiffness": 30.0, "nullspace_stiffness": 2.0}
    assert any(n.startswith("translational_stiffness = 300: not read by franka_ros") and f"{node}.translational_stiffness" in n
               for n in cfg.notes), cfg.notes
    clamped = f"{node}.rotational_stiffness = 50.0 is outside its .cfg range [0, 30]: dynamic_reconfigure clamps it to 30"
    assert clamped in cfg.notes, cfg.notes
    assert not any("unsupported" in n for n in cfg.notes), cfg.notes
    out = cfg.write(nullspace_stiffness=3.0)  # in place, under the server's table
    assert _changed_lines(cfg.text, out) == [("    nullspace_stiffness: 2", "    nullspace_stiffness: 3.0")]
    with pytest.raises(ParameterError, match=r"rotational_stiffness must be within the \.cfg range \[0, 30\]; got 31"):
        cfg.write(rotational_stiffness=31.0)
    bare = read_config(CONFIGS / "franka_cartesian_impedance.yaml")  # no server table: compliance_param.cfg's defaults
    assert bare.parameters == {"translational_stiffness": 200.0, "rotational_stiffness": 10.0, "nullspace_stiffness": 0.5}
    assert any(n.startswith(f"no {node} table in the file") for n in bare.notes)
    with pytest.raises(ParameterError, match=f"cannot write {node}.nullspace_stiffness: its parent key is not in the file"):
        bare.write(nullspace_stiffness=3.0)
    shipped = read_config(CONFIGS / "compliance_param.cfg")  # the ranges used are the .cfg's
    from forcecontrol.realarm.conventions.configs import _FRANKA_RANGES

    assert {name: span[3:] for name, span in shipped._spans.items()} == _FRANKA_RANGES


@pytest.mark.parametrize("text, kind, match", [
    ("c:\n  ros__parameters:\n    admittance: {stiffness: [1, 2, 3, 4, 5, 6]}\n    kinematics: {}\n", None,
     r"key 'admittance.mass' is required \(6 values\); not found"),
    (ROS2_FLOW.replace("force: 23.0", "force: heavy"), None,
     r"key 'gravity_compensation.CoG.force' must be a number; got 'heavy'"),
    ("m:\n  ros__parameters:\n    type: x/CartesianMotionController\n    pd_gains: {}\n", None, "cartesian_motion_controller"),
    ("a: 1\n", None, "no controller configuration found"),
    ("force_mode(tool_pose(), [0,0,1,0,0,0], w, 2, l)\n", None, "expected 25 literal numbers"),
    (ROS2_FLOW, "abb-egm", "kind must be one of"),
])
def test_bad_configurations_are_refused_with_the_key_named(text, kind, match):
    """A missing required key, a non-number, an unmodelled controller, no controller, a script with variables, an unknown kind."""
    with pytest.raises(ParameterError, match=match):
        read_config("bad.yaml", kind, text=text)


def test_writing_a_parameter_the_file_cannot_hold_is_refused():
    """write() names the parameter and the writable ones for a name that is not in the format."""
    with pytest.raises(ParameterError, match="cannot write 'stiffness' to a fzi-force file; writable: p, d, error_scale"):
        read_config(CONFIGS / "fzi_force.yaml").write(stiffness=[1.0] * 6)
