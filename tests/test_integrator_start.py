"""Issue 27: one meaning per ``integrator_start`` at any time of the force step, the book's step response
by default, and the inner position loop in a rotated task frame holding the tangent position.

References are outside the code under test: the closed-form step responses of the chapter's linear loop
(9.42)–(9.43) per axis, computed here with ``scipy.signal`` from the gains (whole PI on the step:
``f_e/f_d = k k_P (k_F s + k_I) / (m s³ + k_D s² + k_P (1 + k_F k) s + k_P k k_I)``; bumpless "tip",
the proportional action on −f_e only: numerator ``k k_P k_I``), the book's Example 9.3 gains, the
arm's gravity torque (a loop at rest commands exactly g(q)), and the geometry of the tilted plane.
"""

from __future__ import annotations

import copy
import math
import textwrap
import warnings

import numpy as np
import pytest
import scipy.signal as sig

import forcecontrol as fc
from forcecontrol.analysis import ForceLoopAxis
from forcecontrol.scenarios import CaseSpec, load_scenario
from forcecontrol.scenarios.build import build_case
from forcecontrol.scenarios.checks import case_analysis, case_response
from forcecontrol.task import planar_rotation

ARM = fc.PlanarTwoLink()
Q0 = ARM.inverse_kinematics([1.0, 0.0], elbow="up")
M, KD, KP, KF, KI, F_D, TS = 100.0, 500.0, 2500.0, 0.00064, 0.0016, 10.0, 1e-3


def _controller(start: str | None, **kw) -> fc.InnerPositionForceController:
    extra = {} if start is None else {"integrator_start": start}
    return fc.InnerPositionForceController(ARM, M, KD, KP, [KF, 0.0], [KI, 0.0], **extra, **kw)


def _run(start: str | None, k: float, step_time: float, duration: float = 3.0, force0: float | None = None):
    """Example 9.3's inner position loop on the plane x = 1 (tip at rest on it), f_d = 10 N stepped at step_time."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], k)
    ref = fc.Setpoint([1.0, 0.0], [F_D, 0.0], force_start=step_time)
    return fc.simulate(ARM, env, _controller(start), ref, q0=Q0, duration=step_time + duration, engine="compiled")


def _closed_form(k: float, bumpless: bool, n: int, step_index: int, dt: float = TS) -> np.ndarray:
    """f_e(t_i) of the continuous loop (9.42)–(9.43) for a 10 N step at sample step_index (scipy.signal)."""
    den = [M, KD, KP * (1.0 + KF * k), KP * k * KI]
    num = [k * KP * KI] if bumpless else [k * KP * KF, k * KP * KI]
    _, y = sig.step(sig.lti(num, den), T=np.arange(n - step_index) * dt)
    return np.concatenate([np.zeros(step_index), F_D * y])


@pytest.mark.parametrize("step_time", [0.0, 0.5])
@pytest.mark.parametrize("k", [1e3, 1e4])
@pytest.mark.parametrize("start", [None, "hold"])
def test_default_and_hold_give_the_books_step_response_at_any_step_time(start, k, step_time):
    """The default ("hold") follows the closed-form step response of (9.42)–(9.43) within 1 % of f_d, peak within 1 %."""
    r = _run(start, k, step_time)
    ref = _closed_form(k, False, r.t.size, int(round(step_time / TS)))
    f = r.wrench[:, 0]
    assert np.abs(f - ref).max() < 0.01 * F_D
    assert f.max() == pytest.approx(ref.max(), rel=0.01)


@pytest.mark.parametrize("step_time", [0.0, 0.5])
@pytest.mark.parametrize("k", [1e3, 1e4])
def test_tip_is_bumpless_at_any_step_time(k, step_time):
    """"tip" follows the closed-form response with the proportional action on −f_e only (no kick), at t = 0 and 0.5 s."""
    r = _run("tip", k, step_time)
    ref = _closed_form(k, True, r.t.size, int(round(step_time / TS)))
    assert np.abs(r.wrench[:, 0] - ref).max() < 0.01 * F_D


@pytest.mark.parametrize("step_time", [0.0, 0.5])
def test_tip_and_hold_differ_whenever_the_force_reference_changes(step_time):
    """f_d from 0 (before the start) to 10 N at t = 0 or 0.5 s: "hold" peaks about 1.5x higher than "tip" (k = 10⁴)."""
    hold, tip = _run("hold", 1e4, step_time), _run("tip", 1e4, step_time)
    assert hold.wrench[:, 0].max() > 1.4 * tip.wrench[:, 0].max()
    i = int(round((step_time + 0.1) / TS))
    assert hold.wrench[i, 0] > 5.0 * tip.wrench[i, 0]  # the proportional kick K_F f_d, 0.1 s after the step


def test_tip_and_hold_are_the_same_loop_when_f_d_never_changes():
    """With f_d = 0 throughout and no contact force, "tip" and "hold" preset the same ξ₀ and run identically."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
    ref = fc.Setpoint([1.0, 0.0], [0.0, 0.0])
    runs = [fc.simulate(ARM, env, _controller(s), ref, q0=Q0, duration=0.3, engine="compiled") for s in ("hold", "tip")]
    np.testing.assert_array_equal(runs[0].x, runs[1].x)


