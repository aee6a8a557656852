"""Design of admittance control (9.37) on a position-interface arm over an environment-stiffness range.

The sampled loop of :mod:`.servo_loop` along the contact normal (IK ≈ identity at the operating
point, every joint with the same servo, the ideal realisation: then the loop does not depend on
the arm, which is why one design serves the chapter's arm, the UR5 and the Panda). K_Pt (the
task's free-space stiffness) and M_t are kept; the damping K_Dt is scanned, and the one that
keeps the required gain and phase margins at k_min, √(k_min k_max) and k_max with the fastest
worst-case 2 % settling time (from the slowest closed-loop pole, ``t_s = T ln 50 / (−ln ρ)``)
is returned. ``--out`` writes a runnable scenario for the chosen robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.validate import nonnegative_scalar, positive_scalar, stiffness_range_arg
from ..errors import ParameterError
from .gain_design import GainDesign
from .servo_loop import ServoLoop

__all__ = ["ServoGainDesign", "design_admittance_servo", "DESIGN_ROBOTS"]

#: robots ``design --out`` writes scenarios for: start posture and environment of each.
DESIGN_ROBOTS = ("chapter-arm", "ur5", "panda")

_Q0 = {
    "ur5": "[0.0, -1.2, 1.5, -1.9, -1.57, 0.0]",
    "panda": "[0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398]",
}


@dataclass(frozen=True)
class ServoGainDesign(GainDesign):
    """A :class:`GainDesign` of the ``admittance-position`` scheme (requirements hold the servo and robot)."""

    def scenario_toml(self, name: str | None = None, *, axis_force: float = 10.0) -> str:
        """A scenario on the requirements' robot: the desired frame pressed into the surface so that
        the force at k_max is ``axis_force``; one case per evaluated stiffness."""
        r, g = self.requirements, self.gains
        robot = r["robot"]
        name = name or f"designed-admittance-position-{robot}"
        k_max = self.stiffness_range[1]
        depth = axis_force * (1.0 / k_max + 1.0 / g["stiffness"])
        lines = [
            f'name = "{name}"',
            f'title = "admittance-position gains designed for k in [{self.stiffness_range[0]:g}, {k_max:g}] N/m ({robot})"',
            'description = """',
            "Written by `forcecontrol design admittance-position`: "
            + ", ".join(f"{c['k']:g} N/m: PM {c['phase_margin_deg']:.1f} deg, GM {c['gain_margin_db']:.1f} dB, "
                        f"settling {c['settling_time']:.3f} s" for c in self.checks)
            + f". Servo: {r['rate']:g} Hz, omega {r['servo_bandwidth']:g} rad/s, zeta {r['servo_damping']:g}, "
              f"delay {r['delay_cycles']} cycle(s).",
            '"""',
            f"duration = {max(2.0, 1.5 * self.worst_settling_time):.3g}",
            f"sample_time = {r['sample_time']:g}",
            "allow_contact_loss = true",
            "",
            "[robot]",
        ]
        if robot == "chapter-arm":
            lines += ['model = "chapter-arm"', "start_position = [1.0, 0.0]", 'elbow = "up"']
        else:
            lines += [f'model = "{robot}"', f"q0 = {_Q0[robot]}"]
        lines += ["", "[robot.servo]", f"rate = {r['rate']:g}", f"bandwidth = {r['servo_bandwidth']:g}",
                  f"damping = {r['servo_damping']:g}", f"delay = {r['delay_cycles']}"]
        if r.get("lowpass_cutoff") is not None:
            lines.append(f"lowpass_cutoff = {r['lowpass_cutoff']:g}")
        M, D, K = g["inertia"], g["damping"], g["stiffness"]
        if robot == "chapter-arm":
            lines += ["", "[environment]", 'type = "elastic-plane"', "point = [1.0, 0.0]", "normal = [-1.0, 0.0]",
                      f"stiffness = {k_max:g}", "", "[controller]", 'type = "admittance-position"',
                      f"inertia = [{M:g}, {M:g}]", f"damping = [{D:g}, {D:g}]", f"stiffness = [{K:g}, {K:g}]",
                      "", "[reference]", 'type = "setpoint"', f"position = [{1.0 + depth:.6g}, 0.0]"]
            sig = '["x", "fx"]'
        else:
            # rotations: the same natural frequency and damping ratio as the translation, on 0.05 of the inertia
            Mr, Kr = 0.05 * M, 0.05 * K
            Dr = D * 0.05
            lines += ["", "[environment]", 'type = "table"', f"stiffness = {k_max:g}", "", "[controller]",
                      'type = "admittance-position"', f"inertia = [{M:g}, {M:g}, {M:g}, {Mr:g}, {Mr:g}, {Mr:g}]",
                      f"damping = [{D:g}, {D:g}, {D:g}, {Dr:g}, {Dr:g}, {Dr:g}]",
                      f"stiffness = [{K:g}, {K:g}, {K:g}, {Kr:g}, {Kr:g}, {Kr:g}]",
                      "", "[reference]", 'type = "pose-setpoint"', f"offset = [0.0, 0.0, {-depth:.6g}]"]
            sig = '["z", "fz"]'
        lines += ["", "[figure]", f'title = "admittance-position ({robot}): designed gains over the stiffness range"',
                  f"signals = {sig}"]
        for c in self.checks:
            lines += ["", "[[case]]", f'label = "k = {c["k"]:g} N/m"', f"environment.stiffness = {c['k']:g}"]
        return "\n".join(lines) + "\n"


