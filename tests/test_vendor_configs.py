"""Reading the vendor/ROS controllers' own configuration files and writing tuned values back in place (issue 30, item 3)."""

from __future__ import annotations

import difflib
import re
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


def test_ur_script_comment_with_parentheses_and_numbers_is_not_part_of_the_call():
    """``force_mode(...)  # press down (10 N)``: the comment was pulled into the call (26 numbers, refused); now the
    call's values are read and a rewrite keeps the comment."""
    text = "force_mode(p[0,0,0,0,0,0], [0,0,1,0,0,0], [0,0,-10,0,0,0], 2, [0.1,0.1,0.05,0.2,0.2,0.2])  # press (10 N)\n"
    cfg = read_config("prog.script", text=text)
    assert cfg.parameters["wrench"] == [0.0, 0.0, -10.0, 0.0, 0.0, 0.0]
    assert cfg.write(wrench=[0, 0, -12, 0, 0, 0]) == text.replace("-10,", "-12,")

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
    # an array with a seventh value (was cut to six), a scalar for an array (was reported as not found)
    (ROS2_FLOW.replace("mass: [", "mass: [1.0, ", 1), None,
     r"key 'admittance.mass' must have 6 values \(one per axis\); got 7: \[1\.0, "),
    (ROS2_FLOW, "scalar-mass", r"key 'admittance.mass' must be a list of 6 values \(one per axis\); got 5\.0"),
    (ROS2_FLOW.replace("force: 23.0", "force: heavy"), None,
     r"key 'gravity_compensation.CoG.force' must be a number; got 'heavy'"),
    ("m:\n  ros__parameters:\n    type: x/CartesianMotionController\n    pd_gains: {}\n", None, "cartesian_motion_controller"),
    ("a: 1\n", None, "no controller configuration found"),
    ("force_mode(tool_pose(), [0,0,1,0,0,0], w, 2, l)\n", None,
     r"task_frame must be written p\[x, x, x, x, x, x\]; got 'tool_pose\(\)'"),
    (ROS2_FLOW, "abb-egm", "kind must be one of"),
])
def test_bad_configurations_are_refused_with_the_key_named(text, kind, match):
    """A missing required key, a non-number, an unmodelled controller, no controller, a script with variables, an unknown kind."""
    if kind == "scalar-mass":
        text, kind = re.sub(r"mass: \[[^\]]*\]", "mass: 5.0", text, count=1), None
    with pytest.raises(ParameterError, match=match):
        read_config("bad.yaml", kind, text=text)


def test_writing_a_parameter_the_file_cannot_hold_is_refused():
    """write() names the parameter and the writable ones for a name that is not in the format."""
    with pytest.raises(ParameterError, match="cannot write 'stiffness' to a fzi-force file; writable: p, d, error_scale"):
        read_config(CONFIGS / "fzi_force.yaml").write(stiffness=[1.0] * 6)



# ---------------------------------------------------------------------------------------------- YAML anchors, aliases, merges
_ROS2 = (CONFIGS / "ros2_admittance.yaml").read_text(encoding="utf-8")
_STIFF = "      stiffness:\n" + "".join(f"        - 214.{i}\n" for i in range(1, 7))
_NEW = [300.0, 214.2, 214.3, 214.4, 214.5, 214.6]


