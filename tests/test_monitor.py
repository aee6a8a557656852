"""The online stability monitor (issue 18, part 2).

References: synthetic signals of known frequency, amplitude and growth rate; the sampled-loop
stability limit of the inner velocity loop from the linear analysis (``sampled_stability_limit``,
an independent model); the chapter's Examples 9.2-9.4, which are stable and must stay quiet.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.supervision.monitor import MonitoredController, StabilityMonitor

TS = 1e-3


def _signal(fn, duration=4.0):
    t = np.arange(int(round(duration / TS)) + 1) * TS
    f = np.array([fn(tk) for tk in t])
    return SimpleNamespace(t=t, wrench_measured=np.column_stack([f, np.zeros_like(f)]))


def test_growing_oscillation_is_divergence_with_its_frequency_and_rate():
    sigma, freq = 1.5, 7.0
    run = _signal(lambda t: 20.0 + 0.5 * math.exp(sigma * t) * math.sin(2 * math.pi * freq * t))
    m = StabilityMonitor(TS, direction=[1.0, 0.0])
    m.scan(run)
    alarm = m.first_alarm()
    assert alarm is not None and alarm.flag == "divergence"
    last = m.history[-1]
    assert last.frequency == pytest.approx(freq, abs=0.5)
    assert last.growth_rate == pytest.approx(sigma, rel=0.15)


def test_steady_oscillation_is_a_limit_cycle_with_its_amplitude():
    run = _signal(lambda t: 30.0 + 5.0 * math.sin(2 * math.pi * 3.0 * t))
    m = StabilityMonitor(TS)
    m.scan(run)
    alarm = m.first_alarm()
    assert alarm is not None and alarm.flag == "limit-cycle"
    last = m.history[-1]
    assert last.amplitude == pytest.approx(5.0, rel=0.05)
    assert last.frequency == pytest.approx(3.0, abs=0.5)
    assert abs(last.growth_rate) < 0.1


def test_decaying_oscillation_noise_and_step_are_quiet():
    rng = np.random.default_rng(0)
    for fn in (
        lambda t: 10.0 + 20.0 * math.exp(-2.0 * t) * math.sin(2 * math.pi * 2.0 * t),  # the chapter's transients
        lambda t: 10.0 * (1.0 - math.exp(-3.0 * t)),  # a slow rise, no oscillation
        lambda t: 10.0 + rng.normal(0.0, 0.5),  # sensor noise below min_amplitude
    ):
        m = StabilityMonitor(TS)
        m.scan(_signal(fn))
        assert m.first_alarm() is None, m.history[-1]


def test_bouncing_is_chatter():
    run = _signal(lambda t: max(0.0, 40.0 * math.sin(2 * math.pi * 4.0 * t)))
    m = StabilityMonitor(TS)
    m.scan(run)
    alarm = m.first_alarm()
    assert alarm is not None and alarm.flag == "chatter" and alarm.contact_losses >= 2


def test_non_finite_force_is_divergence_at_once():
    m = StabilityMonitor(TS)
    m.update(0.0, [1.0, 0.0])
    assert m.update(0.001, [math.nan, 0.0]).flag == "divergence"


@pytest.mark.parametrize("name", ["example-9.2", "example-9.3", "example-9.4"])
def test_quiet_on_the_chapters_examples(name):
    out = fc.scenario(name).run()
    for case in out.cases:
        m = StabilityMonitor(case.result.t[1] - case.result.t[0])
        m.scan(case.result)
        assert m.first_alarm() is None, (case.label, m.first_alarm())


@pytest.fixture(scope="module")
def velocity_loop_limit():
    """Example 9.3's inner velocity loop: its sampled-loop stiffness limit from the linear analysis."""
    from forcecontrol.analysis import ForceLoopAxis, operational_mass, sampled_stability_limit

    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    axis = ForceLoopAxis("inner-velocity", 100.0, 500.0, 2500.0, 0.0024, 0.0, 1e4)
    return arm, q0, sampled_stability_limit(axis, TS, arm_inertia=operational_mass(arm, q0, [1.0, 0.0]))


def _velocity_loop(arm, kf):
    return fc.InnerVelocityForceController(arm, 100.0, 500.0, 2500.0, [kf, 0.0], sample_time=TS)