@pytest.mark.parametrize("start", ["hold", "tip"])
def test_the_loop_holds_the_tip_until_the_force_step(start):
    """Step at 0.5 s: both starts put x_F on the tip, so the arm is at rest until then (torque = g(q0), x = x0)."""
    r = _run(start, 1e3, 0.5, duration=0.2)
    before = r.t < 0.5 - 1e-12
    np.testing.assert_allclose(r.torque[before], np.tile(ARM.gravity(Q0), (before.sum(), 1)), rtol=0, atol=1e-9)
    assert np.abs(r.x[before] - r.x[0]).max() < 1e-12


@pytest.mark.parametrize("start", ["hold", "tip", "zero"])
def test_each_start_presets_x_F_as_documented_with_a_preload(start):
    """Reset with a 3 N preload and f_d(0) = 10 N: hold x_F(0⁻) = tip, tip x_F(0) = tip, zero ξ₀ = 0."""
    ctl = _controller(start)
    q = ARM.inverse_kinematics([1.0, 0.2])
    h = np.array([3.0, 0.0])
    ctl.reset(fc.Measurement(q, np.zeros(2), h), fc.Reference.setpoint([0.0, 0.0], [F_D, 0.0]))
    xi = ctl.integral_action[0]
    if start == "zero":
        assert xi == 0.0
    else:
        f_before = 0.0 if start == "hold" else F_D
        assert KF * (f_before - h[0]) + xi == pytest.approx(1.0, abs=1e-12)


def test_tip_cancels_the_kick_of_a_later_change_of_f_d_in_the_controller():
    """Stepping a "tip" controller by hand: when f_d jumps by 10 N, x_F = K_F (f_d − f_e) + ξ does not move."""
    ctl = _controller("tip")
    meas = fc.Measurement(Q0, np.zeros(2), np.zeros(2))
    ctl.reset(meas, fc.Reference.setpoint([1.0, 0.0], [0.0, 0.0]))
    x_F0 = KF * 0.0 + ctl.integral_action[0]
    ctl.step(0.0, meas, fc.Reference.setpoint([1.0, 0.0], [0.0, 0.0]))
    ctl.step(TS, meas, fc.Reference.setpoint([1.0, 0.0], [F_D, 0.0]))
    xi_after = ctl.integral_action[0] - TS * KI * F_D  # ξ before this sample's integration
    assert KF * F_D + xi_after == pytest.approx(x_F0, abs=1e-15)


# ---------------------------------------------------------------------------- defaults


