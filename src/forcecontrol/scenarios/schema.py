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

import copy
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from dataclasses import field as dc_field
from dataclasses import replace as dc_replace
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
    "unused_keys",
    "unused_reason",
    "part_registries",
]


@dataclass(frozen=True)
class Field:
    """One key of a table.

    Attributes:
        kind: ``"number"``, ``"int"``, ``"bool"``, ``"str"``, ``"vector"`` (list of numbers),
            ``"gain"`` (number, list of numbers or list of lists), ``"strlist"``, ``"boollist"``, ``"table"``.
        required: the key must be present.
        default: value when absent (ignored when required).
        doc: one line for ``forcecontrol schema`` and error messages.
        choices: allowed values for ``"str"`` fields.
        low, high: the allowed range of a ``"number"`` or ``"int"`` value, or of every entry of a
            ``"vector"``/``"gain"`` (inclusive; None: unbounded on that side). Shown by
            ``forcecontrol schema`` and named, with the value, when a value is outside it.
        bound: a limit relative to the run, in words (e.g. "at most the run's samples"), shown
            with the range; the builder checks it.
        fields: a ``"table"`` field's own keys (a nested table such as ``[robot.servo]``): the table is
            checked against them where its parent is (:func:`check_table`), and they appear in the
            schema (``forcecontrol schema``, ``--json``) under ``[parent.key]``.
        used_when: ``(key, values)``: the part uses this key only when the table's ``key`` (given or
            defaulted) is one of ``values`` (e.g. a schedule's or a law's own gain); set otherwise, it is
            accepted (a ``[[case]]`` may switch the law without deleting keys) and said to be unused
            (:func:`unused_keys`: a note on stderr and in ``run --json``; a sweep's warning).
    """

    kind: str
    required: bool = False
    default: Any = None
    doc: str = ""
    choices: tuple[str, ...] = ()
    low: float | None = None
    high: float | None = None
    bound: str = ""
    fields: dict[str, Field] | None = dc_field(default=None, compare=False, hash=False)
    used_when: tuple[str, tuple[Any, ...]] | None = None

    def range_text(self) -> str:
        """The allowed range in words (``"in [0, 100000], at most the run's samples"``), or ``""``."""
        if self.low is None and self.high is None:
            return self.bound
        what = "entries" if self.kind in ("vector", "gain") else ""
        if self.low is None:
            rng = f"at most {self.high:g}"
        elif self.high is None:
            rng = f"at least {self.low:g}"
        else:
            rng = f"in [{self.low:g}, {self.high:g}]"
        return f"{what} {rng}".strip() + (f", {self.bound}" if self.bound else "")

    def described(self) -> str:
        """The doc with the range (what ``forcecontrol schema`` prints)."""
        rng = self.range_text()
        return f"{self.doc} (range: {rng})" if rng and self.doc else (f"range: {rng}" if rng else self.doc)


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


#: magnitude limits of a part's keys declared without a range of their own (:func:`default_range`): far beyond any
#: arm, contact or run, so that a finite 1e300 (which passed every check and overflowed in the loop) is refused.
MAX_POSITION = 1e3  # [m] (or [rad]) positions, offsets, ends of paths
MAX_TIME = 1e7  # [s] durations, start times, ramps (about 116 days)
MAX_SPEED = 1e3  # [m/s]
MAX_PART_FORCE = 1e6  # [N] forces, wrenches (sim.limits.MAX_FORCE)
MAX_VALUE = 1e12  # gains, stiffnesses and every other number (core.validate.MAX_GAIN)
_POSITION_KEYS = frozenset({"position", "start", "end", "offset", "start_offset", "end_offset", "point", "rest_position",
                            "payload_cog", "joint_setpoint", "setpoint_position", "start_position", "task_frame"})
_TIME_KEYS = frozenset({"duration", "accel_time", "start_time", "force_start", "force_ramp"})
_SPEED_KEYS = frozenset({"speed", "velocity", "max_speed"})
_FORCE_KEYS = frozenset({"force", "normal_force", "contact_force", "release_force", "wrench", "max_force", "payload_weight"})


