"""Example 9.2 on the full nonlinear arm at Ts = 1 ms against the chapter's printed numbers."""

from __future__ import annotations

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.analysis import impedance_axis

ARM = fc.PlanarTwoLink()


def _run(k_x: float) -> fc.SimulationResult:
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], k_x)
    ctl = fc.ImpedanceController(ARM, [100, 100], [500, 500], [2500, 2500], force_measurement=True, sample_time=1e-3)
    q0 = ARM.inverse_kinematics([1.0, 0.0], elbow="up")
    return fc.simulate(ARM, env, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=4.0)


# (k_x, contact force [N], displacement [m]) as printed in Example 9.2
BOOK = [(1e3, 71.4, 0.0714), (1e4, 200.0, 0.0200)]


@pytest.mark.parametrize("k_x, force, displacement", BOOK)
def test_steady_force_and_displacement_match_the_book(k_x, force, displacement):
    """Settled f_x and x_e − x_r are the book's 71.4 N / 7.14 cm and 200 N / 2.00 cm within 0.5 %."""
    r = _run(k_x)
    fx, x = r.settled("wrench")[0], r.settled("x")[0]
    assert fx == pytest.approx(force, rel=5e-3)
    assert x - 1.0 == pytest.approx(displacement, rel=5e-3)


@pytest.mark.parametrize("k_x", [1e3, 1e4])
def test_tip_y_reaches_0_1(k_x):
    """The unconstrained vertical motion reaches y_d = 0.1 m within 0.5 %."""
    assert _run(k_x).settled("x")[1] == pytest.approx(0.1, rel=5e-3)


def test_vertical_motion_is_the_same_for_both_environments():
    """Fig. 9.4: the y history does not depend on the environment stiffness (decoupled impedance).

    Exact in continuous time; the 1 ms zero-order hold couples the axes slightly (the force is
    measured at the sample and held), which stays below 0.1 % of the 0.1 m motion.
    """
    a, b = _run(1e3), _run(1e4)
    np.testing.assert_allclose(a.x[:, 1], b.x[:, 1], atol=1e-4)


@pytest.mark.parametrize(
    "k_x, wn, zeta, wn_tol, zeta_tol",
    [(0.0, 5.0, 0.5, 1e-12, 1e-12), (1e3, 5.9, 0.42, 0.05, 0.005), (1e4, 11.2, 0.22, 0.05, 0.005)],
)
def test_natural_frequency_and_damping_as_printed(k_x, wn, zeta, wn_tol, zeta_tol):
    """ω_n, ζ: (5 rad/s, 0.5) free; (5.9, 0.42) and (11.2, 0.22) in contact, to the printed digits."""
    ax = impedance_axis(100, 500, 2500, k_x)
    assert abs(ax.natural_frequency - wn) <= wn_tol
    assert abs(ax.damping_ratio - zeta) <= zeta_tol


def test_simulated_contact_transient_is_the_second_order_impedance():
    """The simulated f_x(t) follows m_d ẍ + k_D ẋ + (k_P + k_x) x = k_x x_r + k_P x_d (closed form)."""
    k = 1e3
    r = _run(k)
    wn, z = np.sqrt((2500 + k) / 100), 500 / (2 * np.sqrt(100 * (2500 + k)))
    wd = wn * np.sqrt(1 - z * z)
    x_inf = (2500 * 1.1 + k * 1.0) / (2500 + k)
    t = r.t
    x_lin = x_inf + (1.0 - x_inf) * np.exp(-z * wn * t) * (np.cos(wd * t) + z * wn / wd * np.sin(wd * t))
    f_lin = k * (x_lin - 1.0)
    assert np.abs(r.wrench[:, 0] - f_lin).max() < 0.01 * 71.4
