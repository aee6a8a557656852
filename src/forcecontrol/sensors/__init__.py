"""Force sensor models: the simple one (bias, white noise, first-order low-pass) and a realistic one.

:class:`ForceSensor` is exact by default and the compiled simulator loop runs it inline.
:class:`RealisticForceSensor` adds what a real wrist F/T sensor does to the signal: a bias and a
drift in the sensor frame, the weight of the tool mounted after it, quantisation of the
converter, a configurable digital filter, transport delay, and the two corrections applied on
real arms, zeroing at start (bias estimation) and tool gravity compensation. It is stateful and
runs in the Python loop (``compiled_ok`` is False). :func:`identify_tool_gravity` identifies a
tool's mass, centre of mass and the sensor bias from a few static poses (least squares).

Derivative-free by design: none of the chapter's direct force schemes (9.39)–(9.48) or the
impedance laws differentiates the measured force; their derivative terms act on ẋ_e = J q̇, and
on a real arm q̇ comes from differences of encoder positions (see :mod:`forcecontrol.sim.encoders`).
Sensor noise therefore enters through proportional and integral paths only and is not
amplified by a numerical derivative; a first-order filter is enough to keep it out of the
torques.
"""

from __future__ import annotations

from .core import ForceSensor, first_order_alpha
from .gravity import (
    ToolGravity,
    identify_tool_gravity,
    planar_sensor_rotation,
)
from .payload import PayloadForceSensor, payload_wrench
from .realistic import RealisticForceSensor

__all__ = [
    "ForceSensor",
    "RealisticForceSensor",
    "PayloadForceSensor",
    "payload_wrench",
    "ToolGravity",
    "identify_tool_gravity",
    "planar_sensor_rotation",
    "first_order_alpha",
]
