"""Analysis functions against closed forms derived by hand."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import forcecontrol as fc
from forcecontrol.analysis import compliance_equilibrium, impedance_axis, joint_space_compliance
from forcecontrol.errors import ParameterError

pos = st.floats(1.0, 1e6)


@settings(max_examples=60, deadline=None)
@given(pos, pos, pos, st.floats(-0.2, 0.2))
def test_compliance_equilibrium_is_the_series_spring(k_px, k_py, k_x, d):
    """(9.22)–(9.23) with diagonal K_P and K = diag(k_x, 0) reduce to Example 9.1's formulas."""
    eq = compliance_equilibrium([k_px, k_py], [[k_x, 0.0], [0.0, 0.0]], [1.0 + d, 0.3], [1.0, 0.0])
    assert eq.contact_force[0] == pytest.approx(k_px * k_x / (k_px + k_x) * d, rel=1e-9, abs=1e-9)
    assert eq.position[0] == pytest.approx((k_px * (1 + d) + k_x) / (k_px + k_x), rel=1e-12)
    assert eq.position[1] == pytest.approx(0.3) and eq.contact_force[1] == 0.0


def test_compliance_equilibrium_balances_both_springs():
    """At the equilibrium K_P dx_{e,d} = h_e = K (x_e − x_r) for a full, coupled K."""
    K_P = np.array([[3000.0, 500.0], [500.0, 2000.0]])
    K = np.array([[1500.0, -300.0], [-300.0, 800.0]])
    eq = compliance_equilibrium(K_P, K, [1.1, 0.2], [1.0, 0.05])
    np.testing.assert_allclose(K_P @ eq.pose_error, eq.contact_force, rtol=1e-12)
    np.testing.assert_allclose(K @ (eq.position - [1.0, 0.05]), eq.contact_force, rtol=1e-12)


def test_joint_space_compliance_is_j_kinv_jt(arm, q_contact):
    """(9.26): the compliance J K_P⁻¹ Jᵀ, checked against the equilibrium of (9.24) for a small force."""
    K_P = np.diag([4000.0, 2500.0])
    C = joint_space_compliance(arm.jacobian(q_contact), K_P)
    h = np.array([1.0, -0.5])
    dq = np.linalg.solve(K_P, arm.jacobian(q_contact).T @ h)
    np.testing.assert_allclose(C @ h, arm.jacobian(q_contact) @ dq, rtol=1e-12)


def test_impedance_axis_steady_state():
    """x_e = (k_P x_d + k x_r)/(k_P + k) and f = k (x_e − x_r) along a constrained axis."""
    ax = impedance_axis(100, 500, 2500, 1e3, desired=1.1, rest=1.0)
    assert ax.position == pytest.approx(3750 / 3500) and ax.contact_force == pytest.approx(1e3 * (3750 / 3500 - 1))


def test_impedance_axis_rejects_bad_values():
    """A zero inertia is refused."""
    with pytest.raises(ParameterError, match="inertia must be a positive number; got 0"):
        impedance_axis(0, 500, 2500)


def test_compliance_equilibrium_rejects_indefinite_environment():
    """An indefinite environment stiffness is refused."""
    with pytest.raises(ParameterError, match="environment_stiffness must be a symmetric positive semi-definite"):
        compliance_equilibrium(1.0, [[1.0, 3.0], [3.0, 1.0]], [0, 0], [0, 0])


def test_public_api_exports_the_foundation():
    """The package re-exports the foundation's public names."""
    for name in ("simulate", "ImpedanceController", "OperationalSpacePD", "ElasticPlane", "ForceControlError"):
        assert hasattr(fc, name)
