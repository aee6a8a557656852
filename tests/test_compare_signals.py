"""`compare` (engines/compare.py, cli/compare.py): the pose, the wrench and the joints are compared, and a signal
absent from both runs is said to be not compared (stdout, --json, stderr)."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from forcecontrol.engines.compare import compare_engines, compare_signals, relative_rotation_angle
from forcecontrol.errors import ParameterError
from forcecontrol.sim.result import SimulationResult

runner = CliRunner()
N = 201


def _run(m: int, n: int = 6, seed: int = 0, contact: bool = True, sensor: bool = True, robot: str = "") -> SimulationResult:
    """A synthetic log (m-D task space, n joints) with smooth random signals; XYZ angles in x[:, 3:6] when m = 6."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 0.2, N)
    wave = np.sin(np.outer(t, rng.uniform(1.0, 20.0, 32)) + rng.uniform(0.0, 6.0, 32))
    x = 0.1 * wave[:, :m] + 0.5
    wrench = 10.0 * wave[:, 8:8 + m] if contact else np.zeros((N, m))
    measured = wrench + 0.1 * wave[:, 16:16 + m] if sensor else np.zeros((N, m))
    q = wave[:, 24:24 + n]
    return SimulationResult(t, q, 0.0 * q, x, 0.0 * x, wrench, measured, 0.0 * q, np.zeros((N, 6 * m)),
                            metadata={"robot": robot} if robot else {})


def test_a_run_against_itself_differs_by_exactly_zero_in_every_signal():
    """6-D log against an identical copy: every max and RMS (per axis, norm, angle, joints) is exactly 0.0."""
    a = _run(6)
    b = dataclasses.replace(a, x=a.x.copy(), wrench=a.wrench.copy(), wrench_measured=a.wrench_measured.copy(), q=a.q.copy())
    s = compare_signals(a, b)
    assert all(s[k]["compared"] for k in s), s
    for k, v in s.items():
        numbers = [v["max"], v["rms"]] if k == "orientation" else [*v["max"], *v["rms"], v["norm_max"], v["norm_rms"]]
        assert all(x == 0.0 for x in numbers), (k, numbers)


def test_a_known_position_offset_is_reported_per_axis_and_as_norm():
    """The copy shifted by d = (1, -2, 2) mm: max = RMS = |d_i| per axis, norm 3 mm; orientation and wrench 0."""
    a = _run(6, seed=1)
    d = np.array([1e-3, -2e-3, 2e-3])
    x = a.x.copy()
    x[:, :3] += d
    s = compare_signals(a, dataclasses.replace(a, x=x))
    p = s["position"]
    assert p["unit"] == "m" and p["axes"] == ["x", "y", "z"]
    np.testing.assert_allclose(p["max"], np.abs(d), rtol=1e-9)
    np.testing.assert_allclose(p["rms"], np.abs(d), rtol=1e-9)
    assert p["norm_max"] == pytest.approx(3e-3, rel=1e-9) and p["norm_rms"] == pytest.approx(3e-3, rel=1e-9)
    assert s["orientation"]["max"] == 0.0 and s["contact_force"]["norm_max"] == 0.0


@pytest.mark.parametrize("angle", [1e-7, 0.01, 0.7, 3.0])
def test_a_known_rotation_is_reported_as_the_angle_of_the_relative_rotation(angle):
    """Each sample's frame turned by a known angle about a fixed body axis (scipy builds the rotations and the
    XYZ angles): max = RMS = that angle (to 1e-9 rad, also at 1e-7 rad where acos of the trace loses digits)."""
    a = _run(6, seed=2)
    R_a = Rotation.from_euler("XYZ", a.x[:, 3:6])
    turn = Rotation.from_rotvec(angle * np.array([2.0, -1.0, 2.0]) / 3.0)
    x = a.x.copy()
    x[:, 3:6] = (R_a * turn).as_euler("XYZ")
    o = compare_signals(a, dataclasses.replace(a, x=x))["orientation"]
    assert o["unit"] == "rad" and "caveat" not in o
    assert o["max"] == pytest.approx(angle, abs=1e-9) and o["rms"] == pytest.approx(angle, abs=1e-9)


