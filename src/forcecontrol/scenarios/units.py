"""The SI unit of every quantity the command line and the Python objects print.

One convention everywhere: field names stay plain (``stability_limit_x``, ``fx``: stable for
scripts), tables carry the unit in the column or quantity name (``stability_limit_x [N/m]``), and
every ``--json`` object carries a ``units`` map, name -> unit, for the physical quantities it holds
(``"-"`` for a dimensionless number; labels, booleans and counts are left out of the map).
"""

from __future__ import annotations

import re
from collections.abc import Iterable

__all__ = ["unit", "with_unit", "units_map", "design_gain_unit", "SWEEP_METRIC_UNITS"]

_AXIS = {
    "x": "m", "y": "m", "z": "m", "rx": "rad", "ry": "rad", "rz": "rad",
    "vx": "m/s", "vy": "m/s", "vz": "m/s", "wx": "rad/s", "wy": "rad/s", "wz": "rad/s",
    "fx": "N", "fy": "N", "fz": "N", "mx": "N m", "my": "N m", "mz": "N m",
}
#: named quantities: log columns and signals, scenario metrics, analysis quantities, result fields
_NAMED = {
    "t": "s", "t_end": "s", "tip_position": "m", "contact_force": "N", "peak_contact_force_norm": "N",
    "tank_energy": "J", "storage": "J", "stiffness_scale": "-", "stiffness_refused": "-", "tank_energy_min": "J",
    "penetration": "m", "normal_force": "N", "contact_force_norm": "N", "impact_peak_force": "N",
    "peak_force_last_second": "N", "first_contact_time": "s", "contact_separation": "m",
    "tangential_speed_error": "m/s", "constraint_violation": "m",
    "steady_normal_force": "N", "steady_penetration": "m", "L_f": "-", "force_sample_pole": "-",
    "settling_time": "s", "overshoot": "%", "steady_state_force_error": "N", "peak_force": "N", "settled_force": "N",
    "diverged_at": "s",
    "k": "N/m", "k_min": "N/m", "k_max": "N/m", "stiffness_range": "N/m", "phase_margin_deg": "deg",
    "gain_margin_db": "dB", "spectral_radius": "-", "sample_time": "s", "delay_samples": "samples",
    "filter_cutoff": "Hz", "arm_inertia": "kg", "damping_ratio": "-", "seconds": "s", "arm_steps_per_second": "1/s",
    "servo_loop_spectral_radius": "-", "servo_loop_stability_limit": "N/m", "servo_loop_gain_margin_db": "dB",
    "servo_loop_phase_margin": "deg", "servo_loop_least_damped_omega_n": "rad/s", "servo_loop_least_damped_zeta": "-",
    "servo_loop_force_per_penetration": "N/m",
    "environment_stiffness": "N/m", "vendor_loop_spectral_radius": "-", "vendor_loop_stability_limit": "N/m",
    "vendor_loop_margin": "-",
    "rate": "Hz", "servo_bandwidth": "rad/s", "servo_damping": "-", "delay_cycles": "cycles", "lowpass_cutoff": "Hz",
    "path_curvature_max": "1/m", "estimate_lag": "rad", "normal_force_bound": "N", "curvature_error": "N", "lag_error": "N",
    "hole_distance": "m", "hole_detection_radius": "m", "hole_time": "s", "hole_x": "m", "hole_y": "m", "hole_z": "m",
    "contact_losses": "count", "bounce_count": "count", "safety_events": "count", "safety_stops": "count",
}
_JOINT = re.compile(r"^(q|qd|u|uc)\d+$")
_JOINT_UNITS = {"q": "rad", "qd": "rad/s", "u": "N m", "uc": "N m"}
_RATE = {"position": "", "velocity": "/s", "acceleration": "/s^2", "force": "", "force_rate": "/s", "force_accel": "/s^2"}
_POSE_TO_FORCE = {"x": "fx", "y": "fy", "z": "fz", "rx": "mx", "ry": "my", "rz": "mz"}
#: analysis quantities per axis: prefix -> unit, or None for the unit of the axis itself
_PER_AXIS: tuple[tuple[str, str | None], ...] = (
    ("pole_re_", "1/s"), ("pole_im_", "rad/s"), ("real_pole_", "1/s"), ("zero_", "1/s"), ("omega_n_", "rad/s"),
    ("zeta_", "-"), ("spectral_radius_", "-"), ("end_spectral_radius_", "-"), ("steady_", None), ("pose_error_", None),
    ("settled_", None),
)
_MODAL = re.compile(r"^(motion|velocity|force|normal)_(omega_n|zeta)(_\d+)?$")
SWEEP_METRIC_UNITS = {"settling_time": "s", "overshoot": "%", "steady_state_force_error": "N", "peak_force": "N",
                      "settled_force": "N", "diverged_at": "s"}


def unit(name: str) -> str:
    """The SI unit of a named quantity (``"fx"`` -> ``"N"``, ``"stability_limit_x"`` -> ``"N/m"``,
    ``"ref_velocity_x"`` -> ``"m/s"``, ``"q1"`` -> ``"rad"``), ``"-"`` for a dimensionless one,
    ``""`` when the name is not a physical quantity (a label, a flag, a count) or is unknown."""
    if name in _AXIS:
        return _AXIS[name]
    if name in _NAMED:
        return _NAMED[name]
    if name.startswith("analysis."):
        return unit(name.removeprefix("analysis."))
    m = _JOINT.match(name)
    if m:
        return _JOINT_UNITS[m.group(1)]
    if name.endswith("_measured"):
        return unit(name.removesuffix("_measured"))
    if name.startswith("stability_limit_"):
        axis = name.removeprefix("stability_limit_")
        return "N m/rad" if axis.startswith("r") else "N/m" if axis in _AXIS else ""
    for prefix, u in _PER_AXIS:
        if name.startswith(prefix) and name.removeprefix(prefix) in _AXIS:
            return u if u is not None else _AXIS[name.removeprefix(prefix)]
    m = _MODAL.match(name)
    if m:
        return "rad/s" if m.group(2) == "omega_n" else "-"
    if name.startswith("ref_"):
        for block, rate in _RATE.items():
            axis = name.removeprefix(f"ref_{block}_")
            if axis != name and axis in _AXIS:
                base = _AXIS[_POSE_TO_FORCE.get(axis, axis) if block.startswith("force") else axis]
                return base + rate
    return ""


def with_unit(name: str, u: str | None = None) -> str:
    """``"name [unit]"``, or ``name`` alone when it has no unit."""
    u = unit(name) if u is None else u
    return f"{name} [{u}]" if u else name


def units_map(names: Iterable[str]) -> dict[str, str]:
    """``{name: unit}`` for the names that are physical quantities (sorted, for JSON)."""
    return {n: u for n in sorted(set(names)) if (u := unit(n))}


def design_gain_unit(scheme: str, gain: str) -> str:
    """The unit of a gain ``forcecontrol design`` prints for a scheme (the controllers' docstrings)."""
    if scheme == "hybrid":
        return {"force_gain": "1/s^2", "force_rate_gain": "1/s", "nominal_stiffness": "N/m"}.get(gain, "")
    return {"inertia": "kg", "damping": "N s/m", "stiffness": "N/m", "force_gain": "m/N",
            "integral_gain": "m/(N s)"}.get(gain, "")
