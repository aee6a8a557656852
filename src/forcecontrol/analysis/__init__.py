"""Analysis: where the loop settles and how it moves (equilibria, poles, ω_n, ζ)."""

from .compliance import ComplianceEquilibrium, compliance_equilibrium, joint_space_compliance
from .impedance import AxisDynamics, impedance_axis

__all__ = [
    "ComplianceEquilibrium",
    "compliance_equilibrium",
    "joint_space_compliance",
    "AxisDynamics",
    "impedance_axis",
]
