"""An independent reference simulator for Chapter 9 (Force Control), written from the book only.

Nothing here imports ``forcecontrol``: the arm, the environments, the control laws and the
sampled-data loop are written from the chapter's equations and the data of
``/work/shared/reference/two-link-arm.md`` (corrected forms of the misprints listed there), so
that the library can be checked against it by comparing numbers.

Conventions (the chapter's):

* plant: ``B(q) q̈ + C(q, q̇) q̇ + F q̇ + g(q) = u − Jᵀ(q) h_e``; q2 is the relative elbow angle,
  the tip is ``p = [a1 c1 + a2 c12, a1 s1 + a2 s12]``, gravity along −y0;
* ``h_e`` is the force the end-effector exerts on the environment, in the base frame;
* the control is sampled: at ``t_k = k Ts`` the controller reads (q, q̇, h_e) and its torque is
  held constant over ``[t_k, t_k + Ts)`` (zero-order hold); the plant in between is integrated
  by a fine fixed-step RK4 (default) or by ``scipy.integrate.solve_ivp`` (rtol 1e-10,
  atol 1e-12) on each interval; the true contact force acts continuously in the plant.

Control laws, all on the inverse-dynamics inner loop (9.30) ``u = B y + n + Jᵀ h_e`` with
``n = C q̇ + F q̇ + g`` and ``y = J⁻¹ (a − J̇ q̇)``:

1. impedance with force measurement, (9.31) corrected (first term M_d ẍ_d, misprint 2):
   ``a = ẍ_d + M_d⁻¹ (K_D (ẋ_d − ẋ_e) + K_P (x_d − x_e) − h_e)``;
2. force control with inner position loop (9.39), (9.41), PI (9.43):
   ``a = M_d⁻¹ (−K_D ẋ_e + K_P (x_F − x_e))``, ``x_F = K_F (f_d − f_e) + ξ``,
   ``ξ = ξ₀ + K_I ∫₀ᵗ (f_d − f_e)`` discretised as a left rectangle sum over the samples
   (``ξ_{k+1} = ξ_k + Ts K_I (f_d,k − f_e,k)``, x_F at t_k uses ξ_k);
3. force control with inner velocity loop (9.45) (J̇ q̇, misprint 1) and (9.46):
   ``a = M_d⁻¹ (−K_D ẋ_e + K_P K_F (f_d − f_e))``;
4. parallel force/position control (9.48): ``a = M_d⁻¹ (−K_D ẋ_e + K_P (x_d − x_e + x_F))``
   with x_F as in 2;
5. hybrid force/velocity control on a compliant plane (9.77), (9.80)-(9.82) (``HybridCompliant``).

For 2 and 4, C_F (K_F, K_I diagonal) may be diagonal in a task frame with rotation R (columns:
its axes in the base frame): ``x_F = R (K_F Rᵀ (f_d − f_e) + ξ)`` with ξ in task coordinates.
The initial integral ξ₀ (axes with K_I > 0 only; ξ₀ = 0 elsewhere), with p₀ the tip at t = 0,
f₀ the contact force at t = 0 and the offset ``o = p₀`` (inner position loop) or
``o = p₀ − x_d`` (parallel):

* ``"hold"``: the loop held the tip still before t = 0 with no force demanded,
  ``K_F Rᵀ (0 − f₀) + ξ₀ = Rᵀ o``;
* ``"tip"``: x_F (parallel: x̃ + x_F) equals the tip at t = 0 with the reference f_d(0) applied,
  ``K_F Rᵀ (f_d(0) − f₀) + ξ₀ = Rᵀ o``, and a later change of f_d does not move x_F (bumpless:
  ξ ← ξ − K_F Rᵀ Δf_d on axes with K_I > 0, i.e. x_F = R (−K_F Rᵀ f_e + ξ + K_F Rᵀ f_d(0)) + …);
* ``"zero"``: ξ₀ = 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

__all__ = [
    "ArmData",
    "Arm",
    "Plane",
    "Spring",
    "Impedance",
    "InnerPosition",
    "InnerVelocity",
    "Parallel",
    "HybridCompliant",
    "Reference",
    "SetpointRef",
    "PathRef",
    "Run",
    "run",
    "plane_at_angle",
    "ik_elbow_up",
]


# --------------------------------------------------------------------------- the arm


@dataclass(frozen=True)
class ArmData:
    """Data of the two-link arm (two-link-arm.md, "Data")."""

    a1: float = 1.0
    a2: float = 1.0
    l1: float = 0.5
    l2: float = 0.5
    m_l1: float = 50.0
    m_l2: float = 50.0
    I_l1: float = 10.0
    I_l2: float = 10.0
    m_m2: float = 5.0
    I_m1: float = 0.01
    I_m2: float = 0.01
    k_r1: float = 100.0
    k_r2: float = 100.0
    F1: float = 100.0
    F2: float = 100.0
    g0: float = 9.81


class Arm:
    """Kinematics and dynamics of the planar two-link arm (Example 7.2 form with motors)."""

    def __init__(self, data: ArmData | None = None) -> None:
        d = data or ArmData()
        self.d = d
        # constant parts of B (two-link-arm.md, model): b11 = b11c + b11v c2, b12 = b12c + b12v c2
        self.b11c = (d.I_l1 + d.m_l1 * d.l1**2 + d.k_r1**2 * d.I_m1 + d.I_l2
                     + d.m_l2 * (d.a1**2 + d.l2**2) + d.I_m2 + d.m_m2 * d.a1**2)
        self.b11v = 2.0 * d.m_l2 * d.a1 * d.l2
        self.b12c = d.I_l2 + d.m_l2 * d.l2**2 + d.k_r2 * d.I_m2
        self.b12v = d.m_l2 * d.a1 * d.l2
        self.b22 = d.I_l2 + d.m_l2 * d.l2**2 + d.k_r2**2 * d.I_m2
        self.hc = -d.m_l2 * d.a1 * d.l2  # h = hc s2
        self.g1c = d.g0 * (d.m_l1 * d.l1 + d.m_m2 * d.a1 + d.m_l2 * d.a1)
        self.g12 = d.g0 * d.m_l2 * d.l2

    # -- kinematics
    def tip(self, q: np.ndarray) -> np.ndarray:
        a1, a2 = self.d.a1, self.d.a2
        q1, q12 = q[0], q[0] + q[1]
        return np.array([a1 * math.cos(q1) + a2 * math.cos(q12), a1 * math.sin(q1) + a2 * math.sin(q12)])

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        a1, a2 = self.d.a1, self.d.a2
        q1, q12 = q[0], q[0] + q[1]
        s1, c1, s12, c12 = math.sin(q1), math.cos(q1), math.sin(q12), math.cos(q12)
        return np.array([[-a1 * s1 - a2 * s12, -a2 * s12], [a1 * c1 + a2 * c12, a2 * c12]])

    def jdot_qdot(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """J̇(q, q̇) q̇ (the centripetal part of the tip acceleration)."""
        a1, a2 = self.d.a1, self.d.a2
        q1, q12 = q[0], q[0] + q[1]
        w1, w12 = qd[0], qd[0] + qd[1]
        return np.array([
            -a1 * math.cos(q1) * w1**2 - a2 * math.cos(q12) * w12**2,
            -a1 * math.sin(q1) * w1**2 - a2 * math.sin(q12) * w12**2,
        ])

    # -- dynamics
    def mass(self, q: np.ndarray) -> np.ndarray:
        c2 = math.cos(q[1])
        b11 = self.b11c + self.b11v * c2
        b12 = self.b12c + self.b12v * c2
        return np.array([[b11, b12], [b12, self.b22]])

    def coriolis_vec(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """C(q, q̇) q̇ with C = [[h q̇2, h (q̇1 + q̇2)], [−h q̇1, 0]], h = −m_l2 a1 l2 s2."""
        h = self.hc * math.sin(q[1])
        return np.array([h * qd[1] * qd[0] + h * (qd[0] + qd[1]) * qd[1], -h * qd[0] ** 2])

    def gravity(self, q: np.ndarray) -> np.ndarray:
        c1, c12 = math.cos(q[0]), math.cos(q[0] + q[1])
        return np.array([self.g1c * c1 + self.g12 * c12, self.g12 * c12])

    def friction(self, qd: np.ndarray) -> np.ndarray:
        return np.array([self.d.F1 * qd[0], self.d.F2 * qd[1]])

    def n(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """n(q, q̇) = C q̇ + F q̇ + g."""
        return self.coriolis_vec(q, qd) + self.friction(qd) + self.gravity(q)

    # -- the plant's right-hand side, written with floats (the integrator calls it many times)
    def accel(self, q1: float, q2: float, w1: float, w2: float, u1: float, u2: float,
              env: Environment) -> tuple[float, float]:
        a1, a2 = self.d.a1, self.d.a2
        c1, s1 = math.cos(q1), math.sin(q1)
        c12, s12 = math.cos(q1 + q2), math.sin(q1 + q2)
        c2, s2 = math.cos(q2), math.sin(q2)
        x = a1 * c1 + a2 * c12
        y = a1 * s1 + a2 * s12
        fx, fy = env.force_xy(x, y)
        # Jᵀ h_e
        j11, j12, j21, j22 = -a1 * s1 - a2 * s12, -a2 * s12, a1 * c1 + a2 * c12, a2 * c12
        th1 = j11 * fx + j21 * fy
        th2 = j12 * fx + j22 * fy
        h = self.hc * s2
        r1 = u1 - th1 - (h * w2 * w1 + h * (w1 + w2) * w2) - self.d.F1 * w1 - (self.g1c * c1 + self.g12 * c12)
        r2 = u2 - th2 - (-h * w1 * w1) - self.d.F2 * w2 - self.g12 * c12
        b11 = self.b11c + self.b11v * c2
        b12 = self.b12c + self.b12v * c2
        b22 = self.b22
        det = b11 * b22 - b12 * b12
        return (b22 * r1 - b12 * r2) / det, (b11 * r2 - b12 * r1) / det


def ik_elbow_up(p, data: ArmData | None = None) -> np.ndarray:
    """Joint angles (q2 <= 0, the chapter's posture) putting the tip at p."""
    d = data or ArmData()
    x, y = float(p[0]), float(p[1])
    c2 = (x * x + y * y - d.a1**2 - d.a2**2) / (2.0 * d.a1 * d.a2)
    if abs(c2) > 1.0:
        raise ValueError(f"{p} is out of reach")
    q2 = -math.acos(c2)
    q1 = math.atan2(y, x) - math.atan2(d.a2 * math.sin(q2), d.a1 + d.a2 * math.cos(q2))
    return np.array([q1, q2])


# --------------------------------------------------------------------------- environments


class Environment:
    def force_xy(self, x: float, y: float) -> tuple[float, float]:  # pragma: no cover - interface
        raise NotImplementedError

    def force(self, p: np.ndarray) -> np.ndarray:
        return np.array(self.force_xy(float(p[0]), float(p[1])))


class Plane(Environment):
    """One-sided frictionless elastic plane (a line): ``h_e = k δ (−ν)`` while δ = ν·(p_r − p) > 0.

    ν is the outward unit normal (from the environment into free space); h_e is the force the
    tip exerts on the environment, i.e. it points into the environment.
    """

    def __init__(self, point, normal, k: float) -> None:
        nv = np.asarray(normal, dtype=float)
        nv = nv / np.linalg.norm(nv)
        self.px, self.py = float(point[0]), float(point[1])
        self.nx, self.ny = float(nv[0]), float(nv[1])
        self.k = float(k)

    def force_xy(self, x: float, y: float) -> tuple[float, float]:
        delta = self.nx * (self.px - x) + self.ny * (self.py - y)
        if delta <= 0.0:
            return 0.0, 0.0
        return -self.k * delta * self.nx, -self.k * delta * self.ny


def plane_at_angle(angle_deg: float, through, k: float) -> Plane:
    """The plane at ``angle_deg`` to x0 through a point, environment on the −y_c side.

    y_c = [−sin a, cos a] is the outward normal: 0° is a floor (environment below), 90° a wall
    with the environment at larger x (Example 9.2's plane x = x_r).
    """
    a = math.radians(angle_deg)
    return Plane(through, [-math.sin(a), math.cos(a)], k)


class Spring(Environment):
    """Bilateral linear spring (9.38): ``h_e = K (p − x_r)``."""

    def __init__(self, K, rest) -> None:
        K = np.asarray(K, dtype=float)
        self.K = K
        self.k11, self.k12, self.k21, self.k22 = (float(v) for v in K.ravel())
        self.rx, self.ry = float(rest[0]), float(rest[1])

    def force_xy(self, x: float, y: float) -> tuple[float, float]:
        dx, dy = x - self.rx, y - self.ry
        return self.k11 * dx + self.k12 * dy, self.k21 * dx + self.k22 * dy


# --------------------------------------------------------------------------- references


_BREAK = 1e-9  # a sample within 1e-9 (relative) of a breakpoint counts as on it


class Reference:
    """x_d(t), ẋ_d(t), ẍ_d(t) and f_d(t), ḟ_d(t), f̈_d(t) in the base frame."""

    def motion(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
        raise NotImplementedError

    def force(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
        raise NotImplementedError

    def x_d(self, t: float) -> np.ndarray:
        return self.motion(t)[0]

    def f_d(self, t: float) -> np.ndarray:
        return self.force(t)[0]


@dataclass
class SetpointRef(Reference):
    """Constant x_d stepped at t = 0; f_d stepped at ``force_start`` (a sample at it sees the step),
    or, with ``force_ramp`` > 0, raised from there by the quintic ``10τ³ − 15τ⁴ + 6τ⁵`` over ``force_ramp``."""

    position: np.ndarray
    force_value: np.ndarray = field(default_factory=lambda: np.zeros(2))
    force_start: float = 0.0
    force_ramp: float = 0.0

    def motion(self, t):
        z = np.zeros(2)
        return np.asarray(self.position, dtype=float), z, z

    def force(self, t):
        f = np.asarray(self.force_value, dtype=float)
        t0, T = self.force_start, self.force_ramp
        eps = _BREAK * max(1.0, t0 + T)
        if t < t0 - eps:
            return 0.0 * f, 0.0 * f, 0.0 * f
        if T <= 0.0 or t >= t0 + T - eps:
            return f.copy(), 0.0 * f, 0.0 * f
        tau = (t - t0) / T
        s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
        sd = 30.0 * tau**2 * (1.0 - tau) ** 2 / T
        sdd = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau) / T**2
        return s * f, sd * f, sdd * f


@dataclass
class PathRef(Reference):
    """Straight segment p_i → p_f with the trapezoidal velocity profile of Sect. 4.2.1 (t_f, t_c), constant f_d.

    s̈_c = 1 / (t_c (t_f − t_c)); a sample on a breakpoint takes the segment that starts there.
    """

    p_i: np.ndarray
    p_f: np.ndarray
    t_f: float
    t_c: float
    force_value: np.ndarray = field(default_factory=lambda: np.zeros(2))

    def motion(self, t):
        tf, tc = self.t_f, self.t_c
        a = 1.0 / (tc * (tf - tc))
        eps = _BREAK * tf
        if t < -eps:
            s, sd, sdd = 0.0, 0.0, 0.0
        elif t >= tf - eps:
            s, sd, sdd = 1.0, 0.0, 0.0
        elif t < tc - eps:
            s, sd, sdd = 0.5 * a * t * t, a * t, a
        elif t < tf - tc - eps:
            s, sd, sdd = a * tc * (t - 0.5 * tc), a * tc, 0.0
        else:
            r = tf - t
            s, sd, sdd = 1.0 - 0.5 * a * r * r, a * r, -a
        d = np.asarray(self.p_f, dtype=float) - np.asarray(self.p_i, dtype=float)
        return np.asarray(self.p_i, dtype=float) + s * d, sd * d, sdd * d

    def force(self, t):
        z = np.zeros(2)
        return np.asarray(self.force_value, dtype=float), z, z


# --------------------------------------------------------------------------- control laws


def _diag(v) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.ndim == 0:
        return np.eye(2) * float(a)
    if a.ndim == 1:
        return np.diag(a)
    return a


class Law:
    """An inverse-dynamics law (9.30): subclasses give the operational acceleration a."""

    def __init__(self, Md, KD, KP) -> None:
        self.Md, self.KD, self.KP = _diag(Md), _diag(KD), _diag(KP)
        self.Md_inv = np.linalg.inv(self.Md)

    def start(self, arm: Arm, q, qd, h, ref: Reference) -> None:
        pass

    def accel(self, t, x, xd, h, ref: Reference, Ts: float) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def torque(self, arm: Arm, t, q, qd, h, ref: Reference, Ts: float) -> np.ndarray:
        J = arm.jacobian(q)
        x = arm.tip(q)
        xd = J @ qd
        a = self.accel(t, x, xd, h, ref, Ts)
        y = np.linalg.solve(J, a - arm.jdot_qdot(q, qd))
        return arm.mass(q) @ y + arm.n(q, qd) + J.T @ h


class Impedance(Law):
    """(9.30)-(9.31), corrected: a = ẍ_d + M_d⁻¹(K_D x̃̇ + K_P x̃ − h_e), x̃ = x_d − x_e."""

    def accel(self, t, x, xd, h, ref, Ts):
        x_d, v_d, a_d = ref.motion(t)
        return a_d + self.Md_inv @ (self.KD @ (v_d - xd) + self.KP @ (x_d - x) - h)


class _PIForce(Law):
    """x_F = R (K_F Rᵀ (f_d − f_e) + ξ) with the left-rectangle integral ξ (module docstring)."""

    parallel = False

    def __init__(self, Md, KD, KP, KF, KI=0.0, start: str = "tip", R=None) -> None:
        super().__init__(Md, KD, KP)
        self.kf = np.diag(_diag(KF)).copy()
        self.ki = np.diag(_diag(KI)).copy()
        self.R = np.eye(2) if R is None else np.asarray(R, dtype=float)
        self.start_mode = start
        self.xi = np.zeros(2)

    def start(self, arm, q, qd, h, ref):
        self.xi = np.zeros(2)
        if self.start_mode == "zero":
            return
        p0 = arm.tip(q)
        offset = p0 - ref.x_d(0.0) if self.parallel else p0
        f_pre = ref.f_d(0.0) if self.start_mode == "tip" else np.zeros(2)
        xi0 = self.R.T @ offset - self.kf * (self.R.T @ (f_pre - h))
        self.xi = np.where(self.ki > 0.0, xi0, 0.0)
        self.f_prev = ref.f_d(0.0)

    def x_F(self, t, h, ref, Ts):
        if self.start_mode == "tip":  # bumpless: no proportional kick at a change of f_d
            f = ref.f_d(t)
            self.xi = self.xi - np.where(self.ki > 0.0, self.kf * (self.R.T @ (f - self.f_prev)), 0.0)
            self.f_prev = f
        ef = self.R.T @ (ref.f_d(t) - h)
        xF = self.R @ (self.kf * ef + self.xi)
        self.xi = self.xi + Ts * self.ki * ef  # ξ_{k+1}, used at the next sample
        return xF


class InnerPosition(_PIForce):
    """(9.39) with (9.41), (9.43): a = M_d⁻¹(−K_D ẋ_e + K_P (x_F − x_e))."""

    def accel(self, t, x, xd, h, ref, Ts):
        return self.Md_inv @ (-self.KD @ xd + self.KP @ (self.x_F(t, h, ref, Ts) - x))


class Parallel(_PIForce):
    """(9.48): a = M_d⁻¹(−K_D ẋ_e + K_P (x̃ + x_F)), x̃ = x_d − x_e."""

    parallel = True

    def __init__(self, Md, KD, KP, KF, KI=0.0, start: str = "zero", R=None) -> None:
        super().__init__(Md, KD, KP, KF, KI, start, R)

    def accel(self, t, x, xd, h, ref, Ts):
        return self.Md_inv @ (-self.KD @ xd + self.KP @ (ref.x_d(t) - x + self.x_F(t, h, ref, Ts)))


class InnerVelocity(Law):
    """(9.45) (with J̇ q̇) and (9.46): a = M_d⁻¹(−K_D ẋ_e + K_P K_F (f_d − f_e))."""

    def __init__(self, Md, KD, KP, KF) -> None:
        super().__init__(Md, KD, KP)
        self.KF = _diag(KF)

    def accel(self, t, x, xd, h, ref, Ts):
        return self.Md_inv @ (-self.KD @ xd + self.KP @ (self.KF @ (ref.f_d(t) - h)))


class HybridCompliant(Law):
    """Hybrid force/velocity control on a compliant plane (9.77), (9.80), (9.81), λ̇ from (9.82).

    The plane's constraint frame: x_c = [cos a, sin a] along it, y_c = [−sin a, cos a] out of the
    environment; S_v = x_c, S_f = y_c (both unit vectors, so S† = Sᵀ); ν = x_cᵀ ẋ_e (9.60),
    λ = y_cᵀ h_e (9.54), ν_d = x_cᵀ ẋ_d, ν̇_d = x_cᵀ ẍ_d, λ_d = y_cᵀ f_d (and its derivatives).
    With Ĉ the compliance the controller assumes (2 × 2, base frame):
    ``Ĉ′ = (I − P_v) Ĉ`` (9.72), ``λ̇ = (y_cᵀ Ĉ y_c)⁻¹ y_cᵀ J q̇`` (9.82 with the estimate),
    ``α_ν = ν̇_d + K_Pν (ν_d − ν) + K_Iν ∫(ν_d − ν)`` (left rectangle sum over the samples),
    ``f_λ = λ̈_d + K_Dλ (λ̇_d − λ̇) + K_Pλ (λ_d − λ)``, ``α = S_v α_ν + Ĉ′ S_f f_λ`` (9.77) and the
    inverse dynamics ``γ_e = B_e α + n_e + h_e``, i.e. ``u = B J⁻¹ (α − J̇ q̇) + n + Jᵀ h_e``.
    """

    def __init__(self, angle_deg: float, C_hat, KPv: float, KIv: float, KPl: float, KDl: float) -> None:
        a = math.radians(angle_deg)
        self.xc = np.array([math.cos(a), math.sin(a)])
        self.yc = np.array([-math.sin(a), math.cos(a)])
        C = _diag(C_hat)
        self.Cp_yc = (np.eye(2) - np.outer(self.xc, self.xc)) @ C @ self.yc
        self.lam_rate_gain = 1.0 / float(self.yc @ C @ self.yc)
        self.KPv, self.KIv, self.KPl, self.KDl = float(KPv), float(KIv), float(KPl), float(KDl)
        self.integral = 0.0

    def start(self, arm, q, qd, h, ref):
        self.integral = 0.0

    def accel(self, t, x, xd, h, ref, Ts):
        _, v_d, a_d = ref.motion(t)
        f_d, fd_d, fdd_d = ref.force(t)
        nu, nu_d, nud_d = self.xc @ xd, self.xc @ v_d, self.xc @ a_d
        lam, lam_d, lamd_d, lamdd_d = self.yc @ h, self.yc @ f_d, self.yc @ fd_d, self.yc @ fdd_d
        lam_rate = self.lam_rate_gain * (self.yc @ xd)
        alpha_nu = nud_d + self.KPv * (nu_d - nu) + self.KIv * self.integral
        f_lam = lamdd_d + self.KDl * (lamd_d - lam_rate) + self.KPl * (lam_d - lam)
        self.integral += Ts * (nu_d - nu)  # used from the next sample on
        return self.xc * alpha_nu + self.Cp_yc * f_lam


# --------------------------------------------------------------------------- the sampled loop


@dataclass
class Run:
    t: np.ndarray  # (N+1,) sample times [s]
    q: np.ndarray  # (N+1, 2)
    qd: np.ndarray  # (N+1, 2)
    x: np.ndarray  # (N+1, 2) tip position [m]
    f: np.ndarray  # (N+1, 2) contact force h_e [N]
    u: np.ndarray  # (N+1, 2) torque applied from t_k on [N m]


def _rk4_interval(arm: Arm, env: Environment, s: list[float], u1: float, u2: float, Ts: float, nsub: int) -> list[float]:
    h = Ts / nsub
    q1, q2, w1, w2 = s
    acc = arm.accel
    for _ in range(nsub):
        a1, a2 = acc(q1, q2, w1, w2, u1, u2, env)
        k1 = (w1, w2, a1, a2)
        hq1, hq2, hw1, hw2 = q1 + 0.5 * h * k1[0], q2 + 0.5 * h * k1[1], w1 + 0.5 * h * k1[2], w2 + 0.5 * h * k1[3]
        a1, a2 = acc(hq1, hq2, hw1, hw2, u1, u2, env)
        k2 = (hw1, hw2, a1, a2)
        hq1, hq2, hw1, hw2 = q1 + 0.5 * h * k2[0], q2 + 0.5 * h * k2[1], w1 + 0.5 * h * k2[2], w2 + 0.5 * h * k2[3]
        a1, a2 = acc(hq1, hq2, hw1, hw2, u1, u2, env)
        k3 = (hw1, hw2, a1, a2)
        hq1, hq2, hw1, hw2 = q1 + h * k3[0], q2 + h * k3[1], w1 + h * k3[2], w2 + h * k3[3]
        a1, a2 = acc(hq1, hq2, hw1, hw2, u1, u2, env)
        k4 = (hw1, hw2, a1, a2)
        q1 += h / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        q2 += h / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        w1 += h / 6.0 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2])
        w2 += h / 6.0 * (k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3])
    return [q1, q2, w1, w2]


