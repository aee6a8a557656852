"""The sampled closed loop of Franka's ``cartesian_impedance_example_controller`` against an elastic surface (issue 30).

The law, read from frankaemika/franka_ros (ROS 1) at c11f000c (2024-03-28),
``franka_example_controllers/src/cartesian_impedance_example_controller.cpp`` (``update``,
``saturateTorqueRate``); franka_ros2 at 40cf08b6 (2024-01-26) has no Cartesian impedance example.
It runs on the torque interface (1 kHz), written in the library as
:func:`forcecontrol.laws.vendor.franka_impedance_torque`::

    τ = Jᵀ (−K e − D J q̇) + (I − Jᵀ J^{T+}) (k_ns (q_ns − q) − 2 sqrt(k_ns) q̇) + C q̇,  D = 2 sqrt(K)
    e = [p − p_d; −R vec(quat⁻¹ ⊗ quat_d)]

Linearised at a pose q* (gravity and C q̇ compensated exactly, as the simulator's plant has them):

* the orientation error is ``vec(quat⁻¹ ⊗ quat_d) = sin(θ/2) axis``, so ``e ≈ S J δq`` with
  ``S = diag(1, 1, 1, ½, ½, ½)``: the rotational stiffness acts as K_rot/2 (D_rot is not halved);
* joint-space feedback ``u = −K_q δq − D_q δq̇`` with ``K_q = Jᵀ K S J + k_ns N``,
  ``D_q = Jᵀ D J + 2 sqrt(k_ns) N``, ``N = I − Jᵀ (J Jᵀ + λ² I)⁻¹ J`` (the damped pseudo-inverse);
* the plant (continuous): ``M(q*) δq̈ = u − k_e J_nᵀ J_n δq − (c J_nᵀ J_n + F_v) δq̇`` with
  ``J_n = nᵀ J_P`` the surface normal's row (a spring k_e and damper c along n at the frame
  origin, as :class:`forcecontrol.environments.spatial.Table`) and F_v the robot's viscous
  friction (not compensated by the law);
* the torque is computed from the sample at t_k and held over [t_k, t_k + T_s) (zero-order hold,
  as ``sim.simulation``'s loop applies it: no delay); ``delay`` adds whole cycles of transport
  delay (a ring of held torques) for an interface that has one.

One cycle is the exact discretisation ``[Φ Γ] = expm([[A T, B T], [0, 0]])``; the closed loop's matrix
is ``Φ − Γ [K_q D_q]`` (with the delay ring appended), stable iff its spectral radius is below 1.

What the linear model leaves out (both are nonlinear, and both are inactive near the limit):

* the gains' soft start (K, D, k_ns filtered towards their targets by 0.005 per cycle) and the
  equilibrium pose's filter: they move the gains and the reference, not the feedback; the model
  uses the target gains (the loop after the start-up);
* the torque-rate clamp (|Δτ| <= 1 N m per cycle): inactive while the oscillation is small; when it
  saturates it bounds the controller's part of the growth (linear instead of exponential).

Also left out: the Jacobian's and the orientation error's second-order terms (the geometric
stiffness of the preload force, ~|f| / lever, negligible against k_e near the limit).

With these gains the contact mode's frequency ``sqrt(k_e / Λ_n)`` (``Λ_n = 1/(J_n M⁻¹ J_nᵀ)``, the
arm's apparent mass along n) meets the Nyquist frequency π/T_s near the limit, where the sampled
damping turns negative: :func:`nyquist_stiffness` ``Λ_n (π/T_s)²`` is its estimate (within a few %),
nearly independent of K.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg import expm

from ..errors import DimensionError, ParameterError

__all__ = ["FrankaContactLoop", "franka_contact_loop", "franka_loop_matrix", "franka_spectral_radius",
           "franka_stability_limit", "franka_contact_modes", "nyquist_stiffness", "point_mass_loop", "with_stiffness",
           "franka_design_stiffness"]


@dataclass(frozen=True)
class FrankaContactLoop:
    """The loop's data at one pose: the arm's M (n, n), J (m, n) (m = 6: ``[J_P; J_O]``, base frame;
    m = 1: a 1-DOF axis), the contact normal's row J_n (n,), the law's diagonal K, D (m,), k_ns, λ,
    the sample time T_s [s], the plant's viscous damping F_v (n, n), the contact's damping c [N s/m]
    and the delay [cycles]."""

    mass_matrix: np.ndarray
    jacobian: np.ndarray
    normal_row: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    sample_time: float
    nullspace_stiffness: float = 0.0
    pinv_damping: float = 0.2
    friction: np.ndarray | None = None
    contact_damping: float = 0.0
    delay: int = 0

    def __post_init__(self) -> None:
        M, J = np.asarray(self.mass_matrix, dtype=np.float64), np.asarray(self.jacobian, dtype=np.float64)
        n = M.shape[0]
        if M.shape != (n, n) or J.ndim != 2 or J.shape[1] != n or np.asarray(self.normal_row).shape != (n,):
            raise DimensionError(f"mass_matrix must be (n, n), jacobian (m, n) and normal_row (n,); got {M.shape}, "
                                 f"{J.shape}, {np.asarray(self.normal_row).shape}")
        m = J.shape[0]
        if np.asarray(self.stiffness).shape != (m,) or np.asarray(self.damping).shape != (m,):
            raise DimensionError(f"stiffness and damping must have one value per Jacobian row ({m}); got "
                                 f"{np.asarray(self.stiffness).shape}, {np.asarray(self.damping).shape}")
        if not (self.sample_time > 0 and math.isfinite(self.sample_time)):
            raise ParameterError(f"sample_time must be a finite number > 0 [s]; got {self.sample_time!r}")
        if isinstance(self.delay, bool) or not isinstance(self.delay, int) or self.delay < 0:
            raise ParameterError(f"delay must be a whole number of cycles >= 0; got {self.delay!r}")

    def feedback(self) -> tuple[np.ndarray, np.ndarray]:
        """(K_q, D_q): the law's joint-space stiffness and damping at the pose (module docstring)."""
        J = np.asarray(self.jacobian, dtype=np.float64)
        m, n = J.shape
        S = np.ones(m) if m != 6 else np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5])  # sin(θ/2): K_rot acts as K_rot/2
        N = np.eye(n) - J.T @ np.linalg.solve(J @ J.T + self.pinv_damping**2 * np.eye(m), J)
        kns = float(self.nullspace_stiffness)
        Kq = J.T @ ((np.asarray(self.stiffness) * S)[:, None] * J) + kns * N
        Dq = J.T @ (np.asarray(self.damping)[:, None] * J) + 2.0 * math.sqrt(kns) * N
        return Kq, Dq


