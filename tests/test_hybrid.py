"""Hybrid force/motion controllers (Sect. 9.7): laws against hand-built torques, estimated compliance, bad inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol import CHAPTER_ARM, ElasticPlane, LinearPath, Measurement, Reference, Setpoint, laws, simulate
from forcecontrol.controllers.hybrid import HybridCompliantController, HybridRigidController
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.task import SelectionMatrices, inclined_plane, sliding_on_plane, turning_crank

R2 = 1.0 / math.sqrt(2.0)
K_ENV = 5e3


@pytest.fixture(scope="module")
def task():
    """The π/4 plane of Example 9.4."""
    return inclined_plane()


@pytest.fixture(scope="module")
def state():
    """A moving state near the plane and a wrench on it."""
    q = CHAPTER_ARM.inverse_kinematics([1.05, 0.04]) + np.array([0.0, 0.0])
    qd = np.array([0.3, -0.2])
    h = np.array([20.0, -25.0])
    return q, qd, h


def _reference(seed: int = 0) -> Reference:
    rng = np.random.default_rng(seed)
    return Reference(*(rng.normal(size=2) for _ in range(6)))


def _compliant(task, compliance=1 / K_ENV):
    return HybridCompliantController(CHAPTER_ARM, task, compliance, 100.0, 2500.0, 2500.0, 100.0)


def test_compliant_law_matches_hand_built_torque(task, state):
    """u = B J⁻¹(α − J̇q̇) + n + Jᵀh_e with α = S_v α_ν + C′ S_f f_λ (9.77), (9.80)–(9.82), built by hand, agrees to 1e-12."""
    q, qd, h = state
    ctrl = _compliant(task)
    ctrl.state[:] = [0.01]
    ref = _reference()
    u = ctrl.step(0.0, Measurement(q, qd, h), ref)
    T = CHAPTER_ARM.terms(q, qd)
    S_f, S_v = np.array([[-R2], [R2]]), np.array([[R2], [R2]])
    S_f_p, S_v_p = S_f.T, S_v.T  # identity weights, unit columns
    C = np.eye(2) / K_ENV
    Cp = (np.eye(2) - S_v @ S_v_p) @ C
    nu = S_v_p @ T.xd
    alpha_nu = S_v_p @ ref.acceleration + 100.0 * (S_v_p @ ref.velocity - nu) + 2500.0 * 0.01
    lam = S_f_p @ h
    lam_dot = np.linalg.solve(S_f.T @ C @ S_f, S_f.T) @ T.xd
    f_lam = S_f_p @ ref.force_accel + 100.0 * (S_f_p @ ref.force_rate - lam_dot) + 2500.0 * (S_f_p @ ref.force - lam)
    alpha = S_v @ alpha_nu + Cp @ S_f @ f_lam
    expected = T.B @ np.linalg.solve(T.J, alpha - T.Jdq) + T.n + T.J.T @ h
    np.testing.assert_allclose(u, expected, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(ctrl.state, 0.01 + 1e-3 * (S_v_p @ ref.velocity - nu), rtol=1e-12)


@pytest.mark.parametrize(
    ("law", "kw", "motion", "mk"),
    [
        ("integral", {"force_integral_gain": 80.0}, "velocity", {"velocity_integral_gain": 900.0}),
        ("proportional", {"force_gain": 0.5}, "position", {"position_gain": 900.0}),
        ("feedforward", {}, "velocity", {"velocity_integral_gain": 900.0}),
    ],
)
def test_rigid_law_matches_hand_built_torque(task, state, law, kw, motion, mk):
    """u = B J⁻¹(S_v α_ν − J̇q̇) + n + Jᵀ S_f f_λ (9.91) with (9.92)–(9.94) and (9.80)/(9.95), built by hand, agrees to 1e-12."""
    q, qd, h = state
    ctrl = HybridRigidController(CHAPTER_ARM, task, motion=motion, velocity_gain=60.0, force_law=law, **kw, **mk)
    ctrl.state[:] = [0.02, -0.3]
    ref = _reference(1)
    u = ctrl.step(0.0, Measurement(q, qd, h), ref)
    T = CHAPTER_ARM.terms(q, qd)
    S_f, S_v = np.array([[-R2], [R2]]), np.array([[R2], [R2]])
    nu = S_v.T @ T.xd
    if motion == "velocity":
        alpha_nu = S_v.T @ ref.acceleration + 60.0 * (S_v.T @ ref.velocity - nu) + 900.0 * 0.02
    else:
        alpha_nu = S_v.T @ ref.acceleration + 60.0 * (S_v.T @ ref.velocity - nu) + 900.0 * (S_v.T @ (ref.position - T.x))
    lam_d, lam = S_f.T @ ref.force, S_f.T @ h
    f_lam = lam_d + kw.get("force_gain", 0.0) * (lam_d - lam) + kw.get("force_integral_gain", 0.0) * (-0.3)
    expected = T.B @ np.linalg.solve(T.J, S_v @ alpha_nu - T.Jdq) + T.n + T.J.T @ (S_f @ f_lam)
    np.testing.assert_allclose(u, expected, rtol=1e-12, atol=1e-9)


def test_compiled_laws_on_the_arms_terms_agree_with_step(task, state):
    """The laws called on the arm's terms (as the compiled loops do) give step()'s torques and state."""
    q, qd, h = state
    ref = _reference(2)
    row = np.concatenate([ref.position, ref.velocity, ref.acceleration, ref.force, ref.force_rate, ref.force_accel])
    T = CHAPTER_ARM.terms(q, qd)
    for ctrl, fn in (
        (_compliant(task), laws.hybrid_compliant),
        (HybridRigidController(CHAPTER_ARM, task, velocity_gain=60.0, velocity_integral_gain=900.0,
                               force_integral_gain=80.0), laws.hybrid_rigid),
        (HybridRigidController(CHAPTER_ARM, task, motion="position", velocity_gain=60.0, position_gain=900.0,
                               force_law="proportional", force_gain=0.5), laws.hybrid_rigid),
    ):
        s = ctrl.state.copy() + 0.1
        ctrl.state[:] = s
        u = ctrl.step(0.0, Measurement(q, qd, h), ref)
        s2 = s.copy()
        u2 = np.empty(2)
        fn(0.0, 1e-3, q, qd, T.x, T.xd, T.J, T.Jdq, T.B, T.n, T.g, h, row, ctrl._params, s2,
           np.empty(laws.workspace_size(2, 2)), u2)
        np.testing.assert_allclose(u2, u, rtol=1e-12)
        np.testing.assert_allclose(s2, ctrl.state, rtol=1e-12)


def test_reset_zeroes_integrators(task, state):
    """reset() returns the integral state to zero."""
    q, qd, h = state
    ctrl = _compliant(task)
    ctrl.step(0.0, Measurement(q, qd, h), _reference())
    assert np.any(ctrl.state != 0)
    ctrl.reset()
    np.testing.assert_array_equal(ctrl.state, 0.0)


def _force_run(compliance):
    env = ElasticPlane.inclined(math.pi / 4, [1.0, 0.0], K_ENV)
    sel = inclined_plane().selection("base")
    ref = Setpoint([1.0, 0.0], force=sel.wrench([-50.0]))
    ctrl = HybridCompliantController(CHAPTER_ARM, inclined_plane(), compliance, 100.0, 2500.0, 2500.0, 100.0)
    res = simulate(CHAPTER_ARM, env, ctrl, ref, q0=CHAPTER_ARM.inverse_kinematics([1.0, 0.0]), duration=1.0)
    return res, (res.wrench @ sel.force_pinv.T).ravel()


def test_estimated_compliance_gives_the_predicted_force_dynamics():
    """Ĉ = 2C: L_f = 2, λ̂̇ = λ̇/2 (9.83), so (9.84) is λ̈ + K_Dλ λ̇ + 2K_Pλ λ = 2K_Pλ λ_d: ζ = 1/√2, overshoot 4.32 %."""
    res, lam = _force_run(2.0 / K_ENV)
    zeta = 100.0 / (2.0 * math.sqrt(2.0 * 2500.0))
    overshoot = 50.0 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))
    assert -lam.min() - 50.0 == pytest.approx(overshoot, abs=0.05)
    assert lam[-1] == pytest.approx(-50.0, rel=1e-4)


def test_exact_compliance_gives_critically_damped_force():
    """With Ĉ = C the force loop is λ̈ + 100 λ̇ + 2500 λ = 2500 λ_d (9.79), (9.81): no overshoot, 1 % band reached by 6.64/50 s."""
    res, lam = _force_run(1.0 / K_ENV)
    assert -lam.min() - 50.0 < 0.005
    outside = np.abs(lam + 50.0) > 0.5
    t_settle = res.t[np.where(outside)[0].max() + 1]
    assert t_settle == pytest.approx(6.638 / 50.0, abs=0.005)


# --------------------------------------------------------------------------- bad inputs


def test_selection_of_wrong_dimension_raises():
    """A 6-D task on the planar arm is rejected."""
    with pytest.raises(DimensionError, match=r"selection must act on the robot's 2-dimensional .*; got 6-dimensional"):
        _compliant(sliding_on_plane())


def test_moving_frame_task_raises():
    """The hybrid controllers assume a fixed task frame; a moving one is refused."""
    with pytest.raises(ParameterError, match=r"selection must have a fixed constraint frame.*turning-crank"):
        HybridCompliantController(CHAPTER_ARM, turning_crank(), 1e-3, 1, 1, 1, 1)


def test_selection_of_wrong_type_raises():
    """The selection must be a Task or SelectionMatrices."""
    with pytest.raises(ParameterError, match=r"selection must be a SelectionMatrices or a Task; got ndarray"):
        _compliant(np.eye(2))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"compliance": -1e-4}, r"compliance must be a symmetric positive definite \(2, 2\) matrix"),
        ({"velocity_gain": 0.0}, r"velocity_gain must be a symmetric positive definite \(1, 1\) matrix"),
        ({"force_gain": [[1.0, 0.0]]}, r"force_gain must be a symmetric positive definite \(1, 1\) matrix; got shape \(1, 2\)"),
    ],
)
def test_bad_compliant_gains_raise(task, kwargs, match):
    """Gains and compliance are checked once, with the parameter named."""
    args = {"compliance": 1e-4, "velocity_gain": 1.0, "velocity_integral_gain": 1.0, "force_gain": 1.0, "force_rate_gain": 1.0}
    args.update(kwargs)
    with pytest.raises((ParameterError, DimensionError), match=match):
        HybridCompliantController(CHAPTER_ARM, task, **args)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"force_law": "pid"}, r"force_law must be 'feedforward', 'proportional' or 'integral'; got 'pid'"),
        ({"motion": "torque"}, r"motion must be 'velocity' or 'position'; got 'torque'"),
        ({"force_law": "proportional"}, r"force_gain must be given for force_law='proportional'"),
        ({"force_integral_gain": None}, r"force_integral_gain must be given for force_law='integral'"),
        ({"force_gain": 1.0}, r"force_gain applies to force_law='proportional' only"),
        ({"velocity_integral_gain": None}, r"velocity_integral_gain must be given for motion='velocity'"),
        ({"motion": "position"}, r"position_gain must be given for motion='position'"),
        ({"position_gain": 3.0}, r"position_gain applies to motion='position' only"),
    ],
)
def test_bad_rigid_options_raise(task, kwargs, match):
    """Unknown laws and missing or misplaced gains are refused with the valid choices named."""
    args = {"velocity_gain": 1.0, "velocity_integral_gain": 1.0, "force_integral_gain": 1.0}
    args.update(kwargs)
    with pytest.raises(ParameterError, match=match):
        HybridRigidController(CHAPTER_ARM, task, **args)


def test_custom_selection_matrices_are_accepted():
    """Base-frame SelectionMatrices with non-unit columns give the same torques as the task (λ, ν are rescaled consistently)."""
    task = inclined_plane()
    sel = task.selection("base")
    scaled = SelectionMatrices(2.0 * sel.force_selection, 3.0 * sel.velocity_selection)
    q, qd, h = CHAPTER_ARM.inverse_kinematics([1.05, 0.04]), np.array([0.3, -0.2]), np.array([20.0, -25.0])
    ref = Reference(np.zeros(2), np.array([0.1, 0.1]), np.zeros(2), sel.wrench([-50.0]), np.zeros(2), np.zeros(2))
    u1 = _compliant(task).step(0.0, Measurement(q, qd, h), ref)
    u2 = _compliant(scaled).step(0.0, Measurement(q, qd, h), ref)
    np.testing.assert_allclose(u1, u2, rtol=1e-10)


def test_path_reference_runs_in_python_loop(task):
    """The hybrid controllers run in simulate() (Python loop) with a LinearPath reference and record their gains."""
    env = ElasticPlane.inclined(math.pi / 4, [1.0, 0.0], K_ENV)
    ref = LinearPath([1.0, 0.0], [1.1, 0.1], 0.5, force=task.selection("base").wrench([-10.0]))
    res = simulate(CHAPTER_ARM, env, _compliant(task), ref, q0=CHAPTER_ARM.inverse_kinematics([1.0, 0.0]), duration=0.05)
    assert res.metadata["controller"]["type"] == "HybridCompliantController"
    np.testing.assert_allclose(res.metadata["controller"]["S_f"], [[-R2], [R2]])


@pytest.mark.parametrize("which", ["compliant", "rigid-velocity", "rigid-position"])
def test_compiled_engine_agrees_with_python_loop(task, which):
    """The compiled loop (dispatcher kinds 7, 8) reproduces the Python loop to round-off for the hybrid controllers."""
    env = ElasticPlane.inclined(math.pi / 4, [1.0, 0.0], K_ENV)
    ref = LinearPath([1.0, 0.0], [1.1, 0.1], 0.3, force=task.selection("base").wrench([-20.0]))

    def make():
        if which == "compliant":
            return _compliant(task, 2.0 / K_ENV)
        if which == "rigid-velocity":
            return HybridRigidController(CHAPTER_ARM, task, velocity_gain=100.0, velocity_integral_gain=2500.0,
                                         force_integral_gain=20.0)
        return HybridRigidController(CHAPTER_ARM, task, motion="position", velocity_gain=100.0, position_gain=2500.0,
                                     force_law="proportional", force_gain=0.3)

    q0 = CHAPTER_ARM.inverse_kinematics([1.0, 0.0])
    a = simulate(CHAPTER_ARM, env, make(), ref, q0=q0, duration=0.5, engine="python")
    b = simulate(CHAPTER_ARM, env, make(), ref, q0=q0, duration=0.5, engine="compiled")
    assert b.metadata["engine"] == "compiled"
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(b.torque, a.torque, rtol=1e-9, atol=1e-8)


def _scenario(controller: dict, environment: dict | None = None, reference: dict | None = None) -> dict:
    return {
        "name": "t", "duration": 0.01,
        "robot": {"start_position": [1.0, 0.0]},
        "environment": environment or {"type": "elastic-plane", "point": [1.0, 0.0], "angle": 45.0, "stiffness": 5000.0},
        "controller": controller,
        "reference": reference or {"type": "path-on-plane", "start": [1.0, 0.0], "end": [1.1, 0.1], "duration": 1.0,
                                   "normal_force": -50.0},
    }


def test_scenario_parts_build_hybrid_controllers():
    """The scenario types hybrid-compliant, hybrid-rigid, rigid-plane and path-on-plane build the library's objects."""
    from forcecontrol.environments.rigid import RigidEnvironment
    from forcecontrol.scenarios import build_case, load_scenario

    comp = {"type": "hybrid-compliant", "velocity_gain": 100.0, "velocity_integral_gain": 2500.0,
            "force_gain": 2500.0, "force_rate_gain": 100.0}
    parts = build_case(load_scenario(_scenario(comp)).cases[0])
    assert isinstance(parts["controller"], HybridCompliantController)
    np.testing.assert_allclose(parts["controller"].compliance, np.eye(2) / K_ENV)  # I/k from the plane
    np.testing.assert_allclose(parts["reference"].force, [50 * R2, -50 * R2])
    rigid = {"type": "hybrid-rigid", "velocity_gain": 100.0, "velocity_integral_gain": 2500.0, "force_integral_gain": 50.0}
    parts = build_case(load_scenario(_scenario(rigid, {"type": "rigid-plane", "point": [1.0, 0.0], "angle": 45.0})).cases[0])
    assert isinstance(parts["controller"], HybridRigidController)
    assert isinstance(parts["environment"], RigidEnvironment) and parts["environment"].unilateral


