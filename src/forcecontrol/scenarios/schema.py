"""The scenario schema: what each table accepts, and the registries of buildable parts.

A scenario (TOML file or dict) has top-level keys ``name``, ``title``, ``description``,
``duration``, ``sample_time``, ``substeps`` and the tables ``robot``, ``environment``,
``controller``, ``reference``, ``sensor``, ``figure``, ``expected`` and ``case`` (a list of
per-case overrides with dotted keys). Each ``type`` of environment, controller and reference is
registered here with its fields and a builder, so a new part plugs in with one
``register_*`` call in its own module.

A field is checked for its type here; values (shapes, signs, definiteness) are checked by the
library's own constructors, whose messages are prefixed with the file and the table.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..errors import ScenarioError

__all__ = [
    "Field",
    "PartSpec",
    "register_controller",
    "register_environment",
    "register_reference",
    "CONTROLLERS",
    "ENVIRONMENTS",
    "REFERENCES",
    "check_table",
]


@dataclass(frozen=True)
class Field:
    """One key of a table.

    Attributes:
        kind: ``"number"``, ``"int"``, ``"bool"``, ``"str"``, ``"vector"`` (list of numbers),
            ``"gain"`` (number, list of numbers or list of lists), ``"strlist"``, ``"table"``.
        required: the key must be present.
        default: value when absent (ignored when required).
        doc: one line for ``forcecontrol schema`` and error messages.
        choices: allowed values for ``"str"`` fields.
    """

    kind: str
    required: bool = False
    default: Any = None
    doc: str = ""
    choices: tuple[str, ...] = ()


@dataclass(frozen=True)
class PartSpec:
    """A registered part type: its fields and a builder ``build(params, context) -> object``."""

    name: str
    fields: dict[str, Field]
    build: Callable[[dict[str, Any], dict[str, Any]], Any]
    doc: str = ""


CONTROLLERS: dict[str, PartSpec] = {}
ENVIRONMENTS: dict[str, PartSpec] = {}
REFERENCES: dict[str, PartSpec] = {}


def _register(registry: dict[str, PartSpec], name: str, fields: dict[str, Field], build, doc: str) -> None:
    if name in registry:
        raise ValueError(f"type {name!r} is already registered")
    registry[name] = PartSpec(name, dict(fields), build, doc)


def register_controller(name: str, fields: dict[str, Field], build, doc: str = "") -> None:
    """Make ``[controller] type = name`` buildable. ``build(params, ctx)`` gets the checked
    table and a context with ``robot`` and ``sample_time``, and returns a Controller."""
    _register(CONTROLLERS, name, fields, build, doc)


def register_environment(name: str, fields: dict[str, Field], build, doc: str = "") -> None:
    """Make ``[environment] type = name`` buildable (context: ``robot``)."""
    _register(ENVIRONMENTS, name, fields, build, doc)


def register_reference(name: str, fields: dict[str, Field], build, doc: str = "") -> None:
    """Make ``[reference] type = name`` buildable (context: ``robot``, ``environment``)."""
    _register(REFERENCES, name, fields, build, doc)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _describe(v: Any) -> str:
    return f"{v!r} ({type(v).__name__})"


def check_value(where: str, key: str, field: Field, value: Any) -> Any:
    """Check one value's type; return it (ints become floats for numbers)."""
    k = field.kind
    ok = True
    if k == "number":
        ok = _is_number(value) and math.isfinite(float(value))
        value = float(value) if ok else value
    elif k == "int":
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif k == "bool":
        ok = isinstance(value, bool)
    elif k == "str":
        ok = isinstance(value, str) and (not field.choices or value in field.choices)
    elif k == "vector":
        ok = isinstance(value, list) and len(value) > 0 and all(_is_number(x) for x in value)
    elif k == "gain":
        ok = _is_number(value) or (
            isinstance(value, list)
            and len(value) > 0
            and (
                all(_is_number(x) for x in value)
                or all(isinstance(r, list) and all(_is_number(x) for x in r) for r in value)
            )
        )
    elif k == "strlist":
        ok = isinstance(value, list) and len(value) > 0 and all(isinstance(x, str) for x in value)
    elif k == "table":
        ok = isinstance(value, dict)
    if not ok:
        expected = {
            "number": "a finite number",
            "int": "an integer",
            "bool": "true or false",
            "str": "one of " + ", ".join(repr(c) for c in field.choices) if field.choices else "a string",
            "vector": "a non-empty list of numbers",
            "gain": "a number, a list of numbers (diagonal) or a list of rows (matrix)",
            "strlist": "a non-empty list of strings",
            "table": "a table",
        }[k]
        raise ScenarioError(f"{where}: key '{key}' must be {expected}; got {_describe(value)}")
    return value


def check_table(where: str, table: Any, fields: dict[str, Field], extra_ok: tuple[str, ...] = ()) -> dict[str, Any]:
    """Check a table against its fields: unknown keys, missing keys and types.

    Args:
        where: prefix for messages, e.g. ``"scenario.toml: [controller]"``.
        table: the parsed table.
        fields: accepted keys.
        extra_ok: keys accepted without checking (such as ``type``).

    Returns:
        A new dict with defaults filled in.
    """
    if not isinstance(table, dict):
        raise ScenarioError(f"{where}: must be a table; got {_describe(table)}")
    unknown = sorted(set(table) - set(fields) - set(extra_ok))
    if unknown:
        raise ScenarioError(
            f"{where}: unknown key '{unknown[0]}'; expected one of: {', '.join(sorted(set(fields) | set(extra_ok)))}"
        )
    out: dict[str, Any] = {}
    for key, field in fields.items():
        if key in table:
            out[key] = check_value(where, key, field, table[key])
        elif field.required:
            raise ScenarioError(f"{where}: missing key '{key}' ({field.doc or field.kind})")
        else:
            out[key] = field.default
    for key in extra_ok:
        if key in table:
            out[key] = table[key]
    return out
