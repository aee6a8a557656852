"""Recorded data: CSV/Parquet tables, ROS 2 bags and MCAP files written by their own libraries, resampling."""

from __future__ import annotations

import numpy as np
import pytest

from forcecontrol.errors import DimensionError, MeasurementError, ParameterError
from forcecontrol.realarm.conventions import ON_END_EFFECTOR
from forcecontrol.realarm.io import RecordedRun, read_bag, read_mcap, read_recording, read_table
from rosfiles_helpers import write_bag, write_mcap


def _signals(N=51, dt=0.002):
    t = 100.0 + dt * np.arange(N)  # absolute stamps, as a robot's clock gives them
    q = np.column_stack([np.sin(t), np.cos(2 * t)])
    qd = np.column_stack([np.cos(t), -2 * np.sin(2 * t)])
    tau = np.column_stack([t, -t])
    t_w = 100.0005 + 0.001 * np.arange(2 * N - 3)  # a faster sensor, offset
    wrench = np.column_stack([np.full_like(t_w, 3.0), t_w - 100, np.zeros_like(t_w), 0.1 + 0 * t_w, 0.2 + 0 * t_w, t_w])
    return t, q, qd, tau, t_w, wrench


@pytest.mark.parametrize("kind", ["bag-sqlite3", "bag-mcap", "mcap"])
def test_ros_files_written_by_their_libraries_read_back_equal(tmp_path, kind):
    """JointState and WrenchStamped written with rosbags' / mcap's writers read back as the arrays written."""
    t, q, qd, tau, t_w, wrench = _signals()
    if kind == "mcap":
        path = write_mcap(tmp_path / "run.mcap", t, q, qd, tau, t_w, wrench, frame="ft_frame")
        rec = read_mcap(path, wrench_sense=ON_END_EFFECTOR)
    else:
        path = write_bag(tmp_path / "bag", t, q, qd, tau, t_w, wrench, frame="ft_frame", storage=kind.split("-")[1])
        rec = read_bag(path, wrench_sense=ON_END_EFFECTOR)
    assert rec.time_origin == pytest.approx(100.0, abs=1e-9) and rec.joint_names == ("j1", "j2")
    np.testing.assert_allclose(rec.t + rec.time_origin, t, atol=1e-9)
    np.testing.assert_array_equal(rec.q, q)
    np.testing.assert_array_equal(rec.qd, qd)
    np.testing.assert_array_equal(rec.tau, tau)
    np.testing.assert_allclose(rec.t_wrench + rec.time_origin, t_w, atol=1e-9)
    np.testing.assert_array_equal(rec.wrench, wrench)
    assert (rec.wrench_frame, rec.wrench_point, rec.wrench_sense) == ("ft_frame", "ft_frame", ON_END_EFFECTOR)
    assert read_recording(path).n == 2  # the format told from the path


def test_joint_names_reorder_and_wrench_components(tmp_path):
    """joint_names picks joints by name, in that order; wrench_components keeps fx fy only."""
    t, q, qd, tau, t_w, wrench = _signals()
    path = write_bag(tmp_path / "bag", t, q, qd, tau, t_w, wrench)
    rec = read_bag(path, joint_names=["j2", "j1"], wrench_components=2)
    np.testing.assert_array_equal(rec.q, q[:, ::-1])
    assert rec.wrench.shape == (t_w.size, 2)
    with pytest.raises(ParameterError, match=r"joint\(s\) \['j9'\] are not in the JointState names"):
        read_bag(path, joint_names=["j9"])


def test_missing_topic_lists_the_topics_present(tmp_path):
    """A missing wrench topic is an error naming the topics (and types) the file has."""
    t, q, qd, tau, t_w, wrench = _signals()
    bag = write_bag(tmp_path / "bag", t, q, qd)
    with pytest.raises(ParameterError, match=r"no wrench topic '/wrench'; the file has: /joint_states \(sensor_msgs/msg/Joint"):
        read_bag(bag, wrench_topic="/wrench")
    mc = write_mcap(tmp_path / "x.mcap", t, q, qd, tau, t_w, wrench)
    with pytest.raises(ParameterError, match="no joint-state topic '/js'; the file has: /force_torque"):
        read_mcap(mc, joint_topic="/js")
    with pytest.raises(ParameterError, match="is geometry_msgs/msg/WrenchStamped, not sensor_msgs/msg/JointState"):
        read_mcap(mc, joint_topic="/force_torque_sensor_broadcaster/wrench")
    rec = read_bag(bag, wrench_topic=None)
    assert rec.wrench is None and rec.tau is None  # no efforts in those messages