@pytest.mark.parametrize(
    ("controller", "environment", "match"),
    [
        ({"type": "hybrid-compliant", "velocity_gain": 1.0, "velocity_integral_gain": 1.0, "force_gain": 1.0,
          "force_rate_gain": 1.0, "force_selection": [[0.0], [1.0]]}, None,
         r"force_selection and velocity_selection must be given together"),
        ({"type": "hybrid-compliant", "velocity_gain": 1.0, "velocity_integral_gain": 1.0, "force_gain": 1.0,
          "force_rate_gain": 1.0, "force_selection": [[1.0], [0.0]], "velocity_selection": [[1.0], [1.0]]}, None,
         r"must be reciprocal, S_fᵀ S_v = O"),
        ({"type": "hybrid-rigid", "velocity_gain": 1.0, "velocity_integral_gain": 1.0, "force_integral_gain": 1.0},
         {"type": "rigid-plane", "point": [1.0, 0.0], "angle": 45.0, "normal": [0.0, 1.0]},
         r"give exactly one of normal or angle for a rigid plane"),
        ({"type": "hybrid-compliant", "velocity_gain": 1.0, "velocity_integral_gain": 1.0, "force_gain": 1.0,
          "force_rate_gain": 1.0}, {"type": "rigid-plane", "point": [1.0, 0.0], "angle": 45.0},
         r"compliance must be given unless the environment is an elastic plane"),
    ],
)
def test_bad_scenario_parts_raise(controller, environment, match):
    """Bad hybrid scenario tables are scenario errors naming the table, type and the problem."""
    from forcecontrol.errors import ScenarioError
    from forcecontrol.scenarios import load_scenario

    with pytest.raises(ScenarioError, match=match):
        load_scenario(_scenario(controller, environment))


