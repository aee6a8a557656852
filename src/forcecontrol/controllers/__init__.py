"""Controllers of the chapter. Each states its law and equation number in its docstring."""

from .admittance import AdmittanceController
from .base import Controller, Measurement, Reference
from .compliance import JointSpacePD, OperationalSpacePD
from .force import (
    InnerPositionForceController,
    InnerVelocityForceController,
    ParallelForcePositionController,
    check_force_reference,
)
from .hybrid import HybridCompliantController, HybridRigidController
from .impedance import ImpedanceController
from .redundant import NullSpacePosture, SingularityHandling
from .spatial import SpatialComplianceController, SpatialImpedanceController
from .spatial_hybrid import SpatialHybridController, SpatialHybridRigidController
from .variable import (
    DirectionalStiffness,
    EnergyTank,
    SinusoidalStiffness,
    VariableAdmittanceController,
    VariableImpedanceController,
)

__all__ = [
    "Controller",
    "Measurement",
    "Reference",
    "OperationalSpacePD",
    "JointSpacePD",
    "ImpedanceController",
    "InnerPositionForceController",
    "InnerVelocityForceController",
    "ParallelForcePositionController",
    "check_force_reference",
    "HybridCompliantController",
    "HybridRigidController",
    "SpatialImpedanceController",
    "SpatialComplianceController",
    "SpatialHybridController",
    "SpatialHybridRigidController",
    "AdmittanceController",
    "NullSpacePosture",
    "SingularityHandling",
    "VariableImpedanceController",
    "VariableAdmittanceController",
    "EnergyTank",
    "DirectionalStiffness",
    "SinusoidalStiffness",
]
