"""Controller.step's time rule (issue 28 item 5): integrators need advancing t, a reset starts again."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import MeasurementError, ParameterError

ARM = fc.PlanarTwoLink()
TS = 1e-3
Q = ARM.inverse_kinematics([1.0005, 0.05])
MEAS = fc.Measurement(Q, np.array([0.01, -0.02]), np.array([5.0, 0.3]))
REF = fc.Reference.setpoint([1.01, 0.1], [10.0, 0.0])
K_I = np.array([0.05, 0.02])


def _pi():
    """Inner position loop with integral action: integrator state ξ (9.43)."""
    return fc.InnerPositionForceController(ARM, 100, 5000, 2500, 0.0024, K_I, sample_time=TS)


def _stateless():
    return fc.ImpedanceController(ARM, 100, 500, 2500, sample_time=TS)


# the fast path takes a Python float; a NumPy float takes the checked path
PATHS = {"fast": float, "checked": np.float64}


@pytest.mark.parametrize("path", sorted(PATHS))
def test_backwards_time_is_refused_naming_both_times_and_reset(path):
    """An integrating controller refuses a t before the previous step's, naming t, the previous t and reset()."""
    ctl, T = _pi(), PATHS[path]
    ctl.step(T(0.0), MEAS, REF)
    ctl.step(T(0.001), MEAS, REF)
    before = ctl.state.copy()
    with pytest.raises(ParameterError, match=r"t = 0\.0 s goes back before the previous step's t = 0\.001 s.*reset\(\)"):
        ctl.step(T(0.0), MEAS, REF)
    np.testing.assert_array_equal(ctl.state, before)


@pytest.mark.parametrize("path", sorted(PATHS))
def test_repeated_time_is_refused_for_integrators(path):
    """A repeated t on an integrating controller is refused (it would integrate twice for one sample); state untouched."""
    ctl, T = _pi(), PATHS[path]
    ctl.step(T(0.0), MEAS, REF)
    before = ctl.state.copy()
    with pytest.raises(ParameterError, match=r"t = 0\.0 s repeats the previous step's t = 0\.0 s.*integrate twice"):
        ctl.step(T(0.0), MEAS, REF)
    np.testing.assert_array_equal(ctl.state, before)


def test_each_call_integrates_one_sample_by_closed_form():
    """ξ after 5 advancing steps is 5 Ts K_I (f_d − f) (closed form of ξ ← ξ + Ts K_I (f_d − f)); a repeat adds nothing."""
    ctl = _pi()
    ctl.reset(MEAS, REF)
    xi0 = ctl.integral_action
    for k in range(5):
        ctl.step(k * TS, MEAS, REF)
    np.testing.assert_allclose(ctl.integral_action - xi0, 5 * TS * K_I * (REF.force - MEAS.wrench), rtol=1e-12)
    with pytest.raises(ParameterError):
        ctl.step(4 * TS, MEAS, REF)
    np.testing.assert_allclose(ctl.integral_action - xi0, 5 * TS * K_I * (REF.force - MEAS.wrench), rtol=1e-12)


def test_reset_allows_time_zero_again():
    """Refused without it, t = 0 is accepted after reset() and the run repeats the first one bit for bit."""
    ctl = _pi()
    first = [ctl.step(k * TS, MEAS, REF).copy() for k in range(3)]
    with pytest.raises(ParameterError):
        ctl.step(0.0, MEAS, REF)
    ctl.reset()
    again = [ctl.step(k * TS, MEAS, REF).copy() for k in range(3)]
    np.testing.assert_array_equal(np.array(first), np.array(again))


def test_stateless_controller_accepts_any_finite_time():
    """Without integrator state repeated and backwards t give the same torque, where an integrating controller refuses them."""
    ctl, pi = _stateless(), _pi()
    u = [ctl.step(t, MEAS, REF).copy() for t in (0.0, 0.0, 0.5, -1.0, np.float64(0.0))]
    for v in u[1:]:
        np.testing.assert_array_equal(v, u[0])
    pi.step(0.5, MEAS, REF)
    for t in (0.5, -1.0, np.float64(0.0)):
        with pytest.raises(ParameterError):
            pi.step(t, MEAS, REF)


