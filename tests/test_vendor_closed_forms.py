"""Closed forms of the vendor and ROS controllers' laws (issue 30, item 3), 1 DOF with an ideal servo.

Every law runs compiled (``forcecontrol.laws.vendor``) in a 1-DOF loop (J = 1, control frame =
base) closed by an ideal servo: the command is reached exactly one cycle later (survey of issue
30, §1.2 and §2.5). References from outside the law code: the continuous-time closed forms of
the documented equations, the steady states solved by hand, and the discrete closed forms
``z_k = z_ss + V Λ^k V⁻¹ (z_0 − z_ss)`` of the documented recurrences, each written out in the
test (eigen-decomposition of the recurrence matrix, not a loop over the law).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from forcecontrol.laws.vendor import fdcc_error, fdcc_step, franka_impedance_torque, ros2_admittance_rule, ur_force_mode_step

I1 = np.eye(1)
INF = np.array([np.inf])


def _closed_form(A: np.ndarray, b: np.ndarray, z0: np.ndarray, k: np.ndarray) -> np.ndarray:
    """``z_k`` of ``z_{k+1} = A z_k + b`` in closed form: ``z_ss + V Λ^k V⁻¹ (z_0 − z_ss)`` (rows: k)."""
    z_ss = np.linalg.solve(np.eye(len(b)) - A, b)
    lam, V = np.linalg.eig(A)
    c = np.linalg.solve(V, (z0 - z_ss).astype(complex))
    return z_ss + np.real((V[None, :, :] * (lam[None, :] ** k[:, None])[:, None, :]) @ c)


def _second_order_step(t: np.ndarray, wn: float, zeta: float) -> np.ndarray:
    """Unit step response of ``ẍ + 2ζω ẋ + ω² x = ω²`` from rest (the textbook closed form)."""
    if zeta < 1.0:
        wd = wn * math.sqrt(1.0 - zeta**2)
        return 1.0 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1.0 - zeta**2) * np.sin(wd * t))
    if zeta == 1.0:
        return 1.0 - np.exp(-wn * t) * (1.0 + wn * t)
    r1 = -wn * (zeta - math.sqrt(zeta**2 - 1.0))
    r2 = -wn * (zeta + math.sqrt(zeta**2 - 1.0))
    return 1.0 - (r2 * np.exp(r1 * t) - r1 * np.exp(r2 * t)) / (r2 - r1)


# ---------------------------------------------------------------------------------- ros2 admittance


def _ros2_run(T, M, zeta, K, c_j, alpha, steps, k_e=0.0, x_e=0.0, w_cmd=0.0):
    """The compiled rule in a 1-DOF loop with an ideal servo: the measured offset is the previous command."""
    D = zeta * 2.0 * math.sqrt(M * K)
    p = np.array([M, D, K, 1.0, c_j, alpha, 0.0])
    s = np.zeros(4)
    out = np.empty(steps)
    for k in range(steps):
        x = s[0]  # q_meas − q_ref = the offset commanded one cycle ago
        w = np.array([-k_e * (x - x_e) + w_cmd])
        assert ros2_admittance_rule(T, I1, I1, np.array([x]), w, p, s)
        out[k] = s[0]
    return out


def test_ros2_admittance_free_space_step_matches_the_continuous_closed_form():
    """A wrench step (α = 1) moves the offset as M ẍ + (D + c_j M) ẋ + K x = F, D = 2ζ sqrt(M K): within 1 % of F/K.

    Continuous limit of the rule (survey §1.2) at T = 0.1 ms: ω_n = sqrt(K/M), ζ_eff = ζ + c_j sqrt(M/K)/2.
    """
    M, zeta, K, c_j, F, T = 5.5, 0.3, 214.1, 1.0, 10.0, 1e-4
    steps = 30000
    x = _ros2_run(T, M, zeta, K, c_j, 1.0, steps, w_cmd=F)
    t = T * np.arange(1, steps + 1)
    wn = math.sqrt(K / M)
    ref = F / K * _second_order_step(t, wn, zeta + c_j * math.sqrt(M / K) / 2.0)
    assert np.max(np.abs(x - ref)) < 0.01 * F / K
    assert x.max() > 1.05 * F / K  # underdamped: the overshoot is there to be matched


def _ros2_matrix(T, M, D, K, c_j, alpha, k_e):
    """The rule's documented recurrence (survey §1.2) on z = [F, v, p] with x_k = p_{k−1}: z_{k+1} = A z_k + b/… ."""
    # F_k = α(−k_e p_{k−1} + c) + (1 − α) F_{k−1}; a_k = (F_k − D v − K p)/M − c_j v; v_k = v + T a_k; p_k = p + T v_k
    A = np.zeros((3, 3))
    A[0] = [1.0 - alpha, 0.0, -alpha * k_e]
    A[1] = T / M * A[0] + np.array([0.0, 1.0 - T * D / M - T * c_j, -T * K / M])
    A[2] = T * A[1] + np.array([0.0, 0.0, 1.0])
    return A


