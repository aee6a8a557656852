"""Recorded data in: joint positions, velocities, torques and wrenches from files, resampled.

One result type, :class:`RecordedRun` (time, q, q̇, τ, wrench and the wrench's frame, point and
sense), from

* CSV and Parquet tables (:func:`read_table`; the columns the simulator's ``save`` writes);
* ROS 2 bags (:func:`read_bag`, rosbags: ``sensor_msgs/JointState`` and
  ``geometry_msgs/WrenchStamped`` topics) and MCAP files (:func:`read_mcap`, CDR-encoded ROS 2
  messages decoded with rosbags' serde);

* the arms' own recordings by their field names (:mod:`.vendor`): UR RTDE CSV (``timestamp``,
  ``actual_q_*``, ``actual_TCP_pose_*``, ``actual_TCP_force_*``) and libfranka RobotState JSON or
  tables (``O_T_EE_*`` column-major, ``O_F_ext_hat_K_*``, ``K_F_ext_hat_K_*``), with their
  documented wrench conventions (:func:`read_vendor`; ``sense=`` overrides);

and :meth:`RecordedRun.resample` puts it on the controller's period (linear interpolation;
non-monotonic time, gaps and NaNs are refused with the column and the time named).
:func:`read_recording` picks the reader from the file's suffix. :func:`convert_recording` converts
the wrench between conventions and :func:`write_recording` writes a table with its metadata.
"""

from __future__ import annotations

from .convert import convert_recording, write_recording
from .recorded import RecordedRun
from .rosfiles import read_bag, read_mcap
from .tables import TABLE_COLUMNS, read_recording, read_table
from .vendor import (
    SENSE_OVERRIDES,
    VENDOR_FORMATS,
    detect_convention,
    franka_pose,
    read_vendor,
    ur_pose,
    vendor_run,
    with_library_options,
)

__all__ = [
    "RecordedRun", "read_table", "read_bag", "read_mcap", "read_recording", "TABLE_COLUMNS", "convert_recording",
    "write_recording", "read_vendor", "vendor_run", "detect_convention", "ur_pose", "franka_pose", "VENDOR_FORMATS",
    "SENSE_OVERRIDES", "with_library_options",
]
