"""ROS 2 message layouts: geometry_msgs WrenchStamped, PoseStamped, TwistStamped.

Messages are plain dictionaries with the ROS 2 field names (what ``ros2 topic echo`` prints and
``rosbags``/``mcap`` decoders give) or rosbags message objects; :func:`ros_message` builds the
rosbags object from a dictionary and :func:`ros_dict` the reverse. Conventions of the messages
(https://docs.ros2.org/latest/api/geometry_msgs/ , REP 103, REP 105):

* ``header.frame_id`` names the frame the vectors are expressed in; a Wrench's torque and a
  Twist's linear velocity refer to that frame's origin;
* ``header.stamp`` is ``{sec, nanosec}``;
* a Quaternion is ``x, y, z, w`` (scalar last), as SciPy's ``Rotation.from_quat`` default;
* a Wrench carries no sense: the caller says which one (``sense=``), because drivers differ.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...core.validate import as_vector
from ...errors import FrameError, ParameterError
from ...spatial import Transform, Twist, Wrench
from .wrench import SensedWrench

__all__ = [
    "wrench_from_ros",
    "wrench_to_ros",
    "pose_from_ros",
    "pose_to_ros",
    "twist_from_ros",
    "twist_to_ros",
    "ros_message",
    "ros_dict",
    "stamp_to_seconds",
    "seconds_to_stamp",
]


def _get(msg: Any, path: str) -> Any:
    node = msg
    for key in path.split("."):
        if isinstance(node, dict):
            if key not in node:
                raise ParameterError(f"ROS message is missing field {path!r} (no {key!r} in {sorted(node)})")
            node = node[key]
        elif hasattr(node, key):
            node = getattr(node, key)
        else:
            raise ParameterError(f"ROS message is missing field {path!r} (a {type(node).__name__} has no {key!r})")
    return node


def _vec3(msg: Any, path: str) -> np.ndarray:
    return as_vector(path, [_get(msg, f"{path}.{a}") for a in "xyz"], 3)


def stamp_to_seconds(stamp: Any) -> float:
    """``{sec, nanosec}`` → seconds (a float: about 0.24 µs resolution at today's epoch; see :func:`stamp_to_ns`)."""
    return float(_get(stamp, "sec")) + 1e-9 * float(_get(stamp, "nanosec"))


def stamp_to_ns(stamp: Any) -> int:
    """``{sec, nanosec}`` → integer nanoseconds, exact (for differences: a float of epoch seconds keeps 0.24 µs)."""
    return int(_get(stamp, "sec")) * 1_000_000_000 + int(_get(stamp, "nanosec"))


def seconds_to_stamp(t: float) -> dict[str, int]:
    """Seconds → ``{sec, nanosec}`` (nanosec in [0, 1e9))."""
    if not math.isfinite(t):
        raise ParameterError(f"stamp must be finite; got {t!r}")
    ns = int(round(t * 1e9))
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _header(frame_id: str, stamp: float | None) -> dict[str, Any]:
    return {"stamp": seconds_to_stamp(0.0 if stamp is None else stamp), "frame_id": frame_id}


def _xyz(v: np.ndarray) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def wrench_from_ros(msg: Any, *, sense: str) -> SensedWrench:
    """A geometry_msgs/WrenchStamped (dict or rosbags object) as a :class:`SensedWrench`.

    Args:
        msg: the message; the wrench is in ``header.frame_id`` about that frame's origin.
        sense: what the publisher reports: ``"by-end-effector"`` or ``"on-end-effector"`` (a
            WrenchStamped does not say; e.g. libfranka's external wrench is on the end-effector).

    Raises:
        ParameterError: a field is missing or not a number; FrameError: an empty frame_id.
    """
    frame = _get(msg, "header.frame_id")
    if not isinstance(frame, str) or not frame:
        raise FrameError(f"WrenchStamped header.frame_id must name the frame the wrench is expressed in; got {frame!r}")
    w = Wrench(_vec3(msg, "wrench.force"), _vec3(msg, "wrench.torque"), frame, frame)
    return SensedWrench(w, sense, stamp_to_seconds(_get(msg, "header.stamp")))


def wrench_to_ros(wrench: SensedWrench, *, sense: str | None = None) -> dict[str, Any]:
    """A :class:`SensedWrench` as a geometry_msgs/WrenchStamped dictionary.

    Args:
        wrench: must be about its own frame's origin (a WrenchStamped has no separate point).
        sense: the sense to publish (converted); by default the wrench's own.

    Raises:
        FrameError: the moment is about another point than the frame's origin (use ``.about`` first).
    """
    if wrench.point != wrench.frame:
        raise FrameError(
            f"a WrenchStamped's torque is about the origin of header.frame_id; this wrench is in {wrench.frame!r} "
            f"about {wrench.point!r}: move it with .about({wrench.frame!r}, r) first"
        )
    w = wrench.in_sense(sense).wrench if sense is not None else wrench.wrench
    return {"header": _header(w.frame, wrench.stamp), "wrench": {"force": _xyz(w.force), "torque": _xyz(w.moment)}}


def pose_from_ros(msg: Any, *, child: str) -> tuple[Transform, float]:
    """A geometry_msgs/PoseStamped as the pose of frame ``child`` in ``header.frame_id`` and its stamp [s].

    The quaternion is read as ``x, y, z, w`` and must have unit norm (within 1e-6).

    Raises:
        ParameterError: a missing field or a quaternion that is not of unit norm.
    """
    from scipy.spatial.transform import Rotation

    quat = as_vector("pose.orientation", [_get(msg, f"pose.orientation.{a}") for a in "xyzw"], 4)
    norm = float(np.linalg.norm(quat))
    if abs(norm - 1.0) > 1e-6:
        raise ParameterError(f"pose.orientation must be a unit quaternion (x, y, z, w); got norm {norm:.9g}: {quat.tolist()}")
    R = Rotation.from_quat(quat).as_matrix()  # SciPy's default order is scalar-last: x, y, z, w
    X = Transform(R, _vec3(msg, "pose.position"), parent=_get(msg, "header.frame_id"), child=child)
    return X, stamp_to_seconds(_get(msg, "header.stamp"))


def pose_to_ros(X: Transform, *, stamp: float | None = None) -> dict[str, Any]:
    """A :class:`~forcecontrol.spatial.Transform` as a PoseStamped dictionary (frame_id = ``X.parent``)."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(X.rotation).as_quat()
    return {
        "header": _header(X.parent, stamp),
        "pose": {"position": _xyz(X.translation), "orientation": {"x": float(x), "y": float(y), "z": float(z), "w": float(w)}},
    }


def twist_from_ros(msg: Any) -> tuple[Twist, float]:
    """A geometry_msgs/TwistStamped as a :class:`~forcecontrol.spatial.Twist` (frame and point: frame_id) and its stamp."""
    frame = _get(msg, "header.frame_id")
    if not isinstance(frame, str) or not frame:
        raise FrameError(f"TwistStamped header.frame_id must name a frame; got {frame!r}")
    tw = Twist(_vec3(msg, "twist.linear"), _vec3(msg, "twist.angular"), frame, frame)
    return tw, stamp_to_seconds(_get(msg, "header.stamp"))


def twist_to_ros(twist: Twist, *, stamp: float | None = None) -> dict[str, Any]:
    """A Twist as a TwistStamped dictionary; it must be at its own frame's origin.

    Raises:
        FrameError: the twist's point is not its frame's origin.
    """
    if twist.point != twist.frame:
        raise FrameError(
            f"a TwistStamped's linear velocity is that of header.frame_id's origin; this twist is in {twist.frame!r} "
            f"at {twist.point!r}: move it with twist_about first"
        )
    return {"header": _header(twist.frame, stamp), "twist": {"linear": _xyz(twist.linear), "angular": _xyz(twist.angular)}}


def _typestore(typestore: Any = None) -> Any:
    if typestore is not None:
        return typestore
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def ros_message(layout: dict[str, Any], msgtype: str, typestore: Any = None) -> Any:
    """The rosbags message object of type ``msgtype`` (e.g. ``"geometry_msgs/msg/WrenchStamped"``) from a dict.

    Args:
        layout: the message as nested dictionaries (as :func:`wrench_to_ros` returns).
        msgtype: the ROS 2 type name; typestore: a rosbags typestore (ROS 2 Humble by default).

    Raises:
        ParameterError: an unknown type or field.
    """
    import dataclasses

    ts = _typestore(typestore)
    if msgtype not in ts.types:
        raise ParameterError(f"unknown ROS message type {msgtype!r}")
    cls = ts.types[msgtype]
    kwargs: dict[str, Any] = {}
    names = [f.name for f in dataclasses.fields(cls) if f.name != "__msgtype__"]
    extra = set(layout) - set(names)
    if extra:
        raise ParameterError(f"{msgtype} has no field(s) {sorted(extra)}; its fields are {names}")
    for name, ftype in ts.fielddefs[msgtype][1]:
        if name not in layout:
            raise ParameterError(f"{msgtype} needs field {name!r}")
        value = layout[name]
        if isinstance(value, dict):  # a nested message: its field definition is (NAME, type name)
            kwargs[name] = ros_message(value, ftype[1], ts)
        elif isinstance(value, (list, tuple, np.ndarray)):  # a sequence or array: (kind, ((BASE, (type, _)), n))
            base = ftype[1][0][1][0] if isinstance(ftype[1][0], tuple) and isinstance(ftype[1][0][1], tuple) else ""
            kwargs[name] = np.asarray(value, dtype=np.float64) if str(base).startswith("float") else list(value)
        else:
            kwargs[name] = value
    return cls(**kwargs)


def ros_dict(msg: Any) -> Any:
    """A rosbags message object (or any nesting of them) as plain dictionaries, lists and numbers."""
    import dataclasses

    if dataclasses.is_dataclass(msg) and not isinstance(msg, type):
        return {f.name: ros_dict(getattr(msg, f.name)) for f in dataclasses.fields(msg) if f.name != "__msgtype__"}
    if isinstance(msg, np.ndarray):
        return msg.tolist()
    if isinstance(msg, (list, tuple)):
        return [ros_dict(v) for v in msg]
    return msg
