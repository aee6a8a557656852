"""The safety layer: every limit triggers when violated, reacts as documented and logs when and why."""

from __future__ import annotations

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.supervision.safety import SAFETY_CAUSES, Safety

ARM = fc.CHAPTER_ARM
Q0 = ARM.inverse_kinematics([1.0, 0.0])
PLANE = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4)
TS = 1e-3


def _impedance() -> fc.ImpedanceController:
    return fc.ImpedanceController(ARM, 100, 500, 2500)


def _meas(q, qd=(0.0, 0.0), h=(0.0, 0.0)) -> fc.Measurement:
    return fc.Measurement(np.asarray(q, float), np.asarray(qd, float), np.asarray(h, float))


def test_torque_limit_clamps_to_the_hand_clipped_torque_and_logs_it():
    """τ_max = 600 N m: output = clip(inner torque, ±600) built by hand; one torque-limit event at t = 0."""
    ref = fc.Reference.setpoint([1.3, 0.4])
    q = ARM.inverse_kinematics([1.0, 0.0])
    u_inner = _impedance().step(0.0, _meas(q), ref)
    assert np.abs(u_inner).max() > 600.0  # built to violate the limit
    s = Safety(_impedance(), max_torque=600.0)
    s.reset(_meas(q), ref)
    u = s.step(0.0, _meas(q), ref)
    np.testing.assert_allclose(u, np.clip(u_inner, -600.0, 600.0), rtol=0, atol=1e-12)
    (e,) = s.events
    j = int(np.argmax(np.abs(u_inner)))
    assert e["t"] == 0.0 and e["cause"] == "torque limit" and e["reaction"] == "clamp"
    assert e["value"] == pytest.approx(abs(u_inner[j])) and e["limit"] == 600.0
    assert f"joint {j + 1}: |u| = " in e["detail"] and not s.stopped


def test_torque_limit_holds_in_a_whole_run_and_logs_each_episode_once():
    """In simulation every logged torque is within ±τ_max; the episode is logged once, with its start time."""
    s = Safety(_impedance(), max_torque=[600.0, 200.0])
    r = fc.simulate(ARM, PLANE, s, fc.Setpoint([1.1, 0.1]), q0=Q0, duration=1.0)
    assert np.all(np.abs(r.torque) <= np.array([600.0, 200.0]) + 1e-12)
    limited = [e for e in r.events if e["cause"] == "torque limit"]
    assert limited and limited[0]["t"] == 0.0
    assert s.counts["torque limit"] >= len(limited)
    assert r.metadata["engine"] == "python"


def test_torque_rate_limit_moves_at_most_rate_times_ts_and_logs_when():
    """τ̇_max = 1e4 N m/s: a torque jump between two samples is cut to u_prev ± 10 N m; logged at t = 1 ms."""
    ref0, ref1 = fc.Reference.setpoint([1.0, 0.0]), fc.Reference.setpoint([1.05, 0.05])
    q = ARM.inverse_kinematics([1.0, 0.0])
    inner = _impedance()
    u0, u1 = inner.step(0.0, _meas(q), ref0), inner.step(TS, _meas(q), ref1)
    assert np.abs(u1 - u0).max() > 10.0  # built to violate the rate
    s = Safety(_impedance(), max_torque_rate=1e4)
    a = s.step(0.0, _meas(q), ref0)
    b = s.step(TS, _meas(q), ref1)
    np.testing.assert_allclose(a, u0, atol=1e-12)
    np.testing.assert_allclose(b, np.clip(u1, u0 - 10.0, u0 + 10.0), atol=1e-9)
    (e,) = s.events
    assert e["t"] == TS and e["cause"] == "torque rate limit" and e["reaction"] == "clamp"
    assert e["value"] == pytest.approx(np.abs(u1 - u0).max() / TS) and "N m/s" in e["detail"]


