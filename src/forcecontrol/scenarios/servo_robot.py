"""The ``[robot.servo]`` table: a robot of a scenario seen through its joint servo (position/velocity interface).

``[robot.servo]`` with ``preset = "ur-e-series" | "kuka-rsi" | "franka-joint-position"``, or UR's
``gain`` and ``lookahead_time`` (servoj), or ``rate`` and ``bandwidth``; any other key of
:class:`~forcecontrol.robots.servo.JointServo` overrides.
"""

from __future__ import annotations

from typing import Any

from ..errors import ForceControlError, ScenarioError
from .schema import Field, check_table

__all__ = ["SERVO_FIELDS", "servo_robot"]

SERVO_FIELDS: dict[str, Field] = {
    "preset": Field("str", choices=("ur-e-series", "kuka-rsi", "franka-joint-position"),
                    doc="start from a named preset (its documented rate and limits; nominal bandwidth/delay)"),
    "rate": Field("number", low=1.0, high=1e5, doc="interface rate [Hz]"),
    "bandwidth": Field("gain", low=0.0, doc="servo natural frequency ω_s [rad/s] (number or one per joint)"),
    "damping": Field("gain", low=0.0, doc="servo damping ratio ζ_s (number or one per joint)"),
    "gain": Field("number", low=1.0, high=1e5, doc="UR servoj gain (ω_s = √gain; inferred mapping)"),
    "lookahead_time": Field("number", low=1e-3, high=1.0, doc="UR servoj lookahead_time [s] (ζ_s = T_la √gain / 2)"),
    "delay": Field("int", low=0, high=100, doc="transport delay [whole interface cycles]"),
    "interface": Field("str", choices=("position", "velocity"), doc="what the arm takes (default position)"),
    "tracking": Field("str", choices=("ideal", "dynamic"),
                      doc="'ideal': the joints follow the servo whatever the contact; 'dynamic': PD on the arm"),
    "tracking_bandwidth": Field("number", low=1.0, doc="ω_t of the ideal realisation's tracking [rad/s]"),
    "velocity_limit": Field("gain", low=0.0, doc="joint speed limit [rad/s]"),
    "acceleration_limit": Field("gain", low=0.0, doc="joint acceleration limit [rad/s²]"),
    "jerk_limit": Field("gain", low=0.0, doc="joint jerk limit [rad/s³]"),
    "lowpass_cutoff": Field("number", low=0.0, doc="first-order low-pass on the commands [Hz]"),
}


def servo_robot(where: str, table: Any, robot: Any) -> Any:
    """The robot wrapped in the servo a ``[robot.servo]`` table (or a preset name) describes."""
    from ..robots.servo import JointServo, PositionInterfaceRobot

    tw = f"{where}: [robot.servo]"
    if isinstance(table, str):
        table = {"preset": table}
    p = check_table(tw, table, SERVO_FIELDS)
    n = int(robot.nq)
    given = {k: v for k, v in p.items() if v is not None and k not in ("preset", "gain", "lookahead_time")}
    try:
        if (p["gain"] is None) != (p["lookahead_time"] is None):
            raise ScenarioError(f"{tw}: give both 'gain' and 'lookahead_time' (UR servoj) or neither")
        if p["gain"] is not None:
            if p["preset"] is not None or "bandwidth" in given or "damping" in given:
                raise ScenarioError(f"{tw}: 'gain'/'lookahead_time' replace 'preset', 'bandwidth' and 'damping'; give one way")
            servo = JointServo.servoj(nq=n, gain=p["gain"], lookahead_time=p["lookahead_time"], **given)
        elif p["preset"] is not None:
            servo = JointServo.preset(p["preset"], nq=n, **given)
        else:
            if "rate" not in given or "bandwidth" not in given:
                raise ScenarioError(f"{tw}: needs 'preset', or 'gain' and 'lookahead_time', or 'rate' and 'bandwidth'")
            servo = JointServo(nq=n, **given)
        return PositionInterfaceRobot(robot, servo)
    except ScenarioError:
        raise
    except ForceControlError as exc:
        raise ScenarioError(f"{tw}: {exc}") from exc