@pytest.mark.parametrize("text, how", [
    # the controller's list is anchored, another controller aliases it
    (_ROS2.replace("      stiffness:\n", "      stiffness: &stiff\n", 1)
     + "other_controller:\n  ros__parameters:\n    admittance:\n      stiffness: *stiff\n", "anchored block '&stiff'"),
    # the controller's list is an alias of a block defined elsewhere
    ("defaults:\n  stiffness: &stiff [214.1, 214.2, 214.3, 214.4, 214.5, 214.6]\n"
     + _ROS2.replace(_STIFF, "      stiffness: *stiff\n"), "anchored block '&stiff'"),
    # the list comes through a merge key
    ("gains: &g\n  stiffness: [214.1, 214.2, 214.3, 214.4, 214.5, 214.6]\n" + _ROS2.replace(_STIFF, "      <<: *g\n"),
     "anchored block '&g' that an alias or a merge key repeats"),
    # one value carries an anchor that an alias uses
    (_ROS2.replace("        - 214.1\n", "        - &k 214.1\n", 1) + "other_controller:\n  ros__parameters:\n    k: *k\n",
     "carries the anchor '&k', which an alias"),
])
def test_a_value_the_file_shares_through_an_anchor_is_not_written_in_place(text, how):
    """Written where it stands, a value held by an anchor changed every alias of it (another controller's gains), and
    an anchored value lost the anchor its alias needs (the file no longer loaded): refused, naming the key and how the
    file shares it. The shared values read as before."""
    cfg = read_config("shared.yaml", text=text)
    assert cfg.parameters["stiffness"] == [214.1, 214.2, 214.3, 214.4, 214.5, 214.6]
    refused = rf"cannot write admittance\.stiffness\.0: .*{re.escape(how)}.*edit the file by hand"
    with pytest.raises(ParameterError, match=refused):
        cfg.write(stiffness=_NEW)
    assert cfg.write(stiffness=cfg.parameters["stiffness"]) == text  # nothing changed: written back byte for byte


def test_a_merged_scalar_is_refused_and_an_anchor_no_alias_uses_is_kept():
    """A scalar inherited through a merge key has no place in the controller's section (it raised KeyError from the
    YAML library); an anchor that no alias uses stays on the value written."""
    fzi = (CONFIGS / "fzi_compliance.yaml").read_text(encoding="utf-8")
    merged = "solver_defaults: &s\n  error_scale: 0.5\n" + fzi.replace("        error_scale: 0.5\n", "        <<: *s\n", 1)
    cfg = read_config("merged.yaml", text=merged)
    assert cfg.parameters["error_scale"] == 0.5
    with pytest.raises(ParameterError, match=r"cannot write solver\.error_scale: its value comes from a merge key"):
        cfg.write(error_scale=0.2)
    lone = _ROS2.replace("        - 214.1\n", "        - &k 214.1\n", 1)
    out = read_config("lone.yaml", text=lone).write(stiffness=_NEW)
    assert out == lone.replace("        - &k 214.1\n", "        - &k 300.0\n", 1)
    assert read_config("lone.yaml", text=out).parameters["stiffness"] == _NEW



def test_aliases_inside_the_section_written_alike_and_merged_mappings_added_to_by_hand():
    """Aliases within the controller's own section (FZI's trans_y: *tr of trans_x: &tr) are written once when this
    write gives them the same value, refused when it gives them different ones; an anchor named in a comment ('*x')
    is no alias; a key added to a mapping of merged keys only is refused (it raised TypeError), one added beside own
    keys of a flow mapping with a merge key is written after them."""
    fzi = (CONFIGS / "fzi_compliance.yaml").read_text(encoding="utf-8")
    tr = (fzi.replace("trans_x: {p: 0.05, d: 0.005}", "trans_x: &tr {p: 0.05, d: 0.005}")
          .replace("trans_y: {p: 0.05, d: 0.005}", "trans_y: *tr").replace("trans_z: {p: 0.05, d: 0.005}", "trans_z: *tr"))
    cfg = read_config("tr.yaml", text=tr)
    out = cfg.write(p=[0.1, 0.1, 0.1, 1.5, 1.5, 1.5])
    assert out == tr.replace("trans_x: &tr {p: 0.05,", "trans_x: &tr {p: 0.1,", 1)
    assert read_config("tr.yaml", text=out).parameters["p"] == [0.1, 0.1, 0.1, 1.5, 1.5, 1.5]
    with pytest.raises(ParameterError, match=r"cannot write pd_gains\.trans_x\.p: it lies in the anchored block '&tr'"):
        cfg.write(p=[0.1, 0.05, 0.05, 1.5, 1.5, 1.5])
    k = fzi.replace("        trans_x: 500\n", "        trans_x: &k 500\n")
    k = k.replace("        trans_y: 500\n", "        trans_y: *k\n")
    assert read_config("k.yaml", text=k).write(stiffness=[600, 600, 500, 20, 20, 20]) == k.replace("&k 500", "&k 600.0")
    with pytest.raises(ParameterError, match=r"carries the anchor '&k', which an alias \('\*k'\) uses"):
        read_config("k.yaml", text=k).write(stiffness=[600, 500, 500, 20, 20, 20])
    comment = fzi.replace("        trans_x: 500\n", "        trans_x: &x 500  # cf. the *x axis\n")
    assert read_config("c.yaml", text=comment).write(stiffness=[600, 500, 500, 20, 20, 20]) == comment.replace(
        "&x 500", "&x 600.0")
    merged = "rot: &rg\n  p: 1.5\n" + fzi.replace("rot_x: {p: 1.5}", "rot_x:\n            <<: *rg")
    with pytest.raises(ParameterError, match=r"cannot add pd_gains\.rot_x\.d: its mapping holds only keys from a merge key"):
        read_config("m.yaml", text=merged).write(d=[0.005, 0.005, 0.005, 0.1, 0.0, 0.0])
    flow = "sd: &sd {error_scale: 0.5}\n" + fzi.replace("    solver:\n        error_scale: 0.5\n        iterations: 1\n",
                                                        "    solver: {<<: *sd, iterations: 1}\n")
    assert "    solver: {<<: *sd, iterations: 5}\n" in read_config("f.yaml", text=flow).write(iterations=5)