def test_csv_and_parquet_tables_read_back(tmp_path):
    """A table with t, q, qd, tau and fx fy is read as written, in both formats."""
    import pandas as pd

    t, q, qd, tau, _, _ = _signals()
    df = pd.DataFrame({"t": t, "q1": q[:, 0], "q2": q[:, 1], "qd1": qd[:, 0], "qd2": qd[:, 1], "tau1": tau[:, 0],
                       "tau2": tau[:, 1], "fx": 2 * t, "fy": -t})
    df.to_csv(tmp_path / "a.csv", index=False)
    df.to_parquet(tmp_path / "a.parquet")
    for p in (tmp_path / "a.csv", tmp_path / "a.parquet"):
        rec = read_recording(p)
        np.testing.assert_allclose(rec.q, q, rtol=1e-15)
        np.testing.assert_allclose(rec.tau, tau, rtol=1e-15)
        np.testing.assert_allclose(rec.wrench, np.column_stack([2 * t, -t]), rtol=1e-15)
        assert rec.to_pandas().columns.tolist()[:3] == ["t", "q1", "qd1"]
    df.drop(columns=["qd2", "t"]).to_csv(tmp_path / "b.csv", index=False)
    with pytest.raises(ParameterError, match=r"missing column\(s\) t, qd2; .* the file has t?.*q1"):
        read_table(tmp_path / "b.csv")
    with pytest.raises(ParameterError, match="cannot tell the format"):
        read_recording(tmp_path / "a.txt")



@pytest.mark.parametrize("drop, add, match", [
    (["q2", "qd2"], {"q3": 0.0, "qd3": 0.0}, r"column q2 is missing between q1 and q3; the file has q1, q3"),  # q3 dropped
    (["q2", "qd2"], {"q0": 0.0, "qd0": 0.0}, r"column q0: joints are numbered from 1 \(q1 ... qn\); the file has q0, q1"),
    (["tau2"], {}, r"tau1 ... tau1 for 2 joint\(s\) \(q1 ... q2\): every joint needs its tau column"),  # torques dropped
    ([], {"qd3": 0.0}, r"qd1 ... qd3 for 2 joint\(s\)"),
    (["fx", "fy"], {"fz": 1.0}, r"wrench columns fz: fx fy missing; a wrench is fx, fx fy, fx fy fz or fx fy fz mx my mz"),
    ([], {"fz": 1.0, "mx": 0.0, "mz": 0.0}, r"wrench columns fx fy fz mx mz: my missing"),  # read as the forces only
    ([], {"fx_measured": 1.0, "fz_measured": 1.0}, r"wrench columns fx_measured fz_measured: fy_measured missing"),
])
def test_columns_that_cannot_be_read_whole_are_refused_naming_them(tmp_path, drop, add, match):
    """A table whose numbered or wrench columns have a gap, start at 0 or cover other joints than q1 ... qn was read
    without them (q3 of q1 q3, q0 of q0 q1, a torque column short, fz alone or the moments of fx fy fz mx mz: no word);
    it is refused, naming the columns."""
    import pandas as pd

    t, q, qd, tau, _, _ = _signals()
    df = pd.DataFrame({"t": t, "q1": q[:, 0], "q2": q[:, 1], "qd1": qd[:, 0], "qd2": qd[:, 1], "tau1": tau[:, 0],
                       "tau2": tau[:, 1], "fx": 2 * t, "fy": -t})
    df = df.drop(columns=drop).assign(**add)
    df.to_csv(tmp_path / "a.csv", index=False)
    with pytest.raises(ParameterError, match=match):
        read_table(tmp_path / "a.csv")


