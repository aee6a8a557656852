"""The vendor and ROS controllers' laws, each written once and compiled (issue 30).

Each module reads its equations from the project's own source (cited with file and commit in
the law's docstring; no code copied) and writes them in the library's notation:

* :mod:`.ros2_admittance`: ros2_controllers ``admittance_controller`` (admittance rule, wrench
  filter, gravity compensation): joint-position offsets for a position-interface arm;
* :mod:`.fzi`: FZI ``cartesian_compliance_controller`` / ``cartesian_force_controller``
  (forward dynamics compliance control, FDCC): one internal solver step;
* :mod:`.franka`: franka_ros ``cartesian_impedance_example_controller``: torques;
* :mod:`.ur_force_mode`: Universal Robots ``force_mode`` (documented semantics, an inferred
  velocity-admittance law on the compliant axes): a Cartesian command offset.

Unlike the chapter's laws (one torque signature, :mod:`forcecontrol.laws`), the position-
interface laws return what their controller sends to the robot's own servo (joint positions or
a Cartesian offset); each signature is documented with its law.
"""

from __future__ import annotations

from .franka import franka_impedance_torque
from .fzi import fdcc_error, fdcc_step
from .ros2_admittance import exponential_smoothing, gravity_compensate, ros2_admittance_rule
from .ur_force_mode import ur_force_mode_step

__all__ = [
    "exponential_smoothing",
    "gravity_compensate",
    "ros2_admittance_rule",
    "fdcc_error",
    "fdcc_step",
    "franka_impedance_torque",
    "ur_force_mode_step",
]
