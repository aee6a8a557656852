"""References from samples (issue 13 item 4): a recorded or designed trajectory, from Python or a file.

References: analytic derivatives of a smooth function; the built-in reference types sampled and
replayed (a set-point and a trapezoidal path: same simulation); a force step at t = 1 s from a file,
whose settled force is the requested one.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import DimensionError, ParameterError, ScenarioError
from forcecontrol.scenarios import load_scenario
from forcecontrol.trajectories import SampledReference


def test_cubic_interpolation_recovers_a_smooth_signal_and_its_derivatives():
    t = np.linspace(0.0, 2.0, 401)
    w = 2 * math.pi * 0.7
    x = np.column_stack([np.sin(w * t), np.cos(w * t)])
    ref = SampledReference(t, x, interpolation="cubic")
    tq = np.linspace(0.3, 1.7, 57) + 0.0013  # between the samples, away from the clamped ends
    rows = ref.sample(tq)
    np.testing.assert_allclose(rows[:, 0], np.sin(w * tq), atol=1e-6)
    np.testing.assert_allclose(rows[:, 2], w * np.cos(w * tq), atol=1e-4)
    np.testing.assert_allclose(rows[:, 4], -w * w * np.sin(w * tq), atol=2e-2)
    held = ref.at(5.0)
    np.testing.assert_allclose(held.position, x[-1])
    assert not np.any(held.velocity) and not np.any(held.acceleration)


def test_linear_interpolation_is_piecewise_linear():
    ref = SampledReference([0.0, 1.0, 3.0], [[0.0], [2.0], [3.0]], [[0.0], [10.0], [10.0]], interpolation="linear")
    r = ref.at(2.0)
    assert r.position[0] == pytest.approx(2.5) and r.velocity[0] == pytest.approx(0.5) and r.acceleration[0] == 0.0
    assert ref.at(0.5).force[0] == pytest.approx(5.0) and ref.at(0.5).force_rate[0] == pytest.approx(10.0)


def test_a_sampled_path_replays_the_same_simulation_as_the_built_in_path():
    """A trapezoidal LinearPath sampled at 1 kHz (positions, velocities, accelerations) and replayed on the same grid
    gives the same run as the LinearPath itself; from positions alone (cubic spline), the same path within 0.5 mm."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    env = fc.ElasticPlane([1.1, 0.0], [-1.0, 0.0], 1e4)
    path = fc.LinearPath([1.0, 0.0], [1.0, 0.2], 1.0, 0.2)
    t = np.arange(0.0, 1.5005, 1e-3)
    rows = path.sample(t)
    sampled = SampledReference(t, rows[:, 0:2], interpolation="linear", velocity=rows[:, 2:4], acceleration=rows[:, 4:6])
    ctl = fc.ImpedanceController(arm, 100.0, 500.0, 2500.0, True)
    a = fc.simulate(arm, env, ctl, path, q0=q0, duration=1.5)
    b = fc.simulate(arm, env, ctl, sampled, q0=q0, duration=1.5)
    np.testing.assert_allclose(b.x, a.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.torque, a.torque, rtol=1e-12, atol=1e-9)
    spline = fc.simulate(arm, env, ctl, SampledReference(t[::20], rows[::20, 0:2]), q0=q0, duration=1.5)
    assert np.max(np.abs(spline.x - a.x)) < 5e-4


def test_force_step_at_one_second_from_a_file_in_a_scenario(tmp_path):
    t = np.array([0.0, 0.999, 1.0, 4.0])
    data = np.column_stack([t, np.full(4, 1.015), np.full(4, 0.1), [0.0, 0.0, 10.0, 10.0], np.zeros(4)])
    np.savetxt(tmp_path / "ref.csv", data, delimiter=",", header="t,x,y,fx,fy", comments="")
    (tmp_path / "scn.toml").write_text(textwrap.dedent("""
        name = "force-step-file"
        duration = 4.0
        [robot]
        start_position = [1.0, 0.0]
        [environment]
        type = "elastic-plane"
        point = [1.0, 0.0]
        normal = [-1.0, 0.0]
        stiffness = 10000.0
        [controller]
        type = "inner-velocity"
        inertia = 100.0
        damping = 500.0
        stiffness = 2500.0
        force_gain = [0.0024, 0.0]
        [reference]
        type = "sampled"
        file = "ref.csv"
        interpolation = "linear"
    """))
    res = load_scenario(tmp_path / "scn.toml").run().cases[0].result
    before = res.wrench[(res.t > 0.5) & (res.t < 0.99), 0]
    assert np.max(np.abs(before)) < 0.5  # no force asked before 1 s
    assert res.settled_values(0.2)["fx"] == pytest.approx(10.0, rel=1e-3)


