"""Linearised direct force control loops: polynomials, responses, sampled-data stability, gain design."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.analysis import (
    ForceLoopAxis,
    design_force_gains,
    force_loop_axes,
    operational_mass,
    sampled_stability_limit,
)
from forcecontrol.errors import DimensionError, DriftWarning, ParameterError, SimulationDivergedError

ARM = fc.PlanarTwoLink()
Q0 = ARM.inverse_kinematics([1.0, 0.0], elbow="up")
TS = 1e-3
PI = dict(inertia=100.0, damping=500.0, stiffness=2500.0, force_gain=0.00064, integral_gain=0.0016)
P = dict(inertia=100.0, damping=500.0, stiffness=2500.0, force_gain=0.0024)


# ---------------------------------------------------------------------------- continuous models


@pytest.mark.parametrize("k", [1e3, 1e4, 3.7e5])
def test_inner_position_polynomial_is_the_corrected_9_42(k):
    """Characteristic polynomial m s³ + k_D s² + k_P (1 + k_F k) s + k_P k k_I (misprint 7), built by hand."""
    ax = ForceLoopAxis("inner-position", **PI, environment_stiffness=k)
    want = [100.0, 500.0, 2500.0 * (1 + 0.00064 * k), 2500.0 * k * 0.0016]
    np.testing.assert_allclose(ax.characteristic_polynomial(), want, rtol=1e-10)


def test_inner_velocity_polynomial_is_9_47():
    """m s² + k_D s + k_P k_F k for the inner velocity loop (9.47)."""
    ax = ForceLoopAxis("inner-velocity", **P, environment_stiffness=1e3)
    np.testing.assert_allclose(ax.characteristic_polynomial(), [100.0, 500.0, 2500.0 * 0.0024 * 1e3], rtol=1e-12)


def test_force_transfer_function_of_the_inner_position_loop():
    """f_e/f_d = k k_P (k_F s + k_I) / (m s³ + …): numerator [k k_P k_F, k k_P k_I] / m, by hand."""
    tf = ForceLoopAxis("inner-position", **PI, environment_stiffness=1e3).force_transfer_function()
    num, den = np.asarray(tf.num[0][0]), np.asarray(tf.den[0][0])
    np.testing.assert_allclose(num / den[0], [1e3 * 2500 * 0.00064 / 100, 1e3 * 2500 * 0.0016 / 100], rtol=1e-10)


def test_damp_gives_natural_frequency_and_damping_of_the_velocity_loop():
    """control.damp: ω_n = √60 rad/s and ζ = 2.5/√60 for the inner velocity loop of Example 9.3."""
    wn, zeta, _ = ForceLoopAxis("inner-velocity", **P, environment_stiffness=1e3).damping_table()
    np.testing.assert_allclose(wn, math.sqrt(60.0), rtol=1e-12)
    np.testing.assert_allclose(zeta, 2.5 / math.sqrt(60.0), rtol=1e-12)


@pytest.mark.parametrize("scheme, gains", [("inner-position", PI), ("parallel", PI), ("inner-velocity", P),
                                           ("inner-position", {**PI, "force_gain": 0.0})])
@pytest.mark.parametrize("k", [0.0, 1e3, 3.7e5])
def test_poles_zeros_and_damping_agree_with_python_control(scheme, gains, k):
    """The analysis computes poles, zeros and damping without importing python-control (start-up time);
    they equal control.poles, control.zeros and control.damp of the same state space."""
    ax = ForceLoopAxis(scheme, **gains, environment_stiffness=k)
    sys = ax.state_space()
    np.testing.assert_allclose(np.sort_complex(ax.poles()), np.sort_complex(control.poles(sys)), rtol=1e-9, atol=1e-9)
    if k > 0:
        np.testing.assert_allclose(np.sort_complex(ax.zeros()), np.sort_complex(control.zeros(sys[0, 0])),
                                   rtol=1e-9, atol=1e-9)
    else:  # no contact: f_e/f_d is identically zero and has no zeros
        assert ax.zeros().size == 0 and not np.any(sys[0, 0].C) and not np.any(sys[0, 0].D)
    with np.errstate(divide="ignore", invalid="ignore"):
        wn, zeta, p = control.damp(sys, doprint=False)
    mine = ax.damping_table()
    order, ref = np.argsort(mine[2]), np.argsort(p)
    np.testing.assert_allclose(mine[0][order], np.asarray(wn)[ref], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(mine[1][order], np.asarray(zeta)[ref], rtol=1e-9, atol=1e-12, equal_nan=True)


@pytest.mark.parametrize("scheme", ["inner-position", "inner-velocity", "parallel"])
def test_equilibrium_is_9_44_and_matches_the_dc_gain(scheme):
    """Steady f_e = f_d and x_e = x_r + f_d/k (9.44); the linear model's final value agrees."""
    gains = P if scheme == "inner-velocity" else PI
    ax = ForceLoopAxis(scheme, **gains, environment_stiffness=1e3)
    x, f = ax.equilibrium(10.0, 1.015, 1.0)
    assert (x, f) == pytest.approx((1.01, 10.0), rel=1e-12)
    t = np.linspace(0, 30, 3001)
    out = ax.response(t, 10.0, 1.015, 1.0).outputs
    assert out[0][-1] == pytest.approx(f, rel=1e-6)
    assert out[1][-1] == pytest.approx(x, rel=1e-6)


