"""Calibration data files: columns of rotations, forces and torques."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...core.files import MAX_TABLE_BYTES, check_regular, read_text_limited
from ...core.validate import is_number
from ...errors import MeasurementError, ParameterError

__all__ = ["calibration_data_from_columns", "read_calibration_data", "read_columns"]


_FORCE = ("fx", "fy", "fz")


_TORQUE = ("tx", "ty", "tz")


_QUAT = ("qx", "qy", "qz", "qw")


_MATRIX = tuple(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))


def calibration_data_from_columns(
    columns: Mapping[str, Any], *, degrees: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Rotations, forces and moments from named columns (a table read from CSV or Parquet).

    Orientation of the sensor frame in the base frame, one of:

    * ``qx, qy, qz, qw``: unit quaternion, scalar last (ROS order); normalised if within 1e-3 of unit;
    * ``r11 … r33``: rotation matrix, row-major (``rij`` is row i, column j);
    * ``angle``: planar sensor angle φ [rad], or [deg] with ``degrees=True`` (a planar calibration).
      Angles in radians beyond ±2π are refused as probably in degrees.

    Readings: ``fx, fy, fz`` [N] (``fx, fy`` when planar) and optionally ``tx, ty, tz`` [N m]
    (``tz`` when planar). Column names are matched without regard to case and surrounding spaces.

    Returns:
        (rotations (k, d, d), forces (k, d), torques (k,)/(k, 3) or None).

    Raises:
        ParameterError: no orientation columns, missing force columns (the message lists what
            is there), a quaternion far from unit, text in a numeric column, an angle beyond ±2π
            (probably degrees: pass ``degrees=True``, ``--degrees``), ``degrees=True`` without an
            angle column. MeasurementError: NaN/inf.
    """
    cols = {str(k).strip().lower(): v for k, v in columns.items()}
    have = sorted(cols)

    def col(name: str) -> np.ndarray:
        try:
            a = np.asarray(cols[name], dtype=np.float64).reshape(-1)
        except (TypeError, ValueError) as exc:
            rows = [i for i, v in enumerate(list(cols[name])) if not is_number(v)]
            raise ParameterError(
                f"column {name!r} must hold numbers; data row {rows[0] + 1 if rows else '?'} is not a number"
            ) from exc
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise MeasurementError(f"column {name!r} must be finite; data row {int(bad[0]) + 1} is {a[bad[0]]}")
        return a

    def missing(names: tuple[str, ...]) -> list[str]:
        return [n for n in names if n not in cols]

    if not missing(_QUAT):
        q = np.stack([col(n) for n in _QUAT], axis=1)
        norm = np.linalg.norm(q, axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > 1e-3)
        if bad.size:
            raise ParameterError(
                f"quaternion (qx, qy, qz, qw) must be unit; data row {int(bad[0]) + 1} has norm {norm[bad[0]]:.6g}"
            )
        from scipy.spatial.transform import Rotation

        R = Rotation.from_quat(q / norm[:, None]).as_matrix()
    elif not missing(_MATRIX):
        R = np.stack([col(n) for n in _MATRIX], axis=1).reshape(-1, 3, 3)
    elif "angle" in cols:
        phi = col("angle")
        if degrees:
            phi = np.deg2rad(phi)
        elif np.any(np.abs(phi) > 2.0 * np.pi):
            i = int(np.flatnonzero(np.abs(phi) > 2.0 * np.pi)[0])
            raise ParameterError(
                f"column 'angle' is in radians and data row {i + 1} is {phi[i]:.6g}, beyond ±2π: the angles look like degrees; "
                "pass degrees=True (calibrate --degrees) if they are"
            )
        c, s = np.cos(phi), np.sin(phi)
        R = np.stack([np.stack([c, -s], axis=1), np.stack([s, c], axis=1)], axis=1)
    else:
        raise ParameterError(
            "no orientation columns: give qx, qy, qz, qw (quaternion, scalar last), r11 ... r33 (rotation matrix) or "
            f"angle (planar, rad); the data has columns {have}"
        )
    if degrees and "angle" not in cols:
        raise ParameterError("degrees=True (--degrees) applies to the planar 'angle' column only; the data has "
                             f"quaternion or rotation-matrix columns ({have})")
    d = R.shape[1]
    fnames = _FORCE[:d]
    if missing(fnames):
        raise ParameterError(f"missing force column(s) {missing(fnames)} for a {'planar' if d == 2 else '3-D'} "
                             f"calibration; the data has columns {have}")
    F = np.stack([col(n) for n in fnames], axis=1)
    tnames = ("tz",) if d == 2 else _TORQUE
    if d == 2 and any(n in cols for n in ("tx", "ty")):
        raise ParameterError(f"a planar calibration takes the moment about z (tz) only; got column(s) "
                             f"{[n for n in ('tx', 'ty') if n in cols]}")
    T = None
    present = [n for n in tnames if n in cols]
    if present:
        if missing(tnames):
            raise ParameterError(f"missing moment column(s) {missing(tnames)} (moments are all or none); "
                                 f"the data has columns {have}")
        T = col("tz") if d == 2 else np.stack([col(n) for n in tnames], axis=1)
    return R, F, T