def franka_contact_loop(robot: Any, q: Any, controller: Any, normal: Any = (0.0, 0.0, 1.0), *,
                        sample_time: float | None = None, contact_damping: float = 0.0, delay: int = 0) -> FrankaContactLoop:
    """The loop of a :class:`~forcecontrol.controllers.vendor.FrankaCartesianImpedanceController` (its target gains)
    on a 6-D ``robot`` (its M(q), J(q), friction) at the pose ``q`` against a surface of normal ``normal``."""
    inner = getattr(robot, "robot", robot)
    qv = np.asarray(q, dtype=np.float64)
    M = np.asarray(inner.mass_matrix(qv), dtype=np.float64)
    J = np.asarray(inner.spatial_jacobian(qv), dtype=np.float64)
    nv = np.asarray(normal, dtype=np.float64)
    if nv.shape != (3,) or not np.linalg.norm(nv) > 0:
        raise ParameterError(f"normal must be a non-zero 3-vector; got {normal!r}")
    nv = nv / np.linalg.norm(nv)
    K = np.array([controller.translational_stiffness] * 3 + [controller.rotational_stiffness] * 3, dtype=np.float64)
    F = getattr(inner, "friction", None)
    return FrankaContactLoop(M, J, nv @ J[:3], K, 2.0 * np.sqrt(K), controller.sample_time if sample_time is None else
                             float(sample_time), nullspace_stiffness=controller.nullspace_stiffness,
                             pinv_damping=controller.pinv_damping, friction=None if F is None else np.asarray(F, dtype=float),
                             contact_damping=contact_damping, delay=delay)