def test_parallel_with_proportional_C_F_settles_at_9_49():
    """k_I = 0: x_e = x_d + k_F (k (x_r − x_e) + f_d) (9.49) solved, and the linear model gets there."""
    ax = ForceLoopAxis("parallel", 100.0, 500.0, 2500.0, 0.002, 0.0, 1e3)
    x, f = ax.equilibrium(10.0, 1.015, 1.0)
    assert x == pytest.approx(1.015 + 0.002 * (1e3 * (1.0 - x) + 10.0), rel=1e-12)
    out = ax.response(np.linspace(0, 20, 2001), 10.0, 1.015, 1.0).outputs
    assert out[1][-1] == pytest.approx(x, rel=1e-9)
    assert f == pytest.approx(1e3 * (x - 1.0), rel=1e-12)


def test_free_axis_with_force_reference_warns_of_drift():
    """k = 0 with f_d ≠ 0 and integral action: no equilibrium, DriftWarning, x = nan; the model has a pole at 0."""
    ax = ForceLoopAxis("inner-position", **PI, environment_stiffness=0.0)
    with pytest.warns(DriftWarning, match="free axis"):
        x, _ = ax.equilibrium(10.0)
    assert math.isnan(x)
    assert np.min(np.abs(ax.poles())) < 1e-12


def test_force_loop_axes_reads_a_controller():
    """force_loop_axes splits Example 9.3's inner position controller into x (in contact) and y (free) axes."""
    ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0])
    ax_x, ax_y = force_loop_axes(ctl, np.diag([1e3, 0.0]))
    assert ax_x == ForceLoopAxis("inner-position", **PI, environment_stiffness=1e3)
    assert not ax_y.has_integral
    np.testing.assert_allclose(np.sort(ax_y.poles().real), [-2.5, -2.5], atol=1e-6)  # position loop s² + 5 s + 25


# ---------------------------------------------------------------------------- sampled data


def test_sampled_model_tends_to_the_continuous_one():
    """For Ts → 0 the sampled poles are exp(p Ts) of the continuous poles (Ts = 1e-5 s, within 1e-8)."""
    ax = ForceLoopAxis("inner-position", **PI, environment_stiffness=1e4)
    zd = np.sort_complex(control.poles(ax.sampled(1e-5, arm_inertia=160.0)))
    zc = np.sort_complex(np.exp(ax.poles() * 1e-5))
    np.testing.assert_allclose(zd, zc, atol=1e-8)


