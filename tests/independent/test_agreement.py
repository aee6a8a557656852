"""The library's ``forcecontrol.simulate`` against the independent reference simulator.

Every case is a geometry or scenario that is not among the built-in examples (Examples 9.2, 9.3,
Problems 9.3/9.10): planes at 0°, 20°, 30°, 45°, 70°, 90°, a coupled linear spring, stiffnesses
2·10³ … 5·10⁴ N/m, other gains, both integrator starts, a force step at t = 0.5 s and sample
times of 0.5 ms and 2 ms. The same scenario is built twice, once through the library's public
API and once in ``reference_sim`` (which never imports the library), and

* the contact force and the tip position are compared at fixed times (0.05, 0.1, 0.2, 0.5, 1,
  2 s and the end, plus times just after a force step) within 1 % of the signal's scale: the
  peak contact-force norm for the force, the largest tip excursion ‖p(t) − p(0)‖ for the
  position (floored at 1 mm);
* the peak contact-force norm is compared within 1 %.

``python tests/independent/test_agreement.py`` prints the table of largest relative differences
(over the fixed times and over every sample).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.controllers.hybrid import HybridCompliantController
from forcecontrol.task import inclined_plane

try:
    from . import reference_sim as ref
except ImportError:  # run as a script
    import reference_sim as ref  # type: ignore[no-redef]

ARM = fc.PlanarTwoLink()
TIMES = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
TOL = 0.01
POSITION_SCALE_FLOOR = 1e-3  # [m]


def _rot(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _on_plane(angle_deg: float, through, along: float, normal: float = 0.0) -> np.ndarray:
    """A point ``along`` the plane (x_c) and ``normal`` out of it (y_c) from ``through``."""
    R = _rot(angle_deg)
    return np.asarray(through, dtype=float) + along * R[:, 0] + normal * R[:, 1]


# --------------------------------------------------------------------------- cases


@dataclass
class Case:
    """One scenario; ``env``/``law`` are (kind, params) read by both builders below."""

    id: str
    env: tuple
    law: tuple
    start: np.ndarray
    x_d: np.ndarray
    f_d: np.ndarray = field(default_factory=lambda: np.zeros(2))
    force_start: float = 0.0
    force_ramp: float = 0.0  # > 0: the smooth (quintic) ramp of f_d from force_start
    path: tuple | None = None  # (p_i, p_f, t_f, t_c): trapezoidal straight path instead of the set-point x_d
    tip_velocity0: np.ndarray | None = None  # the tip's velocity at t = 0 (q̇0 = J⁻¹ v0); rest by default
    duration: float = 2.0
    Ts: float = 1e-3
    extra_times: tuple[float, ...] = ()
    marks: tuple = ()


def _plane(angle: float, through, k: float) -> tuple:
    a = math.radians(angle)
    return ("plane", np.asarray(through, dtype=float), np.array([-math.sin(a), math.cos(a)]), k)


def _cases() -> list[Case]:
    c: list[Case] = []
    # --- impedance control with force measurement (9.30)-(9.31)
    th = [1.0, 0.3]
    c.append(Case("impedance-plane-0deg-k3e3", _plane(0, th, 3e3), ("imp", 50, 300, 1500),
                  start=np.array(th), x_d=_on_plane(0, th, 0.15, -0.05)))
    th = [1.1, 0.1]
    c.append(Case("impedance-plane-20deg-k5e4-impact", _plane(20, th, 5e4), ("imp", 100, 800, 4000),
                  start=_on_plane(20, th, 0.0, 0.02), x_d=_on_plane(20, th, 0.10, -0.03)))
    th = [1.0, 0.0]
    c.append(Case("impedance-plane-45deg-k3e3-anisotropic-gains", _plane(45, th, 3e3),
                  ("imp", [80, 120], [600, 900], [3000, 2000]),
                  start=np.array(th), x_d=_on_plane(45, th, 0.10, -0.08)))
    th = [1.2, 0.2]
    c.append(Case("impedance-plane-70deg-k2e4", _plane(70, th, 2e4), ("imp", 60, 700, 3500),
                  start=np.array(th), x_d=_on_plane(70, th, -0.10, -0.02)))
    th = [1.3, -0.2]
    c.append(Case("impedance-plane-90deg-k5e4-impact", _plane(90, th, 5e4), ("imp", 100, 600, 2500),
                  start=np.array([1.25, -0.2]), x_d=np.array([1.34, 0.0])))
    c.append(Case("impedance-linear-spring-coupled", ("spring", np.array([[4e3, 1.5e3], [1.5e3, 2.5e3]]),
                                                      np.array([1.05, 0.05])),
                  ("imp", 100, 500, 2500), start=np.array([1.0, 0.1]), x_d=np.array([1.2, -0.05])))
    th = [1.0, -0.1]
    c.append(Case("impedance-plane-30deg-k1e4-Ts0.5ms", _plane(30, th, 1e4), ("imp", 100, 500, 2500),
                  start=np.array(th), x_d=_on_plane(30, th, 0.12, -0.04), Ts=5e-4, duration=1.5))
    th = [0.9, 0.0]
    c.append(Case("impedance-plane-90deg-k5e3-Ts2ms", _plane(90, th, 5e3), ("imp", 100, 500, 2500),
                  start=np.array(th), x_d=np.array([0.96, 0.2]), Ts=2e-3, duration=2.5))
    # --- force control with inner position loop (9.39), (9.43)
    for start in ("hold", "tip"):
        th = [1.1, 0.0]
        c.append(Case(f"inner-position-{start}-k2e3", _plane(90, th, 2e3),
                      ("ipos", 100, 500, 2500, [5e-4, 0.0], [2e-3, 0.0], start),
                      start=np.array(th), x_d=np.array(th), f_d=np.array([20.0, 0.0]), duration=2.5))
    for start in ("hold", "tip"):
        th = [1.0, 0.2]
        c.append(Case(f"inner-position-{start}-k2e4-sliding-to-y0", _plane(90, th, 2e4),
                      ("ipos", 100, 500, 2500, [2e-4, 0.0], [5e-4, 0.0], start),
                      start=np.array(th), x_d=np.array(th), f_d=np.array([30.0, 0.0]), duration=2.5))
    th = [1.05, 0.0]
    c.append(Case("inner-position-hold-k5e3-force-step-at-0.5s-from-preload", _plane(90, th, 5e3),
                  ("ipos", 100, 500, 2500, [4e-4, 0.0], [1.5e-3, 0.0], "hold"),
                  start=np.array([1.06, 0.0]), x_d=np.array(th), f_d=np.array([20.0, 0.0]),
                  force_start=0.5, duration=2.5, extra_times=(0.5, 0.55, 0.6, 0.75)))
    # --- force control with inner velocity loop (9.45)-(9.46)
    th = [0.9, 0.0]
    c.append(Case("inner-velocity-k5e3", _plane(90, th, 5e3), ("ivel", 100, 500, 2500, [1e-3, 0.0]),
                  start=np.array(th), x_d=np.array(th), f_d=np.array([15.0, 0.0]), duration=2.0))
    th = [1.0, 0.1]
    c.append(Case("inner-velocity-k3e3-Ts2ms", _plane(90, th, 3e3), ("ivel", 80, 600, 2000, [2e-3, 0.0]),
                  start=np.array(th), x_d=np.array(th), f_d=np.array([25.0, 0.0]), Ts=2e-3, duration=2.0))
    # --- parallel force/position control (9.48)
    th = [1.0, 0.0]
    c.append(Case("parallel-k3e3", _plane(90, th, 3e3), ("par", 100, 500, 2500, [5e-4, 0.0], [2e-3, 0.0], "zero", None),
                  start=np.array(th), x_d=np.array([1.01, 0.15]), f_d=np.array([25.0, 0.0]), duration=2.5))
    th = [1.0, 0.0]
    nu = np.array([-math.sin(math.radians(30)), math.cos(math.radians(30))])
    c.append(Case("parallel-plane-30deg-task-frame-k1e4", _plane(30, th, 1e4),
                  ("par", 100, 500, 2500, [0.0, 3e-4], [0.0, 1e-3], "zero", _rot(30)),
                  start=np.array(th), x_d=_on_plane(30, th, 0.15, 0.0), f_d=-40.0 * nu, duration=2.5))
    th = [1.1, -0.1]
    c.append(Case("parallel-tip-k2e4-force-step-at-0.5s-Ts0.5ms", _plane(90, th, 2e4),
                  ("par", 100, 500, 2500, [2e-4, 0.0], [5e-4, 0.0], "tip", None),
                  start=np.array(th), x_d=np.array([1.105, 0.0]), f_d=np.array([30.0, 0.0]),
                  force_start=0.5, Ts=5e-4, duration=2.0, extra_times=(0.5, 0.55, 0.6, 0.75)))
    # --- impedance tracking a trapezoidal path along a plane (ẋ_d, ẍ_d feedforward of (9.31))
    th = [1.0, 0.2]
    p_i = _on_plane(60, th, 0.0, -0.03)
    c.append(Case("impedance-plane-60deg-k1e4-sliding-trapezoidal-path", _plane(60, th, 1e4), ("imp", 50, 400, 3000),
                  start=np.array(th), x_d=p_i, path=(p_i, p_i + 0.2 * _rot(60)[:, 0], 1.0, 0.2), duration=1.5))
    # --- hybrid force/velocity control on a compliant plane (9.77), (9.80)-(9.82)
    th = [1.0, 0.1]
    y_c = _rot(30)[:, 1]
    c.append(Case("hybrid-plane-30deg-k8e3-trapezoidal-path", _plane(30, th, 8e3),
                  ("hyb", 30, 1 / 8e3, 60, 900, 1600, 80),
                  start=np.array(th), x_d=np.array(th), f_d=-40.0 * y_c,
                  path=(np.array(th), _on_plane(30, th, 0.2), 1.2, 0.3), duration=2.0))
    th = [1.1, 0.3]
    y_c = _rot(60)[:, 1]
    c.append(Case("hybrid-plane-60deg-k2e4-compliance-underestimated", _plane(60, th, 2e4),
                  ("hyb", 60, 1 / (1.5 * 2e4), 80, 1600, 2500, 100),
                  start=np.array(th), x_d=np.array(th), f_d=-25.0 * y_c,
                  path=(np.array(th), _on_plane(60, th, -0.15), 1.0, 0.25), duration=2.0))
    th = [1.2, 0.4]
    c.append(Case("hybrid-plane-0deg-k5e3-smooth-force-ramp-moving-start", _plane(0, th, 5e3),
                  ("hyb", 0, 1 / 5e3, 50, 600, 900, 60),
                  start=np.array(th), x_d=np.array(th), f_d=np.array([0.0, -30.0]), force_start=0.2, force_ramp=0.5,
                  tip_velocity0=np.array([0.1, 0.0]), duration=1.5, extra_times=(0.3, 0.45, 0.7)))
    return c


CASES = _cases()


# --------------------------------------------------------------------------- the two builders


def _library(case: Case) -> fc.SimulationResult:
    kind = case.env[0]
    if kind == "plane":
        env = fc.ElasticPlane(case.env[1], case.env[2], case.env[3])
    else:
        env = fc.LinearSpring(case.env[1], case.env[2])
    name, *p = case.law
    Ts = case.Ts
    if name == "imp":
        ctl = fc.ImpedanceController(ARM, p[0], p[1], p[2], force_measurement=True, sample_time=Ts)
    elif name == "ipos":
        ctl = fc.InnerPositionForceController(ARM, p[0], p[1], p[2], force_gain=p[3], integral_gain=p[4],
                                              integrator_start=p[5], sample_time=Ts)
    elif name == "ivel":
        ctl = fc.InnerVelocityForceController(ARM, p[0], p[1], p[2], force_gain=p[3], sample_time=Ts)
    elif name == "par":
        ctl = fc.ParallelForcePositionController(ARM, p[0], p[1], p[2], force_gain=p[3], integral_gain=p[4],
                                                 integrator_start=p[5], task_frame=p[6], sample_time=Ts)
    else:
        task = inclined_plane(math.radians(p[0]), tuple(case.env[1]))
        ctl = HybridCompliantController(ARM, task, p[1], p[2], p[3], p[4], p[5], sample_time=Ts)
    signal: fc.Setpoint | fc.LinearPath
    if case.path is None:
        signal = fc.Setpoint(case.x_d, case.f_d, force_start=case.force_start, force_ramp=case.force_ramp,
                             force_shape="smooth")
    else:
        signal = fc.LinearPath(case.path[0], case.path[1], case.path[2], accel_time=case.path[3], force=case.f_d)
    q0, qd0 = _initial_state(case)
    return fc.simulate(ARM, env, ctl, signal, q0=q0, qd0=qd0, duration=case.duration)


def _reference(case: Case, integrator: str = "rk4", duration: float | None = None, step: float = 5e-5) -> ref.Run:
    kind = case.env[0]
    if kind == "plane":
        env: ref.Environment = ref.Plane(case.env[1], case.env[2], case.env[3])
    else:
        env = ref.Spring(case.env[1], case.env[2])
    name, *p = case.law
    law: ref.Law
    if name == "imp":
        law = ref.Impedance(p[0], p[1], p[2])
    elif name == "ipos":
        law = ref.InnerPosition(p[0], p[1], p[2], KF=p[3], KI=p[4], start=p[5])
    elif name == "ivel":
        law = ref.InnerVelocity(p[0], p[1], p[2], KF=p[3])
    elif name == "par":
        law = ref.Parallel(p[0], p[1], p[2], KF=p[3], KI=p[4], start=p[5], R=p[6])
    else:
        law = ref.HybridCompliant(p[0], p[1], p[2], p[3], p[4], p[5])
    sig: ref.Reference
    if case.path is None:
        sig = ref.SetpointRef(case.x_d, case.f_d, case.force_start, case.force_ramp)
    else:
        sig = ref.PathRef(case.path[0], case.path[1], case.path[2], case.path[3], case.f_d)
    q0, qd0 = _initial_state(case)
    return ref.run(law, env, sig, q0, case.duration if duration is None else duration, Ts=case.Ts, qd0=qd0,
                   integrator=integrator, step=step)


def _initial_state(case: Case) -> tuple[np.ndarray, np.ndarray]:
    """q0 (elbow up, the reference's own inverse kinematics) and q̇0 = J⁻¹ v0."""
    q0 = ref.ik_elbow_up(case.start)
    if case.tip_velocity0 is None:
        return q0, np.zeros(2)
    return q0, np.linalg.solve(ref.Arm().jacobian(q0), case.tip_velocity0)


@functools.cache
def _pair(case_id: str) -> tuple[fc.SimulationResult, ref.Run]:
    case = next(c for c in CASES if c.id == case_id)
    return _library(case), _reference(case)


def _differences(case: Case, lib: fc.SimulationResult, r: ref.Run) -> dict[str, float]:
    """Largest differences relative to the signal's scale: at the fixed times and over all samples."""
    assert lib.t.shape == r.t.shape
    np.testing.assert_allclose(lib.t, r.t, atol=1e-12)
    f_scale = float(np.linalg.norm(r.f, axis=1).max())
    p_scale = max(float(np.linalg.norm(r.x - r.x[0], axis=1).max()), POSITION_SCALE_FLOOR)
    times = sorted({*(t for t in TIMES if t <= case.duration), *case.extra_times, case.duration})
    idx = np.array([int(round(t / case.Ts)) for t in times])
    df = np.abs(np.asarray(lib.wrench) - r.f)
    dx = np.abs(np.asarray(lib.x) - r.x)
    peak_lib = float(np.linalg.norm(lib.wrench, axis=1).max())
    return {
        "force_fixed": float(df[idx].max() / f_scale),
        "position_fixed": float(dx[idx].max() / p_scale),
        "peak_force": abs(peak_lib - f_scale) / f_scale,
        "force_all": float(df.max() / f_scale),
        "position_all": float(dx.max() / p_scale),
        "f_scale": f_scale,
        "p_scale": p_scale,
    }


# --------------------------------------------------------------------------- tests


@pytest.mark.parametrize("case", [pytest.param(c, id=c.id, marks=c.marks) for c in CASES])
def test_library_agrees_with_independent_simulator(case: Case):
    """Contact force and tip position at fixed times, and the peak force, within 1 % of their scale."""
    lib, r = _pair(case.id)
    d = _differences(case, lib, r)
    assert d["f_scale"] > 1.0, "the case must make contact"
    assert d["force_fixed"] < TOL, d
    assert d["position_fixed"] < TOL, d
    assert d["peak_force"] < TOL, d


def test_cases_are_distinct_and_many():
    """At least 12 scenarios, all with distinct ids."""
    ids = [c.id for c in CASES]
    assert len(ids) >= 12
    assert len(set(ids)) == len(ids)


def test_rk4_reference_matches_solve_ivp_reference():
    """The reference's fixed-step RK4 equals its solve_ivp (rtol 1e-10) mode on a stiff impact case, 0.3 s."""
    case = next(c for c in CASES if c.id == "impedance-plane-90deg-k5e4-impact")
    a = _reference(case, "rk4", duration=0.3)
    b = _reference(case, "ivp", duration=0.3)
    assert np.linalg.norm(a.f, axis=1).max() > 10.0  # contact happened within the window
    np.testing.assert_allclose(a.f, b.f, atol=1e-6 * np.abs(b.f).max())
    np.testing.assert_allclose(a.x, b.x, atol=1e-9)


def _chapter_equilibrium(case: Case) -> tuple[np.ndarray, np.ndarray]:
    """Contact force and tip position at the chapter's equilibrium (NaN where it leaves one free).

    * impedance (9.32) with a set-point: ``K_P (x_d − x) = h_e = K (x − x_r)``, K = k ν νᵀ for a
      plane (in contact), so ``x = (K_P + K)⁻¹ (K_P x_d + K x_r)``;
    * the direct force schemes with PI (inner position, parallel) and the inner velocity loop:
      ``f_e = f_d`` and (9.44) ``K x = K x_r + f_d`` along the normal; along the free direction
      the inner position loop takes the (base) coordinate to 0 (x_F = 0 there, remark after
      (9.47)), the parallel one to x_d (9.49), the inner velocity loop leaves it free;
    * hybrid: λ = λ_d, and with the velocity integral the tangential coordinate of the path's end.
    """
    kind, *e = case.env
    name, *p = case.law
    x_d = case.path[1] if case.path is not None else case.x_d
    if kind == "plane":
        x_r, nu, k = e
        K = k * np.outer(nu, nu)
    else:
        K, x_r = e
    if name == "imp":
        KP = ref._diag(p[2])
        x = np.linalg.solve(KP + K, KP @ x_d + K @ x_r)
        return K @ (x - x_r), x
    f = case.f_d
    normal = nu @ x_r + (nu @ f) / k  # ν·x at f_e = f_d (f_e = −k δ ν)
    tangent = np.array([-nu[1], nu[0]])
    if name == "ipos":
        assert abs(nu[1]) < 1e-12, "cases of the inner position loop use walls x = x_r"
        return f, np.array([normal / nu[0], 0.0])
    if name == "ivel" or case.tip_velocity0 is not None:
        return f, np.full(2, np.nan)
    return f, normal * nu + (tangent @ x_d) * tangent


SETTLE = 5.0  # [s]


@pytest.mark.parametrize("case", [pytest.param(c, id=c.id) for c in CASES])
def test_reference_settles_at_the_chapters_equilibrium(case: Case):
    """The reference alone, run to 5 s: force and position at the chapter's closed-form equilibrium within 0.5 %.

    This checks the reference's sign conventions (h_e, ν, λ, ξ₀) against the chapter, not
    against the library. A coarser RK4 step (0.25 ms) suffices here.
    """
    r = _reference(case, duration=max(SETTLE, case.duration), step=2.5e-4)
    f, x = _chapter_equilibrium(case)
    f_scale = float(np.linalg.norm(r.f, axis=1).max())
    p_scale = max(float(np.linalg.norm(r.x - r.x[0], axis=1).max()), POSITION_SCALE_FLOOR)
    assert np.abs(r.f[-1] - f).max() < 5e-3 * f_scale
    known = ~np.isnan(x)
    assert np.all(np.abs(r.x[-1][known] - x[known]) < 5e-3 * p_scale)


# --------------------------------------------------------------------------- the reference's model


@pytest.fixture(scope="module")
def arm() -> ref.Arm:
    return ref.Arm()


_RNG = np.random.default_rng(7)
_QS = [(_RNG.uniform(-math.pi, math.pi, 2), _RNG.uniform(-2.0, 2.0, 2)) for _ in range(5)]


@pytest.mark.parametrize("q, qd", _QS)
def test_reference_model_properties(arm, q, qd):
    """B symmetric positive definite, Ḃ − 2C skew, g = ∂U/∂q, J and J̇q̇ against finite differences."""
    B = arm.mass(q)
    assert np.allclose(B, B.T) and np.all(np.linalg.eigvalsh(B) > 0)
    eps = 1e-6
    Bdot = (arm.mass(q + eps * qd) - arm.mass(q - eps * qd)) / (2 * eps)
    # C from C q̇ (linear in q̇ for fixed q): build columns by differentiating w.r.t. q̇ is not unique;
    # use the written C = [[h q̇2, h (q̇1 + q̇2)], [−h q̇1, 0]] and check (Ḃ − 2C) skew.
    h = arm.hc * math.sin(q[1])
    C = np.array([[h * qd[1], h * (qd[0] + qd[1])], [-h * qd[0], 0.0]])
    np.testing.assert_allclose(C @ qd, arm.coriolis_vec(q, qd), atol=1e-12)
    N = Bdot - 2 * C
    np.testing.assert_allclose(N, -N.T, atol=1e-6)
    d = arm.d

    def U(qq):
        y1 = d.l1 * math.sin(qq[0])
        y_elbow = d.a1 * math.sin(qq[0])
        y2 = y_elbow + d.l2 * math.sin(qq[0] + qq[1])
        return d.g0 * (d.m_l1 * y1 + d.m_m2 * y_elbow + d.m_l2 * y2)

    grad = np.array([(U(q + eps * e) - U(q - eps * e)) / (2 * eps) for e in np.eye(2)])
    np.testing.assert_allclose(arm.gravity(q), grad, atol=1e-5)
    Jfd = np.column_stack([(arm.tip(q + eps * e) - arm.tip(q - eps * e)) / (2 * eps) for e in np.eye(2)])
    np.testing.assert_allclose(arm.jacobian(q), Jfd, atol=1e-8)
    Jdot = (arm.jacobian(q + eps * qd) - arm.jacobian(q - eps * qd)) / (2 * eps)
    np.testing.assert_allclose(arm.jdot_qdot(q, qd), Jdot @ qd, atol=1e-6)


def test_reference_energy_balance_in_free_motion(arm):
    """Without friction and gravity, free motion under zero torque conserves ½ q̇ᵀ B q̇."""
    free = ref.Arm(ref.ArmData(F1=0.0, F2=0.0, g0=0.0))
    far = ref.Plane([10.0, 0.0], [-1.0, 0.0], 1e3)
    q, qd = np.array([0.3, -1.2]), np.array([1.5, -2.0])

    class Zero(ref.Law):
        def torque(self, arm, t, q, qd, h, ref_, Ts):
            return np.zeros(2)

    r = ref.run(Zero(1, 1, 1), far, ref.SetpointRef(np.zeros(2)), q, 1.0, qd0=qd, arm=free)
    E = [0.5 * w @ free.mass(qq) @ w for qq, w in zip(r.q, r.qd)]
    assert np.ptp(E) < 1e-9 * E[0]


@pytest.mark.parametrize("q, qd", _QS)
def test_library_model_numbers_equal_the_reference(arm, q, qd):
    """The library's B, n = C q̇ + F q̇ + g, g, tip, J, J̇q̇ equal the reference's (compared as numbers)."""
    np.testing.assert_allclose(ARM.mass_matrix(q), arm.mass(q), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(ARM.gravity(q), arm.gravity(q), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(ARM.nonlinear_effects(q, qd), arm.n(q, qd), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(ARM.forward_kinematics(q), arm.tip(q), atol=1e-12)
    np.testing.assert_allclose(ARM.jacobian(q), arm.jacobian(q), atol=1e-12)
    np.testing.assert_allclose(ARM.jdot_qdot(q, qd), arm.jdot_qdot(q, qd), atol=1e-12)


# --------------------------------------------------------------------------- table


def _table(select: Callable[[Case], bool] = lambda c: True) -> None:  # pragma: no cover - script
    print(f"{'case':58s} {'force@t':>9s} {'pos@t':>9s} {'peak':>9s} {'force all':>9s} {'pos all':>9s} "
          f"{'|f|max N':>9s} {'dp mm':>7s} {'s':>5s}")
    for c in CASES:
        if not select(c):
            continue
        t0 = time.perf_counter()
        lib, r = _pair(c.id)
        d = _differences(c, lib, r)
        print(f"{c.id:58s} {d['force_fixed']:9.2e} {d['position_fixed']:9.2e} {d['peak_force']:9.2e} "
              f"{d['force_all']:9.2e} {d['position_all']:9.2e} {d['f_scale']:9.2f} {1e3 * d['p_scale']:7.1f} "
              f"{time.perf_counter() - t0:5.1f}")


if __name__ == "__main__":  # pragma: no cover
    _table()
