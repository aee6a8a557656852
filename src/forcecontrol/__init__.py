"""forcecontrol: the force-control chapter of Siciliano et al., runnable and checked.

Manipulators interacting with an environment and every controller of chapter 9 of *Robotics:
Modelling, Planning and Control*: compliance, impedance, admittance, direct force control,
constrained motion and hybrid force/motion control, with a sampled-data simulator and analysis.

The public names are imported on first use (PEP 562), so ``import forcecontrol`` costs only this
file: Numba, SciPy and the compiled kernels load when a controller, robot or the simulator is
first touched.
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

from .core import numba_cache as _numba_cache  # noqa: E402  (must precede every @njit(cache=True) module)

_numba_cache.configure()

# public name -> submodule that defines it (resolved by __getattr__ on first access)
_LAZY: dict[str, str] = {
    "Actuator": ".sim.actuators",
    "SensedWrench": ".realarm.conventions",
    "RecordedRun": ".realarm.io",
    "read_recording": ".realarm.io",
    "replay": ".realarm.replay",
    "compare_traces": ".realarm.replay",
    "AdmittanceController": ".controllers",
    "Controller": ".controllers",
    "HybridCompliantController": ".controllers",
    "HybridRigidController": ".controllers",
    "ImpedanceController": ".controllers",
    "InnerPositionForceController": ".controllers",
    "InnerVelocityForceController": ".controllers",
    "JointSpacePD": ".controllers",
    "Measurement": ".controllers",
    "OperationalSpacePD": ".controllers",
    "ParallelForcePositionController": ".controllers",
    "Reference": ".controllers",
    "SpatialComplianceController": ".controllers",
    "SpatialImpedanceController": ".controllers",
    "SpatialHybridController": ".controllers",
    "SpatialHybridRigidController": ".controllers",
    "VariableImpedanceController": ".controllers",
    "EnergyTank": ".controllers",
    "DirectionalStiffness": ".controllers",
    "SinusoidalStiffness": ".controllers",
    "StabilityMonitor": ".supervision.monitor",
    "StiffnessEstimator": ".supervision.estimation",
    "MonitoredController": ".supervision.monitor",
    "CalibrationResult": ".realarm.calibration",
    "DriftDetector": ".realarm.calibration",
    "calibrate": ".realarm.calibration",
    "plan_calibration_poses": ".realarm.calibration",
    "EncoderFeedback": ".sim.encoders",
    "JointEncoder": ".sim.encoders",
    "ConstantWrench": ".environments",
    "ElasticPlane": ".environments",
    "Environment": ".environments",
    "LinearSpring": ".environments",
    "PlaneConstraint": ".environments",
    "RigidEnvironment": ".environments",
    "SpatialSpring": ".environments",
    "Table": ".environments",
    "BandwidthWarning": ".errors",
    "SampledLoopWarning": ".errors",
    "DimensionError": ".errors",
    "DriftWarning": ".errors",
    "ForceControlError": ".errors",
    "FrameError": ".errors",
    "MeasurementError": ".errors",
    "ParameterError": ".errors",
    "ScenarioError": ".errors",
    "SimulationDivergedError": ".errors",
    "SingularityError": ".errors",
    "WorkspaceError": ".errors",
    "CHAPTER_ARM": ".robots",
    "PlanarTwoLink": ".robots",
    "PlanarTwoLinkParameters": ".robots",
    "RobotModel": ".robots",
    "RateLimiter": ".realarm.realtime",
    "Safety": ".supervision.safety",
    "ForceSensor": ".sensors",
    "RealisticForceSensor": ".sensors",
    "ToolGravity": ".sensors",
    "identify_tool_gravity": ".sensors",
    "scenario": ".scenarios",
    "SimulationResult": ".sim.simulation",
    "simulate": ".sim.simulation",
    "Transform": ".spatial",
    "Twist": ".spatial",
    "Wrench": ".spatial",
    "SelectionMatrices": ".task",
    "Task": ".task",
    "LinearPath": ".trajectories",
    "ReferenceSignal": ".trajectories",
    "Setpoint": ".trajectories",
    "SampledReference": ".trajectories",
    "ContactSupervisor": ".supervision.transitions",
    "critical_damping": ".supervision.transitions",
    "impact_report": ".supervision.transitions",
}

if TYPE_CHECKING:  # pragma: no cover - static names for type checkers and IDEs
    from .controllers import (
        AdmittanceController,
        Controller,
        DirectionalStiffness,
        EnergyTank,
        HybridCompliantController,
        HybridRigidController,
        ImpedanceController,
        InnerPositionForceController,
        InnerVelocityForceController,
        JointSpacePD,
        Measurement,
        OperationalSpacePD,
        ParallelForcePositionController,
        Reference,
        SinusoidalStiffness,
        SpatialComplianceController,
        SpatialHybridController,
        SpatialHybridRigidController,
        SpatialImpedanceController,
        VariableImpedanceController,
    )
    from .environments import (
        ConstantWrench,
        ElasticPlane,
        Environment,
        LinearSpring,
        PlaneConstraint,
        RigidEnvironment,
        SpatialSpring,
        Table,
    )
    from .errors import (
        BandwidthWarning,
        DimensionError,
        DriftWarning,
        ForceControlError,
        FrameError,
        MeasurementError,
        ParameterError,
        SampledLoopWarning,
        ScenarioError,
        SimulationDivergedError,
        SingularityError,
        WorkspaceError,
    )
    from .realarm.calibration import CalibrationResult, DriftDetector, calibrate, plan_calibration_poses
    from .realarm.conventions import SensedWrench
    from .realarm.io import RecordedRun, read_recording
    from .realarm.realtime import RateLimiter
    from .realarm.replay import compare_traces, replay
    from .robots import CHAPTER_ARM, PlanarTwoLink, PlanarTwoLinkParameters, RobotModel
    from .scenarios import scenario
    from .sensors import ForceSensor, RealisticForceSensor, ToolGravity, identify_tool_gravity
    from .sim.actuators import Actuator
    from .sim.encoders import EncoderFeedback, JointEncoder
    from .sim.simulation import SimulationResult, simulate
    from .spatial import Transform, Twist, Wrench
    from .supervision.estimation import StiffnessEstimator
    from .supervision.monitor import MonitoredController, StabilityMonitor
    from .supervision.safety import Safety
    from .supervision.transitions import ContactSupervisor, critical_damping, impact_report
    from .task import SelectionMatrices, Task
    from .trajectories import LinearPath, ReferenceSignal, SampledReference, Setpoint


def __getattr__(name: str) -> Any:
    """Import a public name's submodule on first access (PEP 562)."""
    try:
        module = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'forcecontrol' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value  # later accesses skip __getattr__
    if "numba" in sys.modules:  # a compiled module was loaded: say so when its kernels compile (cold cache)
        _numba_cache.install_notice()
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "__version__",
    "scenario",
    "Controller",
    "ImpedanceController",
    "InnerPositionForceController",
    "InnerVelocityForceController",
    "ParallelForcePositionController",
    "JointSpacePD",
    "OperationalSpacePD",
    "Measurement",
    "Reference",
    "Environment",
    "ElasticPlane",
    "LinearSpring",
    "ForceControlError",
    "DimensionError",
    "DriftWarning",
    "ParameterError",
    "ScenarioError",
    "MeasurementError",
    "SimulationDivergedError",
    "SingularityError",
    "WorkspaceError",
    "RobotModel",
    "PlanarTwoLink",
    "PlanarTwoLinkParameters",
    "CHAPTER_ARM",
    "ForceSensor",
    "RealisticForceSensor",
    "ToolGravity",
    "identify_tool_gravity",
    "calibrate",
    "plan_calibration_poses",
    "CalibrationResult",
    "DriftDetector",
    "RateLimiter",
    "JointEncoder",
    "EncoderFeedback",
    "Safety",
    "ContactSupervisor",
    "critical_damping",
    "impact_report",
    "simulate",
    "SimulationResult",
    "ReferenceSignal",
    "Setpoint",
    "LinearPath",
    "HybridCompliantController",
    "HybridRigidController",
    "RigidEnvironment",
    "PlaneConstraint",
    "Task",
    "SelectionMatrices",
    "SpatialImpedanceController",
    "SpatialComplianceController",
    "SpatialHybridController",
    "SpatialHybridRigidController",
    "AdmittanceController",
    "SpatialSpring",
    "Table",
    "ConstantWrench",
    "BandwidthWarning",
    "SampledLoopWarning",
    "FrameError",
    "Transform",
    "Twist",
    "Wrench",
    "VariableImpedanceController",
    "EnergyTank",
    "DirectionalStiffness",
    "SinusoidalStiffness",
    "StabilityMonitor",
    "MonitoredController",
    "Actuator",
    "SensedWrench",
    "RecordedRun",
    "read_recording",
    "replay",
    "compare_traces",
    "StiffnessEstimator",
    "SampledReference",
]
