"""UR force-mode parameters as URScript lines: read and write back in place.

The format is a few URScript lines (others are kept untouched and named as not read)::

    force_mode(p[0.1, 0, 0, 0, 0, 0.785], [1, 0, 0, 0, 0, 0], [20, 0, 40, 0, 0, 0], 2, [.2, .1, .1, .785, .785, 1.57])
    force_mode_set_damping(0.025)
    force_mode_set_gain_scaling(0.5)

``force_mode(task_frame, selection_vector, wrench, type, limits)`` with literal numbers (25 of
them); the damping and gain scaling default to URScript's 0.005 and 1 when their calls are absent.
"""

from __future__ import annotations

import re
from typing import Any

from ...errors import ParameterError
from .config_text import Edit, apply_edits, format_number

__all__ = ["read_ur_script", "write_ur_script", "UR_DEFAULTS"]

_NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_CALL = re.compile(r"^(\s*)(force_mode|force_mode_set_damping|force_mode_set_gain_scaling)\s*\((.*?)\)\s*(#.*)?$")
#: URScript's defaults (e-Series Script Directory §14.13–14.14).
UR_DEFAULTS = {"damping": 0.005, "gain_scaling": 1.0}
_ARGS = (("task_frame", 6), ("selection_vector", 6), ("wrench", 6), ("frame_type", 1), ("limits", 6))


def _numbers(where: str, body: str, offset: int, count: int) -> list[tuple[float, int, int, str]]:
    found = [(float(m.group()), offset + m.start(), offset + m.end(), m.group()) for m in _NUM.finditer(body)]
    if len(found) != count:
        raise ParameterError(
            f"{where}: expected {count} literal numbers in the call; got {len(found)} in {body.strip()!r} "
            "(variables and expressions are not read: write the numbers)"
        )
    return found


def read_ur_script(text: str, where: str = "<ur script>") -> tuple[dict[str, Any], list[str], dict[str, Any]]:
    """(parameters, notes, spans) of a force-mode script; ``spans`` locate each number for :func:`write_ur_script`.

    Raises:
        ParameterError: no ``force_mode(...)`` call, or a call without the expected literal numbers.
    """
    params: dict[str, Any] = {}
    spans: dict[str, Any] = {}
    notes: list[str] = []
    for i, line in enumerate(text.splitlines()):
        m = _CALL.match(line)
        if not m:
            if line.strip() and not line.strip().startswith("#"):
                notes.append(f"line {i + 1}: not read (only force_mode, force_mode_set_damping, "
                             f"force_mode_set_gain_scaling are): {line.strip()[:80]!r}")
            continue
        name, body, off = m.group(2), m.group(3), m.start(3)
        if name == "force_mode":
            nums = _numbers(f"{where}: line {i + 1}: force_mode", body, off, 25)
            k = 0
            for arg, n in _ARGS:
                vals = nums[k : k + n]
                params[arg] = int(vals[0][0]) if arg == "frame_type" else [v[0] for v in vals]
                spans[arg] = [(i, v[1], v[2], v[3]) for v in vals]
                k += n
            spans["_indent"] = (i, m.group(1))
        else:
            key = "damping" if name.endswith("damping") else "gain_scaling"
            (v, a, b, tok), = _numbers(f"{where}: line {i + 1}: {name}", body, off, 1)
            params[key] = v
            spans[key] = [(i, a, b, tok)]
    if "task_frame" not in params:
        raise ParameterError(f"{where}: no force_mode(task_frame, selection_vector, wrench, type, limits) call found")
    for key, default in UR_DEFAULTS.items():
        if key not in params:
            params[key] = default
            notes.append(f"force_mode_set_{key}(...) not in the file: URScript's default {default:g} is used")
    return params, notes, spans


def write_ur_script(text: str, spans: dict[str, Any], old: dict[str, Any], new: dict[str, Any]) -> str:
    """The script with the changed values rewritten in place (a missing set_damping/set_gain_scaling
    call is added before ``force_mode``, with its indentation); every other byte kept."""
    edits: list[Edit] = []
    for key, value in new.items():
        if key not in old:
            raise ParameterError(f"{key!r} is not a force-mode parameter; expected one of {sorted(old)}")
        if key in spans:
            vals = value if isinstance(value, list | tuple) else [value]
            olds = old[key] if isinstance(old[key], list) else [old[key]]
            if len(vals) != len(spans[key]):
                raise ParameterError(f"{key} must have {len(spans[key])} values; got {len(vals)}")
            for (line, a, b, tok), v, o in zip(spans[key], vals, olds):
                if float(v) != float(o):
                    edits.append((line, a, b, _ur_number(v, tok)))
        elif float(value) != float(old[key]):
            line, indent = spans["_indent"]
            edits.append((line, -1, None, f"{indent}force_mode_set_{key}({_ur_number(value, '')})\n"))
    return apply_edits(text, edits)


def _ur_number(v: Any, like: str) -> str:
    f = float(v)
    if f.is_integer() and like and not any(c in like for c in ".eE"):
        return str(int(f))
    return format_number(f)