# ---------------------------------------------------------------------------------------------- outside review, session 33
# Inputs written here after the upstream layouts (ros2_controllers, FZI cartesian_controllers ros1/ros2, franka_ros):
# the values are made up; the structure (where the type is declared, nested or dotted keys) is what the ROS tools read.

FRANKA_EXAMPLES = """\
cartesian_pose_example_controller:
    type: franka_example_controllers/CartesianPoseExampleController
    arm_id: panda
cartesian_impedance_example_controller:
    type: franka_example_controllers/CartesianImpedanceExampleController
    arm_id: panda
    joint_names: [panda_joint1, panda_joint2]
dual_arm_cartesian_impedance_example_controller:
    type: franka_example_controllers/DualArmCartesianImpedanceExampleController
    right:
        arm_id: panda_1
"""

FZI_ROS2_MOTION_FIRST = """\
controller_manager:
  ros__parameters:
    update_rate: 500
    cartesian_motion_controller:
      type: cartesian_motion_controller/CartesianMotionController
    cartesian_force_controller:
      type: cartesian_force_controller/CartesianForceController
cartesian_motion_controller:
  ros__parameters:
    end_effector_link: "tool0"
    robot_base_link: "base_link"
    solver:
      error_scale: 1.0
      iterations: 10
    pd_gains:
      trans_x: {p: 1.0}
cartesian_force_controller:
  ros__parameters:
    end_effector_link: "tool0"
    robot_base_link: "base_link"
    ft_sensor_ref_link: "tool0"
    solver:
      error_scale: 0.5
    pd_gains:
      trans_x: {p: 0.05}
"""


def test_the_controller_is_found_by_its_plugin_class_not_by_a_word_in_its_type():
    """franka_ros's example file: its first section (a CartesianPose controller) used to be read as an FZI force
    controller with every gain 0 (exit 0); the impedance example is read and the others are named as not read."""
    c = read_config("franka_example_controllers.yaml", text=FRANKA_EXAMPLES)
    assert c.kind == "franka-cartesian-impedance" and c.section == "cartesian_impedance_example_controller"
    skipped = [n for n in c.notes if "is not a controller this reads" in n]
    assert any("cartesian_pose_example_controller" in n for n in skipped)
    assert any("dual_arm_cartesian_impedance_example_controller" in n for n in skipped)