@pytest.mark.parametrize(("ratio", "fires"), [(0.5, False), (0.8, False), (1.1, True), (1.5, True)])
def test_fires_past_the_sampled_loop_stability_limit_only(velocity_loop_limit, ratio, fires):
    arm, q0, limit = velocity_loop_limit
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], ratio * limit)
    res = fc.simulate(arm, env, _velocity_loop(arm, 0.0024), fc.Setpoint([1.015, 0.1], [10.0, 0.0]), q0=q0, duration=1.5)
    m = StabilityMonitor(TS)
    m.scan(res)
    assert (m.first_alarm() is not None) == fires, (ratio, limit, m.first_alarm())


def test_monitored_controller_backs_off_to_the_safe_gains(velocity_loop_limit):
    """Past the limit, the monitor fires within 0.5 s and the fallback (k_F / 4) settles at f_d."""
    arm, q0, limit = velocity_loop_limit
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1.5 * limit)
    ctl = MonitoredController(_velocity_loop(arm, 0.0024), StabilityMonitor(TS), fallback=_velocity_loop(arm, 0.0006))
    res = fc.simulate(arm, env, ctl, fc.Setpoint([1.015, 0.1], [10.0, 0.0]), q0=q0, duration=2.5)
    (event,) = [e for e in res.events if e["event"] == "stability"]
    assert event["t"] < 0.5 and event["reaction"] == "fallback" and event["flag"] in ("chatter", "divergence")
    assert np.mean(res.wrench[res.t >= 2.3, 0]) == pytest.approx(10.0, rel=0.05)


def test_bad_settings_and_inputs():
    with pytest.raises(ParameterError, match="window must hold at least 16 samples"):
        StabilityMonitor(TS, window=0.01)
    with pytest.raises(ParameterError, match="persistence must be an integer >= 1"):
        StabilityMonitor(TS, persistence=0)
    with pytest.raises(ParameterError, match="direction must be a finite non-zero vector"):
        StabilityMonitor(TS, direction=[0.0, 0.0])
    m = StabilityMonitor(TS, direction=[1.0, 0.0])
    with pytest.raises(DimensionError, match=r"force must have shape \(2,\)"):
        m.update(0.0, [1.0, 2.0, 3.0])
    with pytest.raises(ParameterError, match="sample time"):
        StabilityMonitor(2e-3).scan(_signal(lambda t: 0.0, duration=0.1))
    arm = fc.PlanarTwoLink()
    with pytest.raises(ParameterError, match="monitor.sample_time must equal"):
        MonitoredController(_velocity_loop(arm, 0.001), StabilityMonitor(2e-3))
    with pytest.raises(ParameterError, match="react_to must name flags"):
        MonitoredController(_velocity_loop(arm, 0.001), StabilityMonitor(TS), react_to=("wobble",))


# -- sustained growth (issue 27): the inner position loop of Example 9.3 just past its sampled-loop limit


@pytest.fixture(scope="module")
def position_loop():
    """Example 9.3's inner position loop (k_F = 0.0024, k_I = 0.002), its sampled-loop limit and axis."""
    from forcecontrol.analysis import force_loop_axes, operational_mass, sampled_stability_limit

    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    mx = operational_mass(arm, q0, [1.0, 0.0])
    axis = force_loop_axes(_position_loop(arm, "tip"), 1e4)[0]
    return arm, q0, mx, axis, sampled_stability_limit(axis, TS, arm_inertia=mx)


def _position_loop(arm, start):
    return fc.InnerPositionForceController(arm, 100.0, 500.0, 2500.0, [0.0024, 0.0], [0.002, 0.0], sample_time=TS,
                                           integrator_start=start)


def _press(position_loop, ratio, *, start="tip", noise=0.0, seed=1, duration=3.0):
    arm, q0, _, _, limit = position_loop
    sensor = fc.ForceSensor(noise_std=noise, seed=seed) if noise else None
    return fc.simulate(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], ratio * limit), _position_loop(arm, start),
                       fc.Setpoint([1.015, 0.1], [10.0, 0.0]), q0=q0, duration=duration, sensor=sensor)


@pytest.mark.parametrize("ratio", [1.3, 2.0])
def test_sustained_growth_alarms_early_at_the_growth_rate_of_the_linear_loop(position_loop, ratio):
    """Past the limit the growth path fires within growth_window + 2 hops, below min_amplitude, at σ = ln ρ / Ts."""
    _, _, mx, axis, limit = position_loop
    sigma = math.log(axis.with_environment_stiffness(ratio * limit).spectral_radius(TS, mx)) / TS  # the linear model
    res = _press(position_loop, ratio)
    m = StabilityMonitor(TS, direction=[1.0, 0.0])
    m.scan(res)
    alarm = m.first_alarm()
    assert alarm is not None and alarm.flag == "divergence" and alarm.cause == "sustained-growth", alarm
    # the oscillation starts above growth_floor, so the documented bound is growth_window + 2 hop
    assert alarm.t <= m.growth_window + 2 * m.hop, alarm
    assert alarm.amplitude < m.min_amplitude
    assert alarm.envelope_growth == pytest.approx(sigma, rel=0.1)
    # the amplitude path alone (growth path switched off) has not fired by then
    late = StabilityMonitor(TS, direction=[1.0, 0.0], sustained_growth=1e9)
    late.scan(res)
    first = late.first_alarm()
    assert first is None or first.t > alarm.t + 1.0, first