def point_mass_loop(mass: float, stiffness: float, damping: float, sample_time: float, delay: int = 0) -> FrankaContactLoop:
    """The 1-DOF case: a point mass [kg] with the law's PD (K [N/m], D [N s/m]) along the contact normal."""
    one = np.ones((1, 1))
    return FrankaContactLoop(mass * one, one, np.ones(1), np.array([float(stiffness)]), np.array([float(damping)]),
                             sample_time, delay=delay)


def franka_loop_matrix(loop: FrankaContactLoop, environment_stiffness: float) -> np.ndarray:
    """The closed loop's matrix over one cycle on ``[δq, δq̇, u_{k−1}, …, u_{k−d}]`` (size 2n + d n)."""
    if not environment_stiffness >= 0:
        raise ParameterError(f"environment_stiffness must be >= 0 [N/m]; got {environment_stiffness!r}")
    M = np.asarray(loop.mass_matrix, dtype=np.float64)
    n = M.shape[0]
    Jn = np.asarray(loop.normal_row, dtype=np.float64)
    P = np.outer(Jn, Jn)
    Ce = loop.contact_damping * P + (np.zeros((n, n)) if loop.friction is None else np.asarray(loop.friction))
    Mi = np.linalg.inv(M)
    T = loop.sample_time
    big = np.zeros((3 * n, 3 * n))
    big[:n, n : 2 * n] = np.eye(n) * T
    big[n : 2 * n, :n] = -Mi @ (environment_stiffness * P) * T
    big[n : 2 * n, n : 2 * n] = -Mi @ Ce * T
    big[n : 2 * n, 2 * n :] = Mi * T
    E = expm(big)
    Phi, Gam = E[: 2 * n, : 2 * n], E[: 2 * n, 2 * n :]
    G = np.hstack(loop.feedback())  # u_k = −G z_k
    d = loop.delay
    if d == 0:
        return Phi - Gam @ G
    size = 2 * n + d * n
    A = np.zeros((size, size))
    A[: 2 * n, : 2 * n] = Phi
    A[: 2 * n, 2 * n + (d - 1) * n :] = Gam  # the oldest torque is applied
    A[2 * n : 3 * n, : 2 * n] = -G  # the newest enters the ring
    for i in range(1, d):
        A[2 * n + i * n : 3 * n + i * n, 2 * n + (i - 1) * n : 2 * n + i * n] = np.eye(n)
    return A


def franka_spectral_radius(loop: FrankaContactLoop, environment_stiffness: float) -> float:
    """max |z| of the loop's poles (< 1: stable)."""
    return float(np.max(np.abs(np.linalg.eigvals(franka_loop_matrix(loop, environment_stiffness)))))


def franka_contact_modes(loop: FrankaContactLoop, environment_stiffness: float, count: int = 2) -> np.ndarray:
    """The ``count`` poles whose eigenvectors move the contact coordinate J_n δq most (the contact mode), largest |z|
    first: the growth (|z| > 1) or decay per cycle of the contact force's oscillation."""
    A = franka_loop_matrix(loop, environment_stiffness)
    z, V = np.linalg.eig(A)
    n = np.asarray(loop.mass_matrix).shape[0]
    Jn = np.asarray(loop.normal_row, dtype=np.float64)
    weight = np.abs(Jn @ V[:n]) / np.maximum(np.linalg.norm(V, axis=0), 1e-300)
    pick = np.argsort(-weight)[:count]
    return z[pick][np.argsort(-np.abs(z[pick]))]


def nyquist_stiffness(loop: FrankaContactLoop) -> float:
    """``Λ_n (π/T_s)²`` [N/m]: the stiffness at which the contact mode sqrt(k_e/Λ_n) reaches the Nyquist frequency
    (``Λ_n = 1/(J_n M⁻¹ J_nᵀ)``, the apparent mass along the normal); an estimate of the limit for soft gains."""
    Jn = np.asarray(loop.normal_row, dtype=np.float64)
    lam = 1.0 / float(Jn @ np.linalg.solve(np.asarray(loop.mass_matrix, dtype=np.float64), Jn))
    return lam * (math.pi / loop.sample_time) ** 2