def test_force_limit_triggers_a_safe_stop_at_the_first_violating_sample():
    """Pushing 250 N into a plane with f_max = 50 N: stop logged at the first sample |h_m| > 50 N; the arm holds still."""
    s = Safety(_impedance(), max_force=50.0)
    r = fc.simulate(ARM, PLANE, s, fc.Setpoint([1.1, 0.1]), q0=Q0, duration=1.5)
    k = int(np.argmax(np.linalg.norm(r.wrench_measured, axis=1) > 50.0))
    (e,) = r.events
    assert e["cause"] == "force limit" and e["reaction"] == "stop" and e["t"] == pytest.approx(r.t[k])
    assert "safe stop, holding q" in e["detail"] and s.stopped and s.stop_time == pytest.approx(r.t[k])
    np.testing.assert_allclose(s.q_hold, r.q[k], atol=1e-12)
    assert np.linalg.norm(r.xd[-1]) < 1e-3 and np.abs(r.q[-1] - s.q_hold).max() < 5e-3
    # without the layer the same case reaches the impedance equilibrium ~ 227 N (Example 9.2 law)
    free = fc.simulate(ARM, PLANE, _impedance(), fc.Setpoint([1.1, 0.1]), q0=Q0, duration=1.5)
    assert free.wrench[-1, 0] > 4 * r.wrench[-1, 0]


def test_speed_limit_triggers_a_safe_stop_and_the_arm_comes_to_rest():
    """A fast free-space path with v_max = 0.1 m/s: stop at the first sample ‖ẋ‖ > 0.1; speed ~0 at the end."""
    q1 = ARM.inverse_kinematics([0.8, 0.0])
    s = Safety(fc.ImpedanceController(ARM, 100, 2000, 10000), max_speed=0.1)
    r = fc.simulate(ARM, PLANE, s, fc.LinearPath([0.8, 0.0], [1.0, 0.3], 0.5), q0=q1, duration=1.5)
    speed = np.linalg.norm(r.xd, axis=1)
    k = int(np.argmax(speed > 0.1))
    (e,) = r.events
    assert e["cause"] == "speed limit" and e["t"] == pytest.approx(r.t[k]) and e["value"] == pytest.approx(speed[k])
    assert speed[-1] < 1e-3


def test_path_deviation_limit_on_motion_axes_triggers_a_stop():
    """A path pushed into a plane: |x_d − x| along x exceeds 2 cm at a sample; the stop is logged exactly then."""
    q1 = ARM.inverse_kinematics([0.95, 0.0])
    s = Safety(_impedance(), max_path_deviation=0.02, deviation_axes=[True, False])
    r = fc.simulate(ARM, PLANE, s, fc.LinearPath([0.95, 0.0], [1.1, 0.0], 1.0), q0=q1, duration=1.2)
    dev = np.abs(r.reference_block("position")[:, 0] - r.x[:, 0])
    k = int(np.argmax(dev > 0.02))
    (e,) = r.events
    assert e["cause"] == "path deviation limit" and e["t"] == pytest.approx(r.t[k])
    assert e["value"] == pytest.approx(dev[k], rel=1e-9)


def test_torque_reaction_stop_holds_position_with_clamped_torques():
    """torque_reaction='stop': the first violation stops the arm; later torques are the clamped hold law."""
    s = Safety(_impedance(), max_torque=800.0, torque_reaction="stop")  # above gravity (515 N m at q0)
    r = fc.simulate(ARM, PLANE, s, fc.Setpoint([1.3, 0.4]), q0=Q0, duration=0.5)
    assert s.stopped and s.stop_time == 0.0 and r.events[0]["reaction"] == "stop"
    assert "safe stop" in r.events[0]["detail"]
    k = 200
    q, qd = r.q[k], r.qd[k]
    b = np.diag(ARM.mass_matrix(s.q_hold))  # the documented default: gains scaled by the joint inertias
    K_hold, D_hold = np.diag(b * 18.0**2), np.diag(b * 2 * 1.5 * 18.0)
    hold = ARM.gravity(q) + K_hold @ (s.q_hold - q) - D_hold @ qd
    np.testing.assert_allclose(r.torque[k], np.clip(hold, -800, 800), atol=1e-9)
    assert np.abs(r.q[-1] - s.q_hold).max() < 1e-2


