"""Gain design over a stiffness range and the online stiffness estimate (issue 18, part 3).

References: python-control's own margins (``stability_margins``, FRD method) and poles of the
library's independent sampled-loop model (``ForceLoopAxis.sampled``); the closed-form phase
margin of the continuous inner velocity loop; the analytic sampled-loop stiffness limit (gain
margin 0 dB there); full nonlinear simulations of the designed gains on the chapter's arm and
the Panda; simulated contacts of known stiffness for the estimator.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.analysis import ForceLoopAxis, operational_mass, sampled_stability_limit
from forcecontrol.analysis.design import loop_model
from forcecontrol.analysis.gain_design import design_gains
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.supervision.estimation import StiffnessEstimator

control = pytest.importorskip("control")

EX93 = {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0}


@pytest.mark.parametrize(("scheme", "kf", "ki"), [("inner-position", 0.00064, 0.0016), ("inner-velocity", 0.0024, 0.0),
                                                   ("parallel", 0.00064, 0.0016)])
@pytest.mark.parametrize("arm_inertia", [None, 162.4])
def test_closed_loop_poles_equal_the_force_loop_analysis(scheme, kf, ki, arm_inertia):
    axis = ForceLoopAxis(scheme, 100.0, 500.0, 2500.0, kf, ki, 1e4)
    want = np.sort_complex(np.asarray(control.poles(axis.sampled(1e-3, arm_inertia))))
    model = loop_model(scheme, {**EX93, "force_gain": kf, "integral_gain": ki}, 1e4, 1e-3, arm_inertia=arm_inertia)
    got = np.sort_complex(np.linalg.eigvals(model.closed))
    np.testing.assert_allclose(got, want, atol=1e-9)


@pytest.mark.parametrize(("scheme", "gains"), [
    ("inner-velocity", {**EX93, "force_gain": 0.0024}),
    ("inner-position", {**EX93, "force_gain": 0.00064, "integral_gain": 0.0016}),
    ("impedance", {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0}),
    ("hybrid", {"force_gain": 2500.0, "force_rate_gain": 100.0, "nominal_stiffness": 5000.0}),
])
@pytest.mark.parametrize(("delay", "cutoff"), [(0, None), (2, 100.0)])
def test_margins_agree_with_python_control(scheme, gains, delay, cutoff):
    model = loop_model(scheme, gains, 3e4, 1e-3, delay_samples=delay, filter_cutoff=cutoff)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gm, pm, *_ = control.stability_margins(model.loop_transfer(), method="frd")
    got_gm, got_pm = model.margins()
    if np.isfinite(gm):
        assert got_gm == pytest.approx(20 * math.log10(gm), abs=0.05)
    else:
        assert got_gm == math.inf
    if np.isfinite(pm):
        assert got_pm == pytest.approx(pm, abs=0.2)
    else:
        assert got_pm == math.inf


def test_phase_margin_tends_to_the_continuous_closed_form():
    """Inner velocity loop L(s) = k_P k_F k / (s (m s + k_D)): PM = 90° − atan(ω_c m / k_D)."""
    m, kd, kp, kf, k = 100.0, 500.0, 2500.0, 0.0024, 1e4
    K, a = kp * kf * k / m, kd / m
    wc = math.sqrt((-a * a + math.sqrt(a**4 + 4 * K * K)) / 2)
    pm = 90.0 - math.degrees(math.atan(wc / a))
    _gm, got = loop_model("inner-velocity", {**EX93, "force_gain": kf}, k, 1e-5).margins()
    assert got == pytest.approx(pm, abs=0.05)


def test_gain_margin_vanishes_at_the_sampled_stability_limit():
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    mx = operational_mass(arm, q0, [1.0, 0.0])
    axis = ForceLoopAxis("inner-velocity", 100.0, 500.0, 2500.0, 0.0024, 0.0, 1e4)
    limit = sampled_stability_limit(axis, 1e-3, arm_inertia=mx)
    gains = {**EX93, "force_gain": 0.0024}
    gm_below, _ = loop_model("inner-velocity", gains, 0.9 * limit, 1e-3, arm_inertia=mx).margins()
    gm_at, _ = loop_model("inner-velocity", gains, limit, 1e-3, arm_inertia=mx).margins()
    assert gm_at == pytest.approx(0.0, abs=0.05)
    assert gm_below == pytest.approx(20 * math.log10(1 / 0.9), abs=0.3)


def _settling(t, f, band=0.02):
    out = np.flatnonzero(np.abs(f - f[-1]) > band * abs(f[-1]))
    return t[out[-1] + 1] if out.size else 0.0


@pytest.mark.parametrize("scheme", ["inner-velocity", "inner-position", "impedance", "hybrid"])
def test_designed_gains_meet_the_margins_and_the_simulation_settles_as_predicted(scheme, tmp_path):
    """Margins rechecked with python-control at both ends; the written scenario runs on the full arm."""
    from forcecontrol.scenarios import load_scenario

    design = design_gains(scheme, (1e3, 1e5), 1e-3, phase_margin=45.0, gain_margin=6.0)
    for c in design.checks:
        model = loop_model(scheme, design.gains, c["k"], 1e-3)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gm, pm, *_ = control.stability_margins(model.loop_transfer(), method="frd")
        assert (not np.isfinite(gm)) or 20 * math.log10(gm) >= 6.0 - 0.05
        assert (not np.isfinite(pm)) or pm >= 45.0 - 0.2
    path = tmp_path / "designed.toml"
    path.write_text(design.scenario_toml())
    out = load_scenario(path).run()
    for case, check in zip(out.cases, design.checks):
        f = np.linalg.norm(case.result.wrench, axis=1)
        assert _settling(case.result.t, f) == pytest.approx(check["settling_time"], rel=0.06, abs=0.003), case.label


def test_designed_gains_on_the_panda():
    """The design is per axis: the Panda's inner velocity loop along z settles as predicted at both ends."""
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers import NullSpacePosture
    from forcecontrol.robots.pinocchio import panda

    robot = panda(task="position")
    q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785])
    x0 = robot.terms(q0, np.zeros(7)).x
    design = design_gains("inner-velocity", (2e3, 5e4), 1e-3, inertia=5.0, stiffness=500.0)
    g = design.gains
    for check in (design.checks[0], design.checks[-1]):
        env = fc.ElasticPlane(x0, [0.0, 0.0, 1.0], check["k"])
        ctl = fc.InnerVelocityForceController(robot, g["inertia"], [20.0, 20.0, g["damping"]], g["stiffness"],
                                              [0.0, 0.0, g["force_gain"]], posture=NullSpacePosture(q0))
        res = fc.simulate(robot, env, ctl, fc.Setpoint(x0, [0.0, 0.0, -10.0]), q0=q0,
                          duration=1.5 * check["settling_time"] + 0.1)
        f = -res.wrench[:, 2]
        assert f[-1] == pytest.approx(10.0, rel=1e-3)
        assert _settling(res.t, f) == pytest.approx(check["settling_time"], rel=0.06, abs=0.003)


