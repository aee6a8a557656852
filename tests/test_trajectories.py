"""References: trapezoidal timing law and straight paths."""

from __future__ import annotations

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import ParameterError
from forcecontrol.trajectories import LinearPath, trapezoidal_profile


def test_trapezoid_starts_ends_and_is_continuous():
    """s(0) = 0, s(t_f) = 1, ṡ continuous, ṡ and s̈ are the derivatives of s (finite differences)."""
    t = np.linspace(0, 1, 100001)
    s, sd, sdd = trapezoidal_profile(t, 1.0, 0.2)
    assert s[0] == 0 and s[-1] == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(np.gradient(s, t), sd, atol=1e-4)
    assert sd.max() == pytest.approx(1 / (1 - 0.2))  # cruise speed L / (t_f − t_c)
    assert np.abs(np.diff(sd)).max() < 1e-4


def test_linear_path_follows_the_segment():
    """Positions stay on the segment; velocity is along it; after t_f the reference rests at the end."""
    p = fc.LinearPath([1.0, 0.0], [1.2, 0.2], 1.0, accel_time=0.25)
    rows = p.sample(np.array([0.0, 0.5, 1.0, 2.0]))
    np.testing.assert_allclose(rows[:, 0] - 1.0, rows[:, 1], atol=1e-15)
    np.testing.assert_allclose(rows[-1, :2], [1.2, 0.2])
    np.testing.assert_allclose(rows[1, 2:4], p.cruise_speed * np.array([1, 1]) / np.sqrt(2), rtol=1e-12)
    ref = p.at(0.5)
    np.testing.assert_allclose(ref.position, rows[1, :2])


def test_bad_path_timing_is_refused():
    """An acceleration time longer than half the duration is refused."""
    with pytest.raises(ParameterError, match=r"accel_time must be at most duration/2 = 0.5 s; got 0.6 s"):
        fc.LinearPath([0, 0], [1, 1], 1.0, accel_time=0.6)


def test_profile_rests_before_and_after_the_motion():
    """Outside [0, t_f) the velocity and acceleration references are zero (no feedforward at rest)."""
    s, sd, sdd = trapezoidal_profile(np.array([-0.5, 0.0, 1.0, 1.5]), 1.0, 0.2)
    np.testing.assert_array_equal(s, [0.0, 0.0, 1.0, 1.0])
    np.testing.assert_array_equal(sd, [0.0, 0.0, 0.0, 0.0])
    assert sdd[0] == 0.0 and sdd[1] == pytest.approx(1 / (0.2 * 0.8)) and sdd[2] == 0.0 and sdd[3] == 0.0


def test_impedance_tracks_the_path_end_point():
    """Impedance control along a path ends at p_f (the feedforward stops with the motion)."""
    import forcecontrol as fc

    arm = fc.PlanarTwoLink()
    env = fc.LinearSpring(np.zeros((2, 2)), [0.0, 0.0])
    path = fc.LinearPath([1.0, 0.0], [1.2, 0.2], 1.0)
    ctl = fc.ImpedanceController(arm, 100, 1000, 2500)
    r = fc.simulate(arm, env, ctl, path, q0=arm.inverse_kinematics([1.0, 0.0]), duration=3.0)
    np.testing.assert_allclose(r.x[-1], [1.2, 0.2], atol=1e-4)


@pytest.mark.parametrize("signal", [
    fc.LinearPath([1.0, 0.0], [1.2, 0.3], 1.0, accel_time=0.3, start_time=0.25, force=[5.0, -1.0]),
    fc.Setpoint([1.1, 0.1], force=[10.0, 0.0]),
])
def test_at_equals_the_packed_samples(signal):
    """The scalar `at(t)` gives exactly the numbers of the vectorised `sample` (used by the compiled loop)."""
    from forcecontrol.controllers.base import pack_reference

    times = np.array([-0.1, 0.0, 0.1, 0.25, 0.3, 0.55, 0.9, 1.24, 1.25, 1.3, 3.0])
    rows = signal.sample(times)
    for t, row in zip(times, rows):
        np.testing.assert_allclose(pack_reference(signal.at(t)), row, rtol=0, atol=1e-15)


@pytest.mark.parametrize(("tf", "tc", "Ts"), [(1.0, 0.2, 1e-3), (2.5, 0.5, 1e-3), (0.7, 0.35, 1e-3), (1.3, 0.1, 5e-4)])
def test_sampled_profile_is_exact_under_zero_order_hold(tf, tc, Ts):
    """Samples at k Ts hold the interval after them: integrating the held s̈ reproduces ṡ and s at every sample (closed form)."""
    k = np.arange(int(round((tf + 0.3) / Ts)) + 1)
    t = k * Ts
    s, sd, sdd = trapezoidal_profile(t, tf, tc)
    # ZOH integration of the sampled acceleration, from rest
    v = np.concatenate([[0.0], np.cumsum(Ts * sdd[:-1])])
    x = np.concatenate([[0.0], np.cumsum(Ts * sd[:-1] + 0.5 * Ts**2 * sdd[:-1])])
    np.testing.assert_allclose(v, sd, atol=1e-9)
    np.testing.assert_allclose(x, s, atol=1e-9)
    sdd_c = 1.0 / (tc * (tf - tc))
    # the interval after each breakpoint (no cruise when t_c = t_f / 2: deceleration starts at t_c)
    breaks = {0.0: sdd_c, tc: 0.0}
    breaks[tf - tc] = -sdd_c
    breaks[tf] = 0.0
    for t_b, want in breaks.items():
        i = int(round(t_b / Ts))
        assert sdd[i] == want, (t_b, sdd[i], want)
        assert _at(t[i], tf, tc) == (s[i], sd[i], sdd[i])