def default_range(key: str, field: Field) -> Field:
    """``field`` with a magnitude range by the kind of quantity its key names, when it declares none.

    Numbers, vectors and gains of a registered part: positions ``|x| <= MAX_POSITION``, times
    ``MAX_TIME``, speeds ``MAX_SPEED``, forces ``MAX_PART_FORCE``, anything else (gains,
    stiffnesses, frequencies) ``MAX_VALUE``; integers, strings, tables and declared ranges unchanged.
    """
    if field.kind not in ("number", "vector", "gain") or field.low is not None or field.high is not None:
        return field
    top = (MAX_POSITION if key in _POSITION_KEYS else MAX_TIME if key in _TIME_KEYS
           else MAX_SPEED if key in _SPEED_KEYS else MAX_PART_FORCE if key in _FORCE_KEYS else MAX_VALUE)
    return dc_replace(field, low=-top, high=top)


def _register(registry: dict[str, PartSpec], name: str, fields: dict[str, Field], build, doc: str) -> None:
    if name in registry:
        raise ValueError(f"type {name!r} is already registered")
    if str(getattr(build, "__module__", "")).startswith("forcecontrol."):  # the library's parts; a plugin's as declared
        fields = {k: default_range(k, f) for k, f in fields.items()}
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


def _describe(v: Any) -> str:
    if isinstance(v, int) and not isinstance(v, bool) and v.bit_length() > 64:  # no 4300-digit repr (ValueError)
        if v.bit_length() < 14000:  # within Python's int-to-str limit (4300 digits)
            return f"an integer of {len(str(abs(v)))} digits (int)"
        return f"an integer of about {int(v.bit_length() * 0.30103) + 1} digits (int)"
    text = repr(v)
    return f"{text if len(text) <= 200 else text[:200] + '...'} ({type(v).__name__})"


#: largest integer magnitude accepted anywhere in a scenario before any conversion to float or
#: array (a 401-digit integer would raise OverflowError in float(); 2**63 is int64's range).
MAX_INT = 2**63 - 1


_EXPECTED = {
    "number": "a finite number",
    "int": "an integer",
    "bool": "true or false",
    "str": "a string",
    "vector": "a non-empty list of numbers",
    "gain": "a number, a list of numbers (diagonal) or a list of rows (matrix)",
    "strlist": "a non-empty list of strings",
    "boollist": "a non-empty list of true/false",
    "table": "a table",
}


def _expected(field: Field) -> str:
    if field.kind == "str" and field.choices:
        return "one of " + ", ".join(repr(c) for c in field.choices)
    rng = field.range_text()
    if field.kind in ("int", "number", "vector", "gain"):  # the range, or the size limit of any integer
        rng = rng or f"{'entries ' if field.kind in ('vector', 'gain') else ''}of magnitude at most 2**63 - 1"
        return f"{_EXPECTED[field.kind]} ({rng})"
    return _EXPECTED[field.kind]


# ----------------------------------------------------------------------------- pydantic models


def _finite(v: float | int) -> float:
    if isinstance(v, int) and abs(v) > MAX_INT:  # checked before float(): no OverflowError
        raise ValueError("too large")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError("not finite")
    return v


def _bounded_int(v: int) -> int:
    if abs(v) > MAX_INT:
        raise ValueError("too large")
    return v


def _entry_value(v: float | int) -> float | int:
    if isinstance(v, int) and abs(v) > MAX_INT:  # the constructors' np.asarray(float) would overflow
        raise ValueError("too large")
    return v


