"""CSV and Parquet tables of recorded runs, and :func:`read_recording` (the reader by file suffix)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from ...core.files import MAX_RECORDING_BYTES, check_regular
from ...errors import MeasurementError, ParameterError
from ..conventions import BY_END_EFFECTOR
from .recorded import RecordedRun
from .vendor import VENDOR_FORMATS, detect_convention, read_vendor, vendor_run, with_library_options

__all__ = ["read_table", "read_recording", "TABLE_COLUMNS"]

#: The columns of a table (CSV with a header row, or Parquet), SI units. The simulator's
#: ``SimulationResult.save`` writes exactly these (and more, which are ignored).
TABLE_COLUMNS = {
    "t": "time [s] (required, strictly increasing)",
    "q1 ... qn": "joint positions [rad] (required)",
    "qd1 ... qdn": "joint velocities [rad/s] (required)",
    "tau1 ... taun or u1 ... un": "joint torques [N m] (optional; the simulator writes u)",
    "fx fy [fz [mx my mz]]": "wrench [N, N m] (optional; 2, 3 or 6 components)",
    "fx_measured ...": "the wrench as the sensor measured it (used instead of fx ... when present)",
}


def _numbered(cols: list[str], prefix: str) -> int:
    n = 0
    while f"{prefix}{n + 1}" in cols:
        n += 1
    return n


#: a wrench's columns, in order, and how many of them a table may give (a prefix of them)
_WRENCH = ("fx", "fy", "fz", "mx", "my", "mz")
_WRENCH_SIZES = (6, 3, 2, 1)


def _check_columns(path: Path, cols: list[str]) -> None:
    """Refuse numbered or wrench columns that cannot be read whole: a gap in a joint numbering (q1, q2, q4: q4 was
    dropped), joints numbered from 0 (q0 was dropped), velocities or torques for other joints than the positions (a
    short torque block was dropped), and wrench components other than fx, fx fy, fx fy fz or all six (fz alone, or
    fx fy fz mx mz, was read as no wrench or as the forces only).

    Raises:
        ParameterError: naming the columns and what is missing or extra.
    """
    numbers: dict[str, list[int]] = {}
    for c in cols:
        m = re.fullmatch(r"(q|qd|tau|u)(\d+)", c)
        if m:
            numbers.setdefault(m.group(1), []).append(int(m.group(2)))
    n = max(numbers.get("q", [0]))
    for prefix, got in numbers.items():
        got = sorted(set(got))
        have = ", ".join(f"{prefix}{i}" for i in got[:12]) + (" ..." if len(got) > 12 else "")
        if got[0] == 0:
            raise ParameterError(f"{path}: column {prefix}0: joints are numbered from 1 (q1 ... qn); the file has {have}")
        gaps = [i for i in range(1, got[-1] + 1) if i not in got]
        if gaps:
            raise ParameterError(f"{path}: column {prefix}{gaps[0]} is missing between {prefix}1 and {prefix}{got[-1]}; the "
                                 f"file has {have}")
        if prefix != "q" and n and (got[-1] > n or (got[-1] < n and prefix != "qd")):  # a short qd: named below
            raise ParameterError(f"{path}: {prefix}1 ... {prefix}{got[-1]} for {n} joint(s) (q1 ... q{n}): every joint "
                                 f"needs its {prefix} column, and no other joint has one")
    for suffix in ("", "_measured"):
        present = [w for w in _WRENCH if w + suffix in cols]
        if present and present not in ([*_WRENCH[:k]] for k in _WRENCH_SIZES):
            want = next(list(_WRENCH[:k]) for k in reversed(_WRENCH_SIZES) if set(present) <= set(_WRENCH[:k]))
            missing = [w + suffix for w in want if w not in present]
            raise ParameterError(
                f"{path}: wrench columns {' '.join(w + suffix for w in present)}: {' '.join(missing)} missing; a wrench is "
                f"fx, fx fy, fx fy fz or fx fy fz mx my mz{' (each with _measured)' if suffix else ''}: give the "
                "missing components (zeros for an axis not measured)"
            )


def _wrench_names(cols: list[str], measured: bool) -> list[str]:
    suffix = "_measured" if measured else ""
    for names in (_WRENCH[:k] for k in _WRENCH_SIZES):
        if all(n + suffix in cols for n in names):
            return [n + suffix for n in names]
    return []


def read_table(
    path: str | Path,
    format: str | None = None,
    *,
    wrench: str = "measured",
    wrench_frame: str = "base",
    wrench_point: str = "end-effector",
    wrench_sense: str = BY_END_EFFECTOR,
    max_bytes: int = MAX_RECORDING_BYTES,
    sense: str | None = None,
) -> RecordedRun:
    """Read a CSV or Parquet table of a recorded run (columns: :data:`TABLE_COLUMNS`).

    A table with a vendor's column names (UR RTDE ``actual_q_0 …``, libfranka ``O_T_EE_0 …``;
    :mod:`.vendor`) is read with that vendor's conventions; a table mixing conventions is refused.

    Args:
        path: the file.
        format: ``"csv"`` or ``"parquet"`` (default: from the suffix).
        wrench: ``"measured"`` (the ``f*_measured`` columns when present, else ``f*``) or ``"true"``.
        wrench_frame, wrench_point, wrench_sense: the wrench's convention (default: the library's).
        max_bytes: the size limit [bytes] (default 2 GiB); a folder, FIFO or device is refused unopened.
        sense: for a vendor's table: ``"on-robot"``/``"by-robot"`` instead of the vendor's documented sense.

    Raises:
        ParameterError: an unknown format or option; a special or oversized file; a column
            missing (named, with those present); numbered columns with a gap, from 0, or for other
            joints than q1 ... qn; wrench components other than those listed (named).
        MeasurementError: time not increasing, NaN or inf in a column (named, with the row).
    """
    import pandas as pd

    path = Path(path)
    fmt = format or {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}.get(path.suffix.lower())
    if fmt not in ("csv", "parquet"):
        raise ParameterError(f"format must be 'csv' or 'parquet' (or a .csv/.parquet file); got {format!r} for {str(path)!r}")
    if wrench not in ("measured", "true"):
        raise ParameterError(f"wrench must be 'measured' or 'true'; got {wrench!r}")
    if not path.exists():
        raise ParameterError(f"recorded data file {str(path)!r} does not exist")
    check_regular(path, "recorded data file", max_bytes)
    try:
        df = pd.read_csv(path) if fmt == "csv" else pd.read_parquet(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:  # their text names lines and counts, not content
        raise ParameterError(f"{path}: cannot be read as {fmt}: {str(exc).strip()[:200]}") from None
    except Exception as exc:  # pandas/pyarrow raise many kinds; their text may quote the file
        raise ParameterError(f"{path}: cannot be read as {fmt} ({type(exc).__name__})") from None
    if fmt == "csv" and len(df.columns) == 1 and len(str(df.columns[0]).split()) > 1:  # space-delimited (UR's csv_writer)
        df = pd.read_csv(path, sep=r"\s+")
    df.columns = [str(c).strip() for c in df.columns]
    cols = list(df.columns)
    kind = detect_convention(cols)
    if kind in VENDOR_FORMATS:
        run = vendor_run({c: df[c].to_numpy() for c in cols}, kind, sense=sense, source=str(path))
        return with_library_options(run, wrench_frame=wrench_frame, wrench_point=wrench_point, wrench_sense=wrench_sense)
    if sense is not None:
        raise ParameterError(f"{path}: sense={sense!r} applies to a vendor's recording (UR RTDE, libfranka); this table has the "
                             "library's columns: give wrench_sense= (--wrench-sense) instead")
    _check_columns(path, cols)
    n = _numbered(cols, "q")
    missing = [] if "t" in cols else ["t"]
    if n == 0:
        missing.append("q1")
    missing += [f"qd{i + 1}" for i in range(n) if f"qd{i + 1}" not in cols] or ([] if n else ["qd1"])
    if missing:
        raise ParameterError(
            f"{path}: missing column(s) {', '.join(missing)}; a recorded run needs t, q1..qn, qd1..qn "
            f"(optional tau1..taun or u1..un, fx fy [fz mx my mz]); the file has {', '.join(cols[:20])}"
            + (" ..." if len(cols) > 20 else "")
        )
    for c in cols:
        if not (re.fullmatch(r"t|q\d+|qd\d+|tau\d+|u\d+|[fm][xyz](_measured)?", c)):
            continue
        if not pd.api.types.is_numeric_dtype(df[c]) or pd.api.types.is_bool_dtype(df[c]):
            try:
                bad = pd.to_numeric(df[c], errors="coerce").isna() & df[c].notna()
            except OverflowError:  # an integer of hundreds of digits
                raise MeasurementError(f"{path}: column {c!r} holds an integer beyond a float's range (1.8e308)") from None
            row = int(np.flatnonzero(bad.to_numpy())[0]) if bad.any() else 0
            raise MeasurementError(
                f"{path}: column {c!r} is not numeric (dtype {df[c].dtype}); the first non-number is at data row {row}"
            )
    tau_prefix = "tau" if _numbered(cols, "tau") >= n else ("u" if _numbered(cols, "u") >= n else None)
    names = _wrench_names(cols, measured=True) if wrench == "measured" else []
    names = names or _wrench_names(cols, measured=False)

    def block(prefix: str) -> np.ndarray:
        return df[[f"{prefix}{i + 1}" for i in range(n)]].to_numpy(dtype=np.float64)

    return RecordedRun(
        t=df["t"].to_numpy(dtype=np.float64), q=block("q"), qd=block("qd"),
        tau=None if tau_prefix is None else block(tau_prefix),
        wrench=df[names].to_numpy(dtype=np.float64) if names else None,
        wrench_frame=wrench_frame, wrench_point=wrench_point, wrench_sense=wrench_sense,
        source=str(path), metadata={"format": fmt, "wrench_columns": names},
    )


def read_recording(path: str | Path, format: str | None = None, **kwargs: Any) -> RecordedRun:
    """Read a recorded run with the reader its format needs.

    Args:
        path: a ``.csv``/``.parquet`` table, a ROS 2 bag (a folder with ``metadata.yaml``, or a
            ``.db3`` file's folder) or an ``.mcap`` file.
        format: ``"csv"``, ``"parquet"``, ``"bag"``, ``"mcap"``, ``"ur-rtde"`` or ``"franka"`` (default: from
            the path; a ``.json``/``.jsonl`` file is a libfranka recording, a table's vendor is told from its columns).
        kwargs: passed to :func:`read_table`, :func:`~forcecontrol.realarm.io.read_bag` or
            :func:`~forcecontrol.realarm.io.read_mcap` (topics, joint names, wrench convention).

    Raises:
        ParameterError: a format that cannot be told from the path, or an unknown one.
    """
    from .rosfiles import read_bag, read_mcap

    path = Path(path)
    if format in VENDOR_FORMATS or (format is None and path.suffix.lower() in (".json", ".jsonl")):
        library = {k: kwargs.pop(k) for k in ("wrench_frame", "wrench_point", "wrench_sense") if k in kwargs}
        unknown = set(kwargs) - {"sense", "max_bytes"}
        if unknown:
            raise ParameterError(f"a {format or 'franka'} recording takes sense= and max_bytes=; got {sorted(unknown)}")
        return with_library_options(read_vendor(path, format or "franka", **kwargs), **library)
    if format is None:
        suffix = path.suffix.lower()
        if suffix in (".csv", ".parquet", ".pq"):
            format = "parquet" if suffix != ".csv" else "csv"
        elif suffix == ".mcap":
            format = "mcap"
        elif path.is_dir() or suffix == ".db3":
            format = "bag"
        else:
            raise ParameterError(
                f"cannot tell the format of {str(path)!r}; pass format='csv', 'parquet', 'bag' or 'mcap'"
            )
    if format in ("csv", "parquet"):
        # a folder or FIFO named like a table is refused as such (before the bag-only keywords can confuse it)
        check_regular(path, f"recorded {format} table", kwargs.get("max_bytes", MAX_RECORDING_BYTES))
        return read_table(path, format, **kwargs)
    if format == "bag":
        return read_bag(path.parent if path.suffix.lower() == ".db3" else path, **kwargs)
    if format == "mcap":
        return read_mcap(path, **kwargs)
    raise ParameterError(f"format must be 'csv', 'parquet', 'bag' or 'mcap' (or a vendor's: 'ur-rtde', 'franka'); got {format!r}")
