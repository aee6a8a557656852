"""Write small ROS 2 bags and MCAP files with the rosbags and mcap libraries themselves (test fixtures)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _messages(ts, t, q, qd, tau, t_w, wrench, names, frame, others=(), stamped=True):
    """(topic, msgtype, log time [ns], message) in time order; ``others``: (time, names, positions) of JointStates of
    other joints on the same topic (a gripper beside the arm); ``stamped=False``: every header.stamp left 0 (a driver that
    does not stamp its messages; the log times are the receive times)."""
    Time = ts.types["builtin_interfaces/msg/Time"]
    Header = ts.types["std_msgs/msg/Header"]
    JS = ts.types["sensor_msgs/msg/JointState"]
    WS = ts.types["geometry_msgs/msg/WrenchStamped"]
    W = ts.types["geometry_msgs/msg/Wrench"]
    V = ts.types["geometry_msgs/msg/Vector3"]

    def header(s, fid):
        ns = int(round(s * 1e9)) if stamped else 0
        return Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=fid)

    out = []
    for k, s in enumerate(t):
        eff = np.zeros(0) if tau is None else np.asarray(tau[k], float)
        msg = JS(header=header(s, ""), name=list(names), position=np.asarray(q[k], float),
                 velocity=np.asarray(qd[k], float), effort=eff)
        out.append(("/joint_states", "sensor_msgs/msg/JointState", int(round(s * 1e9)), msg))
    for s, other, pos in others:
        msg = JS(header=header(s, ""), name=list(other), position=np.asarray(pos, float),
                 velocity=np.zeros(len(other)), effort=np.zeros(len(other)))
        out.append(("/joint_states", "sensor_msgs/msg/JointState", int(round(s * 1e9)), msg))
    if wrench is not None:
        for k, s in enumerate(t_w):
            h = np.zeros(6)
            h[: wrench.shape[1]] = wrench[k]
            msg = WS(header=header(s, frame), wrench=W(force=V(x=h[0], y=h[1], z=h[2]), torque=V(x=h[3], y=h[4], z=h[5])))
            out.append(("/force_torque_sensor_broadcaster/wrench", "geometry_msgs/msg/WrenchStamped", int(round(s * 1e9)), msg))
    out.sort(key=lambda m: m[2])
    return out


def write_bag(path: Path, t, q, qd, tau=None, t_w=None, wrench=None, names=("j1", "j2"), frame="base", storage="sqlite3",
              others=(), stamped=True):
    """A rosbag2 folder written by rosbags' Writer (SQLite3 or MCAP storage)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = _typestore()
    plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
    with Writer(path, version=8, storage_plugin=plugin) as writer:
        conns = {}
        for topic, msgtype, ns, msg in _messages(ts, t, q, qd, tau, t_w if t_w is not None else t, wrench, names, frame, others,
                                                 stamped):
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
            writer.write(conns[topic], ns, bytes(ts.serialize_cdr(msg, msgtype)))
    return path


def write_mcap(path: Path, t, q, qd, tau=None, t_w=None, wrench=None, names=("j1", "j2"), frame="base", others=()):
    """A standalone .mcap file written by the mcap library's Writer (ros2msg schemas, CDR messages)."""
    from mcap.writer import Writer

    ts = _typestore()
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="forcecontrol-tests")
        channels = {}
        for topic, msgtype, ns, msg in _messages(ts, t, q, qd, tau, t_w if t_w is not None else t, wrench, names, frame, others):
            if topic not in channels:
                text = ts.generate_msgdef(msgtype, ros_version=2)[0]
                sid = w.register_schema(name=msgtype, encoding="ros2msg", data=text.encode())
                channels[topic] = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
            w.add_message(channels[topic], log_time=ns, data=bytes(ts.serialize_cdr(msg, msgtype)), publish_time=ns)
        w.finish()
    return path
