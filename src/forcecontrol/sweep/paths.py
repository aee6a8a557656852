"""Where a swept value goes: checking a parameter path against a case, setting it, and the row's label."""

from __future__ import annotations

from functools import lru_cache
from typing import Any

from ..scenarios.schema import copy_tree
from .spec import SweepError, SweepParameter

__all__ = ["sweep_label", "copy_tree", "set_values"]


def _sweepable_top() -> list[str]:
    from ..scenarios.core import TOP_FIELDS

    return [k for k, f in TOP_FIELDS.items() if f.kind != "table" and k not in ("name", "title", "description")]


#: keys a part uses only in a check, not in the simulated response: (table, type) -> {key: what uses it}.
CHECK_ONLY: dict[tuple[str, str], dict[str, str]] = {
    ("controller", "admittance"): {"environment_stiffness": "its bandwidth check (a warning when the motion loop is too slow)"},
}


#: top-level keys used only by the checks against expected values, not by the simulation or the sweep's metrics.
CHECK_ONLY_TOP: dict[str, str] = {
    "tolerance": "the checks against the book's values (the sweep's table has no such check)",
    "allow_contact_loss": "whether `run --check` counts a contact loss as a failure (the table reports contact_lost)",
}


def check_only_note(p: SweepParameter, cfg: dict[str, Any], label: str, swept: frozenset[str] = frozenset()) -> str | None:
    """What to say when ``p`` names a key that case ``label`` uses only in a check, or does not use at all (a key whose
    :attr:`~forcecontrol.scenarios.schema.Field.used_when` does not hold in the case, unless the sweep also sets the
    key it depends on: a path of ``swept``); None otherwise."""
    keys = p.keys
    unused = _unused_note(p, cfg, label, swept)
    if unused is not None:
        return unused
    if len(keys) == 1 and keys[0] in CHECK_ONLY_TOP:
        return (f"parameter '{p.path}' (case '{label}'): '{keys[0]}' is used only by {CHECK_ONLY_TOP[keys[0]]}, "
                "not in the simulation: the swept values give the same responses")
    if len(keys) != 2:
        return None
    kind = (cfg.get(keys[0]) or {}).get("type")
    use = CHECK_ONLY.get((keys[0], str(kind)), {}).get(keys[1])
    if use is None:
        return None
    return (f"parameter '{p.path}' (case '{label}'): [{keys[0]}] of type '{kind}' uses '{keys[1]}' only in {use}, "
            "not in the simulation: the swept values give the same responses")


def _unused_note(p: SweepParameter, cfg: dict[str, Any], label: str, swept: frozenset[str]) -> str | None:
    from ..scenarios.schema import part_registries, unused_reason

    keys = p.keys
    registry = part_registries().get(keys[0])
    table = cfg.get(keys[0]) if registry is not None and len(keys) == 2 else None
    spec = registry.get(table.get("type")) if isinstance(table, dict) and registry is not None else None
    f = spec.fields.get(keys[1]) if spec is not None else None
    if f is None or f.used_when is None or f"{keys[0]}.{f.used_when[0]}" in swept:
        return None
    why = unused_reason(spec.fields, keys[1], table)
    if why is None:
        return None
    return (f"parameter '{p.path}' (case '{label}'): [{keys[0]}] of type '{table['type']}' does not use '{keys[1]}' ({why}): "
            "the swept values give the same responses")


def _check_path(p: SweepParameter, cfg: dict[str, Any], label: str) -> None:
    """Reject a path the scenario schema does not know, naming the valid choices."""
    from ..robots import PlanarTwoLinkParameters
    from ..scenarios.core import ROBOT_FIELDS, SENSOR_FIELDS
    from ..scenarios.schema import part_registries

    keys = p.keys
    top = keys[0]
    tables = part_registries()
    where = f"unknown parameter path '{p.path}'"
    if len(keys) == 1:
        choices = _sweepable_top()
        if top not in choices:
            raise SweepError(
                f"{where}: '{top}' is not a sweepable top-level key; expected one of {', '.join(choices)} "
                "or a key of [robot], [environment], [controller], [reference], [sensor]"
            )
        return
    if top in tables:
        registry = tables[top]
        if len(keys) != 2:
            raise SweepError(f"{where}: [{top}] keys are not tables; expected '{top}.<key>'")
        kind = cfg.get(top, {}).get("type")
        spec = registry.get(kind)
        valid = sorted({"type"} | (set(spec.fields) if spec else set()))
        if keys[1] not in valid:
            raise SweepError(
                f"{where} (case '{label}'): [{top}] of type '{kind}' has no key '{keys[1]}'; "
                f"expected one of {', '.join(valid)}"
            )
        return
    if top == "robot":
        if keys[1] not in ROBOT_FIELDS:
            raise SweepError(f"{where}: [robot] has no key '{keys[1]}'; expected one of {', '.join(ROBOT_FIELDS)}")
        if keys[1] == "parameters":
            names = list(PlanarTwoLinkParameters.__dataclass_fields__)
            if len(keys) != 3 or keys[2] not in names:
                raise SweepError(f"{where}: expected 'robot.parameters.<name>' with a name among {', '.join(names)}")
        elif len(keys) != 2:
            raise SweepError(f"{where}: expected 'robot.<key>'")
        return
    if top == "sensor":
        if len(keys) != 2 or keys[1] not in SENSOR_FIELDS:
            raise SweepError(f"{where}: [sensor] keys are {', '.join(SENSOR_FIELDS)}; got '{'.'.join(keys[1:])}'")
        return
    raise SweepError(
        f"{where}: no table '{top}'; expected robot, environment, controller, reference, sensor or a top-level "
        f"key ({', '.join(_sweepable_top())})"
    )


@lru_cache(maxsize=1024)
def _split(path: str) -> tuple[tuple[str, ...], tuple[int, ...]]:
    """A parameter path's keys and indices (:attr:`SweepParameter.keys`, ``.indices``), parsed once per path."""
    p = SweepParameter(path, None)
    return tuple(p.keys), tuple(p.indices)


def _apply(cfg: dict[str, Any], p: SweepParameter, value: Any, label: str) -> None:
    """Set ``p.path = value`` in a case configuration (creating missing [sensor]/parameters tables)."""
    keys, idx = _split(p.path)
    node = cfg
    for k in keys[:-1]:
        if k not in node or node[k] is None:
            node[k] = {}
        node = node[k]
    last = keys[-1]
    if not idx:
        node[last] = copy_tree(value)  # a deep copy (plain data: the same as copy.deepcopy, cheaper)
        return
    if last not in node:
        raise SweepError(
            f"parameter '{p.path}' (case '{label}'): '{'.'.join(keys)}' is not set in the scenario, so it has no "
            "entries to index; sweep the whole value instead"
        )
    cur = copy_tree(node[last])
    target = cur
    for depth, i in enumerate(idx):
        if not isinstance(target, list) or i >= len(target):
            raise SweepError(
                f"parameter '{p.path}' (case '{label}'): index [{i}] needs a list of more than {i} entries at "
                f"'{'.'.join(keys)}{''.join(f'[{j}]' for j in idx[:depth])}'; the scenario has {target!r}"
            )
        if depth == len(idx) - 1:
            target[i] = copy_tree(value)
        else:
            target = target[i]
    node[last] = cur


def set_values(config: dict[str, Any], params: list[SweepParameter], values: dict[str, Any], label: str) -> dict[str, Any]:
    """``config`` with every ``params`` path set to its value, as ``copy_tree`` and :func:`_apply` give it, but
    only the tables along the swept paths copied: the rest is shared with ``config`` (read, never changed)."""
    cfg = dict(config)
    fresh = {id(cfg)}
    for p in params:
        node = cfg
        for k in _split(p.path)[0][:-1]:
            child = node.get(k)
            if child is None:
                child = node[k] = {}
                fresh.add(id(child))
            elif not isinstance(child, dict):  # not a table: the whole copy, and _apply's own outcome
                cfg = copy_tree(config)
                for q in params:
                    _apply(cfg, q, values[q.path], label)
                return cfg
            elif id(child) not in fresh:
                child = node[k] = dict(child)
                fresh.add(id(child))
            node = child
    for p in params:
        _apply(cfg, p, values[p.path], label)
    return cfg


def sweep_label(label: str, overrides: tuple[str, ...], parameters: list[SweepParameter]) -> str:
    """The case label a sweep row carries: the scenario's, marked when the sweep overrides what the case set.

    A case's label often states the values its ``[[case]]`` table sets (``k_x = 1e4 N/m``); when
    a swept parameter replaces such a value (``overrides``: the case's own dotted keys), the
    label would describe another case, so it becomes
    ``"k_x = 1e4 N/m [environment.stiffness swept]"`` and the summary groups it apart.
    """
    own = [p.path for p in parameters
           if any(".".join(p.keys) == k or ".".join(p.keys).startswith(k + ".") or k.startswith(".".join(p.keys) + ".")
                  for k in overrides)]
    return f"{label} [{', '.join(own)} swept]" if own else label


# ----------------------------------------------------------------------------- jobs
