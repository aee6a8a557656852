"""Contact transitions: switching with hysteresis, logged events, impact without bounce for the documented gains."""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import ParameterError, ScenarioError
from forcecontrol.scenarios import load_scenario, run_scenario
from forcecontrol.supervision.safety import Safety
from forcecontrol.supervision.transitions import ContactSupervisor, critical_damping, impact_report

ARM = fc.CHAPTER_ARM
TS = 1e-3
Q_FREE = ARM.inverse_kinematics([0.95, 0.0])
PLANE = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4)
APPROACH = fc.LinearPath([0.95, 0.0], [1.05, 0.0], 0.6, accel_time=0.1, force=[10.0, 0.0])


def _supervisor(kd: float, **kw) -> ContactSupervisor:
    motion = fc.ImpedanceController(ARM, 100, 2000, 10000)
    force = fc.InnerVelocityForceController(ARM, 100, kd, 2500, [0.0024, 0.0])
    return ContactSupervisor(motion, force, [1.0, 0.0], contact_force=2.0, release_force=0.5, release_samples=5, **kw)


def _linear_mode_peak(kd: float, v0: float = 0.2, md: float = 100.0, kpkf: float = 6.0, ke: float = 1e4, fd: float = 10.0):
    """Closed-form reference: m_d ë + k_D ė + k_P k_F k_e e = 0 from e0 = −f_d/k_e, ė0 = v0 (matrix exponential).

    Returns the peak force k_e (e_max − e0) and whether e returns below e0 (the surface: a bounce).
    """
    from scipy.linalg import expm

    A = np.array([[0.0, 1.0], [-kpkf * ke / md, -kd / md]])
    E = expm(A * 1e-5)
    z = np.array([-fd / ke, v0])
    es = []
    for _ in range(150000):
        es.append(z[0])
        z = E @ z
    es = np.array(es)
    return ke * (es.max() + fd / ke), bool((es < -fd / ke - 1e-12).any())


class _OtherArm(fc.PlanarTwoLink):
    """Another robot model type (same kinematics), to check the supervisor refuses mixing models."""


def _meas(q, h) -> fc.Measurement:
    return fc.Measurement(np.asarray(q, float), np.zeros(2), np.asarray(h, float))


def test_critical_damping_is_two_sqrt_of_mass_times_stiffness():
    """k_D = 2 sqrt(m_d k_P k_F k_e): 2 sqrt(100 · 2500 · 0.0024 · 1e4) = 4898.98 N s/m."""
    assert critical_damping(100, 2500, 0.0024, 1e4) == pytest.approx(2 * math.sqrt(100 * 6 * 1e4))


def test_switching_has_hysteresis_and_debounce_and_logs_each_transition():
    """Force 0,1,2.5 → contact at sample 2; 0.4 N for 5 samples → 'contact lost' at the 5th; 1 N in between resets the count."""
    sup = _supervisor(5000.0)
    motion_ref = _supervisor(5000.0)
    q = ARM.inverse_kinematics([1.0, 0.0])
    ref = fc.Reference.setpoint([1.0, 0.0], [10.0, 0.0])
    sup.reset(_meas(q, [0.0, 0.0]), ref)
    motion_ref.reset(_meas(q, [0.0, 0.0]), ref)
    forces = [0.0, 1.0, 2.5, 1.0, 0.4, 0.4, 1.0, 0.4, 0.4, 0.4, 0.4, 0.4, 0.0]
    phases = []
    for k, f in enumerate(forces):
        u = sup.step(k * TS, _meas(q, [f, 0.0]), ref)
        phases.append(sup.phase)
        if k < 2:  # free space: the motion controller's torque, built by a separate instance
            np.testing.assert_allclose(u, motion_ref.motion.step(k * TS, _meas(q, [f, 0.0]), ref), atol=1e-12)
        if k == 2:  # the force controller's torque: inner velocity law with f_e = 2.5 N
            np.testing.assert_allclose(u, motion_ref.force.step(k * TS, _meas(q, [f, 0.0]), ref), atol=1e-12)
    assert phases == ["free", "free"] + ["contact"] * 9 + ["free", "free"]
    assert [(e["event"], e["t"]) for e in sup.events] == [("contact", 0.002), ("contact lost", 0.011)]
    assert "handed back to motion control" in sup.events[1]["detail"]


def test_reset_starts_in_contact_when_already_pressing():
    """A start with 5 N measured along the direction begins in the contact phase."""
    sup = _supervisor(5000.0)
    sup.reset(_meas(ARM.inverse_kinematics([1.0, 0.0]), [5.0, 0.0]), fc.Reference.setpoint([1.0, 0.0], [10.0, 0.0]))
    assert sup.phase == "contact"