def test_the_default_is_hold_for_the_classes_and_the_scenario_files(tmp_path):
    """No integrator_start: "hold" for the inner position loop (class and TOML), "zero" for the parallel scheme."""
    assert _controller(None).integrator_start == "hold"
    par = fc.ParallelForcePositionController(ARM, M, KD, KP, [KF, 0.0], [KI, 0.0])
    assert par.integrator_start == "zero"
    path = tmp_path / "mine.toml"
    path.write_text(textwrap.dedent("""
        name = "my-9.3"
        duration = 1.0
        [robot]
        start_position = [1.0, 0.0]
        [environment]
        type = "elastic-plane"
        point = [1.0, 0.0]
        normal = [-1.0, 0.0]
        stiffness = 10000.0
        [controller]
        type = "inner-position"
        inertia = 100.0
        damping = 500.0
        stiffness = 2500.0
        force_gain = [0.00064, 0.0]
        integral_gain = [0.0016, 0.0]
        [reference]
        type = "setpoint"
        position = [1.0, 0.0]
        force = [10.0, 0.0]
    """))
    parts = build_case(load_scenario(path).cases[0])
    assert parts["controller"].integrator_start == "hold"


def test_the_analysis_response_follows_each_start_at_a_later_step():
    """ForceLoopAxis.response to f_d stepping at 0.5 s: "hold" the whole PI, "tip" no kick (scipy.signal closed forms)."""
    dt = 1e-4  # forced_response ramps the input over one interval: keep it short
    t = np.arange(30001) * dt
    f_d = np.where(t >= 0.5 - 1e-12, F_D, 0.0)
    for start, bumpless in (("hold", False), ("tip", True)):
        ax = ForceLoopAxis("inner-position", M, KD, KP, KF, KI, 1e4, start)
        got = np.asarray(ax.response(t, f_d, 0.0, 1.0).outputs[0])
        np.testing.assert_allclose(got, _closed_form(1e4, bumpless, t.size, 5000, dt), rtol=0, atol=1e-3 * F_D)
    assert ForceLoopAxis("inner-position", M, KD, KP, KF, KI, 1e4).start == "hold"


def test_the_scenario_analysis_response_matches_the_simulation_of_a_tip_step_at_half_a_second(tmp_path):
    """analyze's sampled model (case_response) of a "tip" case with force_start = 0.5 s follows the run within 0.5 % of f_d."""
    path = tmp_path / "tip.toml"
    path.write_text(textwrap.dedent("""
        name = "tip-late"
        duration = 2.5
        [robot]
        start_position = [1.0, 0.0]
        [environment]
        type = "elastic-plane"
        point = [1.0, 0.0]
        normal = [-1.0, 0.0]
        stiffness = 10000.0
        [controller]
        type = "inner-position"
        inertia = 100.0
        damping = 500.0
        stiffness = 2500.0
        force_gain = [0.00064, 0.0]
        integral_gain = [0.0016, 0.0]
        integrator_start = "tip"
        [reference]
        type = "setpoint"
        position = [1.0, 0.0]
        force = [10.0, 0.0]
        force_start = 0.5
    """))
    scn = load_scenario(path)
    res = scn.run(engine="compiled").cases[0].result
    lin = case_response(build_case(scn.cases[0]), res.t)
    assert np.abs(lin[:, 0] - res.wrench[:, 0]).max() < 0.005 * F_D
    assert res.wrench[:, 0].max() < 10.1  # bumpless: no overshoot of the kick (hold peaks at 15.9 N)


def test_the_scenario_analysis_reports_the_zero_only_where_the_step_meets_it():
    """analyze on Example 9.3's k_x = 10³ inner position case: zero −k_I/k_F = −2.5 with "hold", none with bumpless "tip"."""
    scn = load_scenario("example-9.3")
    case = next(c for c in scn.cases if c.label == "inner position, k_x = 1e3 N/m")
    hold = case_analysis(build_case(case))
    assert hold["zero_x"] == pytest.approx(-KI / KF, rel=1e-9)
    cfg = copy.deepcopy(case.config)
    cfg["controller"]["integrator_start"] = "tip"
    tip = case_analysis(build_case(CaseSpec(case.label, cfg, {}, case.overrides)))
    assert "zero_x" not in tip and tip["real_pole_x"] == pytest.approx(hold["real_pole_x"], rel=1e-12)


# ---------------------------------------------------------------------------- rotated task frame