def read_columns(path: str | Path, what: str = "calibration data file", max_bytes: int = MAX_TABLE_BYTES) -> dict[str, Any]:
    """The named columns of a CSV (header row, comma-separated) or Parquet table (numbers as float arrays, text as objects).

    Raises:
        ParameterError: the file does not exist, is special or too large, is not CSV/Parquet, is empty or ragged.
    """
    p = Path(path)
    if not p.is_file():
        if p.exists():
            check_regular(p, what, max_bytes)  # names the kind: folder, FIFO, device
        raise ParameterError(f"{what} {str(p)!r} does not exist")
    check_regular(p, what, max_bytes)
    suffix = p.suffix.lower()
    if suffix in (".parquet", ".pq"):
        try:
            import pyarrow.parquet as pq
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ImportError("reading Parquet needs pyarrow: pip install 'forcecontrol[data]'") from exc
        try:
            table = pq.read_table(p)
        except Exception as exc:  # pyarrow raises its own error types
            raise ParameterError(f"cannot read {str(p)!r} as Parquet ({type(exc).__name__})") from None
        columns = {name: table.column(name).to_numpy(zero_copy_only=False) for name in table.column_names}
    elif suffix in (".csv", ".txt"):
        import csv
        import io

        text = read_text_limited(p, what, max_bytes).removeprefix("\ufeff")  # a byte-order mark (Excel's UTF-8 CSV)
        rows = list(csv.reader(io.StringIO(text, newline="")))
        if len(rows) < 2:
            raise ParameterError(f"{str(p)!r} holds no data rows (a header row and one row per reading are needed)")
        header, body = rows[0], [r for r in rows[1:] if r]
        if any(len(r) != len(header) for r in body):
            i = next(i for i, r in enumerate(body) if len(r) != len(header))
            raise ParameterError(f"{str(p)!r}: data row {i + 1} has {len(body[i])} fields, the header {len(header)}")
        columns = {}
        for j, name in enumerate(header):
            vals = [r[j] for r in body]
            try:
                columns[name] = np.array([float(v) for v in vals])
            except ValueError:
                columns[name] = np.array(vals, dtype=object)
    else:
        raise ParameterError(f"{what} must be a .csv or .parquet file; got {str(p)!r}")
    return columns


def read_calibration_data(
    path: str | Path, *, degrees: bool = False, max_bytes: int = MAX_TABLE_BYTES
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read a calibration table from CSV (header row, comma-separated) or Parquet (needs pyarrow).

    See :func:`calibration_data_from_columns` for the columns and ``degrees``. The file must be a
    regular file of at most ``max_bytes`` (default 64 MiB; :mod:`forcecontrol.core.files`).

    Raises:
        ParameterError: the file does not exist, is special or too large, is not CSV/Parquet, is
            empty or lacks columns.
    """
    p = Path(path)
    columns = read_columns(p, "calibration data file", max_bytes)
    try:
        return calibration_data_from_columns(columns, degrees=degrees)
    except (ParameterError, MeasurementError) as exc:  # name the file
        raise type(exc)(f"{str(p)!r}: {exc}") from None