@pytest.mark.parametrize("scheme,gains,mx", [("inner-position", PI, 160.0), ("inner-velocity", P, None), ("parallel", PI, 80.0)])
def test_sampled_plant_is_python_controls_zero_order_hold(scheme, gains, mx):
    """The plant's discretisation equals control.sample_system(..., "zoh"): the closed loop's first two
    rows are [Ad + Bd_a Gz + Bd_f k e1] with Ad, Bd from python-control (Ts = 1 ms, k = 3e4 N/m)."""
    k = 3e4
    ax = ForceLoopAxis(scheme, **gains, environment_stiffness=k)
    Ap = np.array([[0.0, 1.0], [0.0, 0.0]])
    Bp = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    if mx is not None:
        Ap[1, 0], Bp[1, 1], Bp[1, 2] = -k / mx, 1.0 / mx, k / mx
    pd = control.sample_system(control.ss(Ap, Bp, np.eye(2), np.zeros((2, 3))), TS, method="zoh")
    Ad, Bd = np.asarray(pd.A), np.asarray(pd.B)
    sys = ax.sampled(TS, arm_inertia=mx)
    A, B = np.asarray(sys.A), np.asarray(sys.B)
    Gz, Gw, _, _ = ax._law()  # the law's part (continuous, not discretised): a_k = Gz z + Gw [f_d, x_d, x_r]
    nz = A.shape[0]
    Fz = np.zeros(nz)
    Fz[0] = k
    want = Ad @ np.eye(2, nz) + np.outer(Bd[:, 0], Gz) + np.outer(Bd[:, 1], Fz)
    np.testing.assert_allclose(A[:2], want, rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(B[:2], np.outer(Bd[:, 0], Gw) + np.outer(Bd[:, 1], [0.0, 0.0, -k])
                               + np.outer(Bd[:, 2], [0.0, 0.0, 1.0]), rtol=1e-10, atol=1e-13)
    assert ax.spectral_radius(TS, mx) == pytest.approx(float(np.max(np.abs(control.poles(sys)))), rel=1e-12)


def test_double_integrator_is_the_infinite_arm_inertia_limit():
    """arm_inertia → ∞ gives the perfect-inverse-dynamics double integrator ẍ = a held."""
    ax = ForceLoopAxis("inner-velocity", **P, environment_stiffness=1e5)
    np.testing.assert_allclose(ax.sampled(TS, arm_inertia=1e12).A, ax.sampled(TS).A, atol=1e-9)


def _sim(scheme: str, k: float, duration: float) -> fc.SimulationResult:
    env = fc.LinearSpring(np.diag([k, 0.0]), [1.0, 0.0])
    if scheme == "inner-position":
        ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0])
    else:
        ctl = fc.InnerVelocityForceController(ARM, 100, 500, 2500, [0.0024, 0.0])
    return fc.simulate(ARM, env, ctl, fc.Setpoint([1.0, 0.0], [10.0, 0.0]), q0=Q0, duration=duration, engine="compiled")


def _growth_rate(r: fc.SimulationResult, t1: float, t2: float, window: float = 0.3) -> float:
    """Growth rate [1/s] of the oscillation's envelope, from the sample-to-sample force change
    (which removes the slow real mode and keeps the fast oscillatory one)."""
    d, t = np.diff(r.wrench[:, 0]), r.t[1:]
    a1 = np.abs(d[(t > t1) & (t < t1 + window)]).max()
    a2 = np.abs(d[(t > t2) & (t < t2 + window)]).max()
    return math.log(a2 / a1) / (t2 - t1)


@pytest.mark.parametrize("scheme, gains", [("inner-velocity", P), ("inner-position", PI)])
def test_sampled_growth_rate_matches_the_nonlinear_simulation(scheme, gains):
    """Near the limit, ln|z|max / Ts of the sampled model is the simulated envelope growth rate within 0.06 1/s."""
    mx = operational_mass(ARM, Q0, [1.0, 0.0])
    ax = ForceLoopAxis(scheme, **gains)
    limit = sampled_stability_limit(ax, TS, arm_inertia=mx)
    for factor in (0.8, 1.2):
        k = factor * limit
        predicted = math.log(ax.with_environment_stiffness(k).spectral_radius(TS, mx)) / TS
        measured = _growth_rate(_sim(scheme, k, 3.0), 1.5, 2.6)
        assert measured == pytest.approx(predicted, abs=0.06)
        assert (measured < 0) == (factor < 1)


def test_stability_limit_below_settles_above_grows_far_above_diverges():
    """Inner velocity loop of Example 9.3 at Ts = 1 ms: at 0.9 × the sampled limit the force settles,
    at 1.1 × its oscillation grows, at 2 × the simulator stops with SimulationDivergedError."""
    mx = operational_mass(ARM, Q0, [1.0, 0.0])
    limit = sampled_stability_limit(ForceLoopAxis("inner-velocity", **P), TS, arm_inertia=mx)
    below = _sim("inner-velocity", 0.9 * limit, 8.0)
    assert _growth_rate(below, 2.0, 7.5) < 0
    assert abs(below.wrench[-1, 0] - 10.0) < abs(below.wrench[2000, 0] - 10.0)
    above = _sim("inner-velocity", 1.1 * limit, 8.0)
    assert _growth_rate(above, 2.0, 7.5) > 0
    assert np.abs(above.wrench[-500:, 0] - 10.0).max() > 3 * np.abs(above.wrench[1500:2000, 0] - 10.0).max()
    with pytest.raises(SimulationDivergedError, match="diverged"):
        _sim("inner-velocity", 2.0 * limit, 8.0)