def _tilted(deg: float):
    a = math.radians(deg)
    n_in = np.array([math.cos(a), math.sin(a)])  # into the surface
    tangent = np.array([-math.sin(a), math.cos(a)])
    env = fc.ElasticPlane([1.0, 0.0], -n_in, 1e4)  # through the start tip [1, 0], tilted by deg
    return planar_rotation(a), n_in, tangent, env


@pytest.mark.parametrize("start", ["hold", "tip"])
@pytest.mark.parametrize("deg", [30.0, 45.0])
def test_inner_position_loop_in_a_rotated_frame_holds_the_tangent_position(deg, start):
    """Plane at 30°/45° through the tip, C_F along its normal: the tip moves < 1 mm along it, f_n → 10 N (0.5 %)."""
    R, n_in, tangent, env = _tilted(deg)
    ctl = _controller(start, task_frame=R)
    r = fc.simulate(ARM, env, ctl, fc.Setpoint([1.0, 0.0], F_D * n_in), q0=Q0, duration=6.0, engine="compiled")
    assert np.abs((r.x - r.x[0]) @ tangent).max() < 1e-3
    fn = r.wrench @ n_in
    assert fn[r.t >= 5.5].mean() == pytest.approx(F_D, rel=5e-3)


@pytest.mark.parametrize("deg", [30.0, 45.0])
def test_inner_velocity_and_parallel_in_a_rotated_frame(deg):
    """Same plane: the inner velocity loop moves < 1 mm along it; the parallel scheme reaches x_d 5 cm along it (1 mm)."""
    R, n_in, tangent, env = _tilted(deg)
    ivel = fc.InnerVelocityForceController(ARM, M, KD, KP, [0.0024, 0.0], task_frame=R)
    r = fc.simulate(ARM, env, ivel, fc.Setpoint([1.0, 0.0], F_D * n_in), q0=Q0, duration=4.0, engine="compiled")
    assert np.abs((r.x - r.x[0]) @ tangent).max() < 1e-3
    assert (r.wrench[-1] @ n_in) == pytest.approx(F_D, rel=5e-3)
    par = fc.ParallelForcePositionController(ARM, M, KD, KP, [KF, 0.0], [KI, 0.0], task_frame=R)
    x_d = np.array([1.0, 0.0]) + 0.05 * tangent
    r = fc.simulate(ARM, env, par, fc.Setpoint(x_d, F_D * n_in), q0=Q0, duration=6.0, engine="compiled")
    assert ((r.x[-1] - r.x[0]) @ tangent) == pytest.approx(0.05, abs=1e-3)
    assert (r.wrench[r.t >= 5.5] @ n_in).mean() == pytest.approx(F_D, rel=5e-3)


def test_a_scenario_with_task_frame_angle_keeps_the_tip_on_its_spot(tmp_path):
    """TOML: inner position, task_frame_angle = 30, plane at 30° through the start: tangent motion < 1 mm, |f| → 10 N."""
    a = math.radians(30.0)
    path = tmp_path / "tilted.toml"
    path.write_text(textwrap.dedent(f"""
        name = "tilted-inner-position"
        duration = 6.0
        [robot]
        start_position = [1.0, 0.0]
        [environment]
        type = "elastic-plane"
        point = [1.0, 0.0]
        normal = [{-math.cos(a)!r}, {-math.sin(a)!r}]
        stiffness = 10000.0
        [controller]
        type = "inner-position"
        inertia = 100.0
        damping = 500.0
        stiffness = 2500.0
        force_gain = [0.00064, 0.0]
        integral_gain = [0.0016, 0.0]
        task_frame_angle = 30.0
        [reference]
        type = "setpoint"
        position = [1.0, 0.0]
        force = [{10 * math.cos(a)!r}, {10 * math.sin(a)!r}]
    """))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no drift warning: f_d lies in R(K)
        res = load_scenario(path).run(engine="compiled").cases[0].result
    tangent = np.array([-math.sin(a), math.cos(a)])
    assert np.abs((res.x - res.x[0]) @ tangent).max() < 1e-3
    assert np.linalg.norm(res.wrench[res.t >= 5.5], axis=1).mean() == pytest.approx(10.0, rel=5e-3)