def _annotation(field: Field) -> Any:
    """The pydantic type of a field kind (strict: no strings for numbers, no numbers for booleans)."""
    from typing import Annotated, Literal

    from pydantic import AfterValidator, StrictBool, StrictFloat, StrictInt, StrictStr, conlist

    number = Annotated[StrictInt | StrictFloat, AfterValidator(_finite)]  # a scalar: finite, as a float
    # an entry of a vector or gain: integers bounded (no OverflowError); the constructors check its value
    entry = Annotated[StrictInt | StrictFloat, AfterValidator(_entry_value)]
    kind = field.kind
    if kind == "number":
        return number
    if kind == "int":
        return Annotated[StrictInt, AfterValidator(_bounded_int)]
    if kind == "bool":
        return StrictBool
    if kind == "str":
        return Literal[field.choices] if field.choices else StrictStr  # type: ignore[valid-type]
    if kind == "vector":
        return conlist(entry, min_length=1)
    if kind == "gain":
        return entry | conlist(entry, min_length=1) | conlist(conlist(entry, min_length=1), min_length=1)
    if kind == "strlist":
        return conlist(StrictStr, min_length=1)
    if kind == "boollist":
        return conlist(StrictBool, min_length=1)
    if kind == "table":
        return dict[str, Any]
    raise ValueError(f"unknown field kind {kind!r}")


_MODELS: dict[tuple[int, str, str | None], tuple[dict[str, Field], Any]] = {}


def table_model(name: str, fields: dict[str, Field], type_name: str | None = None) -> Any:
    """The pydantic model of a table with these fields (cached; ``type = type_name`` for a part's table).

    Keys are fields by alias (a TOML key may be any name); unknown keys are refused
    (``extra="forbid"``); each field carries its doc as the JSON schema's description.
    """
    key = (id(fields), name, type_name)
    hit = _MODELS.get(key)
    if hit is not None and hit[0] is fields:
        return hit[1]
    from typing import Literal

    from pydantic import ConfigDict, create_model
    from pydantic import Field as PField

    defs: dict[str, Any] = {}
    if type_name is not None:
        defs["part_type"] = (Literal[type_name], PField(alias="type", description="the part's type"))  # type: ignore[valid-type]
    for i, (k, f) in enumerate(fields.items()):
        default = ... if f.required else f.default
        ann = table_model(f"{name}_{k}", f.fields) if f.kind == "table" and f.fields else _annotation(f)  # [name.k]
        defs[f"f{i}"] = (ann if f.required or f.default is not None else ann | None,
                         PField(default, alias=k, description=f.described() or None))
    model = create_model(  # type: ignore[call-overload]
        name, __config__=ConfigDict(extra="forbid", populate_by_name=False, title=name), **defs,
    )
    _MODELS[key] = (fields, model)
    return model


def _raise_first(where: str, err: Any, table: dict[str, Any], fields: dict[str, Field], extra_ok: tuple[str, ...]) -> None:
    """The library's message for the first problem pydantic found in a table."""
    order = {k: i for i, k in enumerate(fields)}

    def rank(e: dict[str, Any]) -> tuple[int, Any]:  # as the checks read: unknown keys (by name), then fields in order
        k = str((e.get("loc") or ("",))[0])
        return (0, k) if e["type"] == "extra_forbidden" else (1, order.get(k, len(order)))

    e = min(err.errors(), key=rank)
    loc = e.get("loc") or ("",)
    key = str(loc[0])
    nested = fields.get(key)
    if nested is not None and nested.fields and len(loc) > 1 and isinstance(table.get(key), dict):
        check_table(nested_where(where, key), table[key], nested.fields)  # raises the nested table's own message
    if e["type"] == "extra_forbidden":
        raise ScenarioError(
            f"{where}: unknown key '{key}'; expected one of: {', '.join(sorted(set(fields) | set(extra_ok)))}"
        ) from None
    field = fields.get(key)
    if e["type"] == "missing" and field is not None:
        raise ScenarioError(f"{where}: missing key '{key}' ({field.doc or field.kind})") from None
    if field is None:  # pragma: no cover - every located error is on a declared key
        raise ScenarioError(f"{where}: {e.get('msg')}") from None
    value = table.get(key)
    raise ScenarioError(f"{where}: key '{key}' must be {_expected(field)}; got {_describe(value)}") from None


