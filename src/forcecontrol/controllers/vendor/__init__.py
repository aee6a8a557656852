"""The vendor and ROS controllers people run, each from its project's own equations (issue 30).

* :class:`Ros2AdmittanceController`: ros2_controllers ``admittance_controller`` (position interface);
* :class:`FziComplianceController`, :class:`FziForceController`: FZI ``cartesian_compliance_controller``
  and ``cartesian_force_controller`` (forward dynamics compliance control; position interface);
* :class:`FrankaCartesianImpedanceController`: franka_ros ``cartesian_impedance_example_controller``
  (torque interface);
* :class:`UrForceModeController`: Universal Robots ``force_mode`` (position interface; inferred law).

Their laws are in :mod:`forcecontrol.laws.vendor`; their configuration files are read and written
by :mod:`forcecontrol.realarm.conventions.configs`.
"""

from .franka import FrankaCartesianImpedanceController
from .fzi import FziComplianceController, FziForceController
from .ros2_admittance import Ros2AdmittanceController
from .ur_force_mode import UrForceModeController

__all__ = [
    "Ros2AdmittanceController",
    "FziComplianceController",
    "FziForceController",
    "FrankaCartesianImpedanceController",
    "UrForceModeController",
]