def test_a_ros2_type_declared_in_the_controller_manager_decides_the_kind():
    """FZI's ROS 2 files declare each type under controller_manager: the motion controller (no type in its section,
    gains that look like a force controller's) is passed over, named in the notes, and refused when asked for."""
    c = read_config("fzi.yaml", text=FZI_ROS2_MOTION_FIRST)
    assert (c.kind, c.section, c.rate) == ("fzi-force", "cartesian_force_controller", 500.0)
    assert c.parameters["error_scale"] == 0.5 and c.parameters["p"][0] == 0.05
    assert any("cartesian_motion_controller" in n and "not a controller this reads" in n for n in c.notes)
    with pytest.raises(ParameterError, match="cartesian_motion_controller.*tracks a target pose"):
        read_config("fzi.yaml", "fzi-force", "cartesian_motion_controller", text=FZI_ROS2_MOTION_FIRST)
    untyped = FZI_ROS2_MOTION_FIRST.split("cartesian_motion_controller:\n  ros__parameters:", 1)[1].split(
        "cartesian_force_controller:\n  ros__parameters", 1)[0]
    with pytest.raises(ParameterError, match="cartesian_motion_controller"):  # no type at all: no ft_sensor_ref_link
        read_config("motion.yaml", text="cartesian_motion_controller:\n  ros__parameters:" + untyped)


def test_dotted_ros2_keys_are_the_nested_parameters():
    """ROS 2 reads ``solver.error_scale: 0.2`` as ``solver: {error_scale: 0.2}``: read (not the default with a note
    saying it was not set), written back in place, and refused when given both ways."""
    nested = read_config("n.yaml", text=FZI_ROS2_MOTION_FIRST, section="cartesian_force_controller")
    flat_text = FZI_ROS2_MOTION_FIRST.replace("    solver:\n      error_scale: 0.5\n    pd_gains:\n      trans_x: {p: 0.05}\n",
                                              "    solver.error_scale: 0.5\n    pd_gains.trans_x.p: 0.05\n")
    assert flat_text != FZI_ROS2_MOTION_FIRST
    flat = read_config("f.yaml", text=flat_text, section="cartesian_force_controller")
    assert flat.parameters == nested.parameters
    assert not any(n.startswith(("solver.error_scale", "pd_gains.trans_x.p")) for n in flat.notes)
    out = flat.write(error_scale=0.25)
    again = read_config("f.yaml", text=out, section="cartesian_force_controller")
    assert "    solver.error_scale: 0.25\n" in out and again.parameters["error_scale"] == 0.25
    adm = (resources.files("forcecontrol.scenarios") / "configs" / "ros2_admittance.yaml").read_text(encoding="utf-8")
    ref = read_config("a.yaml", text=adm)
    assert "filter_coefficient:" in adm
    both = adm.replace("    ft_sensor:\n", "    ft_sensor.filter_coefficient: 0.5\n    ft_sensor:\n", 1)
    assert both != adm
    with pytest.raises(ParameterError, match="ft_sensor.filter_coefficient.*more than once"):
        read_config("a.yaml", text=both)
    assert ref.parameters["filter_coefficient"] != 0.5


def test_ros1_fzi_values_are_clamped_to_the_dynamic_reconfigure_ranges():
    """FZI's ROS 1 controllers read their gains through dynamic_reconfigure servers, which clamp them to the .cfg
    ranges (ComplianceController.cfg stiffness [100, 5000] N/m and [5, 200] N m/rad; PDGains.cfg p, d [0, 10];
    CartesianController.cfg error_scale [0, 10]): a zero stiffness is 100 N/m on the robot."""
    text = """\
my_cartesian_compliance_controller:
  type: "position_controllers/CartesianComplianceController"
  end_effector_link: "tool0"
  robot_base_link: "base_link"
  ft_sensor_ref_link: "tool0"
  compliance_ref_link: "tool0"
  stiffness: {trans_x: 500, trans_y: 500, trans_z: 0, rot_x: 20, rot_y: 1, rot_z: 20}
  solver: {error_scale: 20}
  pd_gains:
    trans_x: {p: 0.05}
    trans_y: {p: 0.05}
    trans_z: {p: 15}
"""
    c = read_config("ros1.yaml", text=text)
    assert c.layout == "ros1" and c.parameters["stiffness"] == [500.0, 500.0, 100.0, 20.0, 5.0, 20.0]
    assert c.parameters["error_scale"] == 10.0 and c.parameters["p"][:3] == [0.05, 0.05, 10.0]
    assert c.parameters["iterations"] == 10
    assert sum("dynamic_reconfigure range" in n for n in c.notes) == 4
    assert not any("project's default 1 is used" in n for n in c.notes)  # only the ROS 1 default 10 is said


