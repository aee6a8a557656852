"""Standard JSON out of results: NaN and infinities become null, with a note of where."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["json_safe"]


def json_safe(value: Any, notes: list[str] | None = None, where: str = "") -> Any:
    """A copy of ``value`` that standard JSON can hold: NaN and ±inf become None (null); -0.0 becomes 0.0.

    Each replaced value's location is appended to ``notes`` (e.g. ``cases[0].settled.fx = nan``).
    """
    if isinstance(value, float) or (isinstance(value, np.floating)):
        v = float(value)
        if math.isfinite(v):
            return v + 0.0  # -0.0 (a zero force along a negated axis) is written 0.0
        if notes is not None:
            notes.append(f"{where or '<value>'} = {v}")
        return None
    if isinstance(value, dict):
        return {k: json_safe(v, notes, f"{where}.{k}" if where else str(k)) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v, notes, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist(), notes, where)
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    return value