def test_reset_clears_the_stop_and_the_log():
    """After reset the layer passes the controller's torque again and its log is empty."""
    s = Safety(_impedance(), max_speed=0.1)
    q = ARM.inverse_kinematics([1.0, 0.0])
    ref = fc.Reference.setpoint([1.0, 0.0])
    s.step(0.0, _meas(q, qd=[1.0, 0.0]), ref)
    assert s.stopped and len(s.events) == 1
    s.reset(_meas(q), ref)
    assert not s.stopped and s.events == [] and all(v == 0 for v in s.counts.values())
    np.testing.assert_allclose(s.step(0.0, _meas(q), ref), _impedance().step(0.0, _meas(q), ref), atol=1e-12)


def test_torque_limit_below_gravity_warns_at_reset():
    """τ_max = 300 N m < g_1(q0) = 515 N m: the layer warns that a stop could not hold the arm."""
    s = Safety(_impedance(), max_torque=300.0)
    with pytest.warns(UserWarning, match=r"max_torque \[300.0, 300.0\] N m is below the gravity torque"):
        s.reset(_meas(Q0), fc.Reference.setpoint([1.0, 0.0]))


def test_causes_are_listed():
    """Every cause a limit can log is in SAFETY_CAUSES (the log's vocabulary)."""
    assert set(SAFETY_CAUSES) == {"torque limit", "torque rate limit", "force limit", "speed limit", "path deviation limit"}


@pytest.mark.parametrize(
    "kw, exc, match",
    [
        ({"max_torque": -1.0}, ParameterError, r"max_torque must be positive and finite \[N m\]; got \[-1.0, -1.0\]"),
        ({"max_torque": 0.0}, ParameterError, "max_torque must be positive and finite"),
        ({"max_torque": [100.0, 100.0, 100.0]}, DimensionError, r"max_torque must be a scalar or have shape \(2,\)"),
        ({"max_torque": "big"}, ParameterError, "max_torque must be a positive number"),
        ({"max_torque_rate": -5.0}, ParameterError, r"max_torque_rate must be positive and finite \[N m/s\]"),
        ({"max_force": -10.0}, ParameterError, r"max_force must be positive and finite \[N\]"),
        ({"max_speed": -0.1}, ParameterError, r"max_speed must be positive and finite \[m/s\]"),
        ({"max_speed": np.inf}, ParameterError, "max_speed must be positive and finite"),
        ({"max_path_deviation": -0.01}, ParameterError, r"max_path_deviation must be positive and finite \[m\]"),
        ({"deviation_axes": [True]}, DimensionError, r"deviation_axes must have shape \(2,\)"),
        ({"torque_reaction": "ignore"}, ParameterError, "torque_reaction must be 'clamp' or 'stop'; got 'ignore'"),
        ({"hold_stiffness": -1.0, "hold_damping": 1.0}, ParameterError, "hold_stiffness must be a symmetric positive definite"),
        ({"hold_stiffness": 1e4}, ParameterError, "hold_stiffness and hold_damping must be given together"),
        ({"hold_frequency": -18.0}, ParameterError, "hold_frequency must be a positive number; got -18.0"),
    ],
)
def test_bad_limits_are_refused(kw, exc, match):
    """A limit below zero (or zero, wrong shape, unknown reaction) is refused naming the parameter."""
    with pytest.raises(exc, match=match):
        Safety(_impedance(), **kw)


def test_wrapping_a_non_controller_is_refused():
    """Only a forcecontrol Controller can be wrapped."""
    with pytest.raises(ParameterError, match="controller must be a forcecontrol Controller; got str"):
        Safety("pd")


def test_saved_log_metadata_carries_the_events(tmp_path):
    """SimulationResult.save writes the safety log (time, cause, detail) into the JSON beside the data."""
    import json

    s = Safety(_impedance(), max_force=50.0)
    r = fc.simulate(ARM, PLANE, s, fc.Setpoint([1.1, 0.1]), q0=Q0, duration=0.2)
    _, meta = r.save(tmp_path / "run")
    (e,) = json.loads(meta.read_text())["events"]
    assert e["cause"] == "force limit" and e["t"] == pytest.approx(r.events[0]["t"]) and "N > 50 N" in e["detail"]


