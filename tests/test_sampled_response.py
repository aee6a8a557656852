"""The sampled-data (zero-order hold) response of the analysis against hand-written references.

References: the double integrator's exact ZOH map written out by hand, and the continuous
closed loop (``impedance_response``, a matrix exponential) that the sampled loop approaches,
to first order in the sample time.
"""

from __future__ import annotations

import numpy as np
import pytest

from forcecontrol.analysis import held_input_response, impedance_response
from forcecontrol.errors import DimensionError, ParameterError

DOUBLE_INTEGRATOR = (np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]))


def _by_hand(F, g, Ts, z0, times):
    """x_{k+1} = x_k + Ts ẋ_k + Ts²/2 v_k, ẋ_{k+1} = ẋ_k + Ts v_k, v_k = F z_k + g; inside a sample the same with τ."""
    out = []
    for t in times:
        x, v = z0
        k = int(np.floor(t / Ts + 1e-9))
        for _ in range(k):
            a = F[0] * x + F[1] * v + g
            x, v = x + Ts * v + 0.5 * Ts**2 * a, v + Ts * a
        tau = t - k * Ts
        a = F[0] * x + F[1] * v + g
        out.append((x + tau * v + 0.5 * tau**2 * a, v + tau * a))
    return np.array(out)


@pytest.mark.parametrize("Ts", [1e-3, 7e-3, 0.05])
def test_double_integrator_with_held_input_matches_the_map_by_hand(Ts):
    A, B = DOUBLE_INTEGRATOR
    F, g = np.array([-400.0, -30.0]), 400.0 * 0.2
    times = np.array([0.0, 0.0004, Ts, 1.5 * Ts, 0.0123, 0.1, 0.3337, 1.0])
    z = held_input_response(A, B, F.reshape(1, 2), [g], Ts, [0.05, -0.1], times)
    np.testing.assert_allclose(z, _by_hand(F, g, Ts, (0.05, -0.1), times), rtol=1e-10, atol=1e-12)


def test_times_in_any_order_give_the_same_values():
    A, B = DOUBLE_INTEGRATOR
    F = np.array([[-100.0, -5.0]])
    t = np.array([0.9, 0.01, 0.5, 0.0, 0.25])
    z = held_input_response(A, B, F, [1.0], 1e-3, [0.0, 0.0], t)
    order = np.argsort(t)
    np.testing.assert_array_equal(z[order], held_input_response(A, B, F, [1.0], 1e-3, [0.0, 0.0], t[order]))


def test_the_sampled_loop_tends_to_the_continuous_one_at_first_order():
    A, B = DOUBLE_INTEGRATOR
    m, kd, kp, x_d, x0 = 2.0, 40.0, 800.0, 0.1, 0.0
    F, g = np.array([[-kp / m, -kd / m]]), [kp * x_d / m]
    times = np.linspace(0.0, 0.4, 9)
    cont, _ = impedance_response(m, kd, kp, 0.0, [x_d], [0.0], [x0], times)
    errs = []
    for Ts in (2e-3, 1e-3, 5e-4):
        z = held_input_response(A, B, F, g, Ts, [x0, 0.0], times)
        errs.append(np.max(np.abs(z[:, 0] - cont[:, 0])))
    assert errs[-1] < 5e-3 * x_d  # ω_n Ts = 0.01: a 0.3 % difference
    assert 1.7 < errs[0] / errs[1] < 2.3 and 1.7 < errs[1] / errs[2] < 2.3  # first order in Ts


def test_bad_inputs_are_refused_with_the_library_errors():
    A, B = DOUBLE_INTEGRATOR
    F = np.array([[-1.0, -1.0]])
    with pytest.raises(ParameterError, match="sample_time"):
        held_input_response(A, B, F, [0.0], 0.0, [0.0, 0.0], [0.1])
    with pytest.raises(ParameterError, match="times"):
        held_input_response(A, B, F, [0.0], 1e-3, [0.0, 0.0], [-0.1])
    with pytest.raises(ParameterError, match="times"):
        held_input_response(A, B, F, [0.0], 1e-3, [0.0, 0.0], [np.nan])
    with pytest.raises(DimensionError, match="start"):
        held_input_response(A, B, F, [0.0], 1e-3, [0.0], [0.1])


