"""Analysis: where the loop settles and how it moves (equilibria, poles, ω_n, ζ).

Names are imported on first use (PEP 562): :mod:`.force` needs python-control, which the
impedance and compliance analyses (run with every scenario) do not.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_LAZY = {
    "DESIGN_SCHEMES": ".design",
    "GainDesign": ".gain_design",
    "LoopModel": ".design",
    "design_gains": ".gain_design",
    "loop_model": ".design",
    "ComplianceEquilibrium": ".compliance",
    "compliance_equilibrium": ".compliance",
    "joint_space_compliance": ".compliance",
    "compliance_loop": ".compliance",
    "ForceGains": ".force_design",
    "ForceLoopAxis": ".force",
    "design_force_gains": ".force_design",
    "force_loop_axes": ".force_design",
    "operational_mass": ".force_design",
    "sampled_stability_limit": ".force_design",
    "AxisDynamics": ".impedance",
    "impedance_axis": ".impedance",
    "ImpedanceModes": ".impedance",
    "impedance_modes": ".impedance",
    "impedance_response": ".impedance",
    "held_input_response": ".impedance",
    "contact_plant": ".impedance",
    "held_input_matrices": ".impedance",
    "HeldLoop": ".impedance",
    "impedance_loop": ".impedance",
    "axis_spectral_radii": ".sampled_contact",
    "stiffness_limit": ".sampled_contact",
}

if TYPE_CHECKING:  # pragma: no cover
    from .compliance import ComplianceEquilibrium, compliance_equilibrium, compliance_loop, joint_space_compliance
    from .design import DESIGN_SCHEMES, LoopModel, loop_model
    from .force import ForceLoopAxis
    from .force_design import ForceGains, design_force_gains, force_loop_axes, operational_mass, sampled_stability_limit
    from .gain_design import GainDesign, design_gains
    from .impedance import (
        AxisDynamics,
        HeldLoop,
        ImpedanceModes,
        contact_plant,
        held_input_matrices,
        held_input_response,
        impedance_axis,
        impedance_loop,
        impedance_modes,
        impedance_response,
    )
    from .sampled_contact import axis_spectral_radii, stiffness_limit


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name], __name__), name)
    globals()[name] = value
    return value


__all__ = [
    "DESIGN_SCHEMES",
    "GainDesign",
    "LoopModel",
    "design_gains",
    "loop_model",
    "ComplianceEquilibrium",
    "compliance_equilibrium",
    "joint_space_compliance",
    "compliance_loop",
    "AxisDynamics",
    "impedance_axis",
    "ImpedanceModes",
    "impedance_modes",
    "impedance_response",
    "held_input_response",
    "contact_plant",
    "held_input_matrices",
    "HeldLoop",
    "impedance_loop",
    "axis_spectral_radii",
    "stiffness_limit",
    "ForceLoopAxis",
    "ForceGains",
    "force_loop_axes",
    "design_force_gains",
    "sampled_stability_limit",
    "operational_mass",
]