def test_double_integrator_limit_is_conservative():
    """Ignoring the arm's operational mass (ẍ = a held) underestimates the limit for the chapter's arm."""
    mx = operational_mass(ARM, Q0, [1.0, 0.0])
    ax = ForceLoopAxis("inner-position", **PI)
    assert sampled_stability_limit(ax, TS) < sampled_stability_limit(ax, TS, arm_inertia=mx)


def test_stability_limit_scales_with_the_force_gain():
    """Doubling k_F of the inner velocity loop halves the double-integrator limit (the loop gain is k_P k_F k)."""
    a1 = ForceLoopAxis("inner-velocity", **P)
    a2 = ForceLoopAxis("inner-velocity", 100.0, 500.0, 2500.0, 0.0048)
    assert sampled_stability_limit(a2, TS) == pytest.approx(sampled_stability_limit(a1, TS) / 2, rel=1e-4)


def _first_unstable_on_a_dense_grid(ax, Ts, mx, k_max):
    """The first k of a dense grid (4000 log points plus steps of 5e-4 rad in θ = Ts √(k/m_x))
    whose sampled loop has a pole on or outside the unit circle (the sampled model itself is checked
    against python-control's zero-order hold in test_sampled_plant_is_python_controls_zero_order_hold)."""
    ks = np.geomspace(1.0, k_max, 4000)
    if mx is not None:
        theta = np.arange(1e-3, Ts * math.sqrt(k_max / mx), 5e-4)
        ks = np.union1d(ks, mx * (theta / Ts) ** 2)
    for k in ks:
        if ax.with_environment_stiffness(k).spectral_radius(Ts, mx) >= 1.0:
            return k
    return math.inf


@pytest.mark.parametrize("scheme, force_gain, Ts, mx", [
    ("inner-velocity", 3.6e-3, 1e-3, None),     # double integrator: the main crossing
    ("inner-position", 1e-4, 1e-3, 30.0),       # main crossing below the Nyquist point
    ("inner-position", 3.6e-3, 5e-3, 0.5),      # window just below θ = π (a coarse scan stepped over it)
    ("parallel", 1e-2, 1e-3, 3.0),              # same, at another mass
    ("inner-velocity", 1e-4, 1e-4, 0.5),        # stable up to θ = π: the limit is the Nyquist window
])
def test_stability_limit_is_the_first_crossing_of_a_dense_grid(scheme, force_gain, Ts, mx):
    """The root-finder limit is the first unstable stiffness of a dense grid, to the grid's spacing (0.2 %),
    and never above it; with an arm mass it never exceeds m_x (π / Ts)²."""
    gains = dict(inertia=1.0, damping=12.5 if scheme != "inner-velocity" else 50.0, stiffness=25.0,
                 force_gain=force_gain)
    if scheme != "inner-velocity":
        gains["integral_gain"] = 2.5 * force_gain
    ax = ForceLoopAxis(scheme, **gains)
    limit = sampled_stability_limit(ax, Ts, arm_inertia=mx)
    dense = _first_unstable_on_a_dense_grid(ax, Ts, mx, 3.0 * limit)
    assert limit <= dense <= limit * 1.002
    assert ax.with_environment_stiffness(limit).spectral_radius(Ts, mx) < 1.0
    assert ax.with_environment_stiffness(limit * (1 + 1e-5)).spectral_radius(Ts, mx) >= 1.0
    if mx is not None:
        assert limit <= mx * (math.pi / Ts) ** 2


# ---------------------------------------------------------------------------- gain design


def test_design_recovers_the_inner_velocity_gains_of_example_9_3():
    """ω_n = √60, ζ = 2.5/√60 at k = 10³ gives k_D = 500 and k_F = 0.0024 (the book's gains)."""
    g = design_force_gains("inner-velocity", 100.0, 2500.0, 1e3, math.sqrt(60.0), 2.5 / math.sqrt(60.0))
    assert g.damping == pytest.approx(500.0, rel=1e-12)
    assert g.force_gain == pytest.approx(0.0024, rel=1e-12)


def test_design_from_the_book_poles_recovers_the_pi_gains_within_rounding():
    """Poles −1.96 ± j5.74, −1.09 (printed to 3 digits) give k_D ≈ 500, k_F ≈ 0.00064, k_I ≈ 0.0016 within 1 %."""
    wn = abs(-1.96 + 5.74j)
    g = design_force_gains("inner-position", 100.0, 2500.0, 1e3, wn, 1.96 / wn, real_pole=1.09)
    assert g.damping == pytest.approx(500.0, rel=0.01)
    assert g.force_gain == pytest.approx(0.00064, rel=0.01)
    assert g.integral_gain == pytest.approx(0.0016, rel=0.01)