def test_the_iteration_count_is_an_integer_when_read_and_when_written():
    """iterations = 2.5 is refused (it was truncated to 2 while the command said it changed it); 3.0 is 3."""
    path = resources.files("forcecontrol.scenarios") / "configs" / "fzi_issue_171.yaml"
    text = path.read_text(encoding="utf-8")
    c = read_config("fzi_issue_171.yaml", text=text)
    with pytest.raises(ParameterError, match="iterations must be an integer; got 2.5"):
        c.write(iterations=2.5)
    assert read_config("x.yaml", text=c.write(iterations=3.0)).parameters["iterations"] == 3
    bad = c.write(iterations=3).replace("iterations: 3", "iterations: 2.5")
    with pytest.raises(ParameterError, match="iterations.*must be an integer; got 2.5"):
        read_config("x.yaml", text=bad)


def test_ros2_admittance_frames_are_the_base_the_tip_or_refused():
    """admittance_rule_impl.hpp makes K, D, M and the selected axes diagonal in control.frame.id at the current joints:
    kinematics.tip is the tool, kinematics.base and fixed_world_frame.frame.id (said) the base; another name (UR's
    'base', turned by pi from base_link, or a link of the arm) was read as the tool, whose axes turn with the arm:
    refused, naming the key and the frames it may name."""
    text = (resources.files("forcecontrol.scenarios") / "configs" / "ros2_admittance.yaml").read_text(encoding="utf-8")
    control = "    control:\n      frame:\n        id: tool0"
    assert control in text and "    fixed_world_frame:   # gravity points along -z here (usually world or base_link)\n" \
        "      frame:\n        id: base_link" in text
    assert read_config("a.yaml", text=text).parameters["control_frame"] == "tool"
    assert read_config("a.yaml", text=text.replace(control, "    control:\n      frame:\n        id: base_link")
                       ).parameters["control_frame"] == "base"
    world = text.replace(control, "    control:\n      frame:\n        id: world").replace(
        "      frame:\n        id: base_link", "      frame:\n        id: world")
    c = read_config("a.yaml", text=world)
    assert c.parameters["control_frame"] == "base" and any("assumed to coincide" in n for n in c.notes)
    with pytest.raises(ParameterError, match=r"control\.frame\.id 'base' is neither kinematics\.base 'base_link', "
                                             r"kinematics\.tip 'tool0', ft_sensor\.frame\.id 'link_6'"):
        read_config("a.yaml", text=text.replace(control, "    control:\n      frame:\n        id: base"))
    # the sensor's frame (link_6 in the example) is where the sensor is simulated: the tool, said (it was refused)
    gravity = "    gravity_compensation:\n      frame:\n        id: tool0"
    assert gravity in text
    c = read_config("a.yaml", text=text.replace(gravity, "    gravity_compensation:\n      frame:\n        id: link_6"))
    assert c.parameters["payload_frame"] == "tool"
    assert any(n.startswith("gravity_compensation.frame.id = 'link_6' is ft_sensor.frame.id: taken as the tool")
               for n in c.notes), c.notes


def test_a_controllers_own_update_rate_comes_before_the_controller_managers():
    """ros2_control: ``update_rate`` under the controller's own parameters overrides controller_manager's (it was
    called an unsupported key); the difference is said."""
    text = FZI_ROS2_MOTION_FIRST.replace('    ft_sensor_ref_link: "tool0"\n',
                                         '    ft_sensor_ref_link: "tool0"\n    update_rate: 250\n')
    c = read_config("fzi.yaml", text=text)
    assert c.rate == 250.0 and any("update_rate 250 Hz of the controller's own parameters" in n for n in c.notes)
    assert not any(n.startswith("update_rate: unsupported") for n in c.notes)
    with pytest.raises(ParameterError, match="update_rate' must be a positive number"):
        read_config("fzi.yaml", text=text.replace("update_rate: 250", "update_rate: -1"))