def test_problem_9_8_force_subspace_is_inner_velocity_loop():
    """Problem 9.8: along y_c hybrid control is the inner velocity loop (9.45)–(9.47), K_Dλ = k_D/m_d, K_Pλ = k k_P k_F/m_d."""
    from forcecontrol import InnerVelocityForceController

    env = ElasticPlane.inclined(math.pi / 4, [1.0, 0.0], K_ENV)
    task = inclined_plane()
    sel = task.selection("base")
    ref = Setpoint([1.0, 0.0], force=sel.wrench([-50.0]))
    q0 = CHAPTER_ARM.inverse_kinematics([1.0, 0.0])
    m_d, k_D, k_P = 100.0, 100.0 * 100.0, 2500.0
    k_F = 2500.0 * m_d / (K_ENV * k_P)  # K_Pλ = 2500 s⁻²
    inner = InnerVelocityForceController(CHAPTER_ARM, m_d, k_D, k_P, k_F)
    a = simulate(CHAPTER_ARM, env, inner, ref, q0=q0, duration=0.5)
    b = simulate(CHAPTER_ARM, env, _compliant(task), ref, q0=q0, duration=0.5)
    lam_a = (a.wrench @ sel.force_pinv.T).ravel()
    lam_b = (b.wrench @ sel.force_pinv.T).ravel()
    assert np.abs(lam_a - lam_b).max() < 1e-6 * 50.0
    assert lam_b[-1] == pytest.approx(-50.0, rel=1e-3)