@pytest.mark.parametrize("k_e", [0.0, 2000.0])
def test_ros2_admittance_sampled_step_and_steady_state_match_closed_forms(k_e):
    """With the test file's α = 0.005 at 500 Hz, free space and a 2 kN/m spring: the offset equals the discrete
    closed form within 1 % of its final value, and settles at (k_e x_e + w_cmd)/(K + k_e) (survey §1.2)."""
    T, M, zeta, K, c_j, alpha, x_e, w = 0.002, 5.5, 2.828427, 214.1, 5.0, 0.005, -0.01, 10.0
    D = zeta * 2.0 * math.sqrt(M * K)
    steps = 20000
    x = _ros2_run(T, M, zeta, K, c_j, alpha, steps, k_e=k_e, x_e=x_e, w_cmd=w)
    A = _ros2_matrix(T, M, D, K, c_j, alpha, k_e)
    c = alpha * (k_e * x_e + w)
    b = np.array([c, T / M * c, T * T / M * c])
    z = _closed_form(A, b, np.zeros(3), np.arange(1, steps + 1))
    x_ss = (k_e * x_e + w) / (K + k_e)
    assert np.max(np.abs(x - z[:, 2])) < 0.01 * abs(x_ss)
    assert x[-1] == pytest.approx(x_ss, rel=1e-3)


def test_ros2_admittance_wrench_masked_by_selected_axes_spring_still_acts():
    """selected_axes = false ignores the wrench but keeps the spring: an offset decays back to zero (survey §1.1)."""
    p = np.array([1.0, 2.0 * math.sqrt(100.0), 100.0, 0.0, 0.0, 1.0, 0.0])
    s = np.array([0.01, 0.0, 0.0, 0.0])
    for _ in range(5000):
        ros2_admittance_rule(0.002, I1, I1, np.array([s[0]]), np.array([50.0]), p, s)
    assert abs(s[0]) < 1e-6


# --------------------------------------------------------------------------------------------- FZI


def _fzi_run(P, scale, K, m_v, steps, *, k_e=0.0, x_e=0.0, f_d=0.0, x_t=0.0, iterations=1, inst=False, d=0.0):
    """The compiled solver step in a 1-DOF loop (H = m_v, J = 1) with an ideal servo (q_meas = last command)."""
    p = np.array([P, d, scale, 0.02, 0.9, 1.0 if inst else 0.0])
    s = np.zeros(2)
    q = np.zeros(1)
    out = np.empty(steps)
    e = np.empty(1)
    H = np.array([[m_v]])
    for k in range(steps):
        w_err = np.array([f_d - k_e * (q[0] - x_e)])  # sensor held over the iterations
        for _ in range(iterations):
            fdcc_error(np.array([x_t - q[0]]), w_err, np.array([K]), I1, e)
            assert fdcc_step(e, p, s, H, I1, q, -INF, INF)
        out[k] = q[0]
    return out


def _fzi_closed_form(g, e0, k):
    """e_k of ``e_{k+1} = e_k + u_k``, ``u_{k+1} = 0.9 u_k − 0.9 g e_k`` from (e_0, u_0 = 0) (survey §2.5)."""
    return _closed_form(np.array([[1.0, 1.0], [-0.9 * g, 0.9]]), np.zeros(2), np.array([e0, 0.0]), k)[:, 0]


def test_fzi_compliance_free_space_step_matches_closed_form():
    """The README's compliance gains (p 0.05, error_scale 0.5, 500 N/m, m_v 1.3 kg): a 1 cm target step follows
    (z − 1)(z − 0.9) + 0.9 g, g = s p K h²/m_v, within 1 % of the step, and settles on the target.

    Derivation: with the ideal servo the solver's sync leaves q unchanged; u = h q̇ and e = q − x_t give
    e_{k+1} = e_k + u_k (old velocity), u_{k+1} = 0.9 (u_k − h² s p K e_k/m_v).
    """
    P, s, K, m_v, x_t = 0.05, 0.5, 500.0, 1.3, 0.01
    g = s * P * K * 0.02**2 / m_v
    x = _fzi_run(P, s, K, m_v, 400, x_t=x_t)
    ref = x_t + _fzi_closed_form(g, -x_t, np.arange(1, 401))
    assert np.max(np.abs(x - ref)) < 0.01 * x_t
    assert x[-1] == pytest.approx(x_t, rel=1e-3)


