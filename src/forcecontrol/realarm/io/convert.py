"""A recorded run's wrench converted between conventions, and written as a table with the convention in its metadata."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from ...core.jsonsafe import json_safe
from ...errors import ParameterError
from ..conventions import WrenchConvention, convention, convert_wrenches
from .recorded import RecordedRun

__all__ = ["convert_recording", "write_recording"]


def convert_recording(
    run: RecordedRun,
    source: str | WrenchConvention,
    target: str | WrenchConvention,
    *,
    rotations: Any = None,
    flange_offset: Any = None,
    base_frame: str = "base",
    end_effector_frame: str = "end-effector",
) -> RecordedRun:
    """The run with its wrench converted from ``source`` to ``target``.

    (:func:`~forcecontrol.realarm.conventions.convert_wrenches` on every sample.)

    Args:
        run: the recording (its wrench on one time base with the joints when ``rotations`` come
            from the joint positions: resample first otherwise).
        source, target: convention names (``forcecontrol.realarm.conventions.CONVENTIONS``).
        rotations: the end-effector's orientation at each wrench sample (N, 3, 3), when needed.
        flange_offset: the flange's position in the end-effector frame [m] (``"ur-tcp"``).
        base_frame, end_effector_frame: the frame names written into the result's
            ``wrench_frame``/``wrench_point``.

    Returns:
        A RecordedRun with the converted wrench, its frame, point and sense set from ``target``
        and ``metadata["wrench_convention"]`` (and ``"converted_from"``).

    Raises:
        ParameterError: no wrench in the run, an unknown convention, a missing orientation.
    """
    src, dst = convention(source), convention(target)
    if run.wrench is None:
        raise ParameterError(f"{run.source}: has no wrench to convert")
    h = convert_wrenches(run.wrench, src, dst, rotations=rotations, flange_offset=flange_offset)
    frame = {"base": base_frame, "ur-base": "ur-base"}.get(dst.axes, end_effector_frame)
    point = "flange" if dst.point == "flange" else end_effector_frame
    meta = {**run.metadata, "wrench_convention": dst.describe(), "converted_from": src.describe()}
    if flange_offset is not None:
        meta["flange_offset"] = [float(x) for x in flange_offset]
    return replace(run, wrench=h, wrench_frame=frame, wrench_point=point, wrench_sense=dst.sense, metadata=meta)


def write_recording(
    run: RecordedRun, path: str | Path, format: str | None = None, *, extra: dict[str, Any] | None = None
) -> tuple[Path, Path]:
    """Write a run as a CSV or Parquet table (``RecordedRun.columns``) and its metadata as JSON beside it.

    The metadata (``<stem>.json``; for Parquet also the file's schema metadata under
    ``forcecontrol``) holds the wrench's frame, point and sense, ``time_origin``, the joint names
    and the run's own metadata (e.g. ``wrench_convention``).

    Args:
        run: the recording (one time base: resample first when the wrench has its own).
        path: the data file; format: ``"csv"`` or ``"parquet"`` (default: from the suffix).
        extra: more columns (name → one value per row), e.g. the orientation ``qx qy qz qw``.

    Returns:
        The data file and the metadata file.

    Raises:
        ParameterError: an unknown format, or a wrench on its own time base.
    """
    path = Path(path)
    fmt = format or {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}.get(path.suffix.lower())
    if fmt not in ("csv", "parquet"):
        raise ParameterError(f"format must be 'csv' or 'parquet' (or a .csv/.parquet file); got {format!r} for {str(path)!r}")
    df = run.to_pandas()
    for name, col in (extra or {}).items():
        if len(col) != len(df):
            raise ParameterError(f"extra column {name!r} has {len(col)} rows; the run has {len(df)}")
        df[name] = col
    meta = json_safe({
        "source": run.source, "time_origin": run.time_origin, "joint_names": list(run.joint_names),
        "wrench_frame": run.wrench_frame, "wrench_point": run.wrench_point, "wrench_sense": run.wrench_sense,
        "metadata": run.metadata,
    })
    text = json.dumps(meta, indent=2, allow_nan=False)
    path.parent.mkdir(parents=True, exist_ok=True)
    if fmt == "csv":
        df.to_csv(path, index=False, float_format="%.17g")
    else:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pandas(df, preserve_index=False)
        table = table.replace_schema_metadata({**(table.schema.metadata or {}), b"forcecontrol": text.encode()})
        pq.write_table(table, path)
    meta_path = path.with_suffix(".json")
    meta_path.write_text(text + "\n")
    return path, meta_path
