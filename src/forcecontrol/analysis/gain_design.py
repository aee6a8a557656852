"""Gain design: candidate gains from a wanted ω_n and ζ, checked on the sampled loop's margins and settling time."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.validate import nonnegative_scalar, positive_scalar, stiffness_range_arg
from ..errors import ParameterError
from .design import DESIGN_SCHEMES, loop_model
from .force_design import design_force_gains

__all__ = ["GainDesign", "design_gains"]


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
            :func:`~forcecontrol.analysis.force_design.operational_mass`), or None.

    Returns:
        A :class:`GainDesign` (gains and the margins/settling at k_min, √(k_min k_max), k_max).

    Raises:
        ParameterError: bad arguments, or no candidate meets the margins, or the settling target
            is missed (the message gives the best achievable).
    """
    if scheme not in DESIGN_SCHEMES:
        raise ParameterError(f"scheme must be one of {list(DESIGN_SCHEMES)}; got {scheme!r}")
    k_min, k_max = stiffness_range_arg(stiffness_range)
    Ts = positive_scalar("sample_time", sample_time)
    pm_req = positive_scalar("phase_margin", phase_margin, "deg")
    if pm_req >= 180.0:  # a phase margin is at most 180 deg by definition: no gains could meet it
        raise ParameterError(f"phase_margin must be below 180 deg; got {phase_margin!r}")
    gm_req = nonnegative_scalar("gain_margin", gain_margin)
    zeta = positive_scalar("damping_ratio", damping_ratio)
    inertia = positive_scalar("inertia", inertia)
    stiffness = positive_scalar("stiffness", stiffness)
    if settling_time is not None:
        settling_time = positive_scalar("settling_time", settling_time)
    if filter_cutoff is not None:  # None: no filter; a cutoff of 0 Hz would pass nothing
        filter_cutoff = positive_scalar("filter_cutoff", filter_cutoff, "Hz")
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
