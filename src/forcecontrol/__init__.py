"""forcecontrol: the force-control chapter of Siciliano et al., runnable and checked.

Manipulators interacting with an environment and every controller of chapter 9 of *Robotics:
Modelling, Planning and Control*: compliance, impedance, admittance, direct force control,
constrained motion and hybrid force/motion control, with a sampled-data simulator and analysis.
"""

__version__ = "0.1.0"

from . import _numba_cache  # noqa: E402  (must precede every @njit(cache=True) module)

_numba_cache.configure()

from .controllers import (  # noqa: E402  # noqa: E402
    AdmittanceController,
    Controller,
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
    SpatialComplianceController,
    SpatialImpedanceController,
)
from .encoders import EncoderFeedback, JointEncoder  # noqa: E402
from .environments import (  # noqa: E402  # noqa: E402  # noqa: E402
    ConstantWrench,
    ElasticPlane,
    Environment,
    LinearSpring,
    PlaneConstraint,
    RigidEnvironment,
    SpatialSpring,
    Table,
)
from .errors import (  # noqa: E402  # noqa: E402
    BandwidthWarning,
    DimensionError,
    DriftWarning,
    ForceControlError,
    FrameError,
    MeasurementError,
    ParameterError,
    ScenarioError,
    SimulationDivergedError,
    SingularityError,
    WorkspaceError,
)
from .robots import CHAPTER_ARM, PlanarTwoLink, PlanarTwoLinkParameters, RobotModel  # noqa: E402
from .safety import Safety  # noqa: E402
from .sensors import ForceSensor, RealisticForceSensor, ToolGravity, identify_tool_gravity  # noqa: E402
from .simulation import SimulationResult, simulate  # noqa: E402
from .spatial import Transform, Twist, Wrench  # noqa: E402
from .task import SelectionMatrices, Task  # noqa: E402
from .trajectories import LinearPath, ReferenceSignal, Setpoint  # noqa: E402
from .transitions import ContactSupervisor, critical_damping, impact_report  # noqa: E402

__all__ = [
    "__version__",
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
    "AdmittanceController",
    "SpatialSpring",
    "Table",
    "ConstantWrench",
    "BandwidthWarning",
    "FrameError",
    "Transform",
    "Twist",
    "Wrench",
]
