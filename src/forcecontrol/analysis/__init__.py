"""Analysis: where the loop settles and how it moves (equilibria, poles, ω_n, ζ)."""

from .compliance import ComplianceEquilibrium, compliance_equilibrium, joint_space_compliance
from .force import (
    ForceGains,
    ForceLoopAxis,
    design_force_gains,
    force_loop_axes,
    operational_mass,
    sampled_stability_limit,
)
from .impedance import AxisDynamics, ImpedanceModes, impedance_axis, impedance_modes

__all__ = [
    "ComplianceEquilibrium",
    "compliance_equilibrium",
    "joint_space_compliance",
    "AxisDynamics",
    "impedance_axis",
    "ImpedanceModes",
    "impedance_modes",
    "ForceLoopAxis",
    "ForceGains",
    "force_loop_axes",
    "design_force_gains",
    "sampled_stability_limit",
    "operational_mass",
]