def test_documented_gains_keep_contact_after_impact_with_the_closed_form_peak():
    """ζ >= 1: no bounce, one 'contact' event, force settles to 10 N, peak within 10 % of the linear-mode peak."""
    kd = 5000.0
    assert kd >= critical_damping(100, 2500, 0.0024, 1e4)
    r = fc.simulate(ARM, PLANE, _supervisor(kd), APPROACH, q0=Q_FREE, duration=2.0,
                    sensor=fc.ForceSensor(noise_std=0.5, cutoff=100.0, seed=1))
    rep = impact_report(r, [1.0, 0.0])
    peak, bounces = _linear_mode_peak(kd)
    assert not bounces and rep["bounces"] == 0 and rep["contact_kept"]
    assert rep["peak_force"] == pytest.approx(peak, rel=0.10)
    assert [e["event"] for e in r.events] == ["contact"]
    assert r.events[0]["t"] >= rep["first_contact_time"] and r.events[0]["speed"] == pytest.approx(0.2, rel=0.05)
    assert abs(r.wrench[r.t >= 1.5, 0].mean() - 10.0) < 0.2


def test_naive_gains_bounce_and_each_loss_is_handed_back_and_logged():
    """Example 9.3's k_D = 500 (ζ = 0.10): bounces as the linear mode predicts; contact/loss events alternate."""
    r = fc.simulate(ARM, PLANE, _supervisor(500.0), APPROACH, q0=Q_FREE, duration=2.0,
                    sensor=fc.ForceSensor(noise_std=0.5, cutoff=100.0, seed=1))
    rep = impact_report(r, [1.0, 0.0])
    peak, bounces = _linear_mode_peak(500.0)
    assert bounces and rep["bounces"] >= 1 and not rep["contact_kept"]
    assert rep["peak_force"] == pytest.approx(peak, rel=0.10)
    kinds = [e["event"] for e in r.events]
    assert kinds[:4] == ["contact", "contact lost", "contact", "contact lost"]
    assert all(a != b for a, b in zip(kinds, kinds[1:]))
    # the first loss is logged after the true force went to zero (debounce: 5 samples below 0.5 N)
    k0 = int(np.argmax(r.wrench[:, 0] > 0))
    k_zero = k0 + int(np.argmax(r.wrench[k0:, 0] == 0.0))
    assert r.events[1]["t"] >= r.t[k_zero]


def test_safety_around_the_supervisor_merges_both_logs_in_time_order():
    """Safety(ContactSupervisor): a 60 N force limit stops the naive impact after the 'contact' event."""
    s = Safety(_supervisor(500.0), max_force=60.0)
    r = fc.simulate(ARM, PLANE, s, APPROACH, q0=Q_FREE, duration=0.6)
    kinds = [(e["event"], e.get("cause")) for e in r.events]
    assert kinds[0] == ("contact", None) and ("safety", "force limit") in kinds
    assert [e["t"] for e in r.events] == sorted(e["t"] for e in r.events)


def test_impact_scenario_runs_and_meets_its_expected_values():
    """The built-in 'impact' scenario: documented gains never bounce (0.2, 0.7 m/s; k_e = 1e4, 1e5), naive ones do."""
    run = run_scenario("impact")
    assert run.all_checks_pass, [c.checks for c in run.cases]
    doc, naive, fast, stiff, wrong = run.cases
    assert doc.metrics["bounce_count"] == 0 and naive.metrics["bounced"] == 1.0
    assert fast.metrics["bounced"] == 0.0 and stiff.metrics["bounced"] == 0.0 and wrong.metrics["bounced"] == 1.0
    assert doc.result.metadata["controller"]["type"] == "ContactSupervisor"