@pytest.mark.parametrize("path", sorted(PATHS))
def test_failed_step_does_not_record_its_time(path):
    """A step refused for a NaN wrench records neither its t nor its state change: the same t then runs as if first."""
    ctl, ref_ctl, T = _pi(), _pi(), PATHS[path]
    ctl.step(T(0.0), MEAS, REF)
    ref_ctl.step(T(0.0), MEAS, REF)
    bad = fc.Measurement(Q, np.array([0.01, -0.02]), np.array([np.nan, 0.3]))
    with pytest.raises(MeasurementError):
        ctl.step(T(0.001), bad, REF)
    np.testing.assert_array_equal(ctl.step(T(0.001), MEAS, REF), ref_ctl.step(T(0.001), MEAS, REF))
    np.testing.assert_array_equal(ctl.state, ref_ctl.state)
    with pytest.raises(ParameterError, match="repeats"):  # the successful one is recorded
        ctl.step(T(0.001), MEAS, REF)


def test_refused_time_is_not_recorded():
    """A refused t leaves the previous step's t in force (a later valid t is measured against it)."""
    ctl = _pi()
    ctl.step(0.002, MEAS, REF)
    with pytest.raises(ParameterError):
        ctl.step(0.001, MEAS, REF)
    with pytest.raises(ParameterError, match="previous step's t = 0.002 s"):
        ctl.step(0.0015, MEAS, REF)
    ctl.step(0.003, MEAS, REF)


def test_jump_of_many_samples_warns_once_until_reset():
    """t jumping by more than 1.5 sample times warns once (the integrators advance one sample per call), again after reset()."""
    ctl = _pi()
    ctl.step(0.0, MEAS, REF)
    with pytest.warns(UserWarning, match=r"t jumped from 0\.0 s to 0\.01 s, 10 sample times.*sample_time = 0\.001 s per call"):
        ctl.step(0.01, MEAS, REF)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ctl.step(0.02, MEAS, REF)  # shown once
        ctl.reset()
        ctl.step(0.0, MEAS, REF)
        ctl.step(0.001, MEAS, REF)  # one sample: no warning
    with pytest.warns(UserWarning, match="t jumped"):
        ctl.step(0.005, MEAS, REF)


def test_wrapper_of_integrators_refuses_repeat_before_touching_its_own_memory():
    """A safety layer around an integrating controller refuses a repeated t itself (its rate limiter's memory stays)."""
    safe = fc.Safety(_pi(), max_torque_rate=[1e9, 1e9])
    safe.step(0.0, MEAS, REF)
    u_prev = safe._u_prev.copy()
    with pytest.raises(ParameterError, match=r"Safety\.step: t = 0\.0 s repeats"):
        safe.step(0.0, fc.Measurement(Q + 0.01, MEAS.qd, MEAS.wrench), REF)
    np.testing.assert_array_equal(safe._u_prev, u_prev)


def test_wrapper_of_stateless_controller_refuses_only_backwards_time():
    """A safety layer around a stateless controller accepts a repeated t (same torque) and refuses a t going back."""
    safe = fc.Safety(_stateless())
    u0 = safe.step(0.001, MEAS, REF).copy()
    np.testing.assert_array_equal(safe.step(0.001, MEAS, REF), u0)
    with pytest.raises(ParameterError, match=r"t = 0\.0 s goes back before the previous step's t = 0\.001 s"):
        safe.step(0.0, MEAS, REF)


def test_python_simulation_runs_twice_on_one_controller():
    """The Python engine's loop advances t (the controller then refuses t = 0) and a second run, reset, repeats the first."""
    ctl = fc.Safety(_pi())
    env = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
    q0 = ARM.inverse_kinematics([0.99, 0.0])
    runs = []
    for _ in range(2):
        runs.append(fc.simulate(ARM, env, ctl, fc.Setpoint([1.01, 0.0], [10.0, 0.0]), q0=q0, duration=0.02, engine="python"))
        with pytest.raises(ParameterError, match="goes back"):
            ctl.step(0.0, MEAS, REF)
    np.testing.assert_array_equal(runs[0].q, runs[1].q)