def _loop(M: float, D: float, K: float, rate: float, w: float, z: float, delay: int, a: float) -> ServoLoop:
    return ServoLoop(inertia=np.array([[M]]), damping=np.array([[D]]), stiffness=np.array([[K]]), period=1.0 / rate,
                     bandwidth=w, damping_ratio=z, delay=delay, lowpass=a, J=np.eye(1), ik_damping=0.0, normal=[1.0])


def design_admittance_servo(
    stiffness_range: tuple[float, float], *, rate: float = 500.0, servo_bandwidth: float = 44.7,
    servo_damping: float = 0.67, delay_cycles: int = 1, lowpass_cutoff: float | None = None,
    inertia: float = 10.0, stiffness: float = 1000.0, phase_margin: float = 45.0, gain_margin: float = 6.0,
    settling_time: float | None = None, robot: str = "chapter-arm", sample_time: float | None = None,
) -> ServoGainDesign:
    """K_Dt of (9.37) on a position-interface arm for k_e in [k_min, k_max] (see the module docstring).

    Args:
        stiffness_range: (k_min, k_max) [N/m].
        rate: interface rate [Hz]; servo_bandwidth ω_s [rad/s]; servo_damping ζ_s; delay_cycles n_d;
            lowpass_cutoff: the command low-pass [Hz] or None.
        inertia: M_t [kg] and stiffness: K_Pt [N/m] (kept).
        phase_margin [deg], gain_margin [dB]: required over the range; settling_time [s]: required worst case.
        robot: the robot of the scenario ``scenario_toml`` writes (:data:`DESIGN_ROBOTS`).
        sample_time: the scenario's servo step [s] (default: the interface period / 4).

    Raises:
        ParameterError: a bad argument, or no damping meets the margins (the message says what to change).
    """
    from ..robots.servo import JointServo

    k_min, k_max = stiffness_range_arg(stiffness_range)
    if robot not in DESIGN_ROBOTS:
        raise ParameterError(f"robot must be one of {list(DESIGN_ROBOTS)}; got {robot!r}")
    servo = JointServo(nq=1, rate=rate, bandwidth=servo_bandwidth, damping=servo_damping, delay=delay_cycles,
                       lowpass_cutoff=lowpass_cutoff)
    M, K = positive_scalar("inertia", inertia, "kg"), positive_scalar("stiffness", stiffness, "N/m")
    pm_req, gm_req = positive_scalar("phase_margin", phase_margin, "deg"), nonnegative_scalar("gain_margin", gain_margin, "dB")
    T = servo.period
    Ts = T / 4 if sample_time is None else positive_scalar("sample_time", sample_time, "s")
    servo.substeps(Ts)
    ks = sorted({k_min, math.sqrt(k_min * k_max), k_max})
    best: tuple[float, float, list[dict[str, float]]] | None = None
    base = math.sqrt(M * (K + k_max))
    for D in np.geomspace(0.1 * base, 20.0 * base, 48):
        checks = []
        for k in ks:
            loop = _loop(M, float(D), K, rate, float(servo.bandwidth[0]), float(servo.damping[0]), servo.delay,
                         servo.lowpass_gain())
            rho = loop.spectral_radius(k)
            if rho >= 1.0:
                break
            gm, pm, _, _ = loop.margins(k, points=1500)
            gm_db = 20 * math.log10(gm) if gm > 0 else -math.inf
            if gm_db < gm_req or pm < pm_req:
                break
            ts = T * math.log(50.0) / -math.log(rho) if rho > 0 else T
            checks.append({"k": k, "gain_margin_db": gm_db, "phase_margin_deg": pm, "spectral_radius": rho, "settling_time": ts})
        else:
            worst = max(c["settling_time"] for c in checks)
            if best is None or worst < best[0]:
                best = (worst, float(D), checks)
    req = {"phase_margin_deg": pm_req, "gain_margin_db": gm_req, "settling_time": settling_time, "sample_time": Ts,
           "rate": servo.rate, "servo_bandwidth": float(servo.bandwidth[0]), "servo_damping": float(servo.damping[0]),
           "delay_cycles": servo.delay, "lowpass_cutoff": lowpass_cutoff, "robot": robot}
    if best is None:
        raise ParameterError(
            f"no damping keeps a phase margin >= {pm_req:g} deg and a gain margin >= {gm_req:g} dB over k in "
            f"[{k_min:g}, {k_max:g}] N/m with M_t = {M:g} kg, K_Pt = {K:g} N/m behind a {rate:g} Hz servo "
            f"(ω_s = {servo_bandwidth:g} rad/s, delay {delay_cycles} cycle(s)): raise the inertia, lower the margins, "
            "narrow the range, or use a faster servo/interface"
        )
    worst, D, checks = best
    if settling_time is not None and worst > positive_scalar("settling_time", settling_time, "s"):
        raise ParameterError(
            f"settling_time = {settling_time:g} s cannot be met over k in [{k_min:g}, {k_max:g}] N/m with the required "
            f"margins; the fastest design settles in {worst:.3g} s (damping {D:.6g} N s/m)"
        )
    return ServoGainDesign("admittance-position", {"inertia": M, "damping": D, "stiffness": K}, (k_min, k_max), checks, req)