def test_bad_time_and_nan_are_refused_naming_the_row():
    """Non-increasing time and NaN measurements are errors with the column and the row."""
    q = np.zeros((4, 2))
    with pytest.raises(MeasurementError, match=r"t must be strictly increasing; row 2 has t = 0.1 s after t = 0.2 s"):
        RecordedRun(t=[0.0, 0.2, 0.1, 0.3], q=q, qd=q)
    bad = q.copy()
    bad[3, 1] = np.nan
    with pytest.raises(MeasurementError, match=r"qd\[1\] is not finite at row 3"):
        RecordedRun(t=[0.0, 0.1, 0.2, 0.3], q=q, qd=bad)
    with pytest.raises(DimensionError, match=r"tau must have the shape of q \(4, 2\)"):
        RecordedRun(t=[0.0, 0.1, 0.2, 0.3], q=q, qd=q, tau=np.zeros((4, 3)))


def test_resample_reproduces_linear_signals_and_aligns_streams():
    """Linear signals are reproduced exactly on the new grid; the wrench stream is brought onto it."""
    t = np.array([0.0, 0.0013, 0.0021, 0.0042, 0.005, 0.0071, 0.0093, 0.0101])
    q = np.column_stack([2 * t + 1, -t])
    tw = np.linspace(0.0005, 0.0105, 40)
    rec = RecordedRun(t=t, q=q, qd=q, wrench=np.column_stack([5 * tw, tw]), t_wrench=tw)
    r = rec.resample(0.001)
    np.testing.assert_allclose(r.t, 0.0005 + 0.001 * np.arange(10), atol=1e-15)
    np.testing.assert_allclose(r.q, np.column_stack([2 * r.t + 1, -r.t]), atol=1e-14)
    np.testing.assert_allclose(r.wrench, np.column_stack([5 * r.t, r.t]), atol=1e-14)
    assert r.t_wrench is None


def test_resample_refuses_gaps_and_windows_outside_the_recording():
    """A gap larger than max_gap is refused naming the stream and time; so is a window beyond the data."""
    t = np.array([0.0, 0.001, 0.002, 0.05, 0.051])
    q = np.zeros((5, 1))
    rec = RecordedRun(t=t, q=q, qd=q)
    with pytest.raises(MeasurementError, match=r"joint states stream has a gap of 0.048 s after t = 0.002 s"):
        rec.resample(0.001)
    assert rec.resample(0.001, max_gap=0.05).t.size == 52
    with pytest.raises(MeasurementError, match=r"outside the joint states recording"):
        rec.resample(0.001, start=-1.0, max_gap=1)
    with pytest.raises(ParameterError, match="period must be a positive number"):
        rec.resample(0.0)


def test_reader_option_and_file_errors(tmp_path):
    """Bad options, missing files and unreadable files are errors naming what was wrong."""
    t, q, qd, tau, t_w, wrench = _signals(N=5)
    bag = write_bag(tmp_path / "bag", t, q, qd, tau, t_w[:5], wrench[:5])
    with pytest.raises(ParameterError, match="stamps must be 'header'"):
        read_bag(bag, stamps="bag")
    with pytest.raises(ParameterError, match="wrench_components must be 1, 2, 3 or 6"):
        read_bag(bag, wrench_components=4)
    with pytest.raises(ParameterError, match="ROS 2 bag .* does not exist"):
        read_bag(tmp_path / "nope")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ParameterError, match="cannot be opened as a ROS 2 bag"):
        read_bag(tmp_path / "empty")
    with pytest.raises(ParameterError, match="MCAP file .* does not exist"):
        read_mcap(tmp_path / "nope.mcap")
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file at all")
    with pytest.raises(ParameterError, match="cannot be read as an MCAP file"):
        read_mcap(tmp_path / "junk.mcap")
    with pytest.raises(ParameterError, match="recorded data file .* does not exist"):
        read_table(tmp_path / "nope.csv")
    (tmp_path / "a.csv").write_text("t,q1,qd1\n0,a,1\n1,b,2\n")
    with pytest.raises(MeasurementError, match="column 'q1' is not numeric"):
        read_table(tmp_path / "a.csv")
    with pytest.raises(ParameterError, match="wrench must be 'measured' or 'true'"):
        read_table(tmp_path / "a.csv", wrench="both")
    with pytest.raises(ParameterError, match="format must be 'csv' or 'parquet'"):
        read_table(tmp_path / "a.csv", format="xlsx")
    with pytest.raises(ParameterError, match="format must be 'csv', 'parquet', 'bag' or 'mcap'"):
        read_recording(tmp_path / "a.csv", format="hdf5")


