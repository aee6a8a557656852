"""Example 9.1 (active compliance) on the nonlinear arm against the equilibrium (9.22)–(9.23)."""

from __future__ import annotations

import pytest

import forcecontrol as fc

ARM = fc.PlanarTwoLink()
K_X, X_R, X_D, Y_D = 1e3, 1.0, 1.1, 0.1


@pytest.mark.parametrize("ratio, damping", [(0.01, 600.0), (2.5, 1200.0), (100.0, 6000.0)])
def test_equilibrium_matches_9_22_9_23(ratio, damping):
    """Settled f_x and x_e equal Example 9.1's closed forms within 0.5 % for k_Px/k_x = 0.01, 2.5, 100."""
    k_px = ratio * K_X
    env = fc.ElasticPlane([X_R, 0.0], [-1.0, 0.0], K_X)
    ctl = fc.OperationalSpacePD(ARM, [k_px, 2500.0], [damping, 1000.0])
    r = fc.simulate(ARM, env, ctl, fc.Setpoint([X_D, Y_D]), q0=ARM.inverse_kinematics([1.0, 0.0]), duration=15.0)
    # the closed forms printed in Example 9.1
    f_book = k_px * K_X / (k_px + K_X) * (X_D - X_R)
    x_book = (k_px * X_D + K_X * X_R) / (k_px + K_X)
    fx, (x, y) = r.settled("wrench", 0.2)[0], r.settled("x", 0.2)
    assert fx == pytest.approx(f_book, rel=5e-3)
    assert X_D - x == pytest.approx(X_D - x_book, rel=5e-3)  # the pose error dx_{e,d} of (9.23)
    assert y == pytest.approx(Y_D, rel=5e-3)


def test_stiff_arm_dominates_and_soft_arm_complies():
    """k_Px/k_x ≫ 1 gives x_e ≈ x_d; k_Px/k_x ≪ 1 gives x_e ≈ x_r (the chapter's two limits)."""
    from forcecontrol.analysis import compliance_equilibrium

    stiff = compliance_equilibrium([1e6, 1e3], [[K_X, 0], [0, 0]], [X_D, Y_D], [X_R, 0])
    soft = compliance_equilibrium([1.0, 1e3], [[K_X, 0], [0, 0]], [X_D, Y_D], [X_R, 0])
    assert stiff.position[0] == pytest.approx(X_D, abs=1e-3) and stiff.contact_force[0] == pytest.approx(100, rel=2e-3)
    assert soft.position[0] == pytest.approx(X_R, abs=1e-3) and soft.contact_force[0] == pytest.approx(0.1, rel=2e-3)