@pytest.mark.parametrize("ratio", [0.5, 0.9])
@pytest.mark.parametrize("seed", [1, 2])
def test_stable_loop_with_sensor_noise_is_quiet(position_loop, ratio, seed):
    """Below the limit, with 0.05 N of white sensor noise in the loop, nothing fires in 4 s."""
    m = StabilityMonitor(TS, direction=[1.0, 0.0])
    m.scan(_press(position_loop, ratio, noise=0.05, seed=seed, duration=4.0))
    assert m.first_alarm() is None, m.first_alarm()


@pytest.mark.parametrize("ratio", [0.5, 0.9])
def test_stable_loop_with_the_chapters_start_up_kick_never_grows(position_loop, ratio):
    """Example 9.3's start ("hold": the force step through the whole PI) decays at ln ρ / Ts: never a divergence."""
    _, _, mx, axis, limit = position_loop
    sigma = math.log(axis.with_environment_stiffness(ratio * limit).spectral_radius(TS, mx)) / TS  # < 0: stable
    m = StabilityMonitor(TS, direction=[1.0, 0.0])
    m.scan(_press(position_loop, ratio, start="hold", duration=4.0))
    assert all(s.flag != "divergence" for s in m.history), [s for s in m.history if s.flag == "divergence"][:1]
    assert m.history[-1].envelope_growth <= sigma + 0.15  # no mode decays slower than the slowest pole
    if ratio == 0.5:
        assert m.first_alarm() is None, m.first_alarm()


@pytest.mark.parametrize(("a0", "sigma"), [(0.005, 1.0), (0.005, 0.5), (0.1, 0.6)])
def test_time_to_alarm_follows_the_documented_bound(a0, sigma):
    """A synthetic e^{σt} oscillation alarms after ln(floor/A₀)/σ and before it + growth_window + 2 hop."""
    rng = np.random.default_rng(3)
    run = _signal(lambda t: 10.0 + a0 * math.exp(sigma * t) * math.sin(2 * math.pi * 17.0 * t) + rng.normal(0.0, 0.01),
                  duration=7.0)
    m = StabilityMonitor(TS, direction=[1.0, 0.0])
    m.scan(run)
    alarm = m.first_alarm()
    t_floor = max(0.0, math.log(m.growth_floor / a0) / sigma)
    assert alarm is not None and alarm.cause == "sustained-growth", alarm
    assert t_floor - 0.5 <= alarm.t <= t_floor + m.growth_window + 2 * m.hop, (alarm.t, t_floor)


def test_steady_small_oscillation_and_noise_are_not_growth():
    """A steady 0.5 N oscillation (σ = 0) with noise, and noise alone, never trip the growth path."""
    m = StabilityMonitor(TS, direction=[1.0, 0.0])
    m.scan(_signal(lambda t: 10.0 + 0.5 * math.sin(2 * math.pi * 17.0 * t)))
    assert abs(m.history[-1].envelope_growth) < 0.05  # the fit sees the steady envelope
    rng = np.random.default_rng(4)
    for fn in (lambda t: 10.0 + 0.5 * math.sin(2 * math.pi * 17.0 * t) + rng.normal(0.0, 0.05),
               lambda t: 10.0 + rng.normal(0.0, 0.05)):
        m = StabilityMonitor(TS, direction=[1.0, 0.0])
        m.scan(_signal(fn))
        assert m.first_alarm() is None, m.first_alarm()
    assert abs(m.history[-1].envelope_growth) < 1.0  # noise alone: a fit of ln(RMS) with no trend


def test_growth_settings_are_checked():
    """The growth path's settings are refused when not positive."""
    with pytest.raises(ParameterError, match="sustained_growth"):
        StabilityMonitor(TS, sustained_growth=0.0)
    with pytest.raises(ParameterError, match="growth_floor"):
        StabilityMonitor(TS, growth_floor=-1.0)
    with pytest.raises(ParameterError, match="growth_periods must be an integer >= 1"):
        StabilityMonitor(TS, growth_periods=0)