@pytest.mark.parametrize("scheme", ["inner-position", "parallel"])
def test_designed_gains_place_the_poles(scheme):
    """Round trip: designed gains put the continuous poles at −ζω_n ± jω_n√(1−ζ²) and −p (k = 5·10³)."""
    wn, zeta, p = 9.0, 0.7, 3.0
    g = design_force_gains(scheme, 100.0, 2500.0, 5e3, wn, zeta, real_pole=p)
    ax = ForceLoopAxis(scheme, 100.0, g.damping, 2500.0, g.force_gain, g.integral_gain, 5e3)
    want = np.sort_complex([-zeta * wn + 1j * wn * math.sqrt(1 - zeta**2), -zeta * wn - 1j * wn * math.sqrt(1 - zeta**2), -p])
    np.testing.assert_allclose(np.sort_complex(ax.poles()), want, atol=1e-9)


BAD = [
    (lambda: design_force_gains("inner-position", 100, 2500, 1e3, 2.0, 0.5, real_pole=0.5), ParameterError,
     r"cannot place the poles with stiffness k_P = 2500 N/m: it needs force_gain k_F = .* < 0"),
    (lambda: design_force_gains("inner-position", 100, 2500, 1e3, 6.0, 0.3), ParameterError,
     r"real_pole must be given for the inner-position scheme \(third order\); got None"),
    (lambda: design_force_gains("inner-velocity", 100, 2500, 1e3, 6.0, 0.3, real_pole=1.0), ParameterError,
     r"real_pole must be None for the inner velocity loop"),
    (lambda: design_force_gains("hybrid", 100, 2500, 1e3, 6.0, 0.3), ParameterError,
     r"scheme must be one of \['inner-position', 'inner-velocity', 'parallel'\]; got 'hybrid'"),
    (lambda: design_force_gains("inner-velocity", 100, 2500, 0.0, 6.0, 0.3), ParameterError,
     r"environment_stiffness must be a positive number; got 0.0"),
    (lambda: ForceLoopAxis("inner-position", 100, 500, -2500, 1e-3), ParameterError,
     r"stiffness must be a positive number; got -2500"),
    (lambda: ForceLoopAxis("inner-position", 100, 500, 2500, -1e-3), ParameterError,
     r"force_gain must be a non-negative number; got -0.001"),
    (lambda: ForceLoopAxis("inner-velocity", 100, 500, 2500, 1e-3, 1e-3), ParameterError,
     r"integral_gain must be 0 for the inner velocity loop"),
    (lambda: ForceLoopAxis("inner-position", **PI).response([0, 1], 10.0, initial_state=[1.0, 0.0]), DimensionError,
     r"initial_state must have shape \(3,\) \(states \['x', 'xdot', 'xi'\]\); got shape \(2,\)"),
    (lambda: ForceLoopAxis("inner-position", **PI).sampled(0.0), ParameterError,
     r"sample_time must be a positive number; got 0.0"),
    (lambda: sampled_stability_limit(ForceLoopAxis("inner-velocity", **P), 0.5, low=1e6), ParameterError,
     r"the sampled loop is unstable already at low = 1e\+06 N/m"),
    (lambda: force_loop_axes(fc.ImpedanceController(ARM, 100, 500, 2500), 1e3), ParameterError,
     r"controller must be an InnerPositionForceController, .*; got ImpedanceController"),
    (lambda: force_loop_axes(fc.InnerVelocityForceController(ARM, [[100, 5], [5, 100]], 500, 2500, 0.0024), 1e3),
     ParameterError, r"inertia must be diagonal for a per-axis analysis"),
    (lambda: force_loop_axes(fc.InnerVelocityForceController(ARM, 100, 500, 2500, 0.0024), np.ones((3, 3))),
     DimensionError, r"environment_stiffness must be a scalar, \(2,\) or \(2, 2\); got shape \(3, 3\)"),
]


@pytest.mark.parametrize("call, error, match", BAD)
def test_bad_analysis_inputs_are_rejected_with_clear_messages(call, error, match):
    """Each impossible request raises the library error naming the parameter, expected and given."""
    with pytest.raises(error, match=match):
        call()
