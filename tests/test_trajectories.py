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
    from forcecontrol.trajectories import _trapezoid_scalar

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