def test_fzi_compliance_against_spring_settles_at_closed_form():
    """Compliance in contact: x settles at (K x_t + k_e x_e + f_d)/(K + k_e) along the closed form with k = K + k_e."""
    P, s, K, m_v, k_e, x_e, x_t, f_d = 0.05, 0.5, 500.0, 1.3, 1500.0, 0.002, 0.01, 5.0
    g = s * P * (K + k_e) * 0.02**2 / m_v
    x = _fzi_run(P, s, K, m_v, 600, k_e=k_e, x_e=x_e, f_d=f_d, x_t=x_t)
    x_ss = (K * x_t + k_e * x_e + f_d) / (K + k_e)
    ref = x_ss + _fzi_closed_form(g, -x_ss, np.arange(1, 601))
    assert np.max(np.abs(x - ref)) < 0.01 * x_ss
    assert x[-1] == pytest.approx(x_ss, rel=1e-4)


def test_fzi_force_controller_integrates_to_the_target_force():
    """Force controller (K = 0) against a spring: the contact force settles at f_d exactly (integral action)."""
    P, s, m_v, k_e, f_d = 0.05, 0.5, 1.3, 4000.0, 10.0
    x = _fzi_run(P, s, 0.0, m_v, 2000, k_e=k_e, f_d=f_d)
    assert k_e * x[-1] == pytest.approx(f_d, rel=1e-6)


@pytest.mark.parametrize("factor, stable", [(0.95, True), (1.05, False)])
def test_fzi_stability_limit_g_one_ninth(factor, stable):
    """Jury on z² − 1.9 z + 0.9 (1 + g): stable iff g < 1/9; the law's force loop decays below and grows above."""
    P, s, m_v = 0.05, 0.5, 1.3
    k_e = factor * (1.0 / 9.0) * m_v / (s * P * 0.02**2)
    x = _fzi_run(P, s, 0.0, m_v, 6000, k_e=k_e, f_d=10.0)
    err = np.abs(k_e * x - 10.0)
    assert bool(err[-100:].max() < 1e-3 * err[:100].max()) is stable


def test_fzi_iterations_in_free_space_are_internal_steps():
    """In free space N iterations per cycle are N solver steps: cycle k equals the closed form at step N k."""
    P, s, K, m_v, x_t, N = 0.05, 0.5, 500.0, 1.3, 0.01, 3
    g = s * P * K * 0.02**2 / m_v
    x = _fzi_run(P, s, K, m_v, 100, x_t=x_t, iterations=N)
    ref = x_t + _fzi_closed_form(g, -x_t, N * np.arange(1, 101))
    assert np.max(np.abs(x - ref)) < 1e-3 * x_t


def test_fzi_instantaneous_2021_solver_is_a_gradient_step():
    """The 2021 solver (issue #21): each step moves q by h² s p e/(4 m_v): e shrinks by (1 − g/4) per iteration."""
    P, s, K, m_v, x_t, N = 0.05, 0.5, 500.0, 1.3, 0.01, 5
    g = s * P * K * 0.02**2 / m_v
    x = _fzi_run(P, s, K, m_v, 50, x_t=x_t, iterations=N, inst=True)
    ref = x_t - x_t * (1.0 - g / 4.0) ** (N * np.arange(1, 51))
    assert np.max(np.abs(x - ref)) < 1e-9


# ------------------------------------------------------------------------------------------ Franka


def _franka_run(T, Lam, K, steps, *, k_e=0.0, x_e=0.0, x_d=0.0, soft=False, dtau=1.0):
    """The compiled law on a 1-DOF mass Λ (exact zero-order-hold plant with the spring k_e inside)."""
    Ac = np.array([[0.0, 1.0], [-k_e / Lam, 0.0]])
    Bc = np.array([[0.0, 0.0], [1.0 / Lam, k_e * x_e / Lam]])
    E = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    Ad, Bd = E[:2, :2], E[:2, 2:]
    D = 2.0 * math.sqrt(K)
    p = np.array([K, D, 0.0, dtau, 0.005, 0.2, 0.0])
    s = np.array([0.0 if soft else K, 0.0 if soft else D, 0.0, 0.0])
    z = np.zeros(2)
    u = np.empty(1)
    out = np.empty(steps)
    for k in range(steps):
        franka_impedance_torque(I1, np.array([z[0] - x_d]), z[1:2], z[0:1], np.zeros(1), p, s, u)
        z = Ad @ z + Bd @ np.array([u[0], 1.0])
        out[k] = z[0]
    return out, s


