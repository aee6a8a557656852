"""Hostile input files (issue 28 item 4): empty, truncated, corrupt, special, oversized, non-physical.

Each bad file is written by the test itself. Every case checks the library's error type, that the
message names the file and the problem, and that no file content leaks into the message (each
file carries a secret marker). Special files that could block or read forever (FIFO,
``/dev/zero``) are read in a subprocess with a timeout.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from forcecontrol.errors import ForceControlError, ParameterError

SECRET = "SECRETmarker7f3a"


def _refuse(call, path, exc, *needles):
    """call() raises exc; the message names the file and each needle, and holds no secret."""
    with pytest.raises(exc) as info:
        call()
    msg = str(info.value)
    assert isinstance(info.value, ForceControlError)
    assert os.path.basename(str(path)) in msg, msg
    for n in needles:
        assert n in msg, msg
    assert SECRET not in msg, msg
    return msg


# ----------------------------------------------------------------------------- sampled references


REFERENCE_CASES = [
    ("empty.csv", "", "the file is empty"),
    ("blank.csv", "\n\n  \n", "the file is empty"),
    ("header_only.csv", f"t,x,{SECRET}\n", "at least 2 samples"),
    ("text.csv", f"t,x\n0,1\n1,{SECRET}\n", "line 3, column 'x' is not a number"),
    ("ragged.csv", f"t,x\n0,1\n1,2,{SECRET}\n", "line 3 has 3 fields, the header 2"),
    ("nan.csv", f"t,x,note_{SECRET}\n0,1,0\n\n1,nan,0\n", "column 'x' is NaN or inf at line 4"),
    ("repeat.csv", f"t,x,note_{SECRET}\n0,1,0\n0,2,0\n", "time repeats at line 3"),
    ("backwards.csv", f"t,x,note_{SECRET}\n0,1,0\n2,2,0\n1,3,0\n", "time goes backwards at line 4"),
    ("duplicate.csv", f"t,x,x\n0,1,{SECRET}\n", "column 'x' appears more than once"),
    ("environ.csv", f"PATH=/usr/bin\0{SECRET}=hunter2\0HOME=/root\0", "it has 0 data row(s)"),
    ("binary.csv", b"\xff\xfe\x00" + SECRET.encode(), "not UTF-8 text (byte 0"),
]


@pytest.mark.parametrize("name, content, problem", REFERENCE_CASES, ids=[c[0] for c in REFERENCE_CASES])
def test_a_bad_reference_file_is_refused_by_name_and_problem(tmp_path, name, content, problem):
    """Empty, text, ragged, NaN, repeated/backwards time, duplicate columns, an environ dump: ParameterError, no content."""
    from forcecontrol.trajectories.sampled import SampledReference

    p = tmp_path / name
    p.write_bytes(content if isinstance(content, bytes) else content.encode())
    exc = ParameterError
    _refuse(lambda: SampledReference.from_file(p), p, exc, problem)


def test_a_folder_named_like_a_reference_is_refused(tmp_path):
    """A folder x.csv is refused as a folder (was a TypeError)."""
    from forcecontrol.trajectories.sampled import SampledReference

    p = tmp_path / "x.csv"
    p.mkdir()
    _refuse(lambda: SampledReference.from_file(p), p, ParameterError, "it is a folder")


def test_a_reference_above_the_size_limit_is_refused_before_reading(tmp_path):
    """A file larger than max_bytes is refused with its size and the limit."""
    from forcecontrol.trajectories.sampled import SampledReference

    p = tmp_path / "big.csv"
    p.write_text("t,x\n" + "".join(f"{i},{i}\n" for i in range(200)))
    _refuse(lambda: SampledReference.from_file(p, max_bytes=100), p, ParameterError, "above the limit of 100 bytes")
    assert SampledReference.from_file(p).times.shape == (200,)


_SUBPROCESS = """
import sys
from forcecontrol.trajectories.sampled import SampledReference
try:
    SampledReference.from_file(sys.argv[1])
