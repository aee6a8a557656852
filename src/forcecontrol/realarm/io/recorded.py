"""The recorded run: one time base per stream, joint signals, the wrench with its convention."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ...core.axes import axis_names
from ...core.validate import positive_scalar
from ...errors import DimensionError, MeasurementError, ParameterError
from ...spatial import Transform
from ..conventions import BY_END_EFFECTOR, SENSES

__all__ = ["RecordedRun", "wrench_axis_names"]

#: the largest magnitude of a recorded value (time [s], joint positions, velocities, torques, wrench): far
#: beyond any arm; a larger one is a corrupt row (1e300 N was read as a force)
MAX_RECORDED_MAGNITUDE = 1e12


def wrench_axis_names(m: int) -> list[str]:
    """Column names of an m-dimensional wrench: ``fx fy`` (2), ``fx fy fz`` (3), ``fx fy fz mx my mz`` (6)."""
    return axis_names(m)[2]


def _array(name: str, value: Any, rows: int, source: str) -> np.ndarray:
    a = np.array(value, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] != rows:
        raise DimensionError(f"{source}: {name} must have {rows} rows (one per time sample); got shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise MeasurementError(f"{source}: {name}[{c}] is not finite at row {r} ({a[r, c]!r}); clean or drop those rows first")
    big = np.abs(a) > MAX_RECORDED_MAGNITUDE
    if big.any():
        r, c = np.argwhere(big)[0]
        raise MeasurementError(f"{source}: {name}[{c}] is {a[r, c]:.4g} at row {r}, beyond any arm (at most "
                               f"{MAX_RECORDED_MAGNITUDE:.0e} in magnitude); clean or drop those rows first")
    a.flags.writeable = False
    return a


def _poses(value: Any, rows: int, source: str) -> np.ndarray:
    T = np.array(value, dtype=np.float64)
    if T.shape != (rows, 4, 4):
        raise DimensionError(f"{source}: pose must have shape ({rows}, 4, 4) (one homogeneous matrix per sample); got {T.shape}")
    bad = ~np.isfinite(T).all(axis=(1, 2))
    if bad.any():
        raise MeasurementError(f"{source}: pose is not finite at row {int(np.flatnonzero(bad)[0])}")
    R = T[:, :3, :3]
    err = np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(R)
    wrong = (err > 1e-6) | (det <= 0) | (np.abs(T[:, 3, :] - [0, 0, 0, 1]).max(axis=1) > 1e-9)
    if wrong.any():
        i = int(np.flatnonzero(wrong)[0])
        raise MeasurementError(f"{source}: pose at row {i} is not a rigid transform (|RᵀR − I| = {err[i]:.3g}, det R = "
                               f"{det[i]:.6g}, last row {T[i, 3].tolist()}; expected [0, 0, 0, 1])")
    T.flags.writeable = False
    return T


def _interp_poses(t: np.ndarray, T: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Poses at ``grid``: positions linearly, orientations by spherical linear interpolation."""
    from scipy.spatial.transform import Rotation, Slerp

    out = np.zeros((grid.size, 4, 4))
    out[:, 3, 3] = 1.0
    out[:, :3, :3] = Slerp(t, Rotation.from_matrix(T[:, :3, :3]))(np.clip(grid, t[0], t[-1])).as_matrix()
    for j in range(3):
        out[:, j, 3] = np.interp(grid, t, T[:, j, 3])
    return out


def _time(name: str, value: Any, source: str) -> np.ndarray:
    t = np.array(value, dtype=np.float64).reshape(-1)
    if t.size < 2:
        raise MeasurementError(f"{source}: {name} needs at least 2 samples; got {t.size}")
    if not np.all(np.isfinite(t)):
        i = int(np.flatnonzero(~np.isfinite(t))[0])
        raise MeasurementError(f"{source}: {name} is not finite at row {i} ({t[i]!r})")
    if np.any(np.abs(t) > MAX_RECORDED_MAGNITUDE):
        i = int(np.flatnonzero(np.abs(t) > MAX_RECORDED_MAGNITUDE)[0])
        raise MeasurementError(f"{source}: {name} is {t[i]:.4g} s at row {i}, beyond {MAX_RECORDED_MAGNITUDE:.0e} s")
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.flatnonzero(dt <= 0)[0])
        raise MeasurementError(
            f"{source}: {name} must be strictly increasing; row {i + 1} has t = {t[i + 1]:.6g} s after t = {t[i]:.6g} s "
            "(sort the log, or drop repeated samples)"
        )
    t.flags.writeable = False
    return t