def franka_stability_limit(loop: FrankaContactLoop, k_min: float = 1.0, k_max: float = 1e12, rtol: float = 1e-5,
                           step: float = 1.25) -> float:
    """The smallest environment stiffness [N/m] above ``k_min`` at which the loop turns unstable, i.e. the largest
    stable one before it (a geometric scan by ``step``, then bisection on the spectral radius to ``rtol``).

    Returns 0 when the loop is unstable already at ``k_min`` (e.g. in free space at a low rate: the wrist's small
    inertia against the sampled rotational damping), ``inf`` when stable up to ``k_max``. Beyond the first
    instability the sampled loop may be stable again in bands (aliasing): only the first crossing is the limit.
    """
    if franka_spectral_radius(loop, 0.0) >= 1.0 or franka_spectral_radius(loop, k_min) >= 1.0:
        return 0.0
    lo = hi = float(k_min)
    while franka_spectral_radius(loop, hi) < 1.0:
        lo, hi = hi, hi * step
        if hi > k_max:
            return math.inf
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if franka_spectral_radius(loop, mid) < 1.0 else (lo, mid)
    return lo


def with_stiffness(loop: FrankaContactLoop, value: float, axes: str = "rotational") -> FrankaContactLoop:
    """The loop with K = ``value`` on the ``"translational"`` (rows 0-2) or ``"rotational"`` (rows 3-5) axes and D = 2 sqrt(K)
    there, as the example controller sets its damping."""
    import dataclasses

    rows = {"translational": slice(0, 3), "rotational": slice(3, 6)}.get(axes)
    if rows is None or np.asarray(loop.stiffness).shape != (6,):
        raise ParameterError(f"axes must be 'translational' or 'rotational' on a 6-D loop; got {axes!r} on "
                             f"{np.asarray(loop.stiffness).shape[0]} rows")
    if not (value >= 0 and math.isfinite(value)):
        raise ParameterError(f"{axes} stiffness must be a finite number >= 0; got {value!r}")
    K, D = np.array(loop.stiffness, dtype=np.float64), np.array(loop.damping, dtype=np.float64)
    K[rows], D[rows] = value, 2.0 * math.sqrt(value)
    return dataclasses.replace(loop, stiffness=K, damping=D)


def franka_design_stiffness(loop: FrankaContactLoop, environment_stiffness: float, margin: float = 2.0,
                            axes: str = "rotational", upper: float = 1e4, rtol: float = 1e-4) -> float:
    """The largest stiffness on ``axes`` (D = 2 sqrt(K) with it) at which the loop's k_e limit is at least ``margin`` times
    ``environment_stiffness`` (0: stable in free space), by bisection; ``upper`` when every K up to it keeps the margin.

    Assumes the limit falls as K rises (checked at the ends, not in between). At a low rate it is the sampled
    damping against the wrist's small inertia (D T_s / I < 2 of a free inertia) that bounds the rotational stiffness.

    Raises:
        ParameterError: even K = 0 on these axes does not reach the margin (the other axes or the rate limit it).
    """
    if not (margin >= 1.0 and environment_stiffness >= 0):
        raise ParameterError(f"margin must be >= 1 and environment_stiffness >= 0 [N/m]; got {margin!r}, "
                             f"{environment_stiffness!r}")
    target = margin * environment_stiffness

    def ok(k: float) -> bool:
        lp = with_stiffness(loop, k, axes)
        if franka_spectral_radius(lp, 0.0) >= 1.0:
            return False
        kk = 1.0  # franka_stability_limit's scan up to the target (no bisection needed: stable at the target and below)
        while kk < target:
            if franka_spectral_radius(lp, kk) >= 1.0:
                return False
            kk *= 1.25
        return target == 0.0 or franka_spectral_radius(lp, target) < 1.0

    if not ok(0.0):
        raise ParameterError(f"no {axes} stiffness >= 0 keeps the loop stable up to {target:g} N/m at "
                             f"{1.0 / loop.sample_time:g} Hz (the other axes or the rate limit it)")
    if ok(upper):
        return upper
    lo, hi = 0.0, upper
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo
