"""Span edits of configuration text: a changed value rewritten where it stands, every other byte kept.

The YAML files are parsed with ruamel.yaml's round-trip loader only for their structure and the
line and column of each value (``lc``); a write replaces the changed scalars' characters in the
original text (and inserts a missing key beside its siblings), so comments, flow or block
style, key order, indentation, integer-vs-float spelling and unknown keys stay exactly as the
user wrote them. A file with nothing changed is written back byte for byte.
"""

from __future__ import annotations

import math
import re
from typing import Any

from ...errors import ParameterError

__all__ = ["format_number", "plain_scalar_end", "apply_edits", "Edit"]

#: (line, col, end_col or None for an insertion, new text): one edit of the text (0-based line and column).
Edit = tuple[int, int, int | None, str]


def format_number(value: Any, like: str = "") -> str:
    """A value as the configuration expects it: bools as ``true``/``false`` (``True`` when the file
    spells it so), integers as written when ``like`` is an integer, floats always with a ``.``
    or an exponent (ROS 2 refuses an integer for a double parameter; shortest repr, 12 digits)."""
    if isinstance(value, bool):
        return ("True" if value else "False") if like[:1].isupper() else ("true" if value else "false")
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    v = float(value)
    if not math.isfinite(v):
        raise ParameterError(f"a configuration value must be finite; got {value!r}")
    s = repr(float(f"{v:.12g}"))
    if not any(c in s for c in ".eE"):
        s += ".0"
    return s


_END = re.compile(r"\s*(?:[,\]}]|\s#|$)")


def plain_scalar_end(line: str, col: int) -> int:
    """The column where the plain scalar starting at ``col`` ends (before ``,``, ``]``, ``}``, `` #`` or the end)."""
    if col < len(line) and line[col] in "\"'":
        q = line[col]
        end = line.find(q, col + 1)
        if end < 0:
            raise ParameterError(f"unterminated quoted value at column {col + 1}: {line.strip()!r}")
        return end + 1
    m = _END.search(line, col)
    return m.start() if m else len(line)


def apply_edits(text: str, edits: list[Edit]) -> str:
    """The text with the edits applied (replacements ``line[col:end] = new``, insertions of whole lines
    when ``end`` is None and ``col`` < 0, or in-line insertions at ``col``), last position first."""
    lines = text.splitlines(keepends=True)
    if not lines or not lines[-1].endswith(("\n", "\r")):
        pass
    for line, col, end, new in sorted(edits, key=lambda e: (e[0], e[1]), reverse=True):
        if end is None and col < 0:  # a whole new line before `line`
            lines.insert(line, new)
            continue
        src = lines[line]
        if end is None:
            lines[line] = src[:col] + new + src[col:]
        else:
            lines[line] = src[:col] + new + src[end:]
    return "".join(lines)