def test_mcap_with_another_encoding_is_refused(tmp_path):
    """A JointState channel encoded as JSON (not CDR) is refused, naming the encoding."""
    from mcap.writer import Writer

    path = tmp_path / "json.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema(name="sensor_msgs/msg/JointState", encoding="jsonschema", data=b"{}")
        ch = w.register_channel(topic="/joint_states", message_encoding="json", schema_id=sid)
        w.add_message(ch, log_time=0, data=b"{}", publish_time=0)
        w.finish()
    with pytest.raises(ParameterError, match="topic '/joint_states' is encoded as 'json'; expected 'cdr'"):
        read_mcap(path, wrench_topic=None)


def test_recorded_run_consistency_errors():
    """Inconsistent RecordedRun parts are refused: t_wrench alone, joint names, sense, one time base for columns."""
    t = np.array([0.0, 0.1, 0.2])
    q = np.zeros((3, 2))
    with pytest.raises(ParameterError, match="t_wrench is given without a wrench"):
        RecordedRun(t=t, q=q, qd=q, t_wrench=t)
    with pytest.raises(DimensionError, match="1 joint names for 2 joints"):
        RecordedRun(t=t, q=q, qd=q, joint_names=("a",))
    with pytest.raises(ParameterError, match="wrench_sense must be one of"):
        RecordedRun(t=t, q=q, qd=q, wrench_sense="measured")
    with pytest.raises(MeasurementError, match="needs at least 2 samples"):
        RecordedRun(t=[0.0], q=q[:1], qd=q[:1])
    with pytest.raises(DimensionError, match="q must have 3 rows"):
        RecordedRun(t=t, q=q[:2], qd=q)
    rec = RecordedRun(t=t, q=q, qd=q, wrench=np.zeros((4, 1)), t_wrench=[0.0, 0.05, 0.1, 0.2])
    with pytest.raises(ParameterError, match="own time base; resample"):
        rec.columns()
    with pytest.raises(MeasurementError, match="shorter than one period"):
        rec.resample(0.5)


