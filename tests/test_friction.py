"""Coulomb friction with stiction (issue 31, item 2): closed forms on a flat plane with the chapter's arm."""

from __future__ import annotations

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.environments.friction import FrictionalContact
from forcecontrol.errors import ParameterError

ARM = fc.PlanarTwoLink()
Q0 = ARM.inverse_kinematics([1.0, 0.6])  # the tip on the undeformed plane y = 0.6
KP, KD, MD = 4000.0, 400.0, 10.0  # critically damped impedance, omega_n = 20 rad/s
K_ENV = 1e4
# the tip pressed 1 cm below the surface: K_P (0.01 - delta) = k delta
F_N = K_ENV * KP * 0.01 / (KP + K_ENV)


def _contact(mu_s=0.5, mu_k=0.3, viscous=0.0):
    return FrictionalContact(fc.ElasticPlane([0.0, 0.6], [0.0, 1.0], K_ENV), mu_s, mu_k, viscous,
                             stick_stiffness=1e5, stick_damping=200.0)


def _run(env, ref, duration):
    ctl = fc.ImpedanceController(ARM, MD, KD, KP)
    return fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=duration)


def test_sliding_force_is_kinetic_coefficient_times_normal_force():
    """While sliding at constant speed the tangential contact force is mu_k f_n within 1 %, both in the log
    and as seen by the controller (K_P times the tangential lag), and f_n is the closed-form spring balance."""
    env = _contact()
    ref = fc.LinearPath([1.0, 0.59], [1.2, 0.59], duration=2.0, start_time=0.5)
    r = _run(env, ref, 2.5)
    fr, fn, stick = r.signals["friction"], r.signals["normal_force"], r.signals["stick"]
    cruise = (r.t > 1.2) & (r.t < 2.0)  # constant reference speed 0.125 m/s, transients gone
    assert np.all(stick[cruise] == 0.0)
    assert np.all(r.xd[cruise, 0] > 0.12)
    np.testing.assert_allclose(fn[cruise], F_N, rtol=1e-3)
    np.testing.assert_allclose(fr[cruise, 0], 0.3 * fn[cruise], rtol=0.01)
    np.testing.assert_allclose(r.wrench[cruise, 0], 0.3 * -r.wrench[cruise, 1], rtol=0.01)
    lag = ref.sample(r.t[cruise])[:, 0] - r.x[cruise, 0]
    np.testing.assert_allclose(KP * lag, 0.3 * fn[cruise], rtol=0.01)


def test_viscous_friction_adds_b_times_speed():
    """With viscous friction b the sliding force is mu_k f_n + b v within 1 %."""
    env = _contact(viscous=20.0)
    ref = fc.LinearPath([1.0, 0.59], [1.2, 0.59], duration=2.0, start_time=0.5)
    r = _run(env, ref, 2.0)
    cruise = (r.t > 1.2) & (r.t < 2.0)
    expected = 0.3 * r.signals["normal_force"][cruise] + 20.0 * r.xd[cruise, 0]
    np.testing.assert_allclose(r.signals["friction"][cruise, 0], expected, rtol=0.01)


def _pull(force):
    """A tangential pull K_P e = force applied as a slow ramp after the normal force has settled."""
    return fc.LinearPath([1.0, 0.59], [1.0 + force / KP, 0.59], duration=0.5, start_time=0.8)


def test_sticks_below_static_limit_without_creep():
    """A pull between mu_k f_n and mu_s f_n holds the tool: it sticks, its speed stays below 1e-6 m/s."""
    pull = 0.45 * F_N  # above mu_k f_n = 0.3 f_n (a kinetic-only model would slide), below mu_s f_n = 0.5 f_n
    r = _run(_contact(), _pull(pull), 3.0)
    late = r.t > 2.0
    assert np.all(r.signals["stick"][r.t > 0.3] == 1.0)
    assert np.max(np.abs(r.xd[late, 0])) < 1e-6
    # the tool has not moved beyond the bristle's deflection pull / sigma_0
    assert abs(r.x[-1, 0] - 1.0) < 1.05 * pull / 1e5
    # K_P and the bristle sigma_0 in series: the held force is pull sigma_0 / (sigma_0 + K_P)
    np.testing.assert_allclose(r.signals["friction"][-1, 0], pull * 1e5 / (1e5 + KP), rtol=1e-3)


