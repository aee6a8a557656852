"""References given by samples (a recorded or designed trajectory), interpolated in time."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.axes import axis_names
from ..core.files import MAX_TABLE_BYTES, check_regular, column_label, read_text_limited
from ..errors import DimensionError, ParameterError
from .profiles import ReferenceSignal

__all__ = ["SampledReference", "INTERPOLATIONS"]


#: interpolation kinds of :class:`SampledReference`.
INTERPOLATIONS: tuple[str, ...] = ("linear", "cubic")


def _read_columns(path: Any, max_bytes: int) -> tuple[str, dict[str, np.ndarray]]:
    """(name for messages, named float columns) of a CSV (header row) or Parquet reference file."""
    from pathlib import Path

    what = "reference samples from"
    p = Path(path)
    name = repr(str(p))
    lines: list[int] | None = None

    def where(i: int) -> str:  # a data row as the file's line (CSV) or the table's row (Parquet)
        return f"line {lines[i]}" if lines is not None else f"row {i}"

    if p.suffix.lower() == ".parquet":
        check_regular(p, what, max_bytes)
        try:
            import pyarrow.parquet as pq  # type: ignore[import-untyped]
        except ImportError as exc:  # pragma: no cover - pyarrow is in the data extra
            raise ParameterError(f"reading {name} needs pyarrow (pip install 'forcecontrol[data]')") from exc
        try:
            table = pq.read_table(p)
            cols = {c: np.asarray(table.column(c).to_numpy(), dtype=np.float64) for c in table.column_names}
        except Exception as exc:  # pyarrow raises its own error types
            raise ParameterError(f"cannot read {what} {name}: not a readable Parquet file ({type(exc).__name__})") from None
    else:
        import csv
        import io

        reader = csv.reader(io.StringIO(read_text_limited(p, what, max_bytes)))
        rows = [(reader.line_num, r) for r in reader if r and any(f.strip() for f in r)]
        if not rows:
            raise ParameterError(
                f"cannot read {what} {name}: the file is empty; expected a header row (t, x, y, ...) and one row per sample"
            )
        header = [h.strip() for h in rows[0][1]]
        if len(set(header)) != len(header):
            dup = next(h for h in header if header.count(h) > 1)
            raise ParameterError(
                f"cannot read {what} {name}: column {column_label(dup, header.index(dup))} appears more than once in the header"
            )
        lines = [ln for ln, _ in rows[1:]]
        values = np.empty((len(lines), len(header)))
        for i, (ln, r) in enumerate(rows[1:]):
            if len(r) != len(header):
                raise ParameterError(f"cannot read {what} {name}: line {ln} has {len(r)} fields, the header {len(header)}")
            for j, f in enumerate(r):
                try:
                    values[i, j] = float(f)
                except ValueError:
                    raise ParameterError(
                        f"cannot read {what} {name}: line {ln}, column {column_label(header[j], j)} is not a number "
                        f"(a field of {len(f.strip())} characters)"
                    ) from None
        cols = {h: values[:, j] for j, h in enumerate(header)}
    for j, (c, v) in enumerate(cols.items()):
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise ParameterError(f"cannot read {what} {name}: column {column_label(c, j)} is NaN or inf at {where(int(bad[0]))}")
    rows_found = len(next(iter(cols.values()))) if cols else 0
    if rows_found < 2:
        raise ParameterError(f"cannot read {what} {name}: it has {rows_found} data row(s); at least 2 samples are needed")
    t = cols.get("t")
    if t is not None and t.size >= 2 and np.any(np.diff(t) <= 0.0):
        i = int(np.flatnonzero(np.diff(t) <= 0.0)[0])
        kind = "repeats" if t[i + 1] == t[i] else "goes backwards"
        raise ParameterError(
            f"cannot read {what} {name}: time {kind} at {where(i + 1)} (t = {t[i + 1]:.6g} s after t = {t[i]:.6g} s); "
            "times must be strictly increasing"
        )
    return name, cols


def _listing(cols: dict[str, np.ndarray]) -> str:
    """The columns' names, each as a short escaped excerpt, at most 20."""
    names = sorted(cols)
    return "[" + ", ".join(column_label(c, j) for j, c in enumerate(names[:20])) + (", ..." if len(names) > 20 else "") + "]"


#: the largest magnitude of a sample (time [s], position [m], force [N]): far beyond any arm, small
#: enough that a cubic spline's slopes and curvatures stay finite
MAX_SAMPLE_MAGNITUDE = 1e12