def test_coupled_compliance_keeps_force_and_velocity_decoupled_only_with_c_prime():
    """A 30° plane and a compliance coupling normal and tangent (tᵀ C n ≠ 0, same K′): (9.78) ν stays 0 while λ → λ_d.

    The environment only sees K′ = n nᵀ / (nᵀ C n) (9.70), so the coupling term of C changes
    nothing physical; the law must use C′ = (I − P_v) C (9.72), whose C′ S_f = n / k drops it.
    Using C itself would push along the tangent whenever f_λ ≠ 0 (the mutation C′ → C).
    """
    angle = math.radians(30.0)
    task = inclined_plane(angle, (1.0, 0.0))
    sel = task.selection("base")
    n, t = sel.force_selection[:, 0], sel.velocity_selection[:, 0]
    k = 5e3
    c_tt, c_nt = 2.0 / k, 0.8 / k  # SPD: (1/k)(2/k) > (0.8/k)²
    C = np.outer(n, n) / k + c_nt * (np.outer(n, t) + np.outer(t, n)) + c_tt * np.outer(t, t)
    assert float(n @ C @ n) == pytest.approx(1.0 / k) and abs(float(t @ C @ n)) > 0
    env = ElasticPlane.inclined(angle, [1.0, 0.0], k)
    q0 = CHAPTER_ARM.inverse_kinematics([1.0, 0.0], elbow="up")
    ref = Setpoint([1.0, 0.0], force=sel.wrench([-30.0]))
    ctrl = HybridCompliantController(CHAPTER_ARM, task, C, 100.0, 2500.0, 2500.0, 100.0)
    res = simulate(CHAPTER_ARM, env, ctrl, ref, q0=q0, duration=1.5)
    nu = res.xd @ t  # tangential speed: (9.78) with ν_d = 0 from rest keeps it at 0
    lam = res.wrench @ n
    assert np.abs(nu).max() < 1e-4
    assert lam[-1] == pytest.approx(-30.0, rel=1e-3)


