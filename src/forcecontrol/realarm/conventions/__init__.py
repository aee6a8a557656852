"""Conventions made explicit: which frame, which point, which sense — and converters between them.

The chapter's (and this library's) convention: ``h_e`` is the wrench the end-effector exerts
**on** the environment, in the base frame, the moment about the end-effector origin
(Sect. 9.1, (9.1)). Real arms and tools report other things: the wrench the environment exerts
on the end-effector, in a sensor or tool frame, about a flange point. A :class:`SensedWrench`
carries its frame, reference point and sense, and converts:

* change of sense (:meth:`SensedWrench.in_sense`): ``h → −h``;
* change of reference point (:meth:`SensedWrench.about`): ``μ' = μ − r × f`` (moment transport);
* change of frame (:meth:`SensedWrench.rotated`, :meth:`SensedWrench.transformed`).

Adapters: ROS 2 messages (``geometry_msgs`` WrenchStamped / PoseStamped / TwistStamped, as plain
dictionaries or rosbags message objects; quaternions x, y, z, w) in :mod:`.ros`; libfranka's
estimated external wrench, Universal Robots' RTDE ``actual_TCP_force`` and force-mode wrench, and
MuJoCo's force/torque sensors in :mod:`.vendors`, each with the vendor's documented convention.
Recorded arrays: :data:`CONVENTIONS` names them and :func:`convert_wrenches` converts (N, m)
samples between them (``forcecontrol convert``).
"""

from __future__ import annotations

from . import ros, vendors
from .named import CONVENTIONS, UR_BASE_IN_BASE_LINK, WrenchConvention, convention, convert_wrenches
from .ros import *  # noqa: F403  (the ROS 2 adapters; ros.__all__)
from .vendors import *  # noqa: F403  (the vendors' adapters; vendors.__all__)
from .wrench import BY_END_EFFECTOR, ON_END_EFFECTOR, SENSES, SensedWrench, twist_about, twist_rotated

__all__ = [
    "SensedWrench",
    "WrenchConvention",
    "CONVENTIONS",
    "UR_BASE_IN_BASE_LINK",
    "convention",
    "convert_wrenches",
    "BY_END_EFFECTOR",
    "ON_END_EFFECTOR",
    "SENSES",
    "twist_about",
    "twist_rotated",
    *ros.__all__,
    *vendors.__all__,
]