@pytest.mark.parametrize("k_e", [0.0, 300.0])
def test_franka_step_matches_the_continuous_closed_form(k_e):
    """Λ ẍ + 2 sqrt(K) ẋ + (K + k_e) x = K x_d + k_e x_e at 1 kHz: within 1 % of the step, and the steady state.

    K = 200 N/m, Λ = 2 kg: ζ = sqrt(K)/sqrt(Λ (K + k_e)) ("damping ratio 1" only for a unit mass).
    """
    T, Lam, K, x_d, x_e = 1e-3, 2.0, 200.0, 0.004, 0.001
    steps = 3000
    x, _ = _franka_run(T, Lam, K, steps, k_e=k_e, x_e=x_e, x_d=x_d)
    x_ss = (K * x_d + k_e * x_e) / (K + k_e)
    wn = math.sqrt((K + k_e) / Lam)
    zeta = 2.0 * math.sqrt(K) / (2.0 * math.sqrt(Lam * (K + k_e)))
    t = T * np.arange(1, steps + 1)
    ref = x_ss * _second_order_step(t, wn, zeta)
    assert np.max(np.abs(x - ref)) < 0.01 * x_ss
    assert x[-1] == pytest.approx(x_ss, rel=1e-6)


def test_franka_gains_soft_start_filter_closed_form():
    """Started from K = 0, the stiffness follows K (1 − 0.995^k) (the 0.005 filter after each command)."""
    _, s = _franka_run(1e-3, 2.0, 200.0, 300, x_d=0.0, soft=True)
    assert s[0] == pytest.approx(200.0 * (1.0 - 0.995**300), rel=1e-12)
    assert s[1] == pytest.approx(2.0 * math.sqrt(200.0) * (1.0 - 0.995**300), rel=1e-12)


def test_franka_torque_rate_clamp_ramps_one_newton_metre_per_cycle():
    """A 50 N·m demand from rest ramps 1 N·m per cycle (Δτ_max = 1): 1, 2, 3, … (saturateTorqueRate)."""
    p = np.array([5000.0, 0.0, 0.0, 1.0, 0.005, 0.2, 0.0])
    s = np.array([5000.0, 0.0, 0.0, 0.0])
    u = np.empty(1)
    got = []
    for _ in range(5):
        franka_impedance_torque(I1, np.array([-0.01]), np.zeros(1), np.zeros(1), np.zeros(1), p, s, u)
        got.append(u[0])
    assert got == [1.0, 2.0, 3.0, 4.0, 5.0]


# -------------------------------------------------------------------------------------- UR force mode


def _ur_run(T, G, sg, d, steps, F_d, limit=10.0, k_e=None, x_e=0.0):
    """The compiled force-mode step with an ideal Cartesian servo (the measured pose is the previous command)."""
    p = np.array([1.0, F_d, limit, G, sg, d])
    s = np.zeros(2)
    out = np.empty(steps)
    for k in range(steps):
        F = 0.0 if k_e is None else k_e * (s[1] - x_e)
        ur_force_mode_step(T, np.array([F]), p, s)
        out[k] = s[1]
    return out


def test_ur_force_mode_free_space_velocity_closed_form():
    """Free space: v_k = v_∞ (1 − (1 − β)^k), v_∞ = T G s_g F_d/β, and x_k = T v_∞ (k − (1 − β)(1 − (1 − β)^k)/β)."""
    T, G, sg, d, F_d, n = 0.002, 0.05, 0.5, 0.025, 10.0, 500
    x = _ur_run(T, G, sg, d, n, F_d)
    k = np.arange(1, n + 1)
    v_inf = T * G * sg * F_d / d
    ref = T * v_inf * (k - (1.0 - d) * (1.0 - (1.0 - d) ** k) / d)
    assert np.max(np.abs(x - ref)) < 1e-12 + 0.01 * np.max(np.abs(ref))


def test_ur_force_mode_speed_limit():
    """A compliant axis never exceeds its limit speed: with a large force the offset grows at exactly the limit."""
    x = _ur_run(0.002, 0.05, 1.0, 0.005, 2000, 200.0, limit=0.05)
    assert np.diff(x)[-100:] == pytest.approx(0.002 * 0.05, rel=1e-12)


def test_ur_force_mode_against_spring_closed_form_and_equilibrium():
    """Against k_e: the offset follows the closed form of v_k = (1 − β) v + T G s_g (F_d − k_e (x_{k−1} − x_e)),
    x_k = x_{k−1} + T v_k, within 1 %, and the contact force settles at F_d (the wrench the robot applies)."""
    T, G, sg, d, F_d, k_e, x_e = 0.002, 0.05, 0.5, 0.025, 10.0, 5000.0, 0.0
    n = 4000
    x = _ur_run(T, G, sg, d, n, F_d, k_e=k_e, x_e=x_e)
    a = T * G * sg
    A = np.array([[1.0 - d, -a * k_e], [T * (1.0 - d), 1.0 - T * a * k_e]])
    b = np.array([a * (F_d + k_e * x_e), T * a * (F_d + k_e * x_e)])
    z = _closed_form(A, b, np.zeros(2), np.arange(1, n + 1))
    x_ss = x_e + F_d / k_e
    assert np.max(np.abs(x - z[:, 1])) < 0.01 * x_ss
    assert k_e * (x[-1] - x_e) == pytest.approx(F_d, rel=1e-6)