def test_sensor_delay_and_filter_slow_the_design_down():
    fast = design_gains("inner-velocity", (1e3, 1e4), 1e-3)
    slow = design_gains("inner-velocity", (1e3, 1e4), 1e-3, delay_samples=3, filter_cutoff=50.0)
    assert slow.worst_settling_time > 2.0 * fast.worst_settling_time
    for c in slow.checks:
        assert c["phase_margin_deg"] >= 45.0 and c["gain_margin_db"] >= 6.0


def test_impossible_requests_are_refused_with_the_best_achievable():
    with pytest.raises(ParameterError, match=r"settling_time = 0.001 s cannot be met .* the fastest design settles in"):
        design_gains("impedance", (1e3, 1e5), 1e-3, settling_time=0.001)
    with pytest.raises(ParameterError, match="no inner-velocity gains keep a phase margin >= 89"):
        design_gains("inner-velocity", (1e2, 1e7), 1e-3, phase_margin=89.0, gain_margin=40.0, delay_samples=5,
                     filter_cutoff=5.0)
    with pytest.raises(ParameterError, match="stiffness_range must satisfy 0 < k_min <= k_max"):
        design_gains("impedance", (1e4, 1e3))
    with pytest.raises(ParameterError, match="scheme must be one of"):
        design_gains("admittance", (1e3, 1e4))
    with pytest.raises(ParameterError, match="delay_samples must be an integer >= 0"):
        loop_model("impedance", EX93, 1e3, 1e-3, delay_samples=-1)


# ----------------------------------------------------------------------------- the estimator


def test_stiffness_estimate_converges_on_a_noisy_simulated_contact():
    """Example 9.2's stiff case with 0.5 N RMS sensor noise: k̂ within 1 % of 10⁴ N/m, x̂_r within 0.2 mm."""
    from forcecontrol.sensors import RealisticForceSensor

    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4)
    ctl = fc.ImpedanceController(arm, 100.0, 500.0, 2500.0, True)
    res = fc.simulate(arm, env, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=1.0,
                      sensor=RealisticForceSensor(noise_std=0.5, seed=3))
    est = StiffnessEstimator([1.0, 0.0], forgetting=1.0, contact_force=5.0)
    k = est.scan(res.x, res.wrench_measured)
    assert k[-1] == pytest.approx(1e4, rel=0.01)
    assert est.rest_position == pytest.approx(1.0, abs=2e-4)
    lo, hi = est.interval(4.0)
    assert lo <= 1e4 <= hi