def test_near_the_euler_singularity_the_orientation_carries_a_caveat():
    """A frame whose XYZ angle φ2 passes within cos φ2 = 5e-4 of π/2: the orientation entry says how far its
    logged angles can be trusted (2 |cos φ2| = 1.0e-03 rad); the position is still compared as usual."""
    a = _run(6, seed=9)
    x = a.x.copy()
    x[100, 4] = math.acos(5e-4)
    s = compare_signals(a, dataclasses.replace(a, x=x))
    assert "|cos φ2| = 5.0e-04 of the XYZ angles' singularity" in s["orientation"]["caveat"]
    assert "to about 1.0e-03 rad" in s["orientation"]["caveat"] and s["position"]["norm_max"] == 0.0


def test_relative_rotation_angle_against_scipy_on_random_pairs():
    """The angle of R_aᵀR_b equals scipy's magnitude of Rotation(R_a)⁻¹ Rotation(R_b) on 500 random pairs (1e-12)."""
    ra, rb = Rotation.random(500, random_state=3), Rotation.random(500, random_state=4)
    got = relative_rotation_angle(ra.as_matrix(), rb.as_matrix())
    np.testing.assert_allclose(got, (ra.inv() * rb).magnitude(), atol=1e-12)


def test_the_planar_arm_orientation_is_its_frame_angle_and_the_torque_is_said_absent():
    """Chapter arm (2-D log): the copy with q shifted by (0.01, 0.02) rad has orientation difference 0.03 rad
    (φ = q1 + q2); the torque is not compared, with the 2-D task space given as the reason."""
    a = _run(2, n=2, seed=5, robot="PlanarTwoLink")
    s = compare_signals(a, dataclasses.replace(a, q=a.q + [0.01, 0.02]))
    assert s["orientation"]["max"] == pytest.approx(0.03, abs=1e-12) and s["orientation"]["rms"] == pytest.approx(0.03, abs=1e-12)
    np.testing.assert_allclose(s["joint_positions"]["max"], [0.01, 0.02], rtol=1e-9)
    for k in ("contact_torque", "measured_torque"):
        assert not s[k]["compared"] and "2-D task space (x y): the log has no moment" in s[k]["why"]
    assert s["contact_force"]["axes"] == ["fx", "fy"] and s["contact_force"]["unit"] == "N"


def test_no_contact_and_no_sensor_reading_are_said_not_compared():
    """Zero contact wrench in both runs: the force-difference percentages are None and 'absent' says
    'no contact in either run'; a sensor that read zero in both: 'the sensor read no force in either run'."""
    a, b = _run(6, seed=6, contact=False, sensor=False), _run(6, seed=7, contact=False, sensor=False)
    rep = compare_engines(a, b)
    assert rep["steady_force_difference_percent"] is None and rep["max_force_difference_over_peak_percent"] is None
    assert rep["absent"]["contact_force"] == "no contact in either run: contact force [N] not compared"
    assert rep["absent"]["contact_torque"] == "no contact moment in either run: contact torque [N m] not compared"
    assert rep["absent"]["measured_force"] == "the sensor read no force in either run: measured force [N] not compared"
    assert rep["signals"]["position"]["compared"] and rep["signals"]["position"]["norm_max"] > 0.0


def test_a_position_only_log_of_another_arm_says_orientation_not_compared():
    """A 3-D (position) log of an arm that is not the chapter's planar arm has no orientation: said, not zero."""
    a = _run(3, seed=8)
    o = compare_signals(a, a)["orientation"]
    assert o == {"compared": False, "why": "the log holds the position only (3-D task space: x y z) and the arm is not "
                                           "the chapter's planar arm: orientation [rad] not compared"}


