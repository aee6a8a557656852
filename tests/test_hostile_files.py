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


# ----------------------------------------------------------------------------- recorded data


def _run(N=6):
    t = 100.0 + 0.01 * np.arange(N)
    q = np.column_stack([np.sin(t), np.cos(t)])
    return t, q, -q


def _corrupt_mcap(path, bad_index=2):
    """An MCAP file written by the mcap library whose joint-state message bad_index holds truncated CDR bytes."""
    from mcap.writer import Writer

    from rosfiles_helpers import _messages, _typestore

    ts = _typestore()
    t, q, qd = _run()
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="forcecontrol-tests")
        channels, k = {}, 0
        for topic, msgtype, ns, msg in _messages(ts, t, q, qd, None, t, None, ("j1", "j2"), "base"):
            if topic not in channels:
                text = ts.generate_msgdef(msgtype, ros_version=2)[0]
                sid = w.register_schema(name=msgtype, encoding="ros2msg", data=text.encode())
                channels[topic] = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
            data = bytes(ts.serialize_cdr(msg, msgtype))
            if k == bad_index:
                data = data[:7]
            w.add_message(channels[topic], log_time=ns, data=data, publish_time=ns)
            k += 1
        w.finish()
    return path


def _corrupt_bag(path, bad_index=2):
    """A rosbag2 SQLite bag written by rosbags whose joint-state message bad_index is cut to 7 bytes."""
    import sqlite3

    from rosfiles_helpers import write_bag

    write_bag(path, *_run())
    db = next(path.glob("*.db3"))
    con = sqlite3.connect(db)
    ids = [r[0] for r in con.execute("SELECT id FROM messages ORDER BY timestamp")]
    con.execute("UPDATE messages SET data = substr(data, 1, 7) WHERE id = ?", (ids[bad_index],))
    con.commit()
    con.close()
    return path


@pytest.mark.parametrize("kind", ["bag", "mcap"])
def test_a_corrupt_message_is_refused_naming_file_topic_and_index(tmp_path, kind):
    """One corrupt message (was a raw SerdeError): MeasurementError naming file, topic, index; skip_corrupt skips it."""
    from forcecontrol.errors import MeasurementError
    from forcecontrol.realarm.io import read_bag, read_mcap

    pytest.importorskip("rosbags")
    pytest.importorskip("mcap")
    p = _corrupt_bag(tmp_path / "run_bag") if kind == "bag" else _corrupt_mcap(tmp_path / "run.mcap")
    read = read_bag if kind == "bag" else read_mcap
    _refuse(lambda: read(p, wrench_topic=None), p, MeasurementError,
            "message 2 of topic '/joint_states' (sensor_msgs/msg/JointState) cannot be decoded", "skip_corrupt=True")
    with pytest.warns(UserWarning, match="skipped 1 corrupt message"):
        run = read(p, wrench_topic=None, skip_corrupt=True)
    assert run.t.shape == (5,) and run.metadata["skipped_corrupt"] == 1
    t, q, _ = _run()
    np.testing.assert_allclose(run.q, np.delete(q, 2, axis=0))


