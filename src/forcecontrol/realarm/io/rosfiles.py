"""ROS 2 bags (rosbags) and MCAP files (mcap): JointState and WrenchStamped topics to a RecordedRun."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...core.files import MAX_RECORDING_BYTES, check_regular
from ...errors import MeasurementError, ParameterError
from ..conventions import BY_END_EFFECTOR
from ..conventions.ros import stamp_to_ns
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


def _decode_all(
    source: str, topic: str, raws: Iterable[tuple[str, int, bytes]], decode: Callable[[bytes, str], Any],
    skip_corrupt: bool, skipped: list[str],
) -> list[tuple[int, Any]]:
    """Decode (msgtype, log time [ns], CDR bytes) of one topic; a corrupt message is refused or skipped with a warning."""
    out, bad = [], 0
    for k, (msgtype, ns, raw) in enumerate(raws):
        try:
            out.append((ns, decode(raw, msgtype)))
        except Exception as exc:  # rosbags' serde raises its own types (SerdeError) and struct/Index errors
            problem = f"{source}: message {k} of topic {topic!r} ({msgtype}) cannot be decoded ({type(exc).__name__})"
            if not skip_corrupt:
                raise MeasurementError(problem + "; pass skip_corrupt=True to skip corrupt messages with a warning") from None
            bad += 1
            skipped.append(problem)
    if bad:
        warnings.warn(f"{source}: skipped {bad} corrupt message(s) of topic {topic!r} (skip_corrupt=True)", UserWarning,
                      stacklevel=3)
    return out


def _check_stamps(source: str, what: str, stamps_ns: list[int], stamps: str) -> None:
    """Refuse header stamps all left at 0 (a driver that does not stamp its messages). One stamp 0 among others is a
    clock that starts at 0 (a simulator's), not refused."""
    if stamps == "header" and len(stamps_ns) > 1 and not any(stamps_ns):
        raise MeasurementError(f"{source}: the {what} messages carry no header stamps (all 0, a driver that does not "
                               "stamp them): read the log by its receive times, stamps='receive' (--stamps receive)")


def _assemble(
    source: str,
    joints: Iterable[tuple[int, Any]],
    wrenches: Iterable[tuple[int, Any]],
    *,
    joint_names: Sequence[str] | None,
    wrench_components: int,
    prefer_joint_names: Sequence[str] | None = None,
    wrench_sense: str,
    wrench_point: str | None,
    stamps: str,
    skipped: Sequence[str] = (),
    wrench_topic: str | None = None,
) -> RecordedRun:
    """Stack decoded messages ((receive time [ns], message) pairs) into a RecordedRun; what it leaves out or assumes
    is said in ``metadata["notes"]``."""
    if stamps not in ("header", "receive"):
        raise ParameterError(f"stamps must be 'header' (message header stamps) or 'receive' (log times); got {stamps!r}")
    if wrench_components not in (1, 2, 3, 6):
        raise ParameterError(f"wrench_components must be 1, 2, 3 or 6 (fx, fy, fz, mx, my, mz); got {wrench_components!r}")

    def when(ns: int, msg: Any) -> int:  # integer nanoseconds: the origin is subtracted before they become seconds
        return stamp_to_ns(msg.header.stamp) if stamps == "header" else int(ns)

    joints = list(joints)
    sets: dict[frozenset[str], list[str]] = {}  # the topic's joint sets (an arm and a gripper may share /joint_states)
    for _, msg in joints:
        sets.setdefault(frozenset(msg.name), list(msg.name))
    preferred = bool(not joint_names and prefer_joint_names and any(set(prefer_joint_names) <= s_ for s_ in sets))
    if preferred:
        joint_names = list(prefer_joint_names or ())  # a model's joints, all on the topic
    if joint_names:
        names = list(joint_names)
        if len(set(names)) != len(names):
            raise ParameterError(f"{source}: joint_names must name each joint once; got {names}")
        known = set().union(*sets) if sets else set()
        missing = [j for j in names if j not in known]
        if missing:
            raise ParameterError(f"{source}: joint(s) {missing} are not in the JointState names {sorted(known)}")
        holding = [s_ for s_ in sets if set(names) <= s_]
        if not holding:
            raise ParameterError(f"{source}: no JointState message holds all of {names}; the topic's messages hold: "
                                 + "; ".join(", ".join(v) for v in sets.values()))
        chosen = min(holding, key=len)  # the arm's own messages, before those merged with a gripper's
    else:  # the largest set (the arm's, beside a gripper's)
        named = [k for k in sets if k]
        chosen = max(named, key=len) if named else frozenset()
        tied = [sets[k] for k in named if len(k) == len(chosen)]
        if len(tied) > 1:
            raise ParameterError(f"{source}: the joint-state topic carries JointStates of {len(tied)} sets of "
                                 f"{len(chosen)} joints ({'; '.join(', '.join(v) for v in tied)}): name the joints to "
                                 "read (joint_names, --joint-names)")
        names = sets[chosen] if named else []
    others: dict[str, int] = {}  # messages of another set of joints, passed over: their joints -> count
    t, q, qd, tau = [], [], [], []
    for k, (ns, msg) in enumerate(joints):
        msg_names = list(msg.name)
        if frozenset(msg_names) != chosen:
            key = ", ".join(msg_names) or "no joint names"
            others[key] = others.get(key, 0) + 1
            continue
        idx = [msg_names.index(j) for j in names]
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
        raise MeasurementError(f"{source}: the joint-state topic has no messages" if not joints else
                               f"{source}: none of the topic's {len(joints)} JointState messages names its joints")
    _check_stamps(source, "JointState", t, stamps)
    names_note = [f"{n} JointState message(s) of another set of joints ({who}) passed over: the log reads "
                  f"{', '.join(names)}" + ("" if joint_names else " (the topic's largest set of joints; choose others "
                                                                   "with joint_names, --joint-names)")
                  for who, n in others.items()]
    if preferred and sets[chosen] != names:
        names_note.append(f"the log's joints {sets[chosen]} reordered to the model's order {names}")
    tw, h, frames = [], [], set()
    for ns, msg in wrenches:
        f, mu = msg.wrench.force, msg.wrench.torque
        h.append([f.x, f.y, f.z, mu.x, mu.y, mu.z][:wrench_components])
        tw.append(when(ns, msg))
        frames.add(msg.header.frame_id)
    if tw:
        _check_stamps(source, "wrench", tw, stamps)
    if len(frames) > 1:
        raise MeasurementError(f"{source}: the wrench topic changes frame ({sorted(frames)}); one frame per log")
    origin = min(min(t), min(tw) if tw else min(t))
    t_arr = np.array([k - origin for k in t], dtype=np.float64) / 1e9  # exact integers below 2⁵³ ns, then seconds
    order = np.argsort(t_arr, kind="stable")  # bags store by receive time; stamps may interleave
    has_tau = all(x is not None for x in tau)
    wrench = None
    t_wrench = None
    if tw:
        tw_arr = np.array([k - origin for k in tw], dtype=np.float64) / 1e9
        worder = np.argsort(tw_arr, kind="stable")
        wrench, t_wrench = np.asarray(h)[worder], tw_arr[worder]
    frame = frames.pop() if frames else "base"
    notes = names_note
    missing_effort = sum(x is None for x in tau)
    if 0 < missing_effort < len(tau):
        notes.append(f"{missing_effort} of {len(tau)} JointState messages carry no efforts: the recorded torques are "
                     "left out (every message must have them)")
    if wrench_topic is not None and not tw:
        notes.append(f"the wrench topic {wrench_topic!r} has no messages: the log has no wrench")
    if tw and not frame:
        notes.append("the wrench messages' header.frame_id is empty: the wrench is taken as in the base frame, about "
                     "its origin")
    meta: dict[str, Any] = {"skipped_corrupt": len(skipped)} if skipped else {}
    if others:
        meta["joint_states_passed_over"] = others  # their joints -> how many
    if notes:
        meta["notes"] = notes
    return RecordedRun(
        t=t_arr[order], q=np.asarray(q)[order], qd=np.asarray(qd)[order],
        tau=np.asarray(tau)[order] if has_tau else None, wrench=wrench, t_wrench=t_wrench,
        wrench_frame=frame or "base", wrench_point=wrench_point or frame or "base", wrench_sense=wrench_sense,
        joint_names=tuple(names or ()), time_origin=origin / 1e9, source=source, metadata=meta,
    )


def read_bag(
    path: str | Path, *, joint_topic: str = DEFAULT_JOINT_TOPIC, wrench_topic: str | None = DEFAULT_WRENCH_TOPIC,
    joint_names: Sequence[str] | None = None, wrench_components: int = 6, wrench_sense: str = BY_END_EFFECTOR,
    wrench_point: str | None = None, stamps: str = "header", skip_corrupt: bool = False,
    max_bytes: int = MAX_RECORDING_BYTES, prefer_joint_names: Sequence[str] | None = None,
) -> RecordedRun:
    """Read a ROS 2 bag (a rosbag2 folder; SQLite or MCAP storage) with the rosbags library.

    Args:
        path: the bag folder (with ``metadata.yaml``).
        joint_topic: a ``sensor_msgs/msg/JointState`` topic (positions and velocities required;
            efforts read as torques when every message has them).
        wrench_topic: a ``geometry_msgs/msg/WrenchStamped`` topic, or None for no wrench.
        joint_names: the joints to read, in this order; the messages of exactly the smallest set of joints holding them
            are read (an arm's own, not those merged with a gripper's), the others passed over and counted in
            ``metadata["notes"]``. Default: ``prefer_joint_names`` when the topic holds them all, else the topic's
            largest set of joints in its first message's order (two sets of that size are refused).
        prefer_joint_names: a model's joints, read when the topic holds them all (replay passes its robot's).
        wrench_components: keep ``fx fy`` (2), ``fx fy fz`` (3) or all 6 components.
        wrench_sense: what the wrench topic reports (a WrenchStamped does not say; default: the
            library's, by the end-effector on the environment).
        wrench_point: the moment's reference point (default: the header's frame origin).
        stamps: ``"header"`` (message stamps) or ``"receive"`` (the bag's log times).
        skip_corrupt: a message that cannot be decoded is refused (False, the default) or skipped
            with a warning giving the count (True; the count is in ``metadata["skipped_corrupt"]``).
        max_bytes: the size limit of the file (of each storage file of a bag) [bytes], default 2 GiB.

    Returns:
        A RecordedRun with times relative to the first stamp (``time_origin`` holds it); the
        wrench keeps its own time base until :meth:`RecordedRun.resample`.

    Raises:
        ParameterError: no such bag, or a topic missing or of another type (the message lists
            the bag's topics and types); a special or oversized file.
        MeasurementError: a message that cannot be decoded (file, topic, message index and the
            decoder's error type named), unless ``skip_corrupt``.
    """
    from rosbags.rosbag2 import Reader

    path = Path(path)
    if not path.exists():
        raise ParameterError(f"ROS 2 bag {str(path)!r} does not exist")
    if not path.is_dir():
        raise ParameterError(f"ROS 2 bag {str(path)!r} must be a bag folder (with metadata.yaml)")
    for f in sorted(path.iterdir()):
        if f.name == "metadata.yaml" or f.suffix in (".db3", ".mcap"):
            check_regular(f, "ROS 2 bag file", max_bytes)
    ts = _typestore()
    skipped: list[str] = []
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # rosbags raises its own error types
        raise ParameterError(f"{path}: cannot be opened as a ROS 2 bag ({type(exc).__name__})") from None
    try:
        present = {c.topic: c.msgtype for c in reader.connections}
        _check_topics(str(path), present, {"joint-state": (joint_topic, JOINT_STATE), "wrench": (wrench_topic, WRENCH_STAMPED)})

        def stream(topic: str | None) -> list[tuple[int, Any]]:
            if topic is None:
                return []
            conns = [c for c in reader.connections if c.topic == topic]
            raws = ((c.msgtype, ns, raw) for c, ns, raw in reader.messages(connections=conns))
            return _decode_all(str(path), topic, raws, ts.deserialize_cdr, skip_corrupt, skipped)

        try:
            joints, wrenches = stream(joint_topic), stream(wrench_topic)
        except MeasurementError:
            raise
        except Exception as exc:  # the storage itself (SQLite, MCAP) is corrupt or truncated
            raise MeasurementError(f"{path}: the bag's storage is corrupt or truncated ({type(exc).__name__})") from None
    finally:
        reader.close()
    return _assemble(
        str(path), joints, wrenches, joint_names=joint_names, prefer_joint_names=prefer_joint_names,
        wrench_components=wrench_components,
        wrench_sense=wrench_sense, wrench_point=wrench_point, stamps=stamps, skipped=skipped, wrench_topic=wrench_topic,
    )


def read_mcap(
    path: str | Path, *, joint_topic: str = DEFAULT_JOINT_TOPIC, wrench_topic: str | None = DEFAULT_WRENCH_TOPIC,
    joint_names: Sequence[str] | None = None, wrench_components: int = 6, wrench_sense: str = BY_END_EFFECTOR,
    wrench_point: str | None = None, stamps: str = "header", skip_corrupt: bool = False,
    max_bytes: int = MAX_RECORDING_BYTES, prefer_joint_names: Sequence[str] | None = None,
) -> RecordedRun:
    """Read an MCAP file of CDR-encoded ROS 2 messages (mcap library; decoded with rosbags' serde).

    Arguments and result as :func:`read_bag`; the channels' schemas must be ROS 2 types
    (``ros2msg`` encoding) and the messages ``cdr``-encoded.

    Raises:
        ParameterError: no such file, not an MCAP file, a special or oversized file, a topic
            missing or of another type (the message lists the file's topics), or messages in another encoding.
        MeasurementError: a corrupt or truncated file, or a message that cannot be decoded (file,
            topic, message index named), unless ``skip_corrupt``.
    """
    from mcap.reader import make_reader

    path = Path(path)
    if not path.exists():
        raise ParameterError(f"MCAP file {str(path)!r} does not exist")
    check_regular(path, "MCAP file", max_bytes)
    ts = _typestore()
    skipped: list[str] = []
    with path.open("rb") as f:
        try:
            reader = make_reader(f)
            summary = reader.get_summary()
        except Exception as exc:  # the mcap library raises its own error types
            raise ParameterError(f"{path}: cannot be read as an MCAP file ({type(exc).__name__})") from None
        if summary is not None:
            channels, schemas = summary.channels, summary.schemas
        else:  # the summary section is optional (a streaming writer, `mcap recover`): the channels from one pass
            channels, schemas = {}, {}
            try:
                for schema, channel, _ in reader.iter_messages():
                    channels.setdefault(channel.id, channel)
                    if schema is not None:
                        schemas.setdefault(schema.id, schema)
            except Exception as exc:  # the mcap library raises its own error types
                raise MeasurementError(f"{path}: the MCAP file is corrupt or truncated ({type(exc).__name__})") from None
            f.seek(0)
            reader = make_reader(f)
        present = {ch.topic: (schemas[ch.schema_id].name if ch.schema_id in schemas else "?") for ch in channels.values()}
        _check_topics(str(path), present, {"joint-state": (joint_topic, JOINT_STATE), "wrench": (wrench_topic, WRENCH_STAMPED)})
        for ch in channels.values():
            if ch.topic in (joint_topic, wrench_topic) and ch.message_encoding != "cdr":
                raise ParameterError(f"{path}: topic {ch.topic!r} is encoded as {ch.message_encoding!r}; expected 'cdr' (ROS 2)")
        raw: dict[str, list[tuple[str, int, bytes]]] = {t: [] for t in (joint_topic, wrench_topic) if t is not None}
        try:
            for schema, channel, message in reader.iter_messages(topics=list(raw)):
                raw[channel.topic].append((schema.name, message.log_time, message.data))
        except Exception as exc:  # the mcap library raises its own error types (truncated chunk, bad CRC, ...)
            raise MeasurementError(f"{path}: the MCAP file is corrupt or truncated ({type(exc).__name__})") from None
        decode: Callable[[bytes, str], Any] = ts.deserialize_cdr
        joints = _decode_all(str(path), joint_topic, raw[joint_topic], decode, skip_corrupt, skipped)
        wrenches = [] if wrench_topic is None else _decode_all(str(path), wrench_topic, raw[wrench_topic], decode,
                                                                skip_corrupt, skipped)
    return _assemble(
        str(path), joints, wrenches, joint_names=joint_names, prefer_joint_names=prefer_joint_names,
        wrench_components=wrench_components,
        wrench_sense=wrench_sense, wrench_point=wrench_point, stamps=stamps, skipped=skipped, wrench_topic=wrench_topic,
    )
