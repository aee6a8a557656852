"""The compiled plant's 2 x 2 inertia solve (``_linalg.solve2_spd``) against NumPy."""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.core.linalg import solve2_spd as solve_inertia


def test_solves_the_arms_inertia_like_numpy_over_its_workspace():
    arm = fc.PlanarTwoLink()
    rng = np.random.default_rng(3)
    for q in rng.uniform(-np.pi, np.pi, size=(300, 2)):
        B = arm.mass_matrix(q)
        r = rng.normal(size=2) * 100.0
        ok, x0, x1 = solve_inertia(B[0, 0], B[0, 1], B[1, 1], r[0], r[1])
        assert ok
        np.testing.assert_allclose([x0, x1], np.linalg.solve(B, r), rtol=1e-13, atol=1e-14 * np.abs(r).max())


def test_random_spd_matrices():
    rng = np.random.default_rng(4)
    for _ in range(300):
        L = rng.normal(size=(2, 2))
        B = L @ L.T + 1e-3 * np.eye(2)
        r = rng.normal(size=2)
        ok, x0, x1 = solve_inertia(B[0, 0], B[0, 1], B[1, 1], r[0], r[1])
        assert ok
        expected = np.linalg.solve(B, r)
        assert np.max(np.abs(B @ [x0, x1] - r)) <= 1e-9 * np.linalg.norm(B) * np.linalg.norm(expected)


@pytest.mark.parametrize("B", [
    (1.0, 1.0, 1.0),  # singular
    (1.0, 2.0, 1.0),  # indefinite
    (0.0, 0.0, 0.0),
    (math.nan, 0.0, 1.0),
    (math.inf, 0.0, 1.0),
])
def test_refuses_what_is_not_positive_definite(B):
    assert solve_inertia(*B, 1.0, 1.0)[0] is False
