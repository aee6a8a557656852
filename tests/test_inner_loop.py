"""The inverse-dynamics inner loop (9.30), ``laws.inner.inverse_dynamics``: its 2 x 2 shortcut (the
chapter's arm) against its general path and against NumPy."""

from __future__ import annotations

import numpy as np
import pytest

from forcecontrol.laws.inner import inverse_dynamics


def _problem(rng):
    L = rng.normal(size=(2, 2))
    B = L @ L.T + 2.0 * np.eye(2)  # an inertia matrix: symmetric positive definite
    J = rng.normal(size=(2, 2)) + 1.5 * np.eye(2)
    nv, Jdq, a, hc = (rng.normal(size=2) * 10.0 for _ in range(4))
    return B, J, nv, Jdq, a, hc


def _embedded(B, J, nv, Jdq, a, hc):
    """The same problem in 3 x 3, block-diagonal with a unit third axis: it runs the general path,
    whose pivots, eliminations and sums for the first two rows are those of the 2 x 2 problem."""
    B3, J3 = np.eye(3), np.eye(3)
    B3[:2, :2], J3[:2, :2] = B, J
    pad = lambda v: np.append(v, 0.0)  # noqa: E731
    return B3, pad(nv), J3, pad(Jdq), pad(a), pad(hc)


@pytest.mark.parametrize("compensate", [True, False])
def test_two_by_two_shortcut_is_the_general_path_to_the_bit(compensate):
    rng = np.random.default_rng(7)
    for _ in range(200):
        B, J, nv, Jdq, a, hc = _problem(rng)
        u2 = np.empty(2)
        assert inverse_dynamics(B, nv, J, Jdq, a, hc, compensate, np.empty(8), u2)
        B3, nv3, J3, Jdq3, a3, hc3 = _embedded(B, J, nv, Jdq, a, hc)
        u3 = np.empty(3)
        assert inverse_dynamics(B3, nv3, J3, Jdq3, a3, hc3, compensate, np.empty(16), u3)
        np.testing.assert_array_equal(u2, u3[:2])
        # and (9.30) itself: u = B J^-1 (a - J' q') + n [+ J^T h]
        ref = B @ np.linalg.solve(J, a - Jdq) + nv + (J.T @ hc if compensate else 0.0)
        np.testing.assert_allclose(u2, ref, rtol=1e-12, atol=1e-9)


def test_singular_jacobian_gives_nan_torques_and_false():
    B, _, nv, Jdq, a, hc = _problem(np.random.default_rng(1))
    J = np.array([[1.0, 2.0], [2.0, 4.0]])
    u = np.zeros(2)
    assert not inverse_dynamics(B, nv, J, Jdq, a, hc, True, np.empty(8), u)
    assert np.isnan(u).all()