def _ivp_interval(arm: Arm, env: Environment, s: list[float], u1: float, u2: float, Ts: float) -> list[float]:
    def rhs(_t, z):
        a1, a2 = arm.accel(z[0], z[1], z[2], z[3], u1, u2, env)
        return [z[2], z[3], a1, a2]

    sol = solve_ivp(rhs, (0.0, Ts), s, method="DOP853", rtol=1e-10, atol=1e-12)
    if not sol.success:  # pragma: no cover - diagnostic
        raise RuntimeError(sol.message)
    return [float(v) for v in sol.y[:, -1]]


def run(
    law: Law,
    env: Environment,
    ref: Reference,
    q0,
    duration: float,
    Ts: float = 1e-3,
    qd0=None,
    *,
    arm: Arm | None = None,
    integrator: str = "rk4",
    step: float = 5e-5,
    progress: Callable[[int], None] | None = None,
) -> Run:
    """Simulate the sampled loop: samples at t_k = k Ts, k = 0..N, N = round(duration / Ts).

    Args:
        integrator: ``"rk4"`` (fixed step no longer than ``step`` [s]) or ``"ivp"``
            (``solve_ivp`` DOP853, rtol 1e-10, atol 1e-12, on every interval).
    """
    arm = arm or Arm()
    N = int(round(duration / Ts))
    nsub = max(1, int(math.ceil(Ts / step - 1e-9)))
    q = np.asarray(q0, dtype=float).copy()
    qd = np.zeros(2) if qd0 is None else np.asarray(qd0, dtype=float).copy()
    T = np.arange(N + 1) * Ts
    Q, QD, X, Fh, U = (np.zeros((N + 1, 2)) for _ in range(5))
    law.start(arm, q, qd, env.force(arm.tip(q)), ref)
    s = [q[0], q[1], qd[0], qd[1]]
    for k in range(N + 1):
        q = np.array(s[:2])
        qd = np.array(s[2:])
        p = arm.tip(q)
        h = env.force(p)
        u = law.torque(arm, T[k], q, qd, h, ref, Ts)
        Q[k], QD[k], X[k], Fh[k], U[k] = q, qd, p, h, u
        if k == N:
            break
        if integrator == "rk4":
            s = _rk4_interval(arm, env, s, float(u[0]), float(u[1]), Ts, nsub)
        else:
            s = _ivp_interval(arm, env, s, float(u[0]), float(u[1]), Ts)
        if not all(math.isfinite(v) for v in s):
            raise RuntimeError(f"reference simulation diverged at t = {T[k + 1]:.4f} s")
        if progress is not None:
            progress(k)
    return Run(T, Q, QD, X, Fh, U)