@dataclass(frozen=True)
class RecordedRun:
    """Measured joint and wrench signals of one run (SI units).

    Attributes:
        t: joint sample times (N,) [s], strictly increasing, relative to ``time_origin``.
        q, qd: joint positions and velocities (N, n) [rad], [rad/s].
        tau: measured or commanded joint torques (N, n) [N m], or None.
        wrench: the wrench (K, m) [N, N m] at times ``t_wrench``, or None.
        t_wrench: wrench sample times (K,) [s] (None: the same as ``t``).
        wrench_frame, wrench_point, wrench_sense: the wrench's convention (see
            :mod:`forcecontrol.realarm.conventions`); the library's is the base frame, about the
            end-effector, ``"by-end-effector"``.
        joint_names: the joints' names, in column order.
        time_origin: absolute time [s] of t = 0 (e.g. the first ROS stamp).
        source: where it was read from (for messages).
        metadata: what the reader knew (format, columns used, notes for the user).
        pose: the measured pose of ``pose_frame`` in the base frame at each joint sample, (N, 4, 4)
            homogeneous matrices, or None (UR ``actual_TCP_pose``, libfranka ``O_T_EE``, ``r11 … r33``).
        pose_frame: the frame whose pose ``pose`` holds (e.g. ``"tcp"``, ``"EE"``).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray | None = None
    wrench: np.ndarray | None = None
    t_wrench: np.ndarray | None = None
    wrench_frame: str = "base"
    wrench_point: str = "end-effector"
    wrench_sense: str = BY_END_EFFECTOR
    joint_names: tuple[str, ...] = ()
    time_origin: float = 0.0
    source: str = "<arrays>"
    metadata: dict[str, Any] = field(default_factory=dict)
    pose: np.ndarray | None = None
    pose_frame: str = "end-effector"

    def __post_init__(self) -> None:
        src = self.source
        t = _time("t", self.t, src)
        object.__setattr__(self, "t", t)
        q = _array("q", self.q, t.size, src)
        object.__setattr__(self, "q", q)
        qd = _array("qd", self.qd, t.size, src)
        if qd.shape != q.shape:
            raise DimensionError(f"{src}: qd must have the shape of q {q.shape}; got {qd.shape}")
        object.__setattr__(self, "qd", qd)
        if self.tau is not None:
            tau = _array("tau", self.tau, t.size, src)
            if tau.shape != q.shape:
                raise DimensionError(f"{src}: tau must have the shape of q {q.shape}; got {tau.shape}")
            object.__setattr__(self, "tau", tau)
        if self.wrench is not None:
            tw = t if self.t_wrench is None else _time("t_wrench", self.t_wrench, src)
            object.__setattr__(self, "t_wrench", None if self.t_wrench is None else tw)
            object.__setattr__(self, "wrench", _array("wrench", self.wrench, tw.size, src))
        elif self.t_wrench is not None:
            raise ParameterError(f"{src}: t_wrench is given without a wrench")
        if self.wrench_sense not in SENSES:
            raise ParameterError(f"{src}: wrench_sense must be one of {SENSES}; got {self.wrench_sense!r}")
        if self.joint_names and len(self.joint_names) != q.shape[1]:
            raise DimensionError(f"{src}: {len(self.joint_names)} joint names for {q.shape[1]} joints")
        object.__setattr__(self, "joint_names", tuple(self.joint_names) or tuple(f"joint{i + 1}" for i in range(q.shape[1])))
        if self.pose is not None:
            object.__setattr__(self, "pose", _poses(self.pose, t.size, src))

    def pose_at(self, k: int) -> Transform:
        """The recorded pose at joint sample ``k`` as a :class:`~forcecontrol.spatial.Transform` (base ← ``pose_frame``).

        Raises:
            ParameterError: the run has no pose.
        """
        if self.pose is None:
            raise ParameterError(f"{self.source}: the recording has no pose columns")
        T = self.pose[int(k)]
        return Transform(T[:3, :3], T[:3, 3], parent="base", child=self.pose_frame)

    def in_joint_order(self, names: Sequence[str] | None) -> RecordedRun:
        """The run with its joint columns (q, q̇, τ) in the order ``names`` (a model's joints).

        A log's joint order is the recorder's (a ``JointState`` need not follow the URDF's): the
        columns are permuted when the log names the same joints in another order (said in
        ``metadata["notes"]``); unchanged when ``names`` is None, or when either side names no joints
        (``joint1``, ... by column: the order cannot be checked).

        Raises:
            DimensionError: the log names other joints than ``names`` (both lists named).
        """
        if names is None or tuple(names) == self.joint_names:
            return self
        names = tuple(str(n) for n in names)
        unnamed = tuple(f"joint{i + 1}" for i in range(self.n))
        if (self.joint_names == unnamed or names == unnamed) and set(names) != set(self.joint_names):
            return self  # no names on one side (a table's columns q1, q2, ...): the order cannot be checked
        if sorted(names) != sorted(self.joint_names):
            raise DimensionError(
                f"{self.source}: the log's joints {list(self.joint_names)} are not the model's {list(names)}; read the "
                "log with joint_names set to the model's joints in its order (or use the model the log was recorded on)"
            )
        idx = [self.joint_names.index(j) for j in names]
        notes = [*self.metadata.get("notes", []),
                 f"the log's joints {list(self.joint_names)} reordered to the model's order {list(names)}"]
        return replace(self, q=self.q[:, idx], qd=self.qd[:, idx], tau=None if self.tau is None else self.tau[:, idx],
                       joint_names=names, metadata={**self.metadata, "notes": notes})

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q.shape[1])

    @property
    def m(self) -> int:
        """Number of wrench components (0 without a wrench)."""
        return 0 if self.wrench is None else int(self.wrench.shape[1])

    def resample(
        self, period: float, *, max_gap: float | None = None, start: float | None = None, end: float | None = None
    ) -> RecordedRun:
        """The run on a uniform grid ``start + k · period`` by linear interpolation of every stream.

        Args:
            period: the controller's sample time Ts [s].
            max_gap: the largest gap between two recorded samples [s] that may be bridged by
                interpolation (default: 10 · period); a larger gap inside the window is refused.
            start, end: the window [s] (default: where every stream has data).

        Returns:
            A RecordedRun with one time base (``t_wrench`` None).

        Raises:
            MeasurementError: a gap larger than ``max_gap``, or a window outside the recording.
        """
        period = positive_scalar("period", period)
        max_gap = 10.0 * period if max_gap is None else positive_scalar("max_gap", max_gap)
        for name, value in (("start", start), ("end", end)):
            if value is not None and not (isinstance(value, (int, float, np.floating, np.integer))
                                          and math.isfinite(float(value))):
                raise ParameterError(f"{name} must be a finite time [s] or None; got {value!r}")
        if start is not None and end is not None and float(start) >= float(end):
            raise ParameterError(f"start must be before end; got start = {float(start):.6g} s and end = {float(end):.6g} s")
        tw = self.t if self.t_wrench is None else self.t_wrench
        streams = [("joint states", self.t)] + ([("wrench", tw)] if self.wrench is not None else [])
        lo = max(float(ts[0]) for _, ts in streams) if start is None else float(start)
        hi = min(float(ts[-1]) for _, ts in streams) if end is None else float(end)
        for name, ts in streams:
            if lo < ts[0] - 1e-12 or hi > ts[-1] + 1e-12 or lo > ts[-1] or hi < ts[0]:
                raise MeasurementError(
                    f"{self.source}: the window [{lo:.6g}, {hi:.6g}] s is outside the {name} recording "
                    f"[{ts[0]:.6g}, {ts[-1]:.6g}] s"
                )
            inside = (ts[1:] > lo) & (ts[:-1] < hi)
            gaps = np.diff(ts)
            over = inside & (gaps > max_gap * (1.0 + 1e-9))  # a gap of exactly max_gap, to the stamps' round-off, is allowed
            if np.any(over):
                i = int(np.flatnonzero(over)[0])
                raise MeasurementError(
                    f"{self.source}: the {name} stream has a gap of {gaps[i]:.6g} s after t = {ts[i]:.6g} s, larger than "
                    f"max_gap = {max_gap:.6g} s; cut the window (start/end; replay --start/--end) or raise max_gap (--max-gap)"
                )
        if hi - lo < period:
            raise MeasurementError(f"{self.source}: the common window [{lo:.6g}, {hi:.6g}] s is shorter than one period")
        k = int(np.floor((hi - lo) / period + 1e-9))
        grid = lo + period * np.arange(k + 1)

        def interp(ts: np.ndarray, a: np.ndarray) -> np.ndarray:
            return np.column_stack([np.interp(grid, ts, a[:, j]) for j in range(a.shape[1])])

        return replace(
            self,
            t=grid,
            q=interp(self.t, self.q),
            qd=interp(self.t, self.qd),
            tau=None if self.tau is None else interp(self.t, self.tau),
            wrench=None if self.wrench is None else interp(tw, self.wrench),
            t_wrench=None,
            pose=None if self.pose is None else _interp_poses(self.t, self.pose, grid),
            metadata={**self.metadata, "resampled": {"period": period, "max_gap": max_gap}},
        )

    def columns(self) -> dict[str, np.ndarray]:
        """Flat named columns: ``t``, ``q1 qd1 tau1 ...`` and the wrench (one time base needed).

        Raises:
            ParameterError: the wrench has its own time base (resample first).
        """
        if self.t_wrench is not None and self.wrench is not None and not np.array_equal(self.t_wrench, self.t):
            raise ParameterError(f"{self.source}: the wrench has its own time base; resample() first")
        cols: dict[str, np.ndarray] = {"t": self.t}
        for i in range(self.n):
            cols[f"q{i + 1}"] = self.q[:, i]
            cols[f"qd{i + 1}"] = self.qd[:, i]
            if self.tau is not None:
                cols[f"tau{i + 1}"] = self.tau[:, i]
        if self.wrench is not None:
            for name, j in zip(wrench_axis_names(self.m), range(self.m)):
                cols[name] = self.wrench[:, j]
        return cols

    def to_pandas(self) -> Any:
        """The columns as a pandas DataFrame (pandas imported here only)."""
        import pandas as pd

        return pd.DataFrame(self.columns())
