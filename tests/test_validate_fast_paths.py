"""The shortcuts of the input checks (plain numbers, diagonal matrices) give what the general path gives.

References: the same values given as NumPy arrays (which take the general, eigensolver path),
and ``K @ numpy.linalg.pinv(K)`` for the range projector of the force-reference check.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from forcecontrol.controllers.force_checks import _diagonal_gain, _range_projector, check_force_reference
from forcecontrol.core.validate import as_gain_matrix
from forcecontrol.errors import DriftWarning, ParameterError


@pytest.mark.parametrize("value", [3.0, 7, [1.0, 2.0], (4, 5.5), [[2.0, 0.0], [0.0, 3.0]]])
@pytest.mark.parametrize("definite", [True, False])
def test_plain_gains_equal_the_array_path(value, definite):
    fast = as_gain_matrix("stiffness", value, 2, definite=definite)
    ref = as_gain_matrix("stiffness", np.asarray(value, dtype=np.float64), 2, definite=definite)
    assert np.array_equal(fast, ref)
    assert not fast.flags.writeable


@pytest.mark.parametrize("value", [0.0, -1.0, [1.0, 0.0], [1.0, -2.0], [[1.0, 0.0], [0.0, -3.0]]])
def test_plain_gains_that_are_not_definite_are_refused_naming_the_parameter(value):
    with pytest.raises(ParameterError, match=r"^damping must be a symmetric positive definite \(2, 2\) matrix; got eigenvalues"):
        as_gain_matrix("damping", value, 2)
    with pytest.raises(ParameterError, match="eigenvalues"):  # the general path agrees
        as_gain_matrix("damping", np.asarray(value, dtype=np.float64), 2)


@pytest.mark.parametrize("value", [math.nan, math.inf, [1.0, math.nan], (math.inf, 1.0)])
def test_plain_gains_that_are_not_finite_are_refused(value):
    with pytest.raises(ParameterError, match="^inertia must be finite"):
        as_gain_matrix("inertia", value, 2)


def test_semi_definite_diagonal_is_accepted_and_a_negative_entry_refused():
    assert np.array_equal(as_gain_matrix("environment_stiffness", [[1e4, 0.0], [0.0, 0.0]], 2, definite=False),
                          np.diag([1e4, 0.0]))
    with pytest.raises(ParameterError, match="positive semi-definite"):
        as_gain_matrix("environment_stiffness", [[1e4, 0.0], [0.0, -1.0]], 2, definite=False)


def test_text_and_booleans_still_refused():
    with pytest.raises(ParameterError, match="not text or booleans"):
        as_gain_matrix("stiffness", ["1", "2"], 2)
    with pytest.raises(ParameterError):
        as_gain_matrix("stiffness", [True, True], 2)


@pytest.mark.parametrize("value", [0.5, 2, [0.1, 0.0], (0.0, 3.0)])
def test_diagonal_force_gain_plain_equals_array(value):
    assert np.array_equal(_diagonal_gain("force_gain", value, 2, "m/N"),
                          _diagonal_gain("force_gain", np.asarray(value, dtype=np.float64), 2, "m/N"))


@pytest.mark.parametrize("value", [-1.0, [0.1, -0.2], [math.nan, 0.0]])
def test_diagonal_force_gain_plain_refuses_bad_values(value):
    with pytest.raises(ParameterError, match="^force_gain must be"):
        _diagonal_gain("force_gain", value, 2, "m/N")


def _psd(rng, m, rank):
    A = rng.standard_normal((m, rank)) * rng.uniform(0.1, 1e4)
    return A @ A.T


@pytest.mark.parametrize("m", [2, 3, 6])
def test_range_projector_equals_k_pinv_k(m):
    rng = np.random.default_rng(m)
    cases = [np.zeros((m, m)), np.diag(np.r_[1e4, np.zeros(m - 1)]), np.diag(rng.uniform(1, 1e5, m))]
    cases += [_psd(rng, m, r) for r in range(1, m + 1) for _ in range(3)]
    theta = 0.3  # a tilted plane's k n nᵀ
    n = np.zeros(m)
    n[0], n[1] = math.cos(theta), math.sin(theta)
    cases.append(1e4 * np.outer(n, n))
    for K in cases:
        ref = K @ np.linalg.pinv(K, rcond=1e-12) if np.any(K) else np.zeros((m, m))
        assert np.allclose(_range_projector(K), ref, atol=1e-9), K


def test_force_reference_check_warns_as_before_on_a_tilted_plane():
    n = np.array([math.cos(0.4), math.sin(0.4)])
    K = 1e4 * np.outer(n, n)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_force_reference(10.0 * n, K, [True, True])
    with pytest.warns(DriftWarning, match="outside the range"):
        assert not check_force_reference(10.0 * n + [0.5, 0.0], K, [True, True])


def test_closed_form_largest_eigenvalue_of_a_2x2_equals_eigvals():
    """The 2 x 2 shortcut of choose_substeps against numpy.linalg.eigvals: products of PSD matrices
    (the contact modes, real eigenvalues), general matrices (complex pairs: the real part), and a
    non-finite matrix refused as eigvals refuses it, entries whose square overflows answered by eigvals."""
    from forcecontrol.sim.simulation import _largest_real_eigenvalue

    rng = np.random.default_rng(3)
    for _ in range(500):
        a, b = rng.standard_normal((2, 2)), rng.standard_normal((2, 2))
        for A in (a @ a.T @ (b @ b.T), 1e4 * a, np.diag(rng.uniform(0, 1e6, 2)) @ (a @ a.T)):
            ref = float(np.max(np.linalg.eigvals(A).real))
            assert _largest_real_eigenvalue(A) == pytest.approx(ref, rel=1e-9, abs=1e-9 * np.abs(A).max())
    A3 = rng.standard_normal((3, 3))
    assert _largest_real_eigenvalue(A3) == float(np.max(np.linalg.eigvals(A3).real))
    with pytest.raises(np.linalg.LinAlgError):
        _largest_real_eigenvalue(np.array([[np.nan, 0.0], [0.0, 1.0]]))
    huge = np.array([[1e200, 3e199], [2e199, 5e199]])  # the closed form's square overflows: eigvals answers
    assert _largest_real_eigenvalue(huge) == float(np.max(np.linalg.eigvals(huge).real))
