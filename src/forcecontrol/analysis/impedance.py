"""Impedance control on an elastic environment: per-axis dynamics and steady state (Example 9.2).

With force measurement the closed loop is the impedance (9.32); on a plane of stiffness k along
an axis, that axis obeys ``m_d ẍ + k_D ẋ + (k_P + k) x = k x_r + k_P x_d`` with::

    ω_n = sqrt((k_P + k) / m_d),   ζ = k_D / (2 sqrt(m_d (k_P + k)))

and a free axis has ω_n = sqrt(k_P / m_d), ζ = k_D / (2 sqrt(m_d k_P)). At rest the position
is ``x_e = (k_P x_d + k x_r) / (k_P + k)`` and the contact force ``f = k (x_e − x_r)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import as_gain_matrix, as_matrix, as_vector, nonnegative_scalar, positive_scalar
from ..errors import DimensionError, ParameterError

__all__ = ["AxisDynamics", "impedance_axis", "ImpedanceModes", "impedance_modes", "impedance_response",
           "held_input_response", "held_input_matrices", "contact_plant", "HeldLoop", "impedance_loop"]


@dataclass(frozen=True)
class AxisDynamics:
    """Second-order dynamics and steady state of one operational axis.

    Attributes:
        natural_frequency: ω_n [rad/s]; damping_ratio: ζ.
        position: steady position x_e [m]; contact_force: steady f = k (x_e − x_r) [N].
        displacement: x_e − x_r [m] (environment deformation; 0 when free).
    """

    natural_frequency: float
    damping_ratio: float
    position: float
    contact_force: float
    displacement: float


def impedance_axis(
    inertia: float,
    damping: float,
    stiffness: float,
    environment_stiffness: float = 0.0,
    desired: float = 0.0,
    rest: float = 0.0,
) -> AxisDynamics:
    """ω_n, ζ and the steady state along one axis under impedance control with force measurement.

    Args:
        inertia: m_d [kg]; damping: k_D [N s/m]; stiffness: k_P [N/m].
        environment_stiffness: k along the axis [N/m] (0: free motion).
        desired: x_d [m]; rest: x_r, the environment's rest position [m].
    """
    m = positive_scalar("inertia", inertia)
    kd = nonnegative_scalar("damping", damping)
    kp = positive_scalar("stiffness", stiffness)
    k = nonnegative_scalar("environment_stiffness", environment_stiffness)
    wn = math.sqrt((kp + k) / m)
    zeta = kd / (2.0 * math.sqrt(m * (kp + k)))
    x = (kp * desired + k * rest) / (kp + k)
    return AxisDynamics(wn, zeta, x, k * (x - rest), x - rest if k > 0 else 0.0)


@dataclass(frozen=True)
class ImpedanceModes:
    """Equilibrium and modes of the impedance (9.32) on a linear elastic environment, any geometry.

    The closed loop with force measurement and a constant x_d, on an environment whose wrench is
    ``h_e = K (x_e − x_r)`` (a plane of any orientation: ``K = k n nᵀ``; a spring: its matrix), is
    ``M_d ẍ + K_D ẋ + (K_P + K) x = K_P x_d + K x_r`` — coupled through K when the contact is
    not along a base axis. Its equilibrium is ``x_e = (K_P + K)⁻¹ (K_P x_d + K x_r)`` and its
    modes are the eigenvalues λ of ``[[0, I], [−M_d⁻¹ (K_P + K), −M_d⁻¹ K_D]]``: each complex
    pair gives ``ω_n = |λ|`` and ``ζ = −Re λ / |λ|`` (a real pair, ζ ≥ 1, gives
    ``ω_n = sqrt(λ₁ λ₂)``, ``ζ = −(λ₁ + λ₂) / (2 ω_n)``).

    Attributes:
        position: x_e (m,) [m]; contact_force: h_e = K (x_e − x_r) (m,) [N].
        natural_frequencies: ω_n of each mode, ascending (m,) [rad/s].
        damping_ratios: ζ of each mode (m,).
        directions: unit direction of each mode in the base frame, (m, m) (row i: mode i),
            from the eigenvectors of ``M_d⁻¹ (K_P + K)`` (exact when the damping is modal).
        in_contact: False when the equilibrium with contact would pull on a one-sided
            environment (the equilibrium is then the free one, K = 0).
    """

    position: np.ndarray
    contact_force: np.ndarray
    natural_frequencies: np.ndarray
    damping_ratios: np.ndarray
    directions: np.ndarray
    in_contact: bool

    def named(self, axes: Any, *, with_directions: bool = True) -> dict[str, Any]:
        """``omega_n_<name>`` and ``zeta_<name>`` of each mode, named by its axis when every mode lies
        along one of ``axes`` (a distinct one each: the contact is axis-aligned), else numbered from 1
        (with ``mode_<i>``, its direction, when ``with_directions``)."""
        m = len(axes)
        D = np.abs(self.directions)
        aligned = bool(np.all(np.abs(D.max(axis=1) - 1.0) < 1e-9)) and len(set(D.argmax(axis=1).tolist())) == m
        out: dict[str, Any] = {}
        for i in range(m):
            name = axes[int(D[i].argmax())] if aligned else str(i + 1)
            out[f"omega_n_{name}"] = float(self.natural_frequencies[i])
            out[f"zeta_{name}"] = float(self.damping_ratios[i])
            if with_directions and not aligned:
                out[f"mode_{name}"] = [float(v) for v in self.directions[i]]
        return out


def _model_inputs(inertia: Any, damping: Any, stiffness: Any, environment_stiffness: Any, desired: Any, rest: Any,
                  environment_damping: Any) -> tuple[np.ndarray, ...]:
    """The checked (x_d, x_r, M_d, K_D, K_P, K, D_e) of the linear impedance model (D_e = 0 when None)."""
    x_d = as_vector("desired", desired)
    m = x_d.shape[0]
    x_r = as_vector("rest", rest, m)
    return (x_d, x_r, *_gains(inertia, damping, stiffness, environment_stiffness, environment_damping, m))


def _gains(inertia: Any, damping: Any, stiffness: Any, environment_stiffness: Any, environment_damping: Any,
           m: int) -> tuple[np.ndarray, ...]:
    """The checked (M_d, K_D, K_P, K, D_e) of an m-axis impedance model (D_e = 0 when None)."""
    M = as_gain_matrix("inertia", inertia, m)
    D = as_gain_matrix("damping", damping, m, definite=False)
    KP = as_gain_matrix("stiffness", stiffness, m)
    return (M, D, KP, *environment_matrices(environment_stiffness, environment_damping, m))


def environment_matrices(environment_stiffness: Any, environment_damping: Any, m: int) -> tuple[np.ndarray, np.ndarray]:
    """The checked (K, D_e) of a linear environment of m axes, symmetric positive semi-definite (D_e = 0 when None)."""
    K = as_gain_matrix("environment_stiffness", environment_stiffness, m, definite=False)
    De = np.zeros((m, m)) if environment_damping is None else as_gain_matrix(
        "environment_damping", environment_damping, m, definite=False)
    return K, De


def impedance_modes(inertia: Any, damping: Any, stiffness: Any, environment_stiffness: Any, desired: Any, rest: Any,
                    *, one_sided_normal: Any = None, environment_damping: Any = None) -> ImpedanceModes:
    """Equilibrium, ω_n and ζ of the impedance (9.32) on ``h_e = K (x_e − x_r) + D_e ẋ_e``, for any K.

    Args:
        inertia, damping, stiffness: M_d [kg], K_D [N s/m], K_P [N/m], symmetric (m, m).
        environment_stiffness: K, symmetric positive semi-definite (m, m) [N/m] (base frame).
        desired: x_d (m,) [m]; rest: x_r, a point of the undeformed environment (m,) [m].
        one_sided_normal: the outward normal of a one-sided environment (a plane): if the
            equilibrium in contact would not penetrate it, the free equilibrium is returned.
        environment_damping: D_e, symmetric positive semi-definite (m, m) [N s/m] (default 0):
            it adds to K_D in the closed loop (its force is measured like the spring's).
    """
    x_d, x_r, M, D, KP, K, De = _model_inputs(inertia, damping, stiffness, environment_stiffness, desired, rest,
                                              environment_damping)
    m = x_d.shape[0]
    in_contact = True
    x = np.linalg.solve(KP + K, KP @ x_d + K @ x_r)
    if one_sided_normal is not None:
        nrm = as_vector("one_sided_normal", one_sided_normal, m)
        if float(nrm @ (x_r - x)) <= 0.0:  # no penetration at the contact equilibrium: free motion
            K = np.zeros((m, m))
            De = np.zeros((m, m))
            x = x_d.copy()
            in_contact = False
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-Minv @ (KP + K), -Minv @ (D + De)]])
    lam = np.linalg.eigvals(A)
    # pair the 2m eigenvalues into m modes: complex pairs by conjugacy, real ones by size
    cplx = sorted((v for v in lam if v.imag > 1e-9 * max(1.0, abs(v))), key=abs)
    real = sorted(float(v.real) for v in lam if abs(v.imag) <= 1e-9 * max(1.0, abs(v)))
    wn, zeta = [], []
    for v in cplx:
        wn.append(abs(v))
        zeta.append(-v.real / abs(v))
    for i in range(0, len(real) - 1, 2):
        a, b = real[i], real[i + 1]
        w = math.sqrt(a * b) if a * b > 0 else 0.0
        wn.append(w)
        zeta.append(-(a + b) / (2.0 * w) if w > 0 else math.inf)
    order = np.argsort(wn)
    w2, vec = np.linalg.eig(Minv @ (KP + K))
    vec = np.real(vec[:, np.argsort(np.real(w2))]).T
    vec = vec / np.linalg.norm(vec, axis=1, keepdims=True)
    return ImpedanceModes(
        position=x, contact_force=K @ (x - x_r), natural_frequencies=np.asarray(wn)[order],
        damping_ratios=np.asarray(zeta)[order], directions=vec, in_contact=in_contact,
    )


def impedance_response(inertia: Any, damping: Any, stiffness: Any, environment_stiffness: Any, desired: Any, rest: Any,
                       start: Any, times: Any, *, environment_damping: Any = None, sample_time: float | None = None,
                       mobility: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """The transient of the linear model of :func:`impedance_modes` from rest at ``start``.

    ``M_d ẍ + (K_D + D_e) ẋ + (K_P + K) x = K_P x_d + K x_r`` with constant x_d, solved exactly
    (``scipy.linalg.expm`` of the state matrix), ``x(0) = start``, ``ẋ(0) = 0``.

    With ``sample_time`` and ``mobility`` (the arm's ``M = J B⁻¹ Jᵀ`` at the start, (m, m)): the
    loop as a controller runs it, sampled. The law (9.31) reads x_k, ẋ_k and h_k at t_k = k Ts,
    and the torque is held until t_{k+1} while the environment pushes with h(t), so between
    samples ``ẍ = a_k + M (h_k − h(t))`` (:func:`impedance_loop`, :func:`held_input_response`). As
    Ts → 0 this is the continuous model.

    Returns:
        (x (N, m) [m], h_e = K (x − x_r) + D_e ẋ (N, m) [N]) at ``times`` [s].
    """
    from scipy.linalg import expm  # type: ignore[import-untyped]

    x_d, x_r, M, D, KP, K, De = _model_inputs(inertia, damping, stiffness, environment_stiffness, desired, rest,
                                              environment_damping)
    m = x_d.shape[0]
    x0 = as_vector("start", start, m)
    Minv = np.linalg.inv(M)
    if (sample_time is None) != (mobility is None):
        raise ParameterError("sample_time and mobility go together (the sampled loop needs both); "
                             f"got sample_time={sample_time!r} and mobility {'None' if mobility is None else 'given'}")
    if sample_time is not None:
        loop = impedance_loop(M, D, KP, K, as_matrix("mobility", mobility, (m, m)), environment_damping=De)
        z = held_input_response(loop.A, loop.B, loop.F, loop.input(x_d, x_r), sample_time,
                                np.concatenate([x0, np.zeros(m)]), times)
        x = z[:, :m]
        return x, (x - x_r) @ K.T + z[:, m:] @ De.T
    x_e = np.linalg.solve(KP + K, KP @ x_d + K @ x_r)
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-Minv @ (KP + K), -Minv @ (D + De)]])
    z0 = np.concatenate([x0 - x_e, np.zeros(m)])
    t = np.asarray(times, dtype=np.float64)
    z = np.array([expm(A * ti) @ z0 for ti in t]).reshape(len(t), 2 * m)
    x = x_e + z[:, :m]
    return x, (x - x_r) @ K.T + z[:, m:] @ De.T


def contact_plant(mobility: Any, environment_stiffness: Any, environment_damping: Any) -> tuple[np.ndarray, np.ndarray]:
    """The arm on a linear environment between two samples, for :func:`held_input_response`.

    With the held input ``v`` (the commanded acceleration plus ``M`` times what the controller
    cancels at the sample): ``ẍ = v − M (K x + D ẋ)``, state ``[x; ẋ]``; ``M = J B⁻¹ Jᵀ`` the
    mobility (m, m), K and D the environment's stiffness and damping (m, m).

    Returns:
        (A (2m, 2m), B (2m, m)).
    """
    Mob, K, D = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (mobility, environment_stiffness,
                                                                          environment_damping))
    m = Mob.shape[0]
    I, Z = np.eye(m), np.zeros((m, m))
    return np.block([[Z, I], [-Mob @ K, -Mob @ D]]), np.vstack([Z, I])


def held_input_response(A: Any, B: Any, F: Any, g: Any, sample_time: float, start: Any, times: Any, *,
                        controller: tuple[Any, Any, Any, Any] | None = None) -> np.ndarray:
    """The sampled-data response of ``ż = A z + B v`` with ``v = F z_k + g`` held over each sample.

    The controller reads the state at ``t_k = k Ts`` and its output is held until ``t_{k+1}``
    (zero-order hold), as in the simulator; between samples the plant evolves in continuous
    time. Exact for the linear model: ``z(t_k + τ) = Φ(τ) z_k + Γ(τ) v_k`` with
    ``[Φ Γ; 0 I] = expm([A B; 0 0] τ)`` (``scipy.linalg.expm``).

    Args:
        A: (n, n); B: (n, p); F: (p, n); g: (p,); sample_time: Ts > 0 [s]; start: z(0) (n,);
        times: where to evaluate [s], >= 0.
        controller: ``(H, S, T, r)`` for a controller with its own discrete state s (s_0 = 0):
            ``v_k = F z_k + H s_k + g`` and ``s_{k+1} = S s_k + T z_k + r`` (e.g. the compliant
            frame of admittance control (9.37), integrated by the controller at each sample).

    Returns:
        z at ``times``, (N, n).
    """
    A, B, F = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (A, B, F))
    g = np.atleast_1d(np.asarray(g, dtype=np.float64))
    Ts = positive_scalar("sample_time", sample_time, "s")
    n, p = B.shape
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if t.size and (not np.all(np.isfinite(t)) or t.min() < 0.0):
        raise ParameterError(f"times must be finite and >= 0 [s]; got min {t.min()!r}")
    if controller is None:
        H, S, T, r = np.zeros((p, 0)), np.zeros((0, 0)), np.zeros((0, n)), np.zeros(0)
    else:
        H, S, T = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in controller[:3])
        r = np.atleast_1d(np.asarray(controller[3], dtype=np.float64))
        ns = S.shape[0]
        if S.shape != (ns, ns) or H.shape != (p, ns) or T.shape != (ns, n) or r.shape != (ns,):
            raise DimensionError(
                f"controller (H, S, T, r) must have shapes ({p}, s), (s, s), (s, {n}), (s,); got "
                f"{H.shape}, {S.shape}, {T.shape}, {r.shape}"
            )

    def hold(tau: float) -> tuple[np.ndarray, np.ndarray]:
        return _hold(A, B, tau)

    Phi, Gam = hold(Ts)
    k_of = np.floor(t / Ts + 1e-9).astype(np.int64)
    z = as_vector("start", start, n).copy()
    s = np.zeros(S.shape[0])
    out = np.empty((t.size, n))
    order = np.argsort(k_of, kind="stable")
    k = 0
    for i in order:
        while k < k_of[i]:
            z, s = Phi @ z + Gam @ (F @ z + H @ s + g), S @ s + T @ z + r
            k += 1
        tau = float(t[i] - k * Ts)
        if tau <= 1e-12 * Ts:
            out[i] = z
        else:
            P, G = hold(tau)
            out[i] = P @ z + G @ (F @ z + H @ s + g)
    return out


def _hold(A: np.ndarray, B: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Φ(τ), Γ(τ))`` from ``expm([A B; 0 0] τ)`` (A (n, n), B (n, p) already float arrays)."""
    from scipy.linalg import expm  # type: ignore[import-untyped]

    n, p = B.shape
    E = expm(np.block([[A, B], [np.zeros((p, n)), np.zeros((p, p))]]) * tau)
    return E[:n, :n], E[:n, n:]


def held_input_matrices(A: Any, B: Any, sample_time: float) -> tuple[np.ndarray, np.ndarray]:
    """The zero-order hold of ``ż = A z + B v`` over one sample: ``z_{k+1} = Φ z_k + Γ v_k``.

    ``[Φ Γ; 0 I] = expm([A B; 0 0] Ts)`` (``scipy.linalg.expm``), the map :func:`held_input_response`
    steps with.

    Args:
        A: (n, n); B: (n, p); sample_time: Ts > 0 [s].

    Returns:
        (Φ (n, n), Γ (n, p)).
    """
    A, B = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (A, B))
    Ts = positive_scalar("sample_time", sample_time, "s")
    if A.shape != (A.shape[0], A.shape[0]) or B.shape[0] != A.shape[0]:
        raise DimensionError(f"A must be square (n, n) and B (n, p); got shapes {A.shape} and {B.shape}")
    return _hold(A, B, Ts)


@dataclass(frozen=True)
class HeldLoop:
    """A control law held over each sample on the arm in contact with a linear environment.

    Between two samples the plant is ``ż = A z + B v`` (:func:`contact_plant`, state ``z = [x; ẋ]``,
    (2m,)); the controller reads z_k at ``t_k = k Ts`` and holds ``v_k = F z_k + G_d x_d + G_r x_r``
    until ``t_{k+1}`` (zero-order hold, as the simulator runs it). Discretised exactly, the closed
    loop is ``z_{k+1} = (Φ + Γ F) z_k + Γ g`` (:func:`held_input_matrices`); as Ts → 0 it tends to the
    continuous loop ``ż = (A + B F) z + B g``.

    Attributes:
        A: (2m, 2m); B: (2m, m); F: (m, 2m); desired_gain: G_d (m, m); rest_gain: G_r (m, m).
    """

    A: np.ndarray
    B: np.ndarray
    F: np.ndarray
    desired_gain: np.ndarray
    rest_gain: np.ndarray

    @property
    def m(self) -> int:
        """The task dimension m (the state has 2m entries)."""
        return int(self.B.shape[1])

    def input(self, desired: Any, rest: Any) -> np.ndarray:
        """The constant part of the held input, ``g = G_d x_d + G_r x_r`` (m,)."""
        return self.desired_gain @ as_vector("desired", desired, self.m) + self.rest_gain @ as_vector("rest", rest, self.m)

    def continuous(self) -> np.ndarray:
        """``A + B F``: the loop's state matrix as Ts → 0 (2m, 2m) [1/s, 1/s²]."""
        return self.A + self.B @ self.F

    def closed(self, sample_time: float) -> np.ndarray:
        """``Φ + Γ F``: the sampled closed loop's state matrix over one sample Ts [s] (2m, 2m)."""
        Phi, Gam = held_input_matrices(self.A, self.B, sample_time)
        return Phi + Gam @ self.F

    def spectral_radius(self, sample_time: float) -> float:
        """The largest |eigenvalue| of :meth:`closed` (< 1: the sampled loop is stable)."""
        return float(np.max(np.abs(np.linalg.eigvals(self.closed(sample_time)))))


def impedance_loop(inertia: Any, damping: Any, stiffness: Any, environment_stiffness: Any, mobility: Any, *,
                   environment_damping: Any = None, force_measurement: bool = True) -> HeldLoop:
    """Impedance control (9.30)–(9.31), or (9.28) without force measurement, held over each sample on
    ``h_e = K (x − x_r) + D_e ẋ``.

    The inner loop (9.30) makes ``ẍ = a_k`` at the sample, where it cancels the measured h_k with
    ``Jᵀ h_k`` (9.30); while the torque is held the environment pushes with h(t), which acts on the
    arm's mobility ``M = J B⁻¹ Jᵀ``: ``ẍ = a_k + M (h_k − h(t))``. Without force measurement (9.28)
    nothing is cancelled: ``ẍ = a_k − M h(t)``. With ``a_k = M_d⁻¹ (K_P (x_d − x_k) − K_D ẋ_k [− h_k])``
    ((9.31) corrected, constant x_d) and the plant ``ẍ = v − M (K x + D_e ẋ)`` (:func:`contact_plant`):

    * (9.31): ``F = [−M_d⁻¹ K_P + (M − M_d⁻¹) K,  −M_d⁻¹ K_D + (M − M_d⁻¹) D_e]``,
      ``G_d = M_d⁻¹ K_P``, ``G_r = M_d⁻¹ K``; the continuous limit is the impedance (9.32);
    * (9.28): ``F = [−M_d⁻¹ K_P, −M_d⁻¹ K_D]``, ``G_d = M_d⁻¹ K_P``, ``G_r = M K``; the continuous
      limit is (9.29), coupled through ``B_A⁻¹ = M`` (taken at one pose).

    Args:
        inertia, damping, stiffness: M_d [kg], K_D [N s/m], K_P [N/m], symmetric (m, m) (scalar or
            (m,) allowed).
        environment_stiffness: K, symmetric positive semi-definite (m, m) [N/m] (base frame).
        mobility: ``M = J B⁻¹ Jᵀ`` at the pose considered, (m, m) [1/kg].
        environment_damping: D_e (m, m) [N s/m] (default 0).
        force_measurement: (9.30)–(9.31) (True) or (9.28) (False).
    """
    Mob = np.atleast_2d(np.asarray(mobility, dtype=np.float64))
    m = Mob.shape[0]
    Mob = as_matrix("mobility", Mob, (m, m))
    M, D, KP, K, De = _gains(inertia, damping, stiffness, environment_stiffness, environment_damping, m)
    Minv = np.linalg.inv(M)
    A, B = contact_plant(Mob, K, De)
    if force_measurement:
        F = np.hstack([-Minv @ KP + (Mob - Minv) @ K, -Minv @ D + (Mob - Minv) @ De])
        rest_gain = Minv @ K
    else:
        F = np.hstack([-Minv @ KP, -Minv @ D])
        rest_gain = Mob @ K
    return HeldLoop(A, B, F, Minv @ KP, rest_gain)