def test_fzi_hand_frame_default_and_velocity_interface_are_said():
    """FZI's force controllers take the target wrench in end_effector_link unless hand_frame_control is false: a file
    without the key says what the simulation does instead; a ROS 1 velocity_controllers type is named."""
    c = read_config("fzi.yaml", text=FZI_ROS2_MOTION_FIRST)
    assert any(n.startswith("hand_frame_control not set: upstream's default true") for n in c.notes)
    ros1 = ("my_force:\n  type: velocity_controllers/CartesianForceController\n  ft_sensor_ref_link: tool0\n"
            "  hand_frame_control: false\n  solver: {error_scale: 0.5}\n  pd_gains:\n    trans_x: {p: 0.05}\n")
    c = read_config("ros1.yaml", text=ros1)
    assert c.kind == "fzi-force" and any("velocity-interface variant" in n for n in c.notes)
    assert not any(n.startswith("hand_frame_control not set") for n in c.notes)


_UR_CALL = "force_mode(p[{tf}], [{sel}], [{w}], {ty}, [.1,.1,.1,.785,.785,.785])\n"


@pytest.mark.parametrize("tf, sel, w, ty, match", [
    ("x1, y1, z1, 0, 0, 0", "0,0,1,0,0,0", "0,0,-10,0,0,0", "2", r"task_frame\[0\]: 'x1' is not a literal number"),
    ("0,0,0,0,0,0", "0,0,True,0,0,0", "0,0,-10,0,0,0,7", "2", r"selection_vector\[2\]: 'True' is not a literal number"),
    ("0,0,0,0,0,0", "0,0,1,0,0", "0,0,-10,0,0,0", "2", r"selection_vector must have 6 numbers; got 5"),
    ("0,0,0,0,0,0", "0,0,1,0,0,0", "0,0,-10,0,0,0", "2.7", r"type must be 1, 2 or 3; got '2.7'"),
])
def test_ur_force_mode_is_read_argument_by_argument(tf, sel, w, ty, match):
    """Each argument of force_mode holds its own literal numbers: digits inside variable names (x1 read as 1 m),
    a boolean, a short vector (the next argument's numbers shifted in) or a fractional type (2.7 read as 2) are
    refused, naming the argument and the entry; before, the call's 25 first digit runs were taken in order."""
    with pytest.raises(ParameterError, match=match):
        read_config("prog.script", text=_UR_CALL.format(tf=tf, sel=sel, w=w, ty=ty))


def test_ur_force_mode_sign_apart_from_its_digits_and_a_second_call_are_read_as_urscript_does():
    """``- 10`` is −10 (it was read as +10: the tool pushed the other way), and it is written back in place; of two
    force_mode calls the last is read and a note names both lines."""
    text = _UR_CALL.format(tf="0,0,0,0,0,0", sel="0,0,1,0,0,0", w="0,0,- 10,0,0,0", ty="2")
    cfg = read_config("prog.script", text=text)
    assert cfg.parameters["wrench"] == [0.0, 0.0, -10.0, 0.0, 0.0, 0.0]
    assert cfg.write(wrench=[0, 0, -12, 0, 0, 0]) == text.replace("- 10", "-12")
    two = text + _UR_CALL.format(tf="0,0,0,0,0,0", sel="0,0,1,0,0,0", w="0,0,-40,0,0,0", ty="2")
    cfg = read_config("prog.script", text=two)
    assert cfg.parameters["wrench"][2] == -40.0
    assert any("force_mode is called on lines 1, 2: the last one (line 2) is read" in n for n in cfg.notes)