def test_runs_with_other_sample_times_are_refused():
    """Two logs of different lengths cannot be compared sample by sample: ParameterError naming both runs."""
    a = _run(2, n=2)
    b = dataclasses.replace(a, t=a.t[:-1], q=a.q[:-1], x=a.x[:-1], wrench=a.wrench[:-1])
    with pytest.raises(ParameterError, match=r"builtin, mujoco: the two runs must share their sample times; got 201 samples"):
        compare_signals(a, b)


def _cli(*args: str):
    pytest.importorskip("mujoco")
    from forcecontrol.cli import app

    return runner.invoke(app, ["compare", *args])


def test_compare_177_without_contact_says_so_and_compares_the_pose():
    """`compare fzi_issue_177.toml` (a payload in free space, 0.1 s): 'no contact in either run' on stdout, in
    --json and on stderr; the pose difference of the two engines is finite, nonzero and below 1 mm / 0.01 rad."""
    from importlib.resources import files

    path = str(files("forcecontrol.scenarios") / "configs" / "fzi_issue_177.toml")
    res = _cli(path, "--set", "duration=0.1", "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["set"] == {"duration": 0.1} and doc["units"]["orientation"] == "rad" and doc["units"]["contact_torque"] == "N m"
    for c in doc["cases"]:
        assert c["signals"]["contact_force"] == {"compared": False,
                                                 "why": "no contact in either run: contact force [N] not compared"}
        assert c["steady_force_difference_percent"] is None
        p, o = c["signals"]["position"], c["signals"]["orientation"]
        assert 0.0 < p["norm_max"] < 1e-3 and math.isfinite(p["norm_rms"])
        assert 0.0 < o["max"] < 1e-2 and math.isfinite(o["rms"])
        assert c["signals"]["measured_force"]["compared"]  # the payload's wrench is read in both
    assert "no contact in either run: contact force [N] not compared" in res.stderr
    text = _cli(path, "--set", "duration=0.1")
    assert text.exit_code == 0, text.output
    assert "no contact in either run: contact force [N] not compared" in text.stdout
    assert "contact force, built-in simulator vs MuJoCo: not compared" in text.stdout
    assert "|Δp| [m]" in text.stdout and "Δmx [N m]" in text.stdout


def test_compare_planar_chapter_example_says_no_torque_and_keeps_its_contact_table():
    """`compare example-9.2` (0.3 s): the contact table first as before, the pose and force compared, and 'no
    moment: contact and measured torque [N m] not compared' on stdout, in --json's 'absent' and on stderr."""
    res = _cli("example-9.2", "--set", "duration=0.3", "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    why = "2-D task space (x y): the log has no moment: contact and measured torque [N m] not compared"
    for c in doc["cases"]:
        assert c["absent"] == {"contact_torque": why, "measured_torque": why}
        assert c["steady_force_difference_percent"] < 1.0 and c["signals"]["contact_force"]["norm_max"] > 0.0
        assert 0.0 < c["signals"]["orientation"]["max"] < 1e-2
    assert why in res.stderr
    text = _cli("example-9.2", "--set", "duration=0.3")
    assert text.exit_code == 0, text.output
    first = text.stdout.index("contact force, built-in simulator vs MuJoCo")
    assert first < text.stdout.index("pose of the controlled frame") < text.stdout.index(why)
    assert "torque [N m], MuJoCo − built-in: not compared" in text.stdout


def test_compare_set_with_an_unknown_key_is_refused_before_anything_runs():
    """`compare example-9.2 --set controller.stifness=1`: exit 2, the error names the key; no table is printed."""
    res = _cli("example-9.2", "--set", "controller.stifness=1")
    assert res.exit_code == 2, res.output
    assert "--set controller.stifness=1" in " ".join(res.stderr.split()) and "unknown key 'stifness'" in res.stderr
    assert "┏" not in res.stdout