class SampledReference(ReferenceSignal):
    """A reference given by samples (a recorded or designed trajectory), interpolated in time.

    Position (and optionally force) samples at increasing times; velocities, accelerations, force
    rates and force accelerations come from the interpolant: ``"cubic"`` is a C² cubic spline
    with zero end slopes (``scipy.interpolate.CubicSpline``, ``bc_type="clamped"``), so x_d,
    ẋ_d and ẍ_d are continuous; ``"linear"`` joins the samples by straight lines (ẋ_d piecewise
    constant, ẍ_d = 0). Before the first sample and after the last the first/last values hold
    with zero derivatives.

    Args:
        times: sample times (N,) [s], strictly increasing, N >= 2.
        position: x_d samples (N, m) [m].
        force: f_d samples (N, m) [N], or None (zero).
        interpolation: ``"linear"`` or ``"cubic"``.
        velocity, acceleration: ẋ_d, ẍ_d samples (N, m), when the source has them (a saved run,
            a planner): then they are interpolated linearly instead of differentiated.

    Raises:
        ParameterError: non-finite values, times not strictly increasing, an unknown interpolation.
        DimensionError: shapes that do not match.
    """

    def __init__(self, times: Any, position: Any, force: Any = None, *, interpolation: str = "cubic",
                 velocity: Any = None, acceleration: Any = None) -> None:
        t = np.asarray(times, dtype=np.float64)
        if t.ndim != 1 or t.shape[0] < 2:
            raise DimensionError(f"times must be a vector of at least 2 samples; got shape {t.shape}")
        if not np.all(np.isfinite(t)):
            raise ParameterError("times must be finite; got NaN or inf")
        steps = np.diff(t)
        if np.any(steps <= 0.0):
            i = int(np.argmax(steps <= 0.0))
            raise ParameterError(
                f"times must be strictly increasing; got t[{i}] = {t[i]:.6g} s followed by t[{i + 1}] = {t[i + 1]:.6g} s"
            )
        X = np.asarray(position, dtype=np.float64)
        if X.ndim == 1:
            X = X[:, None]
        if X.ndim != 2 or X.shape[0] != t.shape[0]:
            raise DimensionError(f"position must have shape ({t.shape[0]}, m) like times; got shape {X.shape}")
        if not np.all(np.isfinite(X)):
            raise ParameterError("position samples must be finite; got NaN or inf")
        m = X.shape[1]
        F = np.zeros_like(X) if force is None else np.asarray(force, dtype=np.float64)
        if F.ndim == 1:
            F = F[:, None]
        if F.shape != X.shape:
            raise DimensionError(f"force must have shape {X.shape} like position; got shape {F.shape}")
        if not np.all(np.isfinite(F)):
            raise ParameterError("force samples must be finite; got NaN or inf")
        if interpolation not in INTERPOLATIONS:
            raise ParameterError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}; got {interpolation!r}")
        extra = {}
        for name, v in (("velocity", velocity), ("acceleration", acceleration)):
            if v is None:
                continue
            V = np.asarray(v, dtype=np.float64)
            V = V[:, None] if V.ndim == 1 else V
            if V.shape != X.shape:
                raise DimensionError(f"{name} must have shape {X.shape} like position; got shape {V.shape}")
            if not np.all(np.isfinite(V)):
                raise ParameterError(f"{name} samples must be finite; got NaN or inf")
            extra[name] = V
        named = (("times", t, "s"), ("position", X, "m"), ("force", F, "N"), *((k, V, "") for k, V in extra.items()))
        for name, v, unit in named:
            big = np.abs(v) > MAX_SAMPLE_MAGNITUDE  # beyond any arm's reach or force: a spline of it overflows
            if np.any(big):
                k = int(np.flatnonzero(big.reshape(big.shape[0], -1).any(axis=1))[0])
                raise ParameterError(
                    f"{name} samples must be at most {MAX_SAMPLE_MAGNITUDE:.0e} in magnitude{f' [{unit}]' if unit else ''}; "
                    f"got {float(np.max(np.abs(v))):.4g} at sample {k}"
                )
        self._given = extra
        self.times, self.position_samples, self.force_samples = t, X, F
        self.dim = int(m)
        self.interpolation = interpolation
        self._has_force = force is not None
        if interpolation == "cubic":
            from scipy.interpolate import CubicSpline  # type: ignore[import-untyped]

            self._x = CubicSpline(t, X, bc_type="clamped")
            self._f = CubicSpline(t, F, bc_type="clamped")

    def _eval(self, tq: np.ndarray, Y: np.ndarray, spline: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        tc = np.clip(tq, self.times[0], self.times[-1])
        inside = ((tq >= self.times[0]) & (tq <= self.times[-1]))[:, None]
        if self.interpolation == "cubic":
            y, yd, ydd = spline(tc), spline(tc, 1), spline(tc, 2)
        else:
            idx = np.clip(np.searchsorted(self.times, tc, side="right") - 1, 0, self.times.shape[0] - 2)
            t0, t1 = self.times[idx], self.times[idx + 1]
            w = ((tc - t0) / (t1 - t0))[:, None]
            # Y0 + w (Y1 − Y0): a hold (Y1 = Y0) is exactly Y0 whatever w (the (1 − w) Y0 + w Y1 form moved it by an
            # ulp that depended on the segment's length, so a motion's start time reached a run before it started);
            # w = 1 gives Y1 exactly
            y = np.where(w == 1.0, Y[idx + 1], Y[idx] + w * (Y[idx + 1] - Y[idx]))
            yd = (Y[idx + 1] - Y[idx]) / (t1 - t0)[:, None]
            ydd = np.zeros_like(y)
        return y, np.where(inside, yd, 0.0), np.where(inside, ydd, 0.0)

    def sample(self, times: np.ndarray) -> np.ndarray:
        tq = np.asarray(times, dtype=np.float64).reshape(-1)
        m = self.dim
        out = np.zeros((tq.shape[0], 6 * m))
        x, xd, xdd = self._eval(tq, self.position_samples, getattr(self, "_x", None))
        inside = ((tq >= self.times[0]) & (tq <= self.times[-1]))[:, None]
        for name, V in self._given.items():  # given derivatives: interpolated linearly, zero outside
            tc = np.clip(tq, self.times[0], self.times[-1])
            vi = np.column_stack([np.interp(tc, self.times, V[:, j]) for j in range(m)])
            vi = np.where(inside, vi, 0.0)
            if name == "velocity":
                xd = vi
            else:
                xdd = vi
        out[:, 0:m], out[:, m : 2 * m], out[:, 2 * m : 3 * m] = x, xd, xdd
        if self._has_force:
            f, fd, fdd = self._eval(tq, self.force_samples, getattr(self, "_f", None))
            out[:, 3 * m : 4 * m], out[:, 4 * m : 5 * m], out[:, 5 * m : 6 * m] = f, fd, fdd
        return out

    @classmethod
    def from_file(cls, path: Any, *, dim: int | None = None, interpolation: str = "cubic",
                  max_bytes: int = MAX_TABLE_BYTES) -> SampledReference:
        """Read samples from a CSV (header row) or Parquet file.

        Columns: ``t`` [s]; the position per axis, ``x y [z]`` (or ``x0 x1 ...``), or the
        simulator's own log names ``ref_position_x ...`` (preferred when both are present) (so a saved run can be replayed as a
        reference); optionally the force ``fx fy [fz]`` or ``ref_force_x ...``. ``dim`` picks
        the task dimension (default: as many position axes as the file has).

        The file must be a regular file of at most ``max_bytes`` (default 64 MiB); a folder, FIFO
        or device is refused before it is opened (:mod:`forcecontrol.core.files`).

        Raises:
            ParameterError: unreadable, empty, special or too large a file, a field that is not a
                number or a row with the wrong number of fields (the message names the row and
                column, never the file's content), NaN/inf (row named), times not strictly
                increasing (rows named), no ``t`` column, no position columns (the message lists
                the columns found).
        """
        p, cols = _read_columns(path, max_bytes)
        if "t" not in cols:
            raise ParameterError(f"{p} has no column 't'; columns found: {_listing(cols)}")

        def pick(names: list[str], prefixes: tuple[str, str]) -> list[np.ndarray] | None:
            out = []
            for a in names:
                for pre in prefixes:
                    key = f"{pre}{a}"
                    if key in cols:
                        out.append(cols[key])
                        break
                else:
                    return None
            return out

        candidates = [dim] if dim is not None else [6, 3, 2, 1]
        for m in candidates:
            pos = pick(axis_names(m)[0], ("ref_position_", ""))  # a saved run's x, y are the tip, not the reference
            if pos is not None:
                break
        else:
            raise ParameterError(
                f"{p} has no position columns for {'dim = ' + str(dim) if dim else 'any dimension'} "
                f"(expected e.g. x, y or ref_position_x, ref_position_y); columns found: {_listing(cols)}"
            )
        names, _, wrench = axis_names(m)
        force = pick(names, ("ref_force_",)) or pick(wrench, ("",))
        vel = pick(names, ("ref_velocity_",))
        acc = pick(names, ("ref_acceleration_",))
        return cls(cols["t"], np.column_stack(pos), None if force is None else np.column_stack(force),
                   interpolation=interpolation, velocity=None if vel is None else np.column_stack(vel),
                   acceleration=None if acc is None else np.column_stack(acc))

    def describe(self) -> dict[str, Any]:
        return {"type": "sampled", "samples": int(self.times.shape[0]), "t_start": float(self.times[0]),
                "t_end": float(self.times[-1]), "interpolation": self.interpolation, "force": self._has_force}