def test_stiffness_estimate_tracks_a_change_with_forgetting():
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 4.0, 1e-3)
    x = 1.0 + 0.005 + 0.003 * np.sin(2 * np.pi * 1.5 * t)
    k_true = np.where(t < 2.0, 5e3, 2e4)
    f = k_true * (x - 1.0) + rng.normal(0.0, 0.2, t.size)
    est = StiffnessEstimator([1.0], forgetting=0.995)
    k = est.scan(x[:, None], f[:, None])
    assert k[t < 2.0][-1] == pytest.approx(5e3, rel=0.01)
    assert k[np.searchsorted(t, 2.5)] == pytest.approx(2e4, rel=0.01)  # within 0.5 s of the change
    # the estimate feeds the gain design
    design = design_gains("inner-velocity", est.interval(3.0), 1e-3)
    assert design.stiffness_range[0] < 2e4 < design.stiffness_range[1]


def test_estimator_input_checks():
    with pytest.raises(ParameterError, match="forgetting must be in"):
        StiffnessEstimator([1.0, 0.0], forgetting=0.0)
    est = StiffnessEstimator([1.0, 0.0])
    with pytest.raises(DimensionError, match=r"shape \(2,\)"):
        est.update([1.0, 0.0, 0.0], [1.0, 0.0])
    with pytest.raises(ParameterError, match="finite"):
        est.update([1.0, math.nan], [1.0, 0.0])
    with pytest.raises(ParameterError, match="no stiffness estimate yet"):
        est.interval()
    est.update([1.0, 0.0], [0.1, 0.0])  # out of contact: ignored
    assert est.samples == 0


def test_design_command_prints_json_and_writes_a_scenario_with_the_sensor(tmp_path):
    import json

    from typer.testing import CliRunner

    from forcecontrol.cli import app
    from forcecontrol.scenarios import load_scenario

    out = tmp_path / "designed.toml"
    res = CliRunner().invoke(app, ["design", "inner-velocity", "--k-min", "1000", "--k-max", "1e5", "--delay", "1",
                                   "--filter-cutoff", "200", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["scheme"] == "inner-velocity" and len(data["checks"]) == 3 and data["scenario"] == str(out)
    assert all(c["phase_margin_deg"] >= 45.0 and c["gain_margin_db"] >= 6.0 for c in data["checks"])
    sc = load_scenario(out)
    assert [c.label for c in sc.cases] == ["k = 1000 N/m", "k = 10000 N/m", "k = 100000 N/m"]
    assert sc.raw["sensor"] == {"filter": "first-order", "cutoff": 200.0, "delay_samples": 1}
    again = CliRunner().invoke(app, ["design", "inner-velocity", "--k-min", "1000", "--k-max", "1e5", "--out", str(out)])
    assert again.exit_code == 2 and "exists" in again.output
    bad = CliRunner().invoke(app, ["design", "impedance", "--k-min", "1000", "--k-max", "1e5", "--settling-time", "0.001"])
    assert bad.exit_code == 2 and "cannot be met" in bad.output


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--arm-inertia", "-5", "--arm-inertia must be a positive number; got -5.0"),
    ("--sample-time", "nan", "--sample-time must be a positive number; got nan"),
    ("--delay", "-1", "--delay must be an integer >= 0; got -1"),
    ("--filter-cutoff", "0", "--filter-cutoff must be a positive number [Hz]; got 0.0"),
    ("--phase-margin", "200", "--phase-margin must be below 180 deg; got 200.0"),
])
def test_design_refuses_a_bad_option_naming_it_as_typed(option, value, message):
    """`design` names the option the user typed, not the library's parameter; a cutoff of 0 Hz and a phase margin of
    180 deg or more are refused as values (they used to end in "no gains keep a phase margin ...")."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    r = CliRunner().invoke(app, ["design", "inner-velocity", "--k-min", "1e3", "--k-max", "1e5", option, value])
    assert r.exit_code == 2 and f"error: {message}" in r.stderr, r.output


def test_design_gains_refuses_impossible_requirements():
    """The library itself: a phase margin of 180 deg or more, a filter cutoff of 0 Hz."""
    with pytest.raises(ParameterError, match=r"phase_margin must be below 180 deg; got 180"):
        design_gains("inner-velocity", (1e3, 1e5), 1e-3, phase_margin=180)
    with pytest.raises(ParameterError, match=r"filter_cutoff must be a positive number \[Hz\]; got 0"):
        design_gains("inner-velocity", (1e3, 1e5), 1e-3, filter_cutoff=0.0)