def _products(A, x):
    """``A @ x`` summed from 0.0 in column order, in Python floats (the order the compiled laws sum in)."""
    out = []
    for row in A:
        acc = 0.0
        for a_ij, x_j in zip(row, x):
            acc += a_ij * x_j
        out.append(acc)
    return out


def _hybrid_reference(rigid, d, k, position_mode, dt, x, xd, h, ref, p, s):
    """(9.77)/(9.91) with (9.80)/(9.95) and (9.81)/(9.92)–(9.94), term by term in Python: (a, h_c, new state)."""
    l = d - k
    o = 3
    blocks = {}
    names = (("S_v", d, l), ("S_v_pinv", l, d), ("S_f", d, k), ("S_f_pinv", k, d), ("K_1", l, l), ("K_2", l, l),
             ("K_Plam", k, k), ("K_Ilam", k, k), ("S_v_dot", d, l)) if rigid else (
             ("S_v", d, l), ("S_v_pinv", l, d), ("S_f_pinv", k, d), ("CpS_f", d, k), ("L_hat", k, d), ("K_1", l, l),
             ("K_2", l, l), ("K_Dlam", k, k), ("K_Plam", k, k))
    for name, r, c in names:
        blocks[name] = p[o : o + r * c].reshape(r, c).tolist()
        o += r * c
    B = blocks
    x_d, v_d, a_d, f_d, fd_d, fdd_d = (ref[i * d : (i + 1) * d] for i in range(6))
    nu, nu_d = _products(B["S_v_pinv"], xd), _products(B["S_v_pinv"], v_d)
    alpha = _products(B["S_v_pinv"], a_d)
    for i, acc in enumerate(_products(B["K_1"], [nu_d[j] - nu[j] for j in range(l)])):
        alpha[i] += acc
    if position_mode:
        r_d, r = _products(B["S_v_pinv"], x_d), _products(B["S_v_pinv"], x)
        second = _products(B["K_2"], [r_d[j] - r[j] for j in range(l)])
    else:
        second = _products(B["K_2"], s[:l])
    for i, acc in enumerate(second):
        alpha[i] += acc
    lam_d, lam = _products(B["S_f_pinv"], f_d), _products(B["S_f_pinv"], h)
    if rigid:
        f_lam = list(lam_d)
        for terms in (_products(B["K_Plam"], [lam_d[j] - lam[j] for j in range(k)]), _products(B["K_Ilam"], s[l:])):
            for i, acc in enumerate(terms):
                f_lam[i] += acc
        a = _products(B["S_v"], alpha)
        for i, acc in enumerate(_products(B["S_v_dot"], nu)):
            a[i] += acc
        hc = _products(B["S_f"], f_lam)
    else:
        f_lam = _products(B["S_f_pinv"], fdd_d)
        lamdot_d, lamdot = _products(B["S_f_pinv"], fd_d), _products(B["L_hat"], xd)
        for terms in (_products(B["K_Dlam"], [lamdot_d[j] - lamdot[j] for j in range(k)]),
                      _products(B["K_Plam"], [lam_d[j] - lam[j] for j in range(k)])):
            for i, acc in enumerate(terms):
                f_lam[i] += acc
        a = _products(B["S_v"], alpha)
        for i, acc in enumerate(_products(B["CpS_f"], f_lam)):
            a[i] += acc
        hc = list(h)
    s = list(s)
    for j in range(l):
        s[j] += dt * (nu_d[j] - nu[j])
    if rigid:
        for j in range(k):
            s[l + j] += dt * (lam_d[j] - lam[j])
    return a, hc, s


