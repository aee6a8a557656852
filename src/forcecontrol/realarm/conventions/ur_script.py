"""UR force-mode parameters as URScript lines: read and write back in place.

The format is a few URScript lines (others are kept untouched and named as not read)::

    force_mode(p[0.1, 0, 0, 0, 0, 0.785], [1, 0, 0, 0, 0, 0], [20, 0, 40, 0, 0, 0], 2, [.2, .1, .1, .785, .785, 1.57])
    force_mode_set_damping(0.025)
    force_mode_set_gain_scaling(0.5)

``force_mode(task_frame, selection_vector, wrench, type, limits)`` with literal numbers, read argument by
argument (``p[6]``, ``[6]``, ``[6]``, an integer type, ``[6]``); the damping and gain scaling default to URScript's
0.005 and 1 when their calls are absent.
"""

from __future__ import annotations

import re
from typing import Any

from ...errors import ParameterError
from .config_text import Edit, apply_edits, format_number

__all__ = ["read_ur_script", "write_ur_script", "UR_DEFAULTS"]

#: one literal number, its sign possibly apart from its digits (URScript reads "- 10" as −10)
_NUM = re.compile(r"\s*([-+]?\s*(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*")
_CALL = re.compile(r"^(\s*)(force_mode|force_mode_set_damping|force_mode_set_gain_scaling)\s*\((.*?)\)\s*(#.*)?$")
#: URScript's defaults (e-Series Script Directory §14.13–14.14).
UR_DEFAULTS = {"damping": 0.005, "gain_scaling": 1.0}
#: force_mode's arguments: name, the brackets it is written in ("p[", "[" or none) and its count of numbers
_ARGS = (("task_frame", "p[", 6), ("selection_vector", "[", 6), ("wrench", "[", 6), ("frame_type", "", 1), ("limits", "[", 6))


def _split_top(body: str, offset: int) -> list[tuple[str, int]]:
    """The comma-separated arguments of a call at bracket depth 0, each with its offset in the line."""
    out, depth, start = [], 0, 0
    for j, c in enumerate(body):
        if c in "[(":
            depth += 1
        elif c in "])":
            depth -= 1
        elif c == "," and depth == 0:
            out.append((body[start:j], offset + start))
            start = j + 1
    out.append((body[start:], offset + start))
    return out


def _literal(where: str, text: str, offset: int) -> tuple[float, int, int, str]:
    """One literal number filling ``text`` (value, start, end, token), else a ParameterError naming what is there."""
    m = _NUM.fullmatch(text)
    if m is None:
        raise ParameterError(f"{where}: {text.strip()!r} is not a literal number (variables, expressions and booleans "
                             "are not read: write the number)")
    token = m.group(1)
    return float(token.replace(" ", "").replace("\t", "")), offset + m.start(1), offset + m.end(1), token


def _argument(where: str, name: str, bracket: str, count: int, text: str, offset: int) -> list[tuple[float, int, int, str]]:
    """The numbers of one force_mode argument, written as ``p[...]``, ``[...]`` or a bare number."""
    if not bracket:
        return [_literal(f"{where}: {name}", text, offset)]
    m = re.fullmatch(r"\s*" + re.escape(bracket) + r"(.*)\]\s*", text, flags=re.S)
    if m is None:
        raise ParameterError(f"{where}: {name} must be written {bracket}{', '.join(['x'] * count)}]; got {text.strip()!r}")
    items = _split_top(m.group(1), offset + m.start(1))
    if len(items) != count:
        raise ParameterError(f"{where}: {name} must have {count} numbers; got {len(items)} in {text.strip()!r}")
    return [_literal(f"{where}: {name}[{k}]", t, o) for k, (t, o) in enumerate(items)]


def read_ur_script(text: str, where: str = "<ur script>") -> tuple[dict[str, Any], list[str], dict[str, Any]]:
    """(parameters, notes, spans) of a force-mode script; ``spans`` locate each number for :func:`write_ur_script`.

    ``force_mode(p[6], [6], [6], type, [6])`` is read argument by argument: each holds literal numbers (a sign may
    stand apart from its digits), ``type`` an integer 1, 2 or 3. When the script calls force_mode more than once, the
    last call is read (the others are named in a note).

    Raises:
        ParameterError: no ``force_mode(...)`` call, or a call whose arguments are not the expected literal numbers.
    """
    params: dict[str, Any] = {}
    spans: dict[str, Any] = {}
    notes: list[str] = []
    calls: list[int] = []
    for i, line in enumerate(text.splitlines()):
        m = _CALL.match(line)
        if not m:
            if line.strip() and not line.strip().startswith("#"):
                notes.append(f"line {i + 1}: not read (only force_mode, force_mode_set_damping, "
                             f"force_mode_set_gain_scaling are): {line.strip()[:80]!r}")
            continue
        name, body, off = m.group(2), m.group(3), m.start(3)
        at = f"{where}: line {i + 1}: {name}"
        if name == "force_mode":
            args = _split_top(body, off)
            if len(args) != len(_ARGS):
                raise ParameterError(f"{at}: expected {len(_ARGS)} arguments (task_frame, selection_vector, wrench, type, "
                                     f"limits); got {len(args)} in {body.strip()!r}")
            for (arg, bracket, n), (t, o) in zip(_ARGS, args):
                vals = _argument(at, arg, bracket, n, t, o)
                if arg == "frame_type":
                    v = vals[0][0]
                    if v not in (1.0, 2.0, 3.0):
                        raise ParameterError(f"{at}: type must be 1, 2 or 3; got {vals[0][3]!r}")
                    params[arg] = int(v)
                else:
                    params[arg] = [v[0] for v in vals]
                spans[arg] = [(i, v[1], v[2], v[3]) for v in vals]
            spans["_indent"] = (i, m.group(1))
            calls.append(i + 1)
        else:
            key = "damping" if name.endswith("damping") else "gain_scaling"
            v, a, b, tok = _literal(at, body, off)
            params[key] = v
            spans[key] = [(i, a, b, tok)]
    if "task_frame" not in params:
        raise ParameterError(f"{where}: no force_mode(task_frame, selection_vector, wrench, type, limits) call found")
    if len(calls) > 1:
        notes.append(f"force_mode is called on lines {', '.join(map(str, calls))}: the last one (line {calls[-1]}) is read")
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
