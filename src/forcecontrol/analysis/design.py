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
stiffness k_max (:func:`~forcecontrol.analysis.force.design_force_gains`: ζ, and the PI's real
pole at ω_n) and scan ω_n; impedance scans K_D (M_d, K_P are the task's). The fastest
candidate (smallest worst-case settling time) whose margins hold at the three stiffnesses is
returned; if none does, or the settling target is missed, a :class:`ParameterError` says what is
achievable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._lazy import lazy_import
from .._validate import nonnegative_scalar, positive_scalar
from ..errors import ParameterError
from .force_design import design_force_gains

control = lazy_import("control")

__all__ = ["DESIGN_SCHEMES", "LoopModel", "GainDesign", "design_gains", "loop_model"]

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
        """The 2 % settling time of the true force's step response [s] (:func:`forcecontrol.metrics.step_metrics`).

        The final value is exact (``F (I − A_cl)⁻¹ E``); ``inf`` when unstable or not settled
        within the horizon (default: 20 time constants of the slowest pole, at most 60 s).
        """
        from ..metrics import step_metrics

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


@dataclass(frozen=True)
class GainDesign:
    """Gains of one scheme over a stiffness range, with what they achieve at its ends.

    Attributes:
        scheme: the scheme.
        gains: named gains (scenario keys: ``inertia, damping, stiffness, force_gain,
            integral_gain`` for the force schemes; ``inertia, damping, stiffness`` for impedance;
            ``force_gain, force_rate_gain, nominal_stiffness`` for hybrid (K_Pλ, K_Dλ, k_nom)).
        stiffness_range: (k_min, k_max) [N/m].
        checks: per evaluated stiffness: ``k``, ``gain_margin_db``, ``phase_margin_deg``,
            ``settling_time`` [s], ``spectral_radius``.
        requirements: the margins and target asked for, and the sampling/sensor model.
    """

    scheme: str
    gains: dict[str, float]
    stiffness_range: tuple[float, float]
    checks: list[dict[str, float]]
    requirements: dict[str, Any] = field(default_factory=dict)

    @property
    def worst_settling_time(self) -> float:
        """max settling time over the evaluated stiffnesses [s]."""
        return max(c["settling_time"] for c in self.checks)

    def as_dict(self) -> dict[str, Any]:
        """Plain values (for JSON)."""
        return {"scheme": self.scheme, "gains": dict(self.gains), "stiffness_range": list(self.stiffness_range),
                "checks": [dict(c) for c in self.checks], "requirements": dict(self.requirements)}

    def scenario_toml(self, name: str | None = None, *, axis_force: float = 10.0) -> str:
        """A scenario (TOML) on the chapter's arm: the plane x = 1, one case per evaluated stiffness.

        The force schemes ask f_d = axis_force [N] along x (the gains on x; y keeps Example 9.3's
        motion gains); impedance presses to x_d = 1 + 2 axis_force / K_P; hybrid pushes λ_d =
        −axis_force into the plane (normal along −x).
        """
        name = name or f"designed-{self.scheme}"
        g = self.gains
        lines = [
            f'name = "{name}"',
            f'title = "{self.scheme} gains designed for k in [{self.stiffness_range[0]:g}, {self.stiffness_range[1]:g}] N/m"',
            'description = """',
            "Written by `forcecontrol design`: "
            + ", ".join(f"{c['k']:g} N/m: PM {c['phase_margin_deg']:.1f} deg, GM {c['gain_margin_db']:.1f} dB, "
                        f"settling {c['settling_time']:.3f} s" for c in self.checks),
            '"""',
            f"duration = {max(2.0, 1.5 * self.worst_settling_time):.3g}",
            f"sample_time = {self.requirements.get('sample_time', 1e-3):g}",
            "",
            "[robot]", 'model = "chapter-arm"', "start_position = [1.0, 0.0]", 'elbow = "up"', "",
            "[environment]", 'type = "elastic-plane"', "point = [1.0, 0.0]", "normal = [-1.0, 0.0]",
            f"stiffness = {self.stiffness_range[1]:g}", "",
            "[controller]",
        ]
        if self.scheme == "impedance":
            lines += ['type = "impedance"', "force_measurement = true", f"inertia = [{g['inertia']:g}, {g['inertia']:g}]",
                      f"damping = [{g['damping']:g}, {g['damping']:g}]", f"stiffness = [{g['stiffness']:g}, {g['stiffness']:g}]",
                      "", "[reference]", 'type = "setpoint"',
                      f"position = [{1.0 + 2.0 * axis_force / g['stiffness']:.6g}, 0.0]"]
        elif self.scheme == "hybrid":
            lines += ['type = "hybrid-compliant"', "angle = 90.0", "velocity_gain = 100.0", "velocity_integral_gain = 2500.0",
                      f"force_gain = {g['force_gain']:g}", f"force_rate_gain = {g['force_rate_gain']:g}",
                      f"compliance = {1.0 / g['nominal_stiffness']:g}",
                      "", "[reference]", 'type = "path-on-plane"', "start = [1.0, 0.0]", "end = [1.0, 0.0]",
                      "duration = 1.0", "angle = 90.0", f"normal_force = {-axis_force:g}"]
        else:
            lines += [f'type = "{self.scheme}"', f"inertia = [{g['inertia']:g}, 100.0]", f"damping = [{g['damping']:g}, 500.0]",
                      f"stiffness = [{g['stiffness']:g}, 2500.0]", f"force_gain = [{g['force_gain']:.6g}, 0.0]"]
            if self.scheme != "inner-velocity":
                lines.append(f"integral_gain = [{g['integral_gain']:.6g}, 0.0]")
                lines.append('integrator_start = "hold"' if self.scheme == "inner-position" else 'integrator_start = "zero"')
            lines += ["", "[reference]", 'type = "setpoint"', "position = [1.0, 0.0]", f"force = [{axis_force:g}, 0.0]"]
        cutoff, delay = self.requirements.get("filter_cutoff"), int(self.requirements.get("delay_samples") or 0)
        if cutoff is not None or delay:  # the sensor the gains were designed for
            lines += ["", "[sensor]"]
            if cutoff is not None:
                lines += ['filter = "first-order"', f"cutoff = {cutoff:g}"]
            if delay:
                lines.append(f"delay_samples = {delay}")
        lines += ["", "[figure]", f'title = "{self.scheme}: designed gains over the stiffness range"', 'signals = ["x", "fx"]']
        for c in self.checks:
            lines += ["", "[[case]]", f'label = "k = {c["k"]:g} N/m"', f"environment.stiffness = {c['k']:g}"]
        return "\n".join(lines) + "\n"


def _candidate_gains(scheme: str, wn: float, zeta: float, k_ref: float, inertia: float, stiffness: float) -> dict[str, float]:
    if scheme == "hybrid":
        return {"force_gain": wn * wn, "force_rate_gain": 2.0 * zeta * wn, "nominal_stiffness": k_ref}
    if scheme == "inner-velocity":
        fg = design_force_gains(scheme, inertia, stiffness, k_ref, wn, zeta)
        return {"inertia": inertia, "damping": fg.damping, "stiffness": stiffness, "force_gain": fg.force_gain,
                "integral_gain": 0.0}
    fg = design_force_gains(scheme, inertia, stiffness, k_ref, wn, zeta, real_pole=wn)
    return {"inertia": inertia, "damping": fg.damping, "stiffness": stiffness, "force_gain": fg.force_gain,
            "integral_gain": fg.integral_gain}


def design_gains(
    scheme: str,
    stiffness_range: tuple[float, float],
    sample_time: float = 1e-3,
    *,
    delay_samples: int = 0,
    filter_cutoff: float | None = None,
    phase_margin: float = 45.0,
    gain_margin: float = 6.0,
    settling_time: float | None = None,
    damping_ratio: float = 0.8,
    inertia: float = 100.0,
    stiffness: float = 2500.0,
    arm_inertia: float | None = None,
) -> GainDesign:
    """Gains for ``scheme`` that keep the margins over [k_min, k_max] and settle fastest.

    Args:
        scheme: one of :data:`DESIGN_SCHEMES`.
        stiffness_range: (k_min, k_max) [N/m], 0 < k_min <= k_max.
        sample_time: Ts [s]; delay_samples: sensor delay [samples]; filter_cutoff: the sensor's
            first-order cutoff [Hz] or None.
        phase_margin: required phase margin [deg]; gain_margin: required gain margin [dB].
        settling_time: required worst-case 2 % settling time [s], or None (as fast as the
            margins allow).
        damping_ratio: ζ of the placed poles (force schemes and hybrid), > 0.
        inertia: M_d / m_d [kg]; stiffness: K_P / k_P [N/m] (kept: the task's choice; the force
            schemes' position loop, the impedance's free-space stiffness).
        arm_inertia: the arm's operational mass along the axis [kg] (see
            :func:`~forcecontrol.analysis.force.operational_mass`), or None.

    Returns:
        A :class:`GainDesign` (gains and the margins/settling at k_min, √(k_min k_max), k_max).

    Raises:
        ParameterError: bad arguments, or no candidate meets the margins, or the settling target
            is missed (the message gives the best achievable).
    """
    if scheme not in DESIGN_SCHEMES:
        raise ParameterError(f"scheme must be one of {list(DESIGN_SCHEMES)}; got {scheme!r}")
    try:
        k_min, k_max = (float(v) for v in stiffness_range)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"stiffness_range must be (k_min, k_max) in N/m; got {stiffness_range!r}") from exc
    if not (0.0 < k_min <= k_max < math.inf):
        raise ParameterError(f"stiffness_range must satisfy 0 < k_min <= k_max < inf; got {stiffness_range!r}")
    Ts = positive_scalar("sample_time", sample_time)
    pm_req = positive_scalar("phase_margin", phase_margin)
    gm_req = nonnegative_scalar("gain_margin", gain_margin)
    zeta = positive_scalar("damping_ratio", damping_ratio)
    inertia = positive_scalar("inertia", inertia)
    stiffness = positive_scalar("stiffness", stiffness)
    if settling_time is not None:
        settling_time = positive_scalar("settling_time", settling_time)
    ks = sorted({k_min, math.sqrt(k_min * k_max), k_max})
    opts = {"delay_samples": delay_samples, "filter_cutoff": filter_cutoff, "arm_inertia": arm_inertia}

    def evaluate(gains: dict[str, float], bound: float) -> list[dict[str, float]] | None:
        """Checks at each k, or None when a margin fails or the settling exceeds ``bound``."""
        out, models = [], []
        for k in ks:
            model = loop_model(scheme, gains, k, Ts, **opts)
            rho = model.spectral_radius()
            if rho >= 1.0:
                return None
            gm, pm = model.margins()
            if gm < gm_req or pm < pm_req:
                return None
            out.append({"k": k, "gain_margin_db": gm, "phase_margin_deg": pm, "spectral_radius": rho})
            models.append(model)
        for c, model in zip(out, models):
            c["settling_time"] = model.settling_time()
            if c["settling_time"] >= bound:
                return None
        return out

    if scheme == "impedance":
        # scan K_D: from light damping at k_max up to heavy damping at k_min
        lo = 0.2 * math.sqrt(inertia * (stiffness + k_max))
        hi = 8.0 * math.sqrt(inertia * (stiffness + k_max))
        candidates = [{"inertia": inertia, "damping": float(kd), "stiffness": stiffness} for kd in np.geomspace(lo, hi, 40)]
    else:
        nyquist = math.pi / Ts
        candidates = []
        for wn in np.geomspace(0.5, 0.5 * nyquist, 60):
            try:
                candidates.append(_candidate_gains(scheme, float(wn), zeta, k_max, inertia, stiffness))
            except ParameterError:
                continue  # e.g. the PI would need k_F < 0 at this ω_n
    best: tuple[float, dict[str, float], list[dict[str, float]]] | None = None
    for gains in candidates:
        checks = evaluate(gains, math.inf if best is None else best[0])
        if checks is None:
            continue
        worst = max(c["settling_time"] for c in checks)
        if best is None or worst < best[0]:
            best = (worst, gains, checks)
    req = {"phase_margin_deg": pm_req, "gain_margin_db": gm_req, "settling_time": settling_time, "sample_time": Ts,
           "delay_samples": int(delay_samples), "filter_cutoff": filter_cutoff, "arm_inertia": arm_inertia,
           "damping_ratio": zeta}
    if best is None:
        raise ParameterError(
            f"no {scheme} gains keep a phase margin >= {pm_req:g} deg and a gain margin >= {gm_req:g} dB over "
            f"k in [{k_min:g}, {k_max:g}] N/m with Ts = {Ts:g} s, delay {delay_samples} samples, filter "
            f"{filter_cutoff if filter_cutoff is not None else 'none'}: lower the margins, narrow the range, "
            "sample faster or reduce the sensor delay/filtering"
        )
    worst, gains, checks = best
    if settling_time is not None and worst > settling_time:
        raise ParameterError(
            f"settling_time = {settling_time:g} s cannot be met by the {scheme} scheme over k in [{k_min:g}, {k_max:g}] N/m "
            f"with the required margins (PM >= {pm_req:g} deg, GM >= {gm_req:g} dB); the fastest design settles in "
            f"{worst:.3g} s (gains {({k: round(v, 6) for k, v in gains.items()})})"
        )
    return GainDesign(scheme, gains, (k_min, k_max), checks, req)