except Exception as exc:
    print(type(exc).__name__, exc)
"""


def _in_subprocess(path: str) -> str:
    out = subprocess.run([sys.executable, "-c", _SUBPROCESS, path], capture_output=True, text=True, timeout=120)
    return out.stdout.strip()


def test_a_fifo_reference_is_refused_without_blocking(tmp_path):
    """A FIFO as a reference is refused at once (it blocked forever): the subprocess ends within its timeout."""
    p = tmp_path / "pipe.csv"
    os.mkfifo(p)
    line = _in_subprocess(str(p))
    assert line.startswith("ParameterError") and "pipe.csv" in line and "FIFO" in line, line


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_a_device_reference_is_refused_without_reading(device):
    """/dev/zero (read until memory ran out) and /dev/null (IndexError) are refused as devices."""
    line = _in_subprocess(device)
    assert line.startswith("ParameterError") and device in line and "a device" in line, line


def test_a_good_reference_file_still_reads(tmp_path):
    """The strict reader keeps accepting a plain file (values from the file itself)."""
    from forcecontrol.trajectories.sampled import SampledReference

    p = tmp_path / "ok.csv"
    p.write_text("t, x, y\n0, 0, 1\n\n0.5, 1, 2\n1, 2, 3\n")
    ref = SampledReference.from_file(p, interpolation="linear")
    np.testing.assert_array_equal(ref.position_samples, [[0, 1], [1, 2], [2, 3]])


# ----------------------------------------------------------------------------- URDF


def _urdf(links=None, joints=None, comment=f"<!-- {SECRET} -->"):
    """A two-link URDF; links/joints replace the default elements."""
    inertial = '<inertial><mass value="{m}"/><inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial>'
    if links is None:
        links = [("base", inertial.format(m=1, ixx=1, iyy=1, izz=1)), ("arm", inertial.format(m=1, ixx=1, iyy=1, izz=1))]
    if joints is None:
        joints = [("j1", "base", "arm")]
    body = "".join(f'<link name="{n}">{x}</link>' for n, x in links)
    body += "".join(
        f'<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for n, p, c in joints
    )
    return f'<?xml version="1.0"?>\n<robot name="r">{comment}\n{body}</robot>\n'


def _inertial(m="1", ixx="1", iyy="1", izz="1", ixy="0"):
    return f'<inertial><mass value="{m}"/><inertia ixx="{ixx}" ixy="{ixy}" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial>'


URDF_CASES = [
    ("empty.urdf", "", "not well-formed XML: parser error at line 1"),
    ("truncated.urdf", _urdf()[:-30], "not well-formed XML: parser error at line"),
    ("not_xml.urdf", f"{SECRET} this is not xml", "not well-formed XML: parser error at line 1, column 1"),
    ("wrong_root.urdf", f"<sdf>{SECRET}</sdf>", "the root element must be <robot>"),
    ("dup_link.urdf", _urdf(links=[("base", ""), ("base", ""), ("arm", "")]), "link 'base' is defined twice"),
    ("dup_joint.urdf", _urdf(links=[("a", ""), ("b", ""), ("c", "")], joints=[("j", "a", "b"), ("j", "b", "c")]),
     "joint 'j' is defined twice"),
    ("two_parents.urdf", _urdf(links=[("a", ""), ("b", ""), ("c", "")], joints=[("j1", "a", "c"), ("j2", "b", "c")]),
     "link 'c' is the child of two joints, 'j1' and 'j2'"),
    ("cycle.urdf", _urdf(links=[("a", ""), ("b", ""), ("c", "")], joints=[("j1", "a", "b"), ("j2", "b", "c"), ("j3", "c", "a")]),
     "kinematic cycle through link(s) 'a', 'b', 'c' (no root link)"),
    ("detached_cycle.urdf", _urdf(links=[("r", ""), ("a", ""), ("b", "")], joints=[("j1", "a", "b"), ("j2", "b", "a")]),
     "kinematic cycle through link(s) 'a', 'b'"),
    ("two_roots.urdf", _urdf(links=[("a", ""), ("b", "")], joints=[]), "2 links have no parent joint"),
    ("unknown_link.urdf", _urdf(joints=[("j1", "base", "hand")]), "joint 'j1' names an unknown link 'hand' as its <child>"),
    ("nan_mass.urdf", _urdf(links=[("base", ""), ("arm", _inertial(m="nan"))]), "link 'arm': <mass value> must be a finite"),
    ("neg_mass.urdf", _urdf(links=[("base", ""), ("arm", _inertial(m="-2"))]), "must be a finite number >= 0 kg; got -2.0"),
    ("text_mass.urdf", _urdf(links=[("base", ""), ("arm", _inertial(m=SECRET))]), "<mass value> is not a number"),
    ("inf_inertia.urdf", _urdf(links=[("base", ""), ("arm", _inertial(iyy="inf"))]), "<inertia iyy> must be finite"),
    ("neg_inertia.urdf", _urdf(links=[("base", ""), ("arm", _inertial(ixx="-1"))]), "<inertia ixx> must be >= 0 kg m²; got -1.0"),
    ("indefinite.urdf", _urdf(links=[("base", ""), ("arm", _inertial(ixy="2"))]),
     "not positive semi-definite (principal moments -1"),
    ("triangle.urdf", _urdf(links=[("base", ""), ("arm", _inertial(ixx="1", iyy="1", izz="3"))]),
     "principal moments 1, 1, 3 kg m² break the triangle inequality"),
    ("massless.urdf", _urdf(links=[("base", ""), ("arm", _inertial(m="0"))]), "mass 0 with a non-zero inertia"),
]


@pytest.mark.parametrize("name, text, problem", URDF_CASES, ids=[c[0] for c in URDF_CASES])
def test_a_bad_urdf_is_refused_before_pinocchio(tmp_path, name, text, problem):
    """Bad XML, duplicate names, cycles, several roots, NaN/negative/indefinite/non-triangle inertias: ParameterError."""
    pytest.importorskip("pinocchio")
    from forcecontrol.robots.pinocchio import PinocchioRobot

    p = tmp_path / name
    p.write_text(text)
    _refuse(lambda: PinocchioRobot.from_urdf(p, "arm", task="position"), p, ParameterError, problem)


def test_a_good_urdf_loads_and_inertia_checks_can_be_relaxed(tmp_path):
    """The template loads (mass 2 from the file); check_inertia=False loads a triangle-breaking inertia with a warning."""
    pytest.importorskip("pinocchio")
    from forcecontrol.robots.pinocchio import PinocchioRobot

    p = tmp_path / "ok.urdf"
    p.write_text(_urdf(links=[("base", ""), ("arm", _inertial(m="2"))]))
    robot = PinocchioRobot.from_urdf(p, "arm", task="position")
    assert robot.model.inertias[1].mass == 2.0
    p.write_text(_urdf(links=[("base", ""), ("arm", _inertial(ixx="1", iyy="1", izz="3"))]))
    with pytest.warns(UserWarning, match="triangle inequality.*loaded anyway"):
        PinocchioRobot.from_urdf(p, "arm", task="position", check_inertia=False)


@pytest.mark.parametrize("kind", ["folder", "fifo"])
def test_a_special_urdf_path_is_refused(tmp_path, kind):
    """A folder or a FIFO named x.urdf is refused by kind, without opening it."""
    from forcecontrol.robots.urdf_check import check_urdf

    p = tmp_path / "x.urdf"
    p.mkdir() if kind == "folder" else os.mkfifo(p)
    _refuse(lambda: check_urdf(p), p, ParameterError, "a folder" if kind == "folder" else "a FIFO")