def test_impact_report_without_contact():
    """A run that never touches reports no contact time, zero peak and contact not kept."""
    r = fc.simulate(ARM, PLANE, fc.ImpedanceController(ARM, 100, 500, 2500), fc.Setpoint([0.95, 0.0]), q0=Q_FREE,
                    duration=0.05)
    rep = impact_report(r)
    assert math.isnan(rep["first_contact_time"]) and rep["peak_force"] == 0.0 and not rep["contact_kept"]


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: ContactSupervisor(fc.ImpedanceController(ARM, 100, 500, 2500),
                                               fc.ImpedanceController(ARM, 100, 500, 2500), [1, 0],
                                               contact_force=1.0, release_force=1.0),
         "release_force must be below contact_force"),
        (lambda: ContactSupervisor(fc.ImpedanceController(ARM, 100, 500, 2500), fc.ImpedanceController(ARM, 100, 500, 2500),
                                   [1, 0], contact_force=-2.0), "contact_force must be a positive number"),
        (lambda: ContactSupervisor(fc.ImpedanceController(ARM, 100, 500, 2500), fc.ImpedanceController(ARM, 100, 500, 2500),
                                   [1, 0], release_force=-0.1), "release_force must be a non-negative number"),
        (lambda: ContactSupervisor(fc.ImpedanceController(ARM, 100, 500, 2500), fc.ImpedanceController(ARM, 100, 500, 2500),
                                   [1, 0], release_samples=0), "release_samples must be a positive integer"),
        (lambda: ContactSupervisor(fc.ImpedanceController(ARM, 100, 500, 2500), fc.ImpedanceController(ARM, 100, 500, 2500),
                                   [0, 0]), "direction must be a non-zero vector"),
        (lambda: ContactSupervisor(fc.ImpedanceController(ARM, 100, 500, 2500),
                                   fc.ImpedanceController(ARM, 100, 500, 2500, sample_time=2e-3), [1, 0]),
         "must share the sample time"),
        (lambda: ContactSupervisor("pd", fc.ImpedanceController(ARM, 100, 500, 2500), [1, 0]),
         "motion must be a forcecontrol Controller"),
        (lambda: ContactSupervisor(fc.ImpedanceController(ARM, 100, 500, 2500), object(), [1, 0]),
         "force must be a forcecontrol Controller"),
        (lambda: ContactSupervisor(fc.ImpedanceController(ARM, 100, 500, 2500),
                                   fc.ImpedanceController(_OtherArm(), 100, 500, 2500), [1, 0]),
         "motion and force controllers must drive the same robot model"),
        (lambda: critical_damping(100, 2500, 0.0024, -1e4), "environment_stiffness must be a positive number"),
    ],
)
def test_bad_supervisor_configuration_is_refused(make, match):
    """Thresholds out of order, bad counts, a zero direction, mismatched controllers: clear errors."""
    with pytest.raises(ParameterError, match=match):
        make()


def test_scenario_with_unknown_nested_controller_type_is_refused():
    """A [controller.contact] of an unknown type names the table and the valid types."""
    import copy

    data = load_scenario("impact").raw
    bad = copy.deepcopy(data)
    bad["controller"]["contact"]["type"] = "magic"
    with pytest.raises(ScenarioError, match=r"\[controller.contact\]: key 'type' must be one of .*got 'magic'"):
        load_scenario(bad)


def test_own_loop_example_runs_the_stack_against_a_user_interface():
    """examples/own_loop.py: 400 cycles at 1 kHz reach contact through the user interface; compute times are recorded."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "examples" / "own_loop.py"
    spec = importlib.util.spec_from_file_location("own_loop_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    robot = mod.StandInArm(ARM.inverse_kinematics([0.95, 0.0]), samples=401)
    ctl = mod.make_controller()
    stats = mod.run(robot, ctl, APPROACH, 400)
    assert stats["compute"].shape == (400,) and np.all(stats["compute"] > 0)
    assert robot.k == 400 and "contact" in [e["event"] for e in ctl.events]


def test_impact_safety_scenario_trips_the_force_limit_only_for_the_naive_gains():
    """'impact-safety': no stop with the documented gains; the naive ones stop at the first sample with |h_m| > 60 N."""
    run = run_scenario("impact-safety")
    assert run.all_checks_pass, [c.checks for c in run.cases]
    doc, naive = run.cases
    assert not [e for e in doc.result.events if e.get("cause") == "force limit"]
    (stop,) = [e for e in naive.result.events if e.get("reaction") == "stop"]
    later = [e["reaction"] for e in naive.result.events if e.get("cause") == "force limit" and e is not stop]
    assert all(x == "holding" for x in later)  # further crossings while the stop holds
    r = naive.result
    k = int(np.argmax(np.linalg.norm(r.wrench_measured, axis=1) > 60.0))
    assert stop["cause"] == "force limit" and stop["t"] == pytest.approx(r.t[k])
    events = [e["event"] for e in r.events]
    assert events.index("contact") < [i for i, e in enumerate(r.events) if e.get("cause") == "force limit"][0]
    assert naive.result.metadata["controller"]["type"] == "Safety"
    # the default (stiff) hold brakes the arm: the stop does not make the impact worse than no layer
    bare = fc.simulate(ARM, PLANE, _supervisor(500.0), APPROACH, q0=Q_FREE, duration=1.0,
                       sensor=fc.ForceSensor(noise_std=0.5, cutoff=100.0, seed=1))
    assert impact_report(r, [1.0, 0.0])["peak_force"] < impact_report(bare, [1.0, 0.0])["peak_force"]