@pytest.mark.parametrize("stamps", ["header", "receive"])
def test_epoch_nanosecond_stamps_keep_their_spacing_exactly(tmp_path, stamps):
    """Stamps exactly 10 000 000 ns apart at today's epoch (1.7e9 s): read as 0.01 s apart to the last bit of the
    relative times (the origin is subtracted in integer nanoseconds; a float of epoch seconds has 0.24 µs steps), and
    a 100 Hz joint-state stream resamples at 1 ms with the default max_gap = 10 periods (it was refused as a gap of
    0.0100002 s). Stamps 100 ns apart stay apart."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    from rosfiles_helpers import _typestore

    ts = _typestore()
    Time, Header, JS = (ts.types[n] for n in ("builtin_interfaces/msg/Time", "std_msgs/msg/Header",
                                                 "sensor_msgs/msg/JointState"))
    t0 = 1_700_000_000 * 10**9 + 123_456_789
    ns = [t0 + 10_000_000 * k for k in range(40)] + [t0 + 10_000_000 * 39 + 100]  # the last 100 ns after the one before
    with Writer(tmp_path / "bag", version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
        conn = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        for k, n in enumerate(ns):
            msg = JS(header=Header(stamp=Time(sec=n // 10**9, nanosec=n % 10**9), frame_id=""), name=["j1", "j2"],
                     position=np.array([0.1 * k, 0.0]), velocity=np.zeros(2), effort=np.zeros(0))
            w.write(conn, n, bytes(ts.serialize_cdr(msg, "sensor_msgs/msg/JointState")))
    run = read_bag(tmp_path / "bag", wrench_topic=None, stamps=stamps)
    want = np.array([(n - t0) for n in ns], dtype=np.float64) / 1e9
    assert np.array_equal(run.t, want)
    assert run.time_origin == pytest.approx(t0 / 1e9, abs=1e-6)
    assert run.t[-1] - run.t[-2] == pytest.approx(1e-7, rel=1e-6)
    grid = run.resample(0.001, end=0.39)
    assert grid.t.shape == (391,)


def test_a_bag_reader_says_what_it_leaves_out(tmp_path):
    """One JointState without efforts drops the recorded torques (said: 1 of 20), an empty frame_id is taken as the
    base frame (said), and a wrench topic without messages gives no wrench (said, naming the topic); they were silent."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    from rosfiles_helpers import _typestore

    ts = _typestore()
    T = ts.types
    Time, Header, JS, WS = (T[n] for n in ("builtin_interfaces/msg/Time", "std_msgs/msg/Header",
                                           "sensor_msgs/msg/JointState", "geometry_msgs/msg/WrenchStamped"))
    V, W = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Wrench"]

    def write(path, with_wrench):
        with Writer(path, version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
            js = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
            ws = w.add_connection("/force_torque_sensor_broadcaster/wrench", "geometry_msgs/msg/WrenchStamped",
                                  typestore=ts)
            for k in range(20):
                n = 10**9 + 10**6 * k
                h = Header(stamp=Time(sec=n // 10**9, nanosec=n % 10**9), frame_id="")
                eff = np.zeros(0) if k == 7 else np.array([1.0, 2.0])
                w.write(js, n, bytes(ts.serialize_cdr(JS(header=h, name=["j1", "j2"], position=np.array([0.1, 0.2]),
                                                         velocity=np.zeros(2), effort=eff), "sensor_msgs/msg/JointState")))
                if with_wrench:
                    msg = WS(header=h, wrench=W(force=V(x=1.0, y=0.0, z=0.0), torque=V(x=0.0, y=0.0, z=0.0)))
                    w.write(ws, n, bytes(ts.serialize_cdr(msg, "geometry_msgs/msg/WrenchStamped")))
        return path

    run = read_bag(write(tmp_path / "a", True), wrench_components=2)
    notes = run.metadata["notes"]
    assert run.tau is None and any("1 of 20 JointState messages carry no efforts" in n for n in notes)
    assert run.wrench_frame == "base" and any("header.frame_id is empty" in n for n in notes)
    run = read_bag(write(tmp_path / "b", False), wrench_components=2)
    assert run.wrench is None
    assert any("the wrench topic '/force_torque_sensor_broadcaster/wrench' has no messages" in n for n in run.metadata["notes"])



@pytest.mark.parametrize("kind", ["bag-sqlite3", "mcap"])
def test_an_arm_and_a_gripper_on_one_joint_state_topic(tmp_path, kind):
    """An arm's and a gripper's JointStates on one /joint_states topic (written by rosbags and by mcap): the arm's
    joints are read (the topic's largest set, or those named) and the gripper's messages are passed over, said in the
    notes; before, the first gripper message stopped the read ("lacks a joint"), or a gripper message first made the
    log the gripper's. A joint in no message is refused, naming the topic's joints."""
    t, q, qd, tau, _, _ = _signals()
    gripper = [(s + 0.0005, ["finger1"], [0.04]) for s in t[:10]]
    gripper.insert(0, (t[0] - 0.001, ["finger1"], [0.04]))  # the gripper's message first
    path = tmp_path / ("log.mcap" if kind == "mcap" else "bag")
    (write_mcap if kind == "mcap" else write_bag)(path, t, q, qd, tau=tau, others=gripper)
    read = read_mcap if kind == "mcap" else read_bag
    for names in (None, ["j2", "j1"]):
        run = read(path, wrench_topic=None, joint_names=names)
        cols = [0, 1] if names is None else [1, 0]
        np.testing.assert_array_equal(run.q, q[:, cols])
        np.testing.assert_array_equal(run.tau, tau[:, cols])
        assert run.joint_names == (("j1", "j2") if names is None else ("j2", "j1"))
        assert any(n.startswith("11 JointState message(s) of another set of joints (finger1) passed over")
                   for n in run.metadata["notes"]), run.metadata
    with pytest.raises(ParameterError, match=r"joint\(s\) \['j3'\] are not in the JointState names \['finger1', 'j1', 'j2'\]"):
        read(path, wrench_topic=None, joint_names=["j1", "j3"])
    two = [(s + 0.0005, ["finger1", "finger2"], [0.04, 0.04]) for s in t[:3]]  # as many joints as the arm: which?
    (write_mcap if kind == "mcap" else write_bag)(tmp_path / ("two.mcap" if kind == "mcap" else "two"), t, q, qd, others=two)
    with pytest.raises(ParameterError, match=r"JointStates of 2 sets of 2 joints \(j1, j2; finger1, finger2\): name the"):
        read(tmp_path / ("two.mcap" if kind == "mcap" else "two"), wrench_topic=None)
    # the arm's own messages beside messages merged with the gripper's (joint_state_publisher): one stream is read,
    # never the two interleaved; named joints read the smallest set holding them (the arm's own), the largest by default
    merged = [(s + 0.0005, ["j1", "j2", "finger1"], [9.0, 9.0, 0.04]) for s in t]
    path = tmp_path / ("merged.mcap" if kind == "mcap" else "merged")
    (write_mcap if kind == "mcap" else write_bag)(path, t, q, qd, tau=tau, others=merged)
    run = read(path, wrench_topic=None, joint_names=["j1", "j2"])
    np.testing.assert_array_equal(run.q, q)
    assert any(n.startswith(f"{t.size} JointState message(s) of another set of joints (j1, j2, finger1) passed over")
               for n in run.metadata["notes"])
    run = read(path, wrench_topic=None)
    assert run.joint_names == ("j1", "j2", "finger1") and np.all(run.q[:, 0] == 9.0) and run.t.size == t.size
    run = read(path, wrench_topic=None, prefer_joint_names=["j2", "j1"])  # a model's joints, all on the topic
    np.testing.assert_array_equal(run.q, q[:, [1, 0]])
    run = read(path, wrench_topic=None, prefer_joint_names=["a1", "a2"])  # not on the topic: the default
    assert run.joint_names == ("j1", "j2", "finger1")


def test_an_mcap_file_without_a_summary_section_is_read_from_its_messages(tmp_path):
    """The summary section of an MCAP file is optional (a streaming writer, `mcap recover`): such a file, written by the
    mcap library without summary, chunks or repeated channels, reads as the same run as the file with them (it was
    reported as having no topics)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    from rosfiles_helpers import _messages, _typestore

    t = np.arange(30) * 0.01
    q = np.column_stack([0.1 * t, -0.2 * t])
    qd = np.tile([0.1, -0.2], (30, 1))
    ts = _typestore()
    msgs = _messages(ts, t, q, qd, None, t, np.column_stack([t, 2 * t]), ("j1", "j2"), "base")
    path = tmp_path / "nosummary.mcap"
    with path.open("wb") as f:
        w = Writer(f, use_chunking=False, use_statistics=False, use_summary_offsets=False, repeat_channels=False,
                   repeat_schemas=False)
        w.start(profile="ros2", library="forcecontrol-tests")
        channels = {}
        for topic, msgtype, ns, msg in msgs:
            if topic not in channels:
                sid = w.register_schema(name=msgtype, encoding="ros2msg",
                                        data=ts.generate_msgdef(msgtype, ros_version=2)[0].encode())
                channels[topic] = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
            w.add_message(channels[topic], log_time=ns, data=bytes(ts.serialize_cdr(msg, msgtype)), publish_time=ns)
        w.finish()
    with path.open("rb") as f:
        assert make_reader(f).get_summary() is None
    run = read_mcap(path, wrench_components=2)
    ref = read_mcap(write_mcap(tmp_path / "full.mcap", t, q, qd, t_w=t, wrench=np.column_stack([t, 2 * t])),
                    wrench_components=2)
    np.testing.assert_array_equal(run.t, ref.t)
    np.testing.assert_array_equal(run.q, ref.q)
    np.testing.assert_array_equal(run.wrench, ref.wrench)


@pytest.mark.parametrize("read", [read_bag, read_mcap])
def test_a_joint_named_twice_is_refused_by_the_reader(tmp_path, read):
    """joint_names with a repeated joint is a ParameterError naming the list (it read that joint's column twice, and the
    check was only in the command line's --joint-names)."""
    t = np.arange(20) * 0.01
    q = np.column_stack([0.1 * t, -0.2 * t])
    path = tmp_path / ("log" if read is read_bag else "log.mcap")
    write_bag(path, t, q, q) if read is read_bag else write_mcap(path, t, q, q)
    with pytest.raises(ParameterError, match=r"joint_names must name each joint once; got \['j1', 'j1'\]"):
        read(path, wrench_topic=None, joint_names=["j1", "j1"])