def test_breaks_away_above_static_limit():
    """A pull above mu_s f_n breaks the stiction: the tool slides."""
    r = _run(_contact(), _pull(0.55 * F_N), 3.0)
    assert np.any(r.signals["stick"][r.t > 0.8] == 0.0)
    assert r.x[-1, 0] - 1.0 > 0.01 * F_N / KP


def test_friction_parameters_are_checked():
    """Coefficients out of range or mu_k > mu_s are refused naming the key, the range and the value."""
    plane = fc.ElasticPlane([0.0, 0.6], [0.0, 1.0], K_ENV)
    with pytest.raises(ParameterError, match=r"kinetic must not exceed static.*0\.6"):
        FrictionalContact(plane, 0.5, 0.6)
    with pytest.raises(ParameterError, match=r"static must be in \[0, 10\]; got 11"):
        FrictionalContact(plane, 11.0, 0.3)
    with pytest.raises(ParameterError, match="surface must be"):
        FrictionalContact(fc.LinearSpring(1.0, [0.0, 0.0]), 0.5, 0.3)


def test_scenario_friction_keys_are_checked_with_their_ranges():
    """Scenario keys: an out-of-range friction coefficient is refused naming the key, its range and the value;
    valid keys build a FrictionalContact with those coefficients."""
    from forcecontrol.errors import ScenarioError

    base = fc.scenario("arm-circle-contour")
    built = fc.scenarios.build_case(base.with_({"environment.static": 0.4, "environment.kinetic": 0.25}).cases[1])
    env = built["environment"]
    assert isinstance(env, FrictionalContact) and (env.mu_s, env.mu_k) == (0.4, 0.25)
    with pytest.raises(ScenarioError, match=r"static.*\[0, 10\].*12"):
        base.with_({"environment.static": 12.0})
    with pytest.raises(ScenarioError, match=r"kinetic must not exceed static"):
        base.with_({"environment.static": 0.1, "environment.kinetic": 0.2})


