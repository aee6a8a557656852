"""Gain design over an environment-stiffness range, with sampling, sensor delay and filter.

A user rarely knows the stiffness of the surface; they know a range [k_min, k_max]. This module
gives each scheme's gains that keep a stated phase and gain margin over the whole range and
settle as fast as those margins allow, from the sampled-data loop of one contact axis:

* the plant: exact inverse dynamics leaves ``ẍ = a`` over each sample (zero-order hold); if the
  arm's operational mass m_x along the axis is given, the force change within a sample (not
  compensated, since the inner loop adds Jᵀ h_m held from t_k) acts on it:
  ``ẍ = a + (w − k x) / m_x`` (as :meth:`ForceLoopAxis.sampled`);
* the contact: ``f = k x`` (x: penetration [m]) (9.38);
* the sensor: ``d`` samples of delay, then the library's first-order filter
  ``h_k = h_{k−1} + α (f_{k−d} − h_{k−1})`` (``α`` from the cutoff as
  :func:`forcecontrol.sensors.first_order_alpha`); the controller reads ``w = h_k``;
* the law at t_k, per scheme (x̃ = x_d − x, e = f_d − w):

  - ``"inner-velocity"`` (9.45)–(9.46): ``m_d a = −k_D ẋ + k_P k_F e``;
  - ``"inner-position"`` (9.40)–(9.43) and ``"parallel"`` (9.48):
    ``m_d a = −k_D ẋ + k_P (k_F e + ξ − x)``, ``ξ_{k+1} = ξ_k + Ts k_I e`` (same loop);
  - ``"impedance"`` with force measurement (9.30)–(9.31): ``M_d a = K_D x̃̇ + K_P x̃ − w``;
  - ``"hybrid"`` on a compliant surface, force subspace (9.81) with the nominal stiffness
    k_nom (Ĉ = 1/k_nom) of (9.82): ``a = (K_Dλ (λ̇_d − k_nom ẋ) + K_Pλ (λ_d − w)) / k_nom``
    (so that ``λ̈ + K_Dλ λ̇ + (k/k_nom) K_Pλ λ = …``, (9.84)).

The loop is broken at the force the controller reads (w): its loop transfer function L(z) goes
to ``control.stability_margins`` for the gain and phase margins, and the closed loop's step
response (f_d, or x_d for impedance) gives the settling time: the last time the true force is
outside ±2 % of its final value. Margins and settling are evaluated at k_min, √(k_min k_max)
and k_max.

The search, per scheme: the force schemes place the continuous poles at the reference
stiffness k_max (:func:`~forcecontrol.analysis.force_design.design_force_gains`: ζ, and the PI's real
pole at ω_n) and scan ω_n; impedance scans K_D (M_d, K_P are the task's). The fastest
candidate (smallest worst-case settling time) whose margins hold at the three stiffnesses is
returned; if none does, or the settling target is missed, a :class:`ParameterError` says what is
achievable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.lazy import lazy_import
from ..core.validate import positive_scalar
from ..errors import ParameterError

control = lazy_import("control")

__all__ = ["DESIGN_SCHEMES", "LoopModel", "loop_model"]

#: the schemes :func:`design_gains` covers.
DESIGN_SCHEMES: tuple[str, ...] = ("impedance", "inner-position", "inner-velocity", "parallel", "hybrid")


@dataclass(frozen=True)
class LoopModel:
    """The sampled loop of one contact axis at one environment stiffness (see the module text).

    Attributes:
        A: open-loop state matrix (the loop cut at the force the controller reads).
        B: how that force w enters; C: the measured force (sensor output), ``y = C z``.
        E: the reference input (f_d; x_d for impedance); F: the true force, ``f = F z``.
        sample_time: Ts [s].
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    E: np.ndarray
    F: np.ndarray
    sample_time: float

    @property
    def closed(self) -> np.ndarray:
        """Closed-loop state matrix ``A + B C`` (w = y)."""
        return self.A + np.outer(self.B, self.C)

    def spectral_radius(self) -> float:
        """Largest |eigenvalue| of the closed loop (< 1: stable)."""
        return float(np.max(np.abs(np.linalg.eigvals(self.closed))))

    def loop_transfer(self) -> Any:
        """L(z) for ``control.stability_margins`` (negative feedback: closed loop 1 / (1 + L))."""
        return control.ss(self.A, self.B.reshape(-1, 1), -self.C.reshape(1, -1), 0.0, self.sample_time)

    def frequency_response(self, omega: np.ndarray) -> np.ndarray:
        """L(e^{jωTs}) at the angular frequencies ω [rad/s] (up to the Nyquist frequency π/Ts)."""
        z = np.exp(1j * np.asarray(omega, dtype=np.float64) * self.sample_time)
        n = self.A.shape[0]
        M = z[:, None, None] * np.eye(n)[None] - self.A[None]
        rhs = np.broadcast_to(self.B.astype(complex), (z.size, n))[..., None]
        sol = np.linalg.solve(M, rhs)[..., 0]
        return -(sol @ self.C)

    def margins(self, points: int = 1500) -> tuple[float, float]:
        """(gain margin [dB], phase margin [deg]) of L(z); inf when the loop never crosses.

        From L on a logarithmic grid up to the Nyquist frequency (and at z = −1): the phase
        margin at every unit-gain crossing (interpolated), the gain margin at every crossing of
        the negative real axis; the smallest of each. Agrees with
        ``control.stability_margins(self.loop_transfer(), method="frd")`` (tested).
        """
        w_max = math.pi / self.sample_time
        w = np.geomspace(w_max * 1e-7, w_max, points)
        L = self.frequency_response(w)
        mag = np.abs(L)
        pm = math.inf
        lm = np.log(np.maximum(mag, 1e-300))
        phase = np.degrees(np.unwrap(np.angle(L)))  # continuous from the lowest frequency
        for i in np.flatnonzero(np.sign(lm[:-1]) != np.sign(lm[1:])):
            s = lm[i] / (lm[i] - lm[i + 1])
            ph = phase[i] + s * (phase[i + 1] - phase[i])
            pm = min(pm, (180.0 + ph + 180.0) % 360.0 - 180.0)  # in (−180, 180]: negative = unstable crossing
        gm = math.inf
        im = L.imag
        for i in np.flatnonzero(np.sign(im[:-1]) != np.sign(im[1:])):
            s = im[i] / (im[i] - im[i + 1])
            re = L[i].real + s * (L[i + 1].real - L[i].real)
            if re < 0.0:
                gm = min(gm, -20.0 * math.log10(-re))
        if L[-1].real < 0.0:  # z = −1, where L is real: the last point of the Nyquist plot
            gm = min(gm, -20.0 * math.log10(-L[-1].real))
        return gm, pm

    def step(self, duration: float) -> tuple[np.ndarray, np.ndarray]:
        """Times and true force of the closed loop's response to a unit reference step from rest.

        Propagated in blocks of 64 samples with precomputed powers of the closed-loop matrix.
        """
        n = int(round(duration / self.sample_time)) + 1
        Acl = self.closed
        nz = Acl.shape[0]
        blk = 64
        # rows j = 0..blk-1: f_{k+j} = F A^j z_k + F S_j E, S_j = Σ_{i<j} A^i
        FA = np.empty((blk, nz))
        FS = np.empty(blk)
        P = np.eye(nz)
        S = np.zeros((nz, nz))
        for j in range(blk):
            FA[j] = self.F @ P
            FS[j] = self.F @ S @ self.E
            S = S + P
            P = Acl @ P
        SE = S @ self.E
        f = np.empty(n + blk)
        z = np.zeros(nz)
        for k0 in range(0, n, blk):
            f[k0 : k0 + blk] = FA @ z + FS
            z = P @ z + SE
        return np.arange(n) * self.sample_time, f[:n]

    def settling_time(self, band: float = 0.02, horizon: float | None = None) -> float:
        """The 2 % settling time of the true force's step response [s] (:func:`forcecontrol.sim.metrics.step_metrics`).

        The final value is exact (``F (I − A_cl)⁻¹ E``); ``inf`` when unstable or not settled
        within the horizon (default: 20 time constants of the slowest pole, at most 60 s).
        """
        from ..sim.metrics import step_metrics

        Acl = self.closed
        rho = float(np.max(np.abs(np.linalg.eigvals(Acl))))
        if rho >= 1.0:
            return math.inf
        if horizon is None:
            tau = -self.sample_time / math.log(max(rho, 1e-300)) if rho > 0 else self.sample_time
            horizon = min(60.0, max(1.0, 20.0 * tau))
        final = float(self.F @ np.linalg.solve(np.eye(Acl.shape[0]) - Acl, self.E))
        t, f = self.step(horizon)
        st = step_metrics(t, f, band=band, final=final).settling_time
        return st if math.isfinite(st) else math.inf


