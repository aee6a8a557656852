"""The sampled contact loop per axis (analysis.sampled_contact) against models written here from scratch.

References: for impedance (9.30)–(9.31) and (9.28) on a plane, the one-axis loop along the normal,
``s̈ = v_k − μ k s`` between samples with the law's v_k held (μ = nᵀ J B⁻¹ Jᵀ n from the arm's own
Jacobian and inertia), discretised with ``scipy.linalg.expm`` of ``[A B; 0 0] Ts``, and the free
tangent axis, a double integrator under a held PD whose zero-order hold is written out by hand;
python-control's ``sample_system(..., "zoh")`` for one of them; for active compliance (8.110), the
coupled two-axis loop written out here. Example 9.2's arm and gains, planes at several angles and
stiffnesses.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

import forcecontrol as fc
from forcecontrol.analysis import compliance_loop, held_input_matrices, impedance_loop
from forcecontrol.analysis.sampled_contact import (
    axis_frequencies,
    axis_groups,
    axis_spectral_radii,
    first_crossing,
    stiffness_limit,
)
from forcecontrol.errors import DimensionError, ParameterError
from sampled_helpers import KD, KP, MD, Q0, TS, free_axis_radius, mobility, one_axis_radius, plane_normal

STIFFNESSES = [1e3, 1e5, 1e6, 3e6, 1e8, 1e9]


@pytest.mark.parametrize("force_measurement", [True, False])
@pytest.mark.parametrize("k", STIFFNESSES)
def test_an_axis_aligned_plane_gives_each_axis_its_one_axis_radius(k, force_measurement):
    """Example 9.2 (plane normal to x): x has the one-axis loop's ρ along the normal, y the free axis' ρ (rel 1e-9)."""
    n = np.array([-1.0, 0.0])
    Mob = mobility(Q0)
    loop = impedance_loop(MD, KD, KP, k * np.outer(n, n), Mob, force_measurement=force_measurement)
    rho = axis_spectral_radii(loop, TS)
    law = "9.31" if force_measurement else "9.28"
    assert axis_groups(loop) == [[0], [1]]
    assert rho[0] == pytest.approx(one_axis_radius(k, float(n @ Mob @ n), law), rel=1e-9)
    assert rho[1] == pytest.approx(free_axis_radius(), rel=1e-9)
    assert loop.spectral_radius(TS) == pytest.approx(max(rho), rel=1e-12)


@pytest.mark.parametrize("angle", [20.0, 45.0, 70.0])
@pytest.mark.parametrize("k", [1e4, 1e6, 3e6, 1e9])
def test_a_tilted_plane_couples_x_and_y_and_both_get_the_worse_of_normal_and_tangent(angle, k):
    """A plane at 20°, 45°, 70°: x and y are one group whose ρ is max(normal axis, free tangent axis) from scratch."""
    n = plane_normal(angle)
    Mob = mobility(Q0)
    loop = impedance_loop(MD, KD, KP, k * np.outer(n, n), Mob)
    rho = axis_spectral_radii(loop, TS)
    ref = max(one_axis_radius(k, float(n @ Mob @ n), "9.31"), free_axis_radius())
    assert axis_groups(loop) == [[0, 1]]
    np.testing.assert_allclose(rho, [ref, ref], rtol=1e-9)


def test_a_plane_at_90_degrees_is_not_coupled_by_the_round_off_of_its_normal():
    """ElasticPlane.inclined(90°) has the normal [−1, 6e-17]: x and y stay separate groups, x the normal axis' ρ."""
    env = fc.ElasticPlane.inclined(math.pi / 2, [1.0, 0.0], 1e9)
    assert env.normal[1] != 0.0
    Mob = mobility(Q0)
    loop = impedance_loop(MD, KD, KP, env.stiffness_matrix(), Mob)
    assert axis_groups(loop) == [[0], [1]]
    assert axis_spectral_radii(loop, TS)[0] == pytest.approx(one_axis_radius(1e9, Mob[0, 0], "9.31"), rel=1e-9)


def test_the_one_axis_reference_agrees_with_python_control_zoh():
    """The scratch expm discretisation equals control.sample_system(..., 'zoh') on the contact plant (k = 1e7 N/m)."""
    control = pytest.importorskip("control")
    mu, k = 0.006, 1e7
    sysd = control.sample_system(control.ss([[0.0, 1.0], [-mu * k, 0.0]], [[0.0], [1.0]], np.eye(2), 0.0), TS, method="zoh")
    F = np.array([[-(KP + k) / MD + mu * k, -KD / MD]])
    rho = float(np.max(np.abs(np.linalg.eigvals(np.asarray(sysd.A) + np.asarray(sysd.B) @ F))))
    assert rho == pytest.approx(one_axis_radius(k, mu, "9.31"), rel=1e-9)


