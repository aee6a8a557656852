"""Recordings from the arms themselves, by their own field names: UR RTDE and libfranka's RobotState.

**Universal Robots RTDE** (the RTDE guide's output fields,
https://docs.universal-robots.com/tutorials/communication-protocol-tutorials/rtde-guide.html):
``timestamp`` [s] (time since the controller started), ``actual_q`` [rad], ``actual_qd`` [rad/s],
``actual_TCP_pose`` = ``[x, y, z, rx, ry, rz]`` (the TCP's position [m] and orientation as a
rotation vector [rad], in the base frame), ``actual_TCP_force`` = ``[Fx, Fy, Fz, Tx, Ty, Tz]``
("Generalized forces in the TCP", base axes). The controller's base frame (its *Base* feature) is
ur_description's frame ``base``, "the same position as base_link but rotated by 180 degrees around
the Z-axis" (ur_description, doc/robot_frames.rst); ``base_link`` is the root of the UR URDFs (the
library's :func:`~forcecontrol.robots.pinocchio.ur5` and ``ur10`` included), so the reader rotates
both into ``base_link`` (x, y and the moments about them negated) and says so in the run's notes.
Sense and point: :func:`~forcecontrol.realarm.conventions.from_ur_tcp_force`:
the moment is about the tool flange on e-Series and about the TCP on CB3, Universal_Robots_ROS2_Driver
PRs #1287 and #1615; an external sensor through a URCap reports it at the TCP, issue #1849. The
reader does not move it: the series is not in the file).
A CSV writes each vector element as its own column ``<name>_<i>``: UR's own
``rtde/csv_writer.py`` (``record.py``; space-delimited by default) and ur_rtde's
``RTDEReceiveInterface::startFileRecording`` (comma-delimited) both do; both are read.

**libfranka** ``franka::RobotState`` (include/franka/robot_state.h, 0.15.0): ``time`` [ms] (what
``operator<<`` prints: ``time.toMSec()``), ``q``, ``dq`` [rad, rad/s], ``tau_J`` [N m],
``O_T_EE`` (the end-effector pose in the base frame, "a 4x4 matrix in column-major format", 16
numbers), ``EE_T_K`` (the stiffness frame in the end-effector frame, column-major),
``O_F_ext_hat_K`` / ``K_F_ext_hat_K`` (the external wrench at K in base / K axes; sense:
:func:`~forcecontrol.realarm.conventions.from_franka`). Read from JSON (``operator<<``'s output:
one object per line, or a list of objects) or from a table with the same names flattened as
``<name>_<i>`` (``O_T_EE_0 … O_T_EE_15`` in libfranka's column-major order).

The readers return a :class:`RecordedRun` whose wrench keeps the vendor's numbers (UR's in base_link axes, above), tagged with the
vendor's frame, point and sense (a ``K_F_ext_hat_K``-only recording is rotated into the base
frame with ``O_T_EE · EE_T_K``), and whose ``pose`` holds the measured TCP / end-effector pose.
``sense`` overrides the documented sense (``"on-robot"``, ``"by-robot"``) for an arm found to
report the opposite.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...core.files import MAX_RECORDING_BYTES, check_regular, read_text_limited
from ...core.validate import is_number
from ...errors import MeasurementError, ParameterError
from ...spatial.rotations import rotvec_to_rotation
from ..conventions import BY_END_EFFECTOR, ON_END_EFFECTOR, UR_BASE_IN_BASE_LINK
from .recorded import RecordedRun

__all__ = [
    "VENDOR_FORMATS", "SENSE_OVERRIDES", "detect_convention", "vendor_run", "read_vendor", "ur_pose", "franka_pose",
    "with_library_options",
]

#: the library's own table options (read_table's defaults): a vendor's recording carries its own
_LIBRARY_DEFAULTS = {"wrench_frame": "base", "wrench_point": "end-effector", "wrench_sense": BY_END_EFFECTOR}

#: the vendors' recording layouts :func:`read_vendor` knows
VENDOR_FORMATS = ("ur-rtde", "franka")
#: ``--sense`` values: the wrench the environment exerts on the robot, or the one the robot exerts
SENSE_OVERRIDES = {"on-robot": ON_END_EFFECTOR, "by-robot": BY_END_EFFECTOR}

#: the state columns that name a layout; commanded joint positions (UR's ``target_q_i``) are not among
#: them: a library table may carry them beside its own columns (the servo identification reads both)
_MARKERS = {
    "ur-rtde": re.compile(r"timestamp|actual_(q|qd|TCP_pose|TCP_force|current|TCP_speed)_\d+"),
    "franka": re.compile(r"(O_T_EE|O_T_EE_d|EE_T_K|O_F_ext_hat_K|K_F_ext_hat_K|tau_J|q|dq|q_d|dq_d)_\d+"),
    "library table": re.compile(r"t|q\d+|qd\d+|tau\d+|u\d+|[fm][xyz](_measured)?"),
}


def detect_convention(columns: Any) -> str | None:
    """``"ur-rtde"``, ``"franka"``, ``"library table"`` or None from a table's column names.

    Raises:
        ParameterError: columns of more than one convention (a mixed recording), naming them.
    """
    cols = [str(c).strip() for c in columns]
    found = {name: [c for c in cols if rx.fullmatch(c)] for name, rx in _MARKERS.items()}
    found = {k: v for k, v in found.items() if v}
    if len(found) > 1:
        parts = "; ".join(f"{k}: {', '.join(v[:6])}{' ...' if len(v) > 6 else ''}" for k, v in found.items())
        raise ParameterError(f"the recording mixes conventions ({parts}); a recording must use one (split it, or rename "
                             "the columns of one)")
    return next(iter(found), None)


def _sense(sense: str | None, default: str) -> str:
    if sense is None:
        return default
    if sense in SENSE_OVERRIDES:
        return SENSE_OVERRIDES[sense]
    if sense in SENSE_OVERRIDES.values():
        return sense
    raise ParameterError(f"sense must be 'on-robot' (the wrench on the robot) or 'by-robot' (the wrench the robot applies); "
                         f"got {sense!r}")


def ur_pose(pose: Any) -> np.ndarray:
    """UR ``actual_TCP_pose`` rows ``[x, y, z, rx, ry, rz]`` (N, 6) → homogeneous matrices (N, 4, 4), R = exp([r]×)."""
    p = np.atleast_2d(np.asarray(pose, dtype=np.float64))
    T = np.zeros((p.shape[0], 4, 4))
    T[:, 3, 3] = 1.0
    T[:, :3, 3] = p[:, :3]
    T[:, :3, :3] = [rotvec_to_rotation(r) for r in p[:, 3:6]]
    return T


def franka_pose(values: Any, name: str = "O_T_EE", source: str = "<arrays>") -> np.ndarray:
    """libfranka's column-major 4x4 matrices (N, 16) → (N, 4, 4); the rotation is projected onto SO(3).

    libfranka prints 6 significant digits (``operator<<``), so a printed rotation is orthonormal to
    about 1e-6 only: it is projected (SVD); a matrix farther than 1e-3 from a rotation is refused.

    Raises:
        MeasurementError: not a rigid transform within 1e-3 (row named).
    """
    v = np.atleast_2d(np.asarray(values, dtype=np.float64))
    T = v.reshape(-1, 4, 4).transpose(0, 2, 1).copy()  # column-major: element 4 c + r is row r, column c
    R = T[:, :3, :3]
    err = np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3)).max(axis=(1, 2))
    bad = (err > 1e-3) | (np.abs(T[:, 3, :] - [0, 0, 0, 1]).max(axis=1) > 1e-6)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise MeasurementError(f"{source}: {name} at row {i} is not a column-major rigid transform (|RᵀR − I| = {err[i]:.3g}, "
                               f"bottom row {T[i, 3].tolist()}, expected [0, 0, 0, 1]); is it stored row-major?")
    U, _, Vt = np.linalg.svd(R)
    T[:, :3, :3] = U @ Vt
    T[:, 3] = [0.0, 0.0, 0.0, 1.0]
    return T


def _block(cols: Mapping[str, np.ndarray], name: str, size: int | None, source: str, required: bool = True) -> np.ndarray | None:
    n = 0
    while f"{name}_{n}" in cols:
        n += 1
    if n == 0 or (size is not None and n < size):
        if not required and n == 0:
            return None
        want = f"{name}_0 … {name}_{(size or 1) - 1}"
        raise ParameterError(f"{source}: missing column(s) {want} ({n} found); the columns are {', '.join(list(cols)[:20])}")
    n = size or n
    return np.column_stack([_numeric(cols, f"{name}_{i}", source) for i in range(n)])


def _numeric(cols: Mapping[str, Any], name: str, source: str) -> np.ndarray:
    a = np.asarray(cols[name])
    try:
        return a.astype(np.float64)
    except (TypeError, ValueError):
        row = next(i for i, v in enumerate(a) if not is_number(v))
        raise MeasurementError(f"{source}: column {name!r} is not numeric; data row {row} holds {str(a[row])[:40]!r}") from None


def vendor_run(columns: Mapping[str, Any], format: str, *, sense: str | None = None, source: str = "<columns>") -> RecordedRun:
    """A :class:`RecordedRun` from a vendor's named columns (``<field>_<i>`` per vector element).

    Args:
        columns: name → values (one per sample).
        format: ``"ur-rtde"`` or ``"franka"``.
        sense: override of the documented sense: ``"on-robot"`` or ``"by-robot"``.
        source: for messages.

    Raises:
        ParameterError: an unknown format, missing fields (named), a mixed recording.
        MeasurementError: text in a numeric column, a pose that is not a rigid transform.
    """
    cols = {str(k).strip(): v for k, v in columns.items()}
    kind = detect_convention(cols)
    if format not in VENDOR_FORMATS:
        raise ParameterError(f"format must be one of {VENDOR_FORMATS}; got {format!r}")
    if kind not in (format, None):
        raise ParameterError(f"{source}: format {format!r} was asked, but the columns are a {kind} recording "
                             f"({', '.join(list(cols)[:8])} ...)")
    notes: list[str] = []
    if format == "ur-rtde":
        if "timestamp" not in cols:
            raise ParameterError(f"{source}: an RTDE recording needs the 'timestamp' column; the columns are "
                                 f"{', '.join(list(cols)[:20])}")
        t = _numeric(cols, "timestamp", source)
        q = _block(cols, "actual_q", None, source)
        qd = _block(cols, "actual_qd", q.shape[1], source)
        tcp = _block(cols, "actual_TCP_pose", 6, source, required=False)
        force = _block(cols, "actual_TCP_force", 6, source, required=False)
        # RTDE's base is the controller's Base feature: ur_description's frame ``base``, Rz(180°) from ``base_link``,
        # the root of every UR URDF (the library's ur5/ur10 models included); both vectors are rotated into base_link
        pose = None if tcp is None else ur_pose(tcp)
        if pose is not None:
            pose[:, :3, :] = UR_BASE_IN_BASE_LINK @ pose[:, :3, :]  # R and p of the TCP in base_link
        wsense = _sense(sense, ON_END_EFFECTOR)
        if force is not None:
            force = np.hstack([force[:, :3] @ UR_BASE_IN_BASE_LINK.T, force[:, 3:] @ UR_BASE_IN_BASE_LINK.T])
            notes.append("actual_TCP_force: base axes, the moment about the tool flange (e-Series; about the TCP on CB3): "
                         "the moment is not moved to the TCP")
        if force is not None or tcp is not None:
            notes.append("actual_TCP_force/actual_TCP_pose are in the controller's base frame (ur_description's 'base', "
                         "rotated 180° about z from 'base_link', the root of the UR models): rotated into base_link "
                         "(x, y and their moments negated)")
        meta = {"format": "ur-rtde", "wrench_columns": [] if force is None else [f"actual_TCP_force_{i}" for i in range(6)],
                "pose_columns": [] if tcp is None else [f"actual_TCP_pose_{i}" for i in range(6)]}
        run = dict(t=t, q=q, qd=qd, tau=None, wrench=force, wrench_frame="base", wrench_point="flange", pose=pose,
                   pose_frame="tcp")
    else:
        tname = "time" if "time" in cols else None
        if tname is None:
            raise ParameterError(f"{source}: a libfranka RobotState recording needs the 'time' column [ms]; the columns are "
                                 f"{', '.join(list(cols)[:20])}")
        t = _numeric(cols, "time", source) * 1e-3
        q = _block(cols, "q", None, source)
        qd = _block(cols, "dq", q.shape[1], source)
        tau = _block(cols, "tau_J", q.shape[1], source, required=False)
        o_t_ee = _block(cols, "O_T_EE", 16, source, required=False)
        pose = None if o_t_ee is None else franka_pose(o_t_ee, "O_T_EE", source)
        O_F = _block(cols, "O_F_ext_hat_K", 6, source, required=False)
        K_F = _block(cols, "K_F_ext_hat_K", 6, source, required=False)
        wsense = _sense(sense, BY_END_EFFECTOR)
        wrench, used = O_F, "O_F_ext_hat_K"
        if O_F is None and K_F is not None:
            if pose is None:
                raise ParameterError(f"{source}: K_F_ext_hat_K is in the stiffness frame; rotating it into the base frame "
                                     "needs O_T_EE_0 … O_T_EE_15 (or record O_F_ext_hat_K)")
            ee_t_k = _block(cols, "EE_T_K", 16, source, required=False)
            R_ek = (np.broadcast_to(np.eye(3), (t.size, 3, 3)) if ee_t_k is None
                    else franka_pose(ee_t_k, "EE_T_K", source)[:, :3, :3])
            R = np.einsum("kij,kjl->kil", pose[:, :3, :3], R_ek)
            wrench = np.hstack([np.einsum("kij,kj->ki", R, K_F[:, :3]), np.einsum("kij,kj->ki", R, K_F[:, 3:])])
            used = "K_F_ext_hat_K"
            notes.append("K_F_ext_hat_K rotated into the base frame with O_T_EE" + (" · EE_T_K" if ee_t_k is not None else
                                                                                   " (EE_T_K not recorded: identity)"))
        meta = {"format": "franka", "wrench_columns": [] if wrench is None else [f"{used}_{i}" for i in range(6)],
                "pose_columns": [] if o_t_ee is None else [f"O_T_EE_{i}" for i in range(16)]}
        run = dict(t=t, q=q, qd=qd, tau=tau, wrench=wrench, wrench_frame="base", wrench_point="K", pose=pose, pose_frame="EE")
    if sense is not None:
        notes.append(f"wrench sense set to {wsense} by sense={sense!r} (the documented one is "
                     f"{ON_END_EFFECTOR if format == 'ur-rtde' else BY_END_EFFECTOR})")
    meta["wrench_sense_source"] = "override" if sense is not None else "vendor documentation"
    meta["notes"] = notes
    return RecordedRun(**run, wrench_sense=wsense, source=source, metadata=meta)


def with_library_options(run: RecordedRun, **given: Any) -> RecordedRun:
    """A vendor's run checked against the library's table options (``wrench_frame``, ``wrench_point``, ``wrench_sense``).

    A value equal to the vendor's tag is consistent; one equal to the library's default is taken
    as not given (the vendor's convention is used, and a differing sense is noted); any other
    value contradicts the vendor's documentation and is refused rather than ignored.

    Raises:
        ParameterError: a value that is neither the vendor's nor the library's default (named).
    """
    tags = {"wrench_frame": run.wrench_frame, "wrench_point": run.wrench_point, "wrench_sense": run.wrench_sense}
    conflict = {k: v for k, v in given.items() if v != tags[k] and v != _LIBRARY_DEFAULTS[k]}
    if conflict:
        raise ParameterError(
            f"{run.source}: a {run.metadata.get('format')} recording has the vendor's documented wrench convention "
            f"({', '.join(f'{k} {tags[k]!r}' for k in conflict)}); {', '.join(f'{k}={v!r}' for k, v in conflict.items())} "
            "does not apply (override the sense with sense='on-robot'|'by-robot', --sense)")
    if given.get("wrench_sense", run.wrench_sense) != run.wrench_sense and run.metadata.get("wrench_sense_source") != "override":
        run.metadata["notes"].append(f"the wrench's sense is the vendor's documented {run.wrench_sense} (not the default "
                                     f"{given['wrench_sense']}; --sense overrides it)")
    return run


def _json_states(path: Path, max_bytes: int) -> dict[str, np.ndarray]:
    text = read_text_limited(path, "libfranka JSON recording", max_bytes).strip()
    try:
        doc = json.loads(text)
        states = doc if isinstance(doc, list) else doc.get("states", [doc]) if isinstance(doc, dict) else None
    except json.JSONDecodeError:
        try:
            states = [json.loads(line) for line in text.splitlines() if line.strip()]
        except json.JSONDecodeError as exc:
            raise ParameterError(f"{path}: neither JSON nor one JSON object per line (line {exc.lineno}: {exc.msg})") from None
    if not isinstance(states, list) or not states or not all(isinstance(s, dict) for s in states):
        raise ParameterError(f"{path}: expected libfranka RobotState objects (a list, or one per line)")
    cols: dict[str, list[Any]] = {}
    for k, st in enumerate(states):
        for name, value in st.items():
            if isinstance(value, list):
                for i, v in enumerate(value):
                    cols.setdefault(f"{name}_{i}", [None] * len(states))[k] = v
            elif isinstance(value, (int, float)) and not isinstance(value, bool):
                cols.setdefault(name, [None] * len(states))[k] = value
    return {k: np.array(v, dtype=object) for k, v in cols.items()}


def read_vendor(
    path: str | Path, format: str | None = None, *, sense: str | None = None, max_bytes: int = MAX_RECORDING_BYTES
) -> RecordedRun:
    """Read a UR RTDE or libfranka recording (CSV comma- or space-delimited, Parquet, or libfranka JSON).

    Args:
        path: the file.
        format: ``"ur-rtde"`` or ``"franka"`` (default: from the column names).
        sense: ``"on-robot"`` or ``"by-robot"`` to override the vendor's documented sense.
        max_bytes: size limit [bytes].

    Raises:
        ParameterError: unknown format, a file that is not one of these recordings, a mixed recording.
    """
    import pandas as pd

    path = Path(path)
    if not path.exists():
        raise ParameterError(f"recorded data file {str(path)!r} does not exist")
    check_regular(path, "recorded data file", max_bytes)
    suffix = path.suffix.lower()
    if suffix in (".json", ".jsonl"):
        cols: Mapping[str, Any] = _json_states(path, max_bytes)
    else:
        try:
            if suffix in (".parquet", ".pq"):
                df = pd.read_parquet(path)
            else:
                with path.open(encoding="utf-8", errors="replace") as fh:
                    header = fh.readline()
                df = pd.read_csv(path, sep="," if "," in header else r"\s+")
        except Exception as exc:  # pandas/pyarrow raise many kinds; their text may quote the file
            raise ParameterError(f"{path}: cannot be read as a table ({type(exc).__name__})") from None
        cols = {str(c).strip(): df[c].to_numpy() for c in df.columns}
    kind = detect_convention(cols)
    fmt = format or kind
    if fmt not in VENDOR_FORMATS:
        raise ParameterError(f"{path}: not a UR RTDE or libfranka recording (columns {', '.join(list(cols)[:12])}); "
                             f"pass format='ur-rtde' or 'franka' for one, or read it as a library table")
    return vendor_run(cols, fmt, sense=sense, source=str(path))