def check_value(where: str, key: str, field: Field, value: Any) -> Any:
    """Check one value's type (by the field's pydantic type); return it (ints become floats for numbers)."""
    from pydantic import TypeAdapter, ValidationError

    adapter = _ADAPTERS.get((field.kind, field.choices))
    if adapter is None:
        adapter = _ADAPTERS[(field.kind, field.choices)] = TypeAdapter(_annotation(field))
    try:
        out = adapter.validate_python(value)
    except ValidationError:
        raise ScenarioError(f"{where}: key '{key}' must be {_expected(field)}; got {_describe(value)}") from None
    check_range(where, key, field, out)
    return out


_ADAPTERS: dict[tuple[str, tuple[str, ...]], Any] = {}


def _entries(value: Any) -> list[Any]:
    if isinstance(value, (list, tuple)):
        return [x for v in value for x in _entries(v)]
    return [value]


def check_range(where: str, key: str, field: Field, value: Any) -> None:
    """Refuse a checked value (or any entry of a vector/gain) outside the field's ``[low, high]``.

    Raises:
        ScenarioError: naming the key, the allowed range and the value.
    """
    if value is None:
        return
    for v in _entries(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        if not math.isfinite(v):  # NaN/inf: the finiteness checks name them (a scalar number never gets here)
            continue
        if (field.low is not None and v < field.low) or (field.high is not None and v > field.high):
            raise ScenarioError(
                f"{where}: key '{key}' must {'have' if field.kind in ('vector', 'gain') else 'be'} {field.range_text()} "
                f"({field.doc or field.kind}); got {_describe(value)}"
            )


_ATOMS = (str, int, float, bool, type(None))
_ATOM_TYPES = frozenset(_ATOMS)


def copy_tree(node: Any) -> Any:
    """A deep copy of scenario data (tables, arrays, scalars): ``copy.deepcopy`` at a fraction of its
    cost on the plain dicts, lists and scalars a TOML file gives; anything else is deep-copied."""
    if isinstance(node, dict):
        return {k: copy_tree(v) for k, v in node.items()}
    if isinstance(node, list):
        if all(type(v) in _ATOM_TYPES for v in node):  # a vector: a shallow copy is a deep one
            return node[:]
        return [copy_tree(v) for v in node]
    if isinstance(node, _ATOMS):
        return node
    return copy.deepcopy(node)


def check_table_memo(memo: dict[Any, Any] | None, where: str, table: Any, fields: dict[str, Field],
                     extra_ok: tuple[str, ...] = ()) -> dict[str, Any]:
    """:func:`check_table`, remembered in ``memo`` (when given) by the table's content.

    For callers that check many equal tables (a sweep builds one case per parameter value; most
    of its tables do not change): a table equal to one already checked gets a copy of that
    result. ``memo`` must not outlive the field definitions (``fields`` is keyed by identity).
    """
    if memo is None or not isinstance(table, dict):
        return check_table(where, table, fields, extra_ok)
    try:
        key = ("table", id(fields), extra_ok, json.dumps(table, sort_keys=True))
    except (TypeError, ValueError):  # not plain data (e.g. arrays in a Python dict): no memo
        return check_table(where, table, fields, extra_ok)
    hit = memo.get(key)
    if hit is None:
        hit = memo[key] = check_table(where, table, fields, extra_ok)
    return copy_tree(hit)


def nested_where(where: str, key: str) -> str:
    """The message prefix of a nested table: ``"f.toml: [robot]"`` and ``"servo"`` give ``"f.toml: [robot.servo]"``."""
    return f"{where[:-1]}.{key}]" if where.endswith("]") else f"{where}: [{key}]"


def check_table(where: str, table: Any, fields: dict[str, Field], extra_ok: tuple[str, ...] = ()) -> dict[str, Any]:
    """Check a table against its fields with its pydantic model: unknown keys, missing keys, types.

    Args:
        where: prefix for messages, e.g. ``"scenario.toml: [controller]"``.
        table: the parsed table.
        fields: accepted keys.
        extra_ok: keys accepted without checking (such as ``type``).

    Returns:
        A new dict with defaults filled in (numbers as floats).

    Raises:
        ScenarioError: naming the file, the table and the key, what was expected and what was given.
    """
    from pydantic import ValidationError

    if not isinstance(table, dict):
        raise ScenarioError(f"{where}: must be a table; got {_describe(table)}")
    model = table_model("table", fields)
    try:
        checked = model.model_validate({k: v for k, v in table.items() if k not in extra_ok})
    except ValidationError as err:
        _raise_first(where, err, table, fields, extra_ok)
    out = checked.model_dump(by_alias=True)
    for key, field in fields.items():
        if field.low is not None or field.high is not None:
            check_range(where, key, field, out.get(key))
        if field.fields and isinstance(table.get(key), dict):  # a nested table: its ranges, then kept as given
            check_table(nested_where(where, key), table[key], field.fields)
            out[key] = copy_tree(table[key])
    for key in extra_ok:
        if key in table:
            out[key] = table[key]
    return out


#: The keys of a straight segment with a trapezoidal speed profile (the paths of
#: :mod:`.parts`, :mod:`.parts_hybrid` and :mod:`.parts_spatial`).
TIMING_FIELDS = {
    "duration": Field("number", doc="t_f [s] (give this or speed)"),
    "speed": Field("number", doc="top speed [m/s] instead of duration: t_f = L/v + t_c (t_c = t_f/5 by default)"),
    "accel_time": Field("number", doc="t_c [s] (t_f/5 by default)"),
    "start_time": Field("number", default=0.0, doc="when the motion starts [s]"),
}
TRAPEZOID_FIELDS = {
    "start": Field("vector", True, doc="p_i [m]"),
    "end": Field("vector", True, doc="p_f [m]"),
    **TIMING_FIELDS,
}


def force_law_fields(default: str) -> dict[str, Field]:
    """The keys of a rigid hybrid's force law (9.92)-(9.94), planar or 6-D; ``default`` the law's."""
    return {
        "force_law": Field("str", default=default, choices=("feedforward", "proportional", "integral"),
                           doc="(9.92), (9.93) or (9.94)"),
        "force_gain": Field("gain", doc="K_Pλ (9.93) [-], below 1 (sampled reaction) (force_law = proportional)",
                            used_when=("force_law", ("proportional",))),
        "force_integral_gain": Field("gain", doc="K_Iλ (9.94) [1/s], below 2/Ts (force_law = integral)",
                                     used_when=("force_law", ("integral",))),
    }


def _toml_value(v: Any) -> str:
    return json.dumps(v) if isinstance(v, (bool, str)) else repr(v)


def unused_reason(fields: dict[str, Field], key: str, table: dict[str, Any]) -> str | None:
    """Why the part of ``table`` (its fields ``fields``) does not use ``key`` (its :attr:`Field.used_when` does not
    hold: ``'it applies only when schedule = "directional"; schedule is "constant"'``), or None when it does; the
    condition's key as given in ``table`` or defaulted."""
    f = fields.get(key)
    if f is None or f.used_when is None:
        return None
    cond, values = f.used_when
    value = table.get(cond)
    if value is None:
        value = fields[cond].default
    if value in values:
        return None
    return f"it applies only when {cond} = {' or '.join(_toml_value(v) for v in values)}; {cond} is {_toml_value(value)}"


def unused_keys(fields: dict[str, Field], table: dict[str, Any]) -> list[tuple[str, str]]:
    """The keys ``table`` sets (as written: a key absent or ``None`` is not set) that its part does not use, each with
    :func:`unused_reason`."""
    reasons = ((key, unused_reason(fields, key, table)) for key in fields if table.get(key) is not None)
    return [(key, why) for key, why in reasons if why is not None]


def part_registries() -> dict[str, dict[str, PartSpec]]:
    """The registered part types of the tables that have a ``type``: environment, controller, reference."""
    return {"environment": ENVIRONMENTS, "controller": CONTROLLERS, "reference": REFERENCES}