def test_friction_on_a_table_under_a_pose_task():
    """A Table (6-D pose task) with friction: sliding at v the wrench is [μ_k f_n v/|v| − f_n ν; 0] (f_n = k δ);
    at rest on touching it sticks and the bristle holds the displacement with σ₀ e."""
    from forcecontrol.environments.spatial import Table

    class Tip:  # a stand-in robot whose pose and twist are the joint vectors themselves
        def pose_twist(self, q, qd):
            return np.asarray(q, dtype=float), np.asarray(qd, dtype=float)

    env = FrictionalContact(Table([0, 0, 0.5], [0, 0, 1], 1e4), 0.6, 0.4, stick_stiffness=1e5)
    x = np.array([0.1, 0.2, 0.499, 0.0, 0.0, 0.0])  # 1 mm deep: f_n = 10 N
    v = np.array([0.03, -0.04, 0.0, 0.0, 0.0, 0.0])
    env.start(Tip(), x, v, 2)
    np.testing.assert_allclose(env.wrench(x, v), [0.4 * 10 * 0.6, 0.4 * 10 * -0.8, -10.0, 0, 0, 0], rtol=1e-9)
    env.start(Tip(), x, np.zeros(6), 2)
    e = np.array([1e-5, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(env.wrench(x + e, np.zeros(6)), [1.0, 0, -10.0, 0, 0, 0], rtol=1e-9)


# -- a pressed block (a 1 kg point pushed along a plane), the stand-in of the review's closed forms: Coulomb says a load
# below μ_s W never moves it, above it slides at (F − μ_k W)/m, and a block that friction stops stays where it stopped

class _Point:  # a stand-in robot whose pose and twist are the state itself
    def pose_twist(self, q, qd):
        return q, qd


def _block(env, load, duration, *, v0=0.0, m=1.0, w=10.0, dt=1e-4):
    """RK4 of m ẍ = (load(t), −w) − h_e on the plane y = 0 (k = 1e4), the stick/slip state advanced after every
    step as the simulator does; rows (t, x, ẋ, h_t, mode)."""
    x, v = np.array([0.0, -w / 1e4]), np.array([v0, 0.0])  # resting on the spring under w
    env.start(_Point(), x, v, 1)
    out = []

    def f(t, x, v):
        return v, (np.array([load(t), -w]) - env.wrench(x, v)) / m

    for i in range(int(round(duration / dt))):
        t = i * dt
        k1 = f(t, x, v)
        k2 = f(t + dt / 2, x + dt / 2 * k1[0], v + dt / 2 * k1[1])
        k3 = f(t + dt / 2, x + dt / 2 * k2[0], v + dt / 2 * k2[1])
        k4 = f(t + dt, x + dt * k3[0], v + dt * k3[1])
        x = x + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        v = v + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        env.advance(_Point(), x, v)
        out.append((t + dt, x[0], v[0], env.wrench(x, v)[0], env.mode))
    return np.array(out)


def _pressed(mu_s, mu_k, **kw):
    kw.setdefault("stick_damping", 200.0)  # critical for the 1 kg block on σ₀ = 1e4: 2 √(σ₀ m)
    return FrictionalContact(fc.ElasticPlane([0.0, 0.0], [0.0, 1.0], 1e4), mu_s, mu_k, **kw)


@pytest.mark.parametrize("fraction", [0.5, 0.9, 0.99])
def test_a_step_load_below_the_static_limit_never_breaks_away(fraction):
    """A step F = fraction · μ_s W on a block at rest: it sticks for good, moving by the bristle's deflection F/σ₀ only
    (an undamped bristle swung to 2F and broke away from μ_s W/2 on)."""
    r = _block(_pressed(0.6, 0.4), lambda t: fraction * 6.0, 0.5)
    assert np.all(r[:, 4] == 1)
    assert np.max(r[:, 1]) <= fraction * 6.0 / 1e4 * (1 + 1e-9)
    np.testing.assert_allclose(r[-1, 1], fraction * 6.0 / 1e4, rtol=1e-6)
    assert abs(r[-1, 2]) < 1e-9


def test_a_step_load_above_the_static_limit_slides_at_the_kinetic_acceleration():
    """F = 1.1 μ_s W: it breaks away within the bristle's rise and then accelerates at (F − μ_k W)/m."""
    r = _block(_pressed(0.6, 0.4), lambda t: 6.6, 0.5)
    slip = np.flatnonzero(r[:, 4] == 2)
    assert slip.size and r[slip[0], 0] < 0.05
    late = slip[slip > slip[0] + 1000]
    accel = np.diff(r[late, 2]) / np.diff(r[late, 0])
    np.testing.assert_allclose(accel, 6.6 - 4.0, rtol=1e-6)


def test_a_block_that_friction_stops_stays_stopped_and_friction_did_all_the_work():
    """Launched at v₀ with no load: it stops at v₀²/(2 μ_k W/m) and stays there with h_t = 0; friction dissipated
    ½ m v₀² exactly (the bristle preloaded with μ_k W pushed it back and forth for ever, giving back (μ_k W)²/(2σ₀))."""
    r = _block(_pressed(0.5, 0.5), lambda t: 0.0, 1.0, v0=0.2)
    stop = 0.2**2 / (2 * 0.5 * 10.0)
    stuck = r[:, 0] > 0.2
    np.testing.assert_allclose(r[stuck, 1], stop, rtol=1e-3)
    assert np.ptp(r[stuck, 1]) < 1e-9 and np.max(np.abs(r[stuck, 3])) < 1e-9
    work = np.sum(0.5 * (r[1:, 3] + r[:-1, 3]) * np.diff(r[:, 1]))
    first = 0.5 * (r[0, 3] + 0.5 * 10.0) * r[0, 1]  # the first step, from x = 0 under μ_k W
    np.testing.assert_allclose(work + first, 0.5 * 0.2**2, rtol=1e-3)


@pytest.mark.parametrize("load", [1e-3, 0.05, 1.0])
def test_zero_friction_is_the_frictionless_plane(load):
    """μ_s = μ_k = 0 never sticks: a small push from rest follows F t²/2m as on the plane without friction (the
    stick/slip toggling below stick_speed held it back by 0.8 % at 1 mN)."""
    r = _block(_pressed(0.0, 0.0), lambda t: load, 0.2)
    assert np.all(r[:, 4] == 2) and np.all(r[:, 3] == 0.0)
    np.testing.assert_allclose(r[-1, 1], load * 0.2**2 / 2, rtol=1e-9)


def test_an_undamped_bristle_that_breaks_away_under_a_step_below_the_limit_says_so():
    """σ₁ = 0: a load stepped to 0.7 μ_s W swings the spring to 1.4 μ_s W and breaks away (an elastic contact without
    damping does); the contact says so once, then forgets; a damped bristle under the same load neither slips nor
    says anything."""
    undamped = _pressed(0.6, 0.4, stick_damping=0.0)
    r = _block(undamped, lambda t: 0.7 * 6.0, 0.1)
    assert np.any(r[:, 4] == 2)
    note = undamped.take_projection_note()
    assert note is not None and "undamped bristle" in note and "stick_damping" in note
    assert undamped.take_projection_note() is None
    damped = _pressed(0.6, 0.4)
    assert np.all(_block(damped, lambda t: 0.7 * 6.0, 0.1)[:, 4] == 1)
    assert damped.take_projection_note() is None


def test_simulate_warns_when_the_tool_broke_away_from_an_undamped_bristle():
    """Through simulate on the chapter's arm (stick_damping 0, a quick pull): a ContactModelWarning names the cause."""
    from forcecontrol.errors import ContactModelWarning

    env = FrictionalContact(fc.ElasticPlane([0.0, 0.6], [0.0, 1.0], K_ENV), 0.5, 0.3, stick_stiffness=1e5,
                            stick_damping=0.0)
    with pytest.warns(ContactModelWarning, match="undamped bristle"):
        r = _run(env, _pull(0.55 * F_N), 2.0)
    assert np.any(r.signals["stick"][r.t > 0.8] == 0.0)


@pytest.mark.parametrize("key, value", [("viscous", 30.0), ("stick_speed", 1e-3), ("stick_stiffness", 1e5),
                                        ("stick_damping", 50.0)])
def test_a_friction_key_on_a_frictionless_surface_is_refused_not_ignored(key, value):
    """A sphere without static/kinetic has no friction: viscous, stick_speed (and the bristle's keys) given there would
    do nothing, so they are refused naming the key and its value (viscous = 30 N s/m used to run frictionless)."""
    from forcecontrol.errors import ScenarioError
    from forcecontrol.scenarios import build_case, load_scenario

    doc = {
        "name": "s", "duration": 0.1, "sample_time": 0.001,
        "robot": {"model": "chapter-arm", "start_position": [1.0, 0.0]},
        "environment": {"type": "elastic-sphere", "center": [1.3, 0.0], "radius": 0.3, "stiffness": 1e4, key: value},
        "controller": {"type": "impedance", "inertia": 10.0, "damping": 300.0, "stiffness": 1000.0},
        "reference": {"type": "setpoint", "position": [1.02, 0.0]},
    }
    with pytest.raises(ScenarioError, match=rf"\[environment\].*{key} needs friction: give static"):
        load_scenario(doc)
    doc["environment"]["static"] = 0.3
    assert isinstance(build_case(load_scenario(doc).cases[0])["environment"], FrictionalContact)