def test_default_hold_is_stable_on_a_panda():
    """The inertia-scaled safe stop holds a Panda still (fixed 5e4/8000 joint gains diverged on its wrist)."""
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers.spatial import SpatialImpedanceController
    from forcecontrol.environments.spatial import ConstantWrench
    from forcecontrol.robots.pinocchio import panda

    robot = panda()
    q0 = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])
    ctl = SpatialImpedanceController(robot, inertia=5.0, damping=100.0, stiffness=500.0)
    s = Safety(ctl, max_force=5.0)
    push = ConstantWrench([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    r = fc.simulate(robot, push, s, fc.Setpoint(robot.forward_kinematics(q0)), q0=q0, duration=0.5, substeps=2)
    assert s.stopped and r.events[0]["cause"] == "force limit"
    assert np.abs(r.qd[-1]).max() < 0.05 and np.abs(r.q[-1] - s.q_hold).max() < 0.05


def test_6d_limits_ignore_euler_angle_wrap():
    """Panda hand pointing down (φ₁ = ±π): moving the wrist 2 mrad does not trip a 1 cm deviation limit."""
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers.spatial import SpatialImpedanceController
    from forcecontrol.robots.pinocchio import panda

    robot = panda()
    q0 = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])
    s = Safety(SpatialImpedanceController(robot, inertia=5.0, damping=100.0, stiffness=500.0),
               max_path_deviation=0.01, max_speed=1.0)
    x_d = robot.forward_kinematics(q0)
    for dq in (2e-3, -2e-3):
        q = q0.copy()
        q[4] += dq
        s.reset(fc.Measurement(q, np.zeros(7), np.zeros(6)), fc.Reference.setpoint(x_d))
        s.step(0.0, fc.Measurement(q, np.zeros(7), np.zeros(6)), fc.Reference.setpoint(x_d))
        assert not s.stopped and not s.events


def test_a_stack_checks_the_inputs_once_per_step_and_still_refuses_bad_ones(monkeypatch):
    """Safety(ContactSupervisor(impedance, force)): the outer step checks the measurement and the
    reference, the layers inside do not check the same objects again within that call; a NaN is
    still refused (by the outer check) and leaves no trace, and after the call a layer stepped
    alone checks its inputs again. The torques equal those of the same stack without the skip."""
    import forcecontrol.controllers.base as base
    from forcecontrol.errors import MeasurementError
    from forcecontrol.supervision.transitions import ContactSupervisor

    def stack():
        sup = ContactSupervisor(_impedance(), fc.InnerVelocityForceController(ARM, 100, 5000, 2500, [0.0024, 0.0]),
                                [1.0, 0.0])
        return sup, Safety(sup, max_torque=3000.0, max_torque_rate=2e5, max_force=80.0, max_speed=0.5)

    (sup, safe), (_, twin) = stack(), stack()
    calls = []
    real = base._check_inputs

    def counting(ctl, t, m, r):
        calls.append(type(ctl).__name__)
        return real(ctl, t, m, r)

    ref = fc.Reference.setpoint([1.01, 0.0], [10.0, 0.0])
    meas = _meas(ARM.inverse_kinematics([1.0005, 0.0]), (0.01, -0.02), (5.0, 0.0))
    want = [twin.step(k * TS, meas, ref) for k in range(3)]
    got = [safe.step(0.0, meas, ref)]  # the first sample switches to force control (its reset checks too)
    monkeypatch.setattr(base, "_check_inputs", counting)
    got += [safe.step(k * TS, meas, ref) for k in (1, 2)]
    assert calls == ["Safety"] * 2
    np.testing.assert_array_equal(np.array(got), np.array(want))
    bad = _meas(meas.q, meas.qd, (np.nan, 0.0))
    with pytest.raises(MeasurementError, match="measurement.wrench is not finite"):
        safe.step(3 * TS, bad, ref)
    assert base._SCOPE.checked is None
    calls.clear()
    sup.step(4 * TS, meas, ref)
    assert calls == ["ContactSupervisor"]