@pytest.mark.parametrize("k", [1e4, 1e6, 1e9])
def test_compliance_is_one_coupled_group_equal_to_the_loop_written_out(k):
    """(8.110) on Example 9.2's plane: ẍ = M (K_P x̃ − K_D ẋ)_k − M K x(t), the 4-state loop by hand; x, y coupled."""
    n = np.array([-1.0, 0.0])
    K = k * np.outer(n, n)
    Mob = mobility(Q0)
    KPm, KDm = np.diag([2500.0, 4000.0]), np.diag([400.0, 300.0])
    big = np.zeros((6, 6))
    big[:2, 2:4] = np.eye(2)
    big[2:4, :2] = -Mob @ K
    big[2:4, 4:] = np.eye(2)
    E = expm(big * TS)
    closed = E[:4, :4] + E[:4, 4:] @ np.hstack([-Mob @ KPm, -Mob @ KDm])
    ref = float(np.max(np.abs(np.linalg.eigvals(closed))))
    loop = compliance_loop(KPm, KDm, K, Mob)
    assert axis_groups(loop) == [[0, 1]]
    np.testing.assert_allclose(axis_spectral_radii(loop, TS), [ref, ref], rtol=1e-9)


def test_the_continuous_limit_of_9_31_has_example_9_2s_frequencies():
    """ω_n of each group = that of (9.32): √((k_P + k)/m_d) along the normal, √(k_P/m_d) along the free axis."""
    k = 1e4
    n = np.array([-1.0, 0.0])
    loop = impedance_loop(MD, KD, KP, k * np.outer(n, n), mobility(Q0))
    np.testing.assert_allclose(axis_frequencies(loop), [math.sqrt((KP + k) / MD), math.sqrt(KP / MD)], rtol=1e-12)


def test_the_sampled_loop_tends_to_the_continuous_one():
    """Φ + Γ F − expm((A + B F) Ts) is O(Ts²) per sample (the held law's error): halving Ts divides it by 4."""
    n = np.array([-0.6, 0.8])
    loop = impedance_loop(MD, KD, KP, 1e5 * np.outer(n, n), mobility(Q0))
    err = [float(np.max(np.abs(loop.closed(ts) - expm(loop.continuous() * ts)))) for ts in (2e-5, 1e-5)]
    assert 3.8 < err[0] / err[1] < 4.2


def test_stiffness_limit_is_where_the_scratch_radius_crosses_one():
    """Example 9.2's contact axis: the limit's ρ (the scratch model's) is < 1 and 1e-5 above it >= 1; about 2.59e6 N/m."""
    mu = float(mobility(Q0)[0, 0])
    limit = stiffness_limit(lambda k: one_axis_radius(k, mu, "9.31"))
    assert one_axis_radius(limit, mu, "9.31") < 1.0 <= one_axis_radius(limit * (1 + 1e-5), mu, "9.31")
    assert limit == pytest.approx(2.592e6, rel=1e-3)


def test_stiffness_limit_edges():
    """Stable up to high: inf; unstable at low: 0; the crossing inside a doubling is found with brentq."""
    assert stiffness_limit(lambda k: 0.5) == math.inf
    assert stiffness_limit(lambda k: 2.0) == 0.0
    assert stiffness_limit(lambda k: k / 1e5) == pytest.approx(1e5, rel=1e-6)
    assert first_crossing(lambda u: u - 3.0, 0.0, 2.0, 1e-9) is None


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: stiffness_limit(lambda k: 0.5, low=10.0, high=1.0), ParameterError, "high must be above low"),
        (lambda: stiffness_limit(lambda k: 0.5, low=0.0), ParameterError, "low must be a positive number"),
        (lambda: held_input_matrices(np.eye(2), np.ones((3, 1)), TS), DimensionError, "A must be square"),
        (lambda: held_input_matrices(np.eye(2), np.ones((2, 1)), 0.0), ParameterError, "sample_time"),
        (lambda: impedance_loop(MD, KD, KP, -np.eye(2), mobility(Q0)), ParameterError, "environment_stiffness"),
        (lambda: compliance_loop(KP, KD, np.eye(2), np.eye(3)), DimensionError, "stiffness"),
    ],
)
def test_bad_inputs_are_refused_with_the_library_errors(call, error, match):
    """Each refusal is the library's error naming the parameter."""
    with pytest.raises(error, match=match):
        call()