@pytest.mark.parametrize("rigid", [False, True], ids=["compliant", "rigid"])
def test_hybrid_accelerations_equal_the_equations_term_by_term_to_the_bit(rigid):
    """The compiled (9.77)/(9.91) accelerations on random sizes (d = 2, 3, 6, every k), gains and states, both motion
    servos: a, h_c and the integrals equal a Python evaluation of the equations, each product summed from 0.0 in
    column order, to the bit (the engines' bit-for-bit agreement rests on this order)."""
    fn = laws.hybrid_rigid_acceleration if rigid else laws.hybrid_compliant_acceleration
    rng = np.random.default_rng(11)
    for trial in range(120):
        d = int(rng.choice([2, 3, 6]))
        k = int(rng.integers(0, d + 1))
        l = d - k
        size = 3 + (3 * d * l + 2 * d * k if rigid else 2 * d * l + 3 * k * d) + 2 * l * l + 2 * k * k
        p = rng.normal(size=size)
        p[:3] = d, k, float(trial % 2)
        s = rng.normal(size=l + k)
        x, xd, h = rng.normal(size=d), rng.normal(size=d), rng.normal(size=d)
        ref = rng.normal(size=6 * d)
        want_a, want_hc, want_s = _hybrid_reference(rigid, d, k, trial % 2, 1e-3, x, xd, h, ref, p, s)
        a, hc, ws = np.full(d, np.nan), np.full(d, np.nan), np.full(laws.workspace_size(d, d), np.nan)
        assert fn(0.0, 1e-3, x, xd, h, ref, p, s, ws, a, hc)
        assert a.tolist() == want_a and hc.tolist() == want_hc and s.tolist() == want_s, (d, k, trial % 2)