def test_a_saved_run_is_a_reference_file(tmp_path):
    """The simulator's own log (ref_position_*, ref_force_* columns) reads back as the reference it ran."""
    res = fc.scenario("example-9.2").run().cases[0].result
    data, _meta = res.save(tmp_path / "run", format="csv")
    ref = SampledReference.from_file(data)
    assert ref.dim == 2
    np.testing.assert_allclose(ref.at(1.0).position, [1.1, 0.1])


def test_bad_samples_and_files_get_clear_errors(tmp_path):
    with pytest.raises(ParameterError, match=r"strictly increasing; got t\[1\] = 1 s followed by t\[2\] = 1 s"):
        SampledReference([0.0, 1.0, 1.0], [[0.0], [1.0], [2.0]])
    with pytest.raises(DimensionError, match=r"position must have shape \(3, m\)"):
        SampledReference([0.0, 1.0, 2.0], [[0.0], [1.0]])
    with pytest.raises(ParameterError, match="finite"):
        SampledReference([0.0, 1.0], [[0.0], [math.nan]])
    with pytest.raises(ParameterError, match="interpolation must be one of"):
        SampledReference([0.0, 1.0], [[0.0], [1.0]], interpolation="spline")
    (tmp_path / "bad.csv").write_text("time,a,b\n0,1,2\n1,1,2\n")
    with pytest.raises(ParameterError, match=r"no column 't'; columns found: \['a', 'b', 'time'\]"):
        SampledReference.from_file(tmp_path / "bad.csv")
    (tmp_path / "scn.toml").write_text(textwrap.dedent("""
        name = "missing-file"
        duration = 1.0
        [robot]
        start_position = [1.0, 0.0]
        [environment]
        type = "elastic-plane"
        point = [1.0, 0.0]
        normal = [-1.0, 0.0]
        stiffness = 1000.0
        [controller]
        type = "impedance"
        inertia = 100.0
        damping = 500.0
        stiffness = 2500.0
        [reference]
        type = "sampled"
        file = "nowhere.csv"
    """))
    with pytest.raises(ScenarioError, match=r"\[reference\].*cannot read reference samples from .*nowhere.csv"):
        load_scenario(tmp_path / "scn.toml")


def test_linear_hold_is_exactly_constant_and_samples_are_exact():
    """A linear reference holding a pose (two equal samples) returns that pose bit for bit at every time, whatever the
    hold's length (a motion's start time then cannot reach a run that ends before it); each sample time, the last
    included, returns its sample exactly; between samples the value is on the segment."""
    from forcecontrol.trajectories.sampled import SampledReference

    rng = np.random.default_rng(3)
    x0 = rng.normal(size=6) * np.array([0.3, 0.3, 0.5, 3.0, 1.0, 2.0])
    x1 = x0 + 0.1
    tq = np.linspace(0.0, 0.3, 3001)
    for start in (0.37, 0.5, 0.65, 1.0 / 3.0, 7.123):
        ref = SampledReference([0.0, start, start + 1.0], np.vstack([x0, x0, x1]), np.zeros((3, 6)), interpolation="linear")
        assert np.array_equal(ref.sample(tq)[:, :6], np.broadcast_to(x0, (tq.size, 6)))
        got = ref.sample(np.array([0.0, start, start + 1.0]))[:, :6]
        assert np.array_equal(got, np.vstack([x0, x0, x1]))
        mid = ref.sample(np.array([start + 0.25]))[0, :6]
        np.testing.assert_allclose(mid, x0 + 0.25 * (x1 - x0), rtol=0, atol=1e-15)
