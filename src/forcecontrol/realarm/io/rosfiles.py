"""ROS 2 bags (rosbags) and MCAP files (mcap): JointState and WrenchStamped topics to a RecordedRun."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import MeasurementError, ParameterError
from ..conventions import BY_END_EFFECTOR
from ..conventions.ros import stamp_to_seconds
from .recorded import RecordedRun

__all__ = ["read_bag", "read_mcap", "DEFAULT_JOINT_TOPIC", "DEFAULT_WRENCH_TOPIC"]

#: where ``joint_state_broadcaster`` publishes (ros2_controllers).
DEFAULT_JOINT_TOPIC = "/joint_states"
#: where ``force_torque_sensor_broadcaster`` publishes (ros2_controllers, ``~/wrench``).
DEFAULT_WRENCH_TOPIC = "/force_torque_sensor_broadcaster/wrench"

JOINT_STATE = "sensor_msgs/msg/JointState"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"


def _typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _check_topics(source: str, present: dict[str, str], wanted: dict[str, tuple[str | None, str]]) -> None:
    """Every wanted topic exists with the right type; else an error listing what the file has."""
    listing = ", ".join(f"{t} ({ty})" for t, ty in sorted(present.items())) or "none"
    for role, (topic, msgtype) in wanted.items():
        if topic is None:
            continue
        if topic not in present:
            raise ParameterError(f"{source}: no {role} topic {topic!r}; the file has: {listing}")
        if present[topic] != msgtype:
            raise ParameterError(f"{source}: topic {topic!r} is {present[topic]}, not {msgtype}; the file has: {listing}")


def _assemble(
    source: str,
    joints: Iterable[tuple[int, Any]],
    wrenches: Iterable[tuple[int, Any]],
    *,
    joint_names: Sequence[str] | None,
    wrench_components: int,
    wrench_sense: str,
    wrench_point: str | None,
    stamps: str,
) -> RecordedRun:
    """Stack decoded messages ((receive time [ns], message) pairs) into a RecordedRun."""
    if stamps not in ("header", "receive"):
        raise ParameterError(f"stamps must be 'header' (message header stamps) or 'receive' (log times); got {stamps!r}")
    if wrench_components not in (1, 2, 3, 6):
        raise ParameterError(f"wrench_components must be 1, 2, 3 or 6 (fx, fy, fz, mx, my, mz); got {wrench_components!r}")

    def when(ns: int, msg: Any) -> float:
        return stamp_to_seconds(msg.header.stamp) if stamps == "header" else ns * 1e-9

    t, q, qd, tau, names = [], [], [], [], None
    for k, (ns, msg) in enumerate(joints):
        msg_names = list(msg.name)
        if names is None:
            names = list(joint_names) if joint_names else msg_names
            missing = [j for j in names if j not in msg_names]
            if missing:
                raise ParameterError(f"{source}: joint(s) {missing} are not in the JointState names {msg_names}")
        try:
            idx = [msg_names.index(j) for j in names]
        except ValueError as exc:
            raise MeasurementError(f"{source}: JointState message {k} lacks a joint of {names}: it has {msg_names}") from exc
        pos, vel, eff = (np.asarray(a, dtype=np.float64) for a in (msg.position, msg.velocity, msg.effort))
        if pos.size != len(msg_names) or vel.size != len(msg_names):
            raise MeasurementError(
                f"{source}: JointState message {k} has {pos.size} positions and {vel.size} velocities for "
                f"{len(msg_names)} names (velocities are required)"
            )
        t.append(when(ns, msg))
        q.append(pos[idx])
        qd.append(vel[idx])
        tau.append(eff[idx] if eff.size == len(msg_names) else None)
    if not t:
        raise MeasurementError(f"{source}: the joint-state topic has no messages")
    tw, h, frames = [], [], set()
    for ns, msg in wrenches:
        f, mu = msg.wrench.force, msg.wrench.torque
        h.append([f.x, f.y, f.z, mu.x, mu.y, mu.z][:wrench_components])
        tw.append(when(ns, msg))
        frames.add(msg.header.frame_id)
    if len(frames) > 1:
        raise MeasurementError(f"{source}: the wrench topic changes frame ({sorted(frames)}); one frame per log")
    t_arr = np.asarray(t)
    origin = float(min(t_arr.min(), min(tw) if tw else np.inf))
    order = np.argsort(t_arr, kind="stable")  # bags store by receive time; stamps may interleave
    has_tau = all(x is not None for x in tau)
    wrench = None
    t_wrench = None
    if tw:
        tw_arr = np.asarray(tw)
        worder = np.argsort(tw_arr, kind="stable")
        wrench, t_wrench = np.asarray(h)[worder], tw_arr[worder] - origin
    frame = frames.pop() if frames else "base"
    return RecordedRun(
        t=t_arr[order] - origin, q=np.asarray(q)[order], qd=np.asarray(qd)[order],
        tau=np.asarray(tau)[order] if has_tau else None, wrench=wrench, t_wrench=t_wrench,
        wrench_frame=frame or "base", wrench_point=wrench_point or frame or "base", wrench_sense=wrench_sense,
        joint_names=tuple(names or ()), time_origin=origin, source=source,
    )


def read_bag(
    path: str | Path, *, joint_topic: str = DEFAULT_JOINT_TOPIC, wrench_topic: str | None = DEFAULT_WRENCH_TOPIC,
    joint_names: Sequence[str] | None = None, wrench_components: int = 6, wrench_sense: str = BY_END_EFFECTOR,
    wrench_point: str | None = None, stamps: str = "header",
) -> RecordedRun:
    """Read a ROS 2 bag (a rosbag2 folder; SQLite or MCAP storage) with the rosbags library.

    Args:
        path: the bag folder (with ``metadata.yaml``).
        joint_topic: a ``sensor_msgs/msg/JointState`` topic (positions and velocities required;
            efforts read as torques when every message has them).
        wrench_topic: a ``geometry_msgs/msg/WrenchStamped`` topic, or None for no wrench.
        joint_names: the joints to read, in this order (default: the first message's order).
        wrench_components: keep ``fx fy`` (2), ``fx fy fz`` (3) or all 6 components.
        wrench_sense: what the wrench topic reports (a WrenchStamped does not say; default: the
            library's, by the end-effector on the environment).
        wrench_point: the moment's reference point (default: the header's frame origin).
        stamps: ``"header"`` (message stamps) or ``"receive"`` (the bag's log times).

    Returns:
        A RecordedRun with times relative to the first stamp (``time_origin`` holds it); the
        wrench keeps its own time base until :meth:`RecordedRun.resample`.

    Raises:
        ParameterError: no such bag, or a topic missing or of another type (the message lists
            the bag's topics and types).
    """
    from rosbags.rosbag2 import Reader

    path = Path(path)
    if not path.exists():
        raise ParameterError(f"ROS 2 bag {str(path)!r} does not exist")
    ts = _typestore()
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # rosbags raises its own error types
        raise ParameterError(f"{path}: cannot be opened as a ROS 2 bag: {exc}") from exc
    try:
        present = {c.topic: c.msgtype for c in reader.connections}
        _check_topics(str(path), present, {"joint-state": (joint_topic, JOINT_STATE), "wrench": (wrench_topic, WRENCH_STAMPED)})

        def stream(topic: str | None) -> list[tuple[int, Any]]:
            if topic is None:
                return []
            conns = [c for c in reader.connections if c.topic == topic]
            return [(ns, ts.deserialize_cdr(raw, c.msgtype)) for c, ns, raw in reader.messages(connections=conns)]

        joints, wrenches = stream(joint_topic), stream(wrench_topic)
    finally:
        reader.close()
    return _assemble(
        str(path), joints, wrenches, joint_names=joint_names, wrench_components=wrench_components,
        wrench_sense=wrench_sense, wrench_point=wrench_point, stamps=stamps,
    )


def read_mcap(
    path: str | Path, *, joint_topic: str = DEFAULT_JOINT_TOPIC, wrench_topic: str | None = DEFAULT_WRENCH_TOPIC,
    joint_names: Sequence[str] | None = None, wrench_components: int = 6, wrench_sense: str = BY_END_EFFECTOR,
    wrench_point: str | None = None, stamps: str = "header",
) -> RecordedRun:
    """Read an MCAP file of CDR-encoded ROS 2 messages (mcap library; decoded with rosbags' serde).

    Arguments and result as :func:`read_bag`; the channels' schemas must be ROS 2 types
    (``ros2msg`` encoding) and the messages ``cdr``-encoded.

    Raises:
        ParameterError: no such file, not an MCAP file, a topic missing or of another type (the
            message lists the file's topics), or messages in another encoding.
    """
    from mcap.reader import make_reader

    path = Path(path)
    if not path.is_file():
        raise ParameterError(f"MCAP file {str(path)!r} does not exist")
    ts = _typestore()
    with path.open("rb") as f:
        try:
            reader = make_reader(f)
            summary = reader.get_summary()
        except Exception as exc:  # the mcap library raises its own error types
            raise ParameterError(f"{path}: cannot be read as an MCAP file: {exc}") from exc
        channels = summary.channels if summary is not None else {}
        schemas = summary.schemas if summary is not None else {}
        present = {ch.topic: (schemas[ch.schema_id].name if ch.schema_id in schemas else "?") for ch in channels.values()}
        _check_topics(str(path), present, {"joint-state": (joint_topic, JOINT_STATE), "wrench": (wrench_topic, WRENCH_STAMPED)})
        for ch in channels.values():
            if ch.topic in (joint_topic, wrench_topic) and ch.message_encoding != "cdr":
                raise ParameterError(f"{path}: topic {ch.topic!r} is encoded as {ch.message_encoding!r}; expected 'cdr' (ROS 2)")
        joints: list[tuple[int, Any]] = []
        wrenches: list[tuple[int, Any]] = []
        decode: Callable[[bytes, str], Any] = ts.deserialize_cdr
        topics = [t for t in (joint_topic, wrench_topic) if t is not None]
        for schema, channel, message in reader.iter_messages(topics=topics):
            item = (message.log_time, decode(message.data, schema.name))
            (joints if channel.topic == joint_topic else wrenches).append(item)
    return _assemble(
        str(path), joints, wrenches, joint_names=joint_names, wrench_components=wrench_components,
        wrench_sense=wrench_sense, wrench_point=wrench_point, stamps=stamps,
    )