def _alpha(cutoff: float | None, sample_time: float) -> float:
    if cutoff is None:
        return 1.0
    from ..sensors import first_order_alpha

    return float(first_order_alpha("filter_cutoff", cutoff, sample_time))


def loop_model(
    scheme: str,
    gains: dict[str, float],
    environment_stiffness: float,
    sample_time: float,
    *,
    delay_samples: int = 0,
    filter_cutoff: float | None = None,
    arm_inertia: float | None = None,
) -> LoopModel:
    """The sampled loop of one axis for a scheme and its gains (names as :class:`GainDesign`).

    Args:
        scheme: one of :data:`DESIGN_SCHEMES`.
        gains: ``inertia, damping, stiffness, force_gain, integral_gain`` (force schemes),
            ``inertia, damping, stiffness`` (impedance), ``force_gain, force_rate_gain,
            nominal_stiffness`` (hybrid: K_Pλ, K_Dλ, k_nom).
        environment_stiffness: k [N/m], > 0.
        sample_time: Ts [s]; delay_samples: sensor delay d; filter_cutoff: the sensor's first-order
            cutoff [Hz] (None: no filter); arm_inertia: m_x [kg] (None: exact inverse dynamics).
    """
    if scheme not in DESIGN_SCHEMES:
        raise ParameterError(f"scheme must be one of {list(DESIGN_SCHEMES)}; got {scheme!r}")
    k = positive_scalar("environment_stiffness", environment_stiffness)
    Ts = positive_scalar("sample_time", sample_time)
    if isinstance(delay_samples, bool) or not isinstance(delay_samples, (int, np.integer)) or delay_samples < 0:
        raise ParameterError(f"delay_samples must be an integer >= 0; got {delay_samples!r}")
    d = int(delay_samples)
    alpha = _alpha(filter_cutoff, Ts)
    g = {name: float(v) for name, v in gains.items()}
    # the law as m a = −kd v − kx x − kw w + kxi ξ + kr r ; ξ⁺ = ξ + Ts ki (r − w)
    if scheme == "hybrid":
        kn = positive_scalar("nominal_stiffness", g["nominal_stiffness"])
        m, kd, kx, kw, kxi, kr, ki = 1.0, g["force_rate_gain"], 0.0, g["force_gain"] / kn, 0.0, g["force_gain"] / kn, 0.0
    elif scheme == "impedance":
        m, kd, kx, kw, kxi, kr, ki = g["inertia"], g["damping"], g["stiffness"], 1.0, 0.0, g["stiffness"], 0.0
    else:
        kp, kf = g["stiffness"], g["force_gain"]
        ki = g.get("integral_gain", 0.0) if scheme != "inner-velocity" else 0.0
        m, kd = g["inertia"], g["damping"]
        if scheme == "inner-velocity":
            kx, kw, kxi, kr = 0.0, kp * kf, 0.0, kp * kf
        else:
            kx, kw, kxi, kr = kp, kp * kf, (kp if ki > 0 else 0.0), kp * kf
    pi = ki > 0.0
    # state: x, v, [ξ], [h (filter memory, when α < 1)], D_1..D_d (delay line of the true force)
    filt = alpha < 1.0
    ix, iv = 0, 1
    ixi = 2 if pi else -1
    ih = 3 if pi else 2  # h's index (or where the delay line starts, minus one, without a filter)
    n = ih + (1 if filt else 0) + d
    i0 = ih + (1 if filt else 0)  # D_1
    # plant over one sample, inputs [a, w] (ZOH): a double integrator, or with the arm's mass
    if arm_inertia is None:
        Ad = np.array([[1.0, Ts], [0.0, 1.0]])
        Bd = np.array([[0.5 * Ts * Ts, 0.0], [Ts, 0.0]])
    else:
        from scipy.linalg import expm  # type: ignore[import-untyped]

        mx = positive_scalar("arm_inertia", arm_inertia)
        big = np.zeros((4, 4))
        big[:2, :2] = np.array([[0.0, 1.0], [-k / mx, 0.0]]) * Ts
        big[:2, 2:] = np.array([[0.0, 0.0], [1.0, 1.0 / mx]]) * Ts
        Ephi = expm(big)
        Ad, Bd = Ephi[:2, :2], Ephi[:2, 2:]
    # a = Gz z + gw w + gr r
    Gz = np.zeros(n)
    Gz[ix], Gz[iv] = -kx / m, -kd / m
    if pi:
        Gz[ixi] = kxi / m
    gw, gr = -kw / m, kr / m
    A = np.zeros((n, n))
    B = np.zeros(n)
    E = np.zeros(n)
    A[:2, :2] = Ad
    A[:2] += np.outer(Bd[:, 0], Gz)
    B[:2] = Bd[:, 0] * gw + Bd[:, 1]
    E[:2] = Bd[:, 0] * gr
    if pi:
        A[ixi, ixi] = 1.0
        B[ixi] = -Ts * ki
        E[ixi] = Ts * ki
    # the measured force y = (1 − α) h + α f_{k−d}; h⁺ = y; D⁺ = [k x, D_1 … D_{d−1}]
    C = np.zeros(n)
    if filt:
        C[ih] = 1.0 - alpha
    if d == 0:
        C[ix] += alpha * k
    else:
        C[i0 + d - 1] += alpha
        A[i0, ix] = k
        for j in range(1, d):
            A[i0 + j, i0 + j - 1] = 1.0
    if filt:
        A[ih] = C
    F = np.zeros(n)
    F[ix] = k
    return LoopModel(A, B, C, E, F, Ts)