def test_a_controller_with_its_own_discrete_state_matches_the_loop_by_hand():
    """A PI position loop on the double integrator, by hand:
    s_{k+1} = s_k + Ts (x_r − x_k), v_k = −k_p x_k − k_d ẋ_k + k_i s_k + k_p x_r."""
    A, B = DOUBLE_INTEGRATOR
    Ts, kp, kd, ki, xr = 2e-3, 300.0, 25.0, 900.0, 0.3
    times = np.array([0.0, 0.0031, 0.05, 0.2, 0.71, 1.5])
    z = held_input_response(A, B, [[-kp, -kd]], [kp * xr], Ts, [0.0, 0.0], times,
                            controller=([[ki]], [[1.0]], [[-Ts, 0.0]], [Ts * xr]))
    ref = []
    for t in times:
        x = v = s = 0.0
        k = int(np.floor(t / Ts + 1e-9))
        for _ in range(k):
            a = -kp * x - kd * v + ki * s + kp * xr
            x, v, s = x + Ts * v + 0.5 * Ts**2 * a, v + Ts * a, s + Ts * (xr - x)
        tau = t - k * Ts
        a = -kp * x - kd * v + ki * s + kp * xr
        ref.append((x + tau * v + 0.5 * tau**2 * a, v + tau * a))
    np.testing.assert_allclose(z, np.array(ref), rtol=1e-10, atol=1e-12)
    assert abs(z[-1, 0] - xr) < 1e-3  # the integrator removes the offset


def test_a_controller_of_the_wrong_shape_is_refused():
    A, B = DOUBLE_INTEGRATOR
    with pytest.raises(DimensionError, match="controller"):
        held_input_response(A, B, [[-1.0, -1.0]], [0.0], 1e-3, [0.0, 0.0], [0.1],
                            controller=([[1.0]], [[1.0]], [[1.0]], [0.0]))


def test_the_sampled_impedance_needs_the_sample_time_and_the_mobility_together():
    with pytest.raises(ParameterError, match="sample_time and mobility go together"):
        impedance_response(2.0, 40.0, 800.0, 0.0, [0.1], [0.0], [0.0], [0.1], sample_time=1e-3)
    with pytest.raises(DimensionError, match="mobility"):
        impedance_response(2.0, 40.0, 800.0, 0.0, [0.1], [0.0], [0.0], [0.1], sample_time=1e-3, mobility=np.eye(2))


def test_the_sampled_impedance_on_a_spring_is_the_held_input_loop_written_out():
    """impedance_response(sample_time, mobility) against held_input_response with the plant and the
    law (9.31) written here: ẍ = a_k + μ (h_k − h(t)), a_k = (k_P (x_d − x_k) − k_D ẋ_k − h_k) / m_d."""
    m, kd, kp, k, mu, xd, Ts = 2.0, 40.0, 800.0, 5000.0, 0.3, 0.1, 1e-3
    times = np.array([0.0, 0.0105, 0.05, 0.2, 0.6])
    x, h = impedance_response(m, kd, kp, k, [xd], [0.0], [0.0], times, sample_time=Ts, mobility=[[mu]])
    A = np.array([[0.0, 1.0], [-mu * k, 0.0]])
    B = np.array([[0.0], [1.0]])
    F = np.array([[-kp / m - k / m + mu * k, -kd / m]])
    z = held_input_response(A, B, F, [kp * xd / m], Ts, [0.0, 0.0], times)
    np.testing.assert_allclose(x[:, 0], z[:, 0], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(h[:, 0], k * z[:, 0], rtol=1e-12, atol=1e-12)