@pytest.mark.parametrize("value", ['"fast"', "[100]", ".nan", ".inf", "true", "0", "-100", "1e9"])
def test_an_update_rate_that_is_no_rate_is_refused_naming_the_key(value):
    """controller_manager's update_rate must be a finite positive number of Hz: a string, a list, NaN, inf, a boolean,
    zero, a negative or an absurd rate is a ParameterError naming the key (they were a traceback, or true read as
    1 Hz); the shipped file's 100 Hz reads."""
    text = (CONFIGS / "fzi_compliance.yaml").read_text(encoding="utf-8")
    assert read_config("fzi.yaml", text=text).parameters is not None
    bad = text.replace("update_rate: 100  # Hz", f"update_rate: {value}", 1)
    assert bad != text
    with pytest.raises(ParameterError, match=r"key 'controller_manager\.ros__parameters\.update_rate' must be a positive "
                                             r"number of Hz"):
        read_config("fzi.yaml", text=bad)


def test_a_yaml_alias_bomb_is_refused_at_once():
    """Twelve lines whose aliases expand to 9⁷ values (they ran past 2 minutes and 1.7 GB, then read) are refused,
    naming the limit (the walk stops there); the shipped files, with hundreds of values, read."""
    lines = ["ctl:", "  ros__parameters:", "    pd_gains: {trans_x: {p: 0.05}}", "    stiffness: {trans_x: 500}",
             "    a: &a {" + ", ".join(f"x{i}: 1" for i in range(1, 10)) + "}"]
    for prev, name, key in zip("abcdef", "bcdefg", "yzwvut"):
        lines.append(f"    {name}: &{name} {{" + ", ".join(f"{key}{i}: *{prev}" for i in range(1, 10)) + "}")
    with pytest.raises(ParameterError, match=r"bomb.yaml: the file expands to more than 100,000 values"):
        read_config("bomb.yaml", text="\n".join(lines) + "\n")
    for f in sorted(CONFIGS.glob("*.yaml")):
        assert read_config(f).parameters


def test_a_missing_frame_id_or_compliance_ref_link_is_said_with_what_is_assumed():
    """ros2 admittance without control.frame.id (and without gravity_compensation.frame.id) and an FZI compliance file
    without compliance_ref_link: each is read as the tool frame, and the notes say so (it was silent)."""
    configs = resources.files("forcecontrol.scenarios") / "configs"
    text = (configs / "ros2_admittance.yaml").read_text(encoding="utf-8")
    control = "    control:\n      frame:\n        id: tool0 # displacements and gains are diagonal in this frame\n"
    assert control in text
    c = read_config("a.yaml", text=text.replace(control, "    control:\n      frame:\n"))
    assert c.parameters["control_frame"] == "tool"
    assert any(n.startswith("control.frame.id not set: taken as kinematics.tip, the tool") for n in c.notes), c.notes
    assert not any("not set: taken as kinematics.tip" in n for n in read_config("a.yaml", text=text).notes)
    fzi = (configs / "fzi_issue_21.yaml").read_text(encoding="utf-8")
    assert '    compliance_ref_link: "tool0"\n' in fzi
    c = read_config("f.yaml", text=fzi.replace('    compliance_ref_link: "tool0"\n', ""))
    assert c.parameters["compliance_frame"] == "tool"
    assert any(n.startswith("compliance_ref_link not set: the stiffness is taken in the end-effector (tool) frame")
               for n in c.notes), c.notes


def test_integers_for_the_admittance_controllers_doubles_are_said():
    """ros2_controllers' admittance parameters are doubles: `mass: [5, ...]` does not load on the robot (the shipped
    example's own comment: write the ".0"); read as numbers here, and the notes name the key (it was silent)."""
    text = (resources.files("forcecontrol.scenarios") / "configs" / "ros2_admittance.yaml").read_text(encoding="utf-8")
    assert "        - 5.5\n" in text and "        - 6.6\n" in text
    ints = text.replace("        - 5.5\n", "        - 5\n", 1).replace("        - 6.6\n", "        - 6\n", 1)
    c = read_config("a.yaml", text=ints)
    assert c.parameters["mass"][:2] == [5.0, 6.0]
    assert any(n.startswith("admittance.mass (2 values): written as integers") for n in c.notes), c.notes
    assert not any("written as integers" in n for n in read_config("a.yaml", text=text).notes)