def _table(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


TABLE_CASES = [
    ("empty.csv", "", ParameterError, "cannot be read as csv: No columns to parse"),
    ("nan.csv", f"t,q1,qd1,note\n0,1,1,{SECRET}\n1,nan,2,x\n", "MeasurementError", "q[0] is not finite at row 1"),
    ("dup_time.csv", f"t,q1,qd1,note\n0,1,1,{SECRET}\n0,1,2,x\n", "MeasurementError", "row 1 has t = 0 s after t = 0 s"),
    ("back_time.csv", f"t,q1,qd1,note\n0,1,1,{SECRET}\n2,1,2,x\n1,1,2,x\n", "MeasurementError",
     "row 2 has t = 1 s after t = 2 s"),
    ("text.csv", f"t,q1,qd1\n0,1,1\n1,{SECRET},2\n", "MeasurementError", "the first non-number is at data row 1"),
    ("ragged.csv", f"t,q1,qd1\n0,1,1\n1,2,2,{SECRET}\n", ParameterError, "Expected 3 fields in line 3, saw 4"),
]


@pytest.mark.parametrize("name, text, exc, problem", TABLE_CASES, ids=[c[0] for c in TABLE_CASES])
def test_a_bad_recorded_table_is_refused_naming_the_row(tmp_path, name, text, exc, problem):
    """Empty, NaN, repeated or backwards time, text, ragged rows: the library's error naming the file and the row."""
    from forcecontrol.errors import MeasurementError
    from forcecontrol.realarm.io import read_table

    exc = MeasurementError if exc == "MeasurementError" else exc
    p = _table(tmp_path, name, text)
    _refuse(lambda: read_table(p), p, exc, problem)


@pytest.mark.parametrize("kind", ["folder.csv", "fifo.csv", "fifo.mcap", "folder.mcap", "big.csv"])
def test_a_special_or_oversized_recording_is_refused_unopened(tmp_path, kind):
    """Folders and FIFOs named like recordings, and files above max_bytes, are refused without reading them."""
    from forcecontrol.realarm.io import read_recording

    p = tmp_path / kind
    if kind.startswith("folder"):
        p.mkdir()
    elif kind.startswith("fifo"):
        os.mkfifo(p)
    else:
        p.write_text("t,q1,qd1\n" + "".join(f"{i},0,0\n" for i in range(100)))
    problem = {"folder": "a folder", "fifo": "a FIFO", "big": "above the limit of 64 bytes"}[kind.split(".")[0]]
    kwargs = {"max_bytes": 64} if kind == "big.csv" else {}
    _refuse(lambda: read_recording(p, **kwargs), p, ParameterError, problem)


# ----------------------------------------------------------------------------- calibration data


def _planar_readings(angles_rad, mass=1.2, g=9.81, bias=(0.3, -0.2)):
    """Planar free-space forces f_S = −R(φ)ᵀ g m + b_f (the ToolGravity model written out, g along −y)."""
    rows = []
    for a in angles_rad:
        c, s = np.cos(a), np.sin(a)
        u = np.array([[c, s], [-s, c]]) @ np.array([0.0, -g])  # R(φ)ᵀ g
        f = -u * mass + np.asarray(bias)
        rows.append((a, f[0], f[1]))
    return rows


def test_planar_angles_in_degrees_are_refused_and_read_with_degrees(tmp_path):
    """Angles written in degrees (gave a mass of about −0.1 kg) are refused; --degrees reads them: mass 1.2 kg."""
    from forcecontrol.realarm.calibration import calibrate, read_calibration_data

    rad = np.deg2rad([0.0, 60.0, 120.0, 180.0, 240.0, 300.0])
    p = tmp_path / "deg.csv"
    p.write_text("angle,fx,fy\n" + "".join(f"{np.rad2deg(a):.12g},{fx:.12g},{fy:.12g}\n" for a, fx, fy in _planar_readings(rad)))
    _refuse(lambda: read_calibration_data(p), p, ParameterError, "beyond ±2π", "--degrees")
    r = calibrate(*read_calibration_data(p, degrees=True)[:2])
    assert r.mass == pytest.approx(1.2, abs=1e-9)


def test_the_calibrate_command_takes_degrees(tmp_path):
    """`forcecontrol calibrate --degrees` reads the degree angles (mass 1.2 kg); without it the command refuses them."""
    from typer.testing import CliRunner

    from forcecontrol.cli.app import app

    rad = np.deg2rad([0.0, 60.0, 120.0, 180.0, 240.0, 300.0])
    p = tmp_path / "deg.csv"
    p.write_text("angle,fx,fy\n" + "".join(f"{np.rad2deg(a):.12g},{fx:.12g},{fy:.12g}\n" for a, fx, fy in _planar_readings(rad)))
    bad = CliRunner().invoke(app, ["calibrate", str(p), "--json"])
    assert bad.exit_code != 0 and "--degrees" in bad.output
    ok = CliRunner().invoke(app, ["calibrate", str(p), "--json", "--degrees"])
    assert ok.exit_code == 0, ok.output
    import json

    assert json.loads(ok.output)["mass"] == pytest.approx(1.2, abs=1e-9)


def test_a_negative_mass_within_the_noise_is_never_reported():
    """A bare sensor whose least-squares mass comes out negative: reported as 0 kg with a note and a warning, bias = mean."""
    from forcecontrol.realarm.calibration import calibrate

    angles = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    R = np.array([[[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]] for a in angles])
    F = np.array([[fx, fy] for _, fx, fy in _planar_readings(angles, mass=0.0)])
    F += np.random.default_rng(3).normal(0.0, 0.5, F.shape)  # this noise gives m = −0.044 ± 0.024 kg unconstrained
    with pytest.warns(UserWarning, match="negative but within its noise: reported as 0 kg"):
        r = calibrate(R, F)
    assert r.mass == 0.0 and any("reported as 0 kg" in n for n in r.notes)
    np.testing.assert_allclose(r.force_bias, F.mean(axis=0))


def test_a_special_calibration_file_is_refused(tmp_path):
    """A folder named x.csv is refused as a folder, not as 'does not exist'."""
    from forcecontrol.realarm.calibration import read_calibration_data

    p = tmp_path / "x.csv"
    p.mkdir()
    _refuse(lambda: read_calibration_data(p), p, ParameterError, "it is a folder")


def test_an_xml_entity_bomb_urdf_is_refused_in_bounded_time(tmp_path):
    """A 'billion laughs' URDF is refused as bad XML (expat's amplification limit) before Pinocchio parses it."""
    import pyexpat

    if tuple(int(x) for x in pyexpat.EXPAT_VERSION.split("_")[1].split(".")) < (2, 4, 1):
        pytest.skip("expat without the amplification limit")
    entities = "".join(f'<!ENTITY {chr(98 + i)} "' + f"&{chr(97 + i)};" * 10 + '">' for i in range(9))
    p = tmp_path / "bomb.urdf"
    p.write_text(f'<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "{SECRET}">{entities}]><robot name="r">&j;</robot>')
    code = ("import sys\nfrom forcecontrol.robots.urdf_check import check_urdf\ntry:\n    check_urdf(sys.argv[1])\n"
            "except Exception as exc:\n    print(type(exc).__name__, exc)\n")
    out = subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, timeout=120).stdout
    assert out.startswith("ParameterError") and "bomb.urdf" in out and "amplification" in out and SECRET not in out, out
