"""A small TOML writer for scenario tables (the standard library reads TOML but does not write it).

Writes what scenario files hold: strings, booleans, integers, finite floats, arrays of those
(nested: gain matrices) and tables (sub-tables inline, arrays of tables as ``[[name]]``).
"""

from __future__ import annotations

import math
import re
from typing import Any

from ..errors import ParameterError

__all__ = ["dumps_toml"]

_BARE = re.compile(r"[A-Za-z0-9_-]+")  # used with fullmatch: "$" would accept a trailing newline


_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _string(s: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters (U+0000-U+001F, U+007F) escaped."""
    out = []
    for ch in s:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _key(k: Any) -> str:
    if not isinstance(k, str):
        raise ParameterError(f"TOML keys must be strings; got {k!r} ({type(k).__name__})")
    return k if _BARE.fullmatch(k) else _string(k)


def _value(v: Any, where: str) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ParameterError(f"{where}: must be a finite number to be written; got {v!r}")
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x, where) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x, f'{where}.{k}')}" for k, x in v.items()) + " }"
    if hasattr(v, "item") and hasattr(v, "dtype"):  # a NumPy scalar
        return _value(v.item(), where)
    if hasattr(v, "tolist"):  # a NumPy array
        return _value(v.tolist(), where)
    raise ParameterError(f"{where}: cannot be written to TOML: {v!r} ({type(v).__name__})")


def _table_body(d: dict[str, Any], where: str) -> list[str]:
    return [f"{_key(k)} = {_value(v, f'{where}.{k}')}" for k, v in d.items() if v is not None]


def dumps_toml(data: dict[str, Any]) -> str:
    """A TOML document of ``data``: top-level values first, then one ``[table]`` per dict and one
    ``[[name]]`` per dict of a list of dicts; deeper dicts are written as inline tables.

    ``None`` values are left out (TOML has no null).

    Args:
        data: the document (string keys).

    Returns:
        The TOML text (``tomllib.loads`` of it gives ``data`` back, without the ``None`` values).

    Raises:
        ParameterError: a value TOML cannot hold (NaN or infinite, an unknown type) or a non-string key.
    """
    if not isinstance(data, dict):
        raise ParameterError(f"data must be a dict; got {type(data).__name__}")
    top: list[str] = []
    tables: list[str] = []
    for k, v in data.items():
        if v is None:
            continue
        if isinstance(v, dict):
            tables += ["", f"[{_key(k)}]", *_table_body(v, k)]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for i, item in enumerate(v):
                tables += ["", f"[[{_key(k)}]]", *_table_body(item, f"{k}[{i}]")]
        else:
            top.append(f"{_key(k)} = {_value(v, k)}")
    return "\n".join(top + tables).lstrip("\n") + "\n"