def _at(t, tf, tc):
    from forcecontrol.trajectories.profiles import _trapezoid_scalar

    return _trapezoid_scalar(float(t), tf, tc)


def test_linear_path_by_top_speed():
    """LinearPath(speed=v) cruises at v: t_f = L/v + t_c, and the sampled peak speed is v."""
    path = LinearPath([0.0, 0.0], [0.3, 0.4], speed=0.25, accel_time=0.4)
    assert path.duration == pytest.approx(0.5 / 0.25 + 0.4)
    ref = path.sample(np.linspace(0.0, path.duration, 2001))
    assert np.max(np.linalg.norm(ref[:, 2:4], axis=1)) == pytest.approx(0.25, rel=1e-12)
    default = LinearPath([0.0, 0.0], [0.3, 0.4], speed=0.25)
    assert default.duration == pytest.approx(1.25 * 0.5 / 0.25) and default.cruise_speed == pytest.approx(0.25)
    with pytest.raises(ParameterError, match="exactly one of duration and speed"):
        LinearPath([0.0, 0.0], [0.3, 0.4], 1.0, speed=0.25)


@pytest.mark.parametrize("shape", ["linear", "smooth"])
def test_force_profile_closed_form_and_derivatives(shape):
    """σ(t) is 0 before start, 1 after start + ramp; σ̇ and σ̈ are its derivatives (central differences)."""
    from forcecontrol.trajectories import force_profile

    t = np.linspace(0.0, 3.0, 30001)
    s, sd, sdd = force_profile(t, 1.0, 0.5, shape)
    assert np.all(s[t < 1.0] == 0.0) and np.all(s[t >= 1.5] == 1.0)
    h = t[1] - t[0]
    inner = (t > 1.01) & (t < 1.49)
    np.testing.assert_allclose(np.gradient(s, h)[inner], sd[inner], atol=1e-6)
    if shape == "smooth":
        np.testing.assert_allclose(np.gradient(sd, h)[inner], sdd[inner], atol=1e-4)
        assert s[np.searchsorted(t, 1.25)] == pytest.approx(0.5, abs=1e-12)  # quintic midpoint


def test_force_step_later_is_the_same_response_shifted():
    """Example 9.3's inner velocity loop with f_d stepped at 1 s: nothing before, then the t = 0 response shifted by 1 s."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)

    def run(start):
        ctl = fc.InnerVelocityForceController(arm, [100, 100], [500, 500], [2500, 2500], force_gain=[0.0024, 0.0])
        ref = fc.Setpoint([1.015, 0.1], [10.0, 0.0], force_start=start)
        return fc.simulate(arm, env, ctl, ref, q0=q0, duration=3.0 + start)

    now, later = run(0.0), run(1.0)
    assert np.abs(later.wrench[:1000, 0]).max() < 1e-9  # no force demanded before 1 s, tip at rest on the plane
    np.testing.assert_allclose(later.wrench[1000:, 0], now.wrench[:, 0], atol=1e-6)
    assert later.reference_block("force")[999, 0] == 0.0 and later.reference_block("force")[1000, 0] == 10.0


def test_force_profile_is_refused_when_malformed():
    """Negative start or ramp and unknown shapes are ParameterErrors naming the argument."""
    with pytest.raises(ParameterError, match="force_start must be a non-negative number"):
        fc.Setpoint([1.0, 0.0], [1.0, 0.0], force_start=-1.0)
    with pytest.raises(ParameterError, match="force_shape must be one of linear, smooth; got 'cubic'"):
        fc.Setpoint([1.0, 0.0], [1.0, 0.0], force_ramp=1.0, force_shape="cubic")


def test_a_scenario_path_can_be_given_by_its_top_speed():
    """[reference] speed = v instead of duration: Problem 9.10's path at v = 1.25 L / t_f is the same path
    (t_f = L/v + t_c, t_c = t_f/5); neither or both is refused naming the two keys."""
    import copy
    import math

    from forcecontrol.errors import ScenarioError
    from forcecontrol.scenarios import build_case, load_scenario

    scn = load_scenario("problem-9.10")
    case = scn.cases[0]
    ref = case.config["reference"]
    L = math.dist(ref["start"], ref["end"])
    by_speed = copy.deepcopy(case)
    by_speed.config["reference"].pop("duration")
    by_speed.config["reference"]["speed"] = 1.25 * L / ref["duration"]
    t = np.linspace(0.0, 1.5, 1501)
    a = build_case(case)["reference"].sample(t)
    b = build_case(by_speed)["reference"].sample(t)
    np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
    neither = copy.deepcopy(by_speed)
    neither.config["reference"].pop("speed")
    with pytest.raises(ScenarioError, match="give exactly one of duration and speed"):
        build_case(neither)
