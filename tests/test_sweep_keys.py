"""Every key a built-in scenario sets can be swept, and a swept value changes what it names (issue 13).

For each built-in scenario (planar and 6-D) and each number, vector or matrix its first case sets
in ``[environment]``, ``[controller]``, ``[reference]`` and ``[sensor]``, a sweep over two values
(the scenario's own and a perturbed one) is prepared. Either the perturbed value is refused with
a SweepError that names the swept path, or the built part it names differs between the two
values while the other parts stay the same. A sweep over the same value twice builds identical
parts (so the comparison cannot pass by accident).
"""

from __future__ import annotations

import copy
import types

import numpy as np
import pytest

from forcecontrol.scenarios import list_scenarios, load_scenario
from forcecontrol.sweep import SweepError
from forcecontrol.sweep.prepare import prepare_sweep
from forcecontrol.sweep.spec import SweepDefinition

TABLES = ("environment", "controller", "reference", "sensor")


def _keys() -> list[tuple[str, str]]:
    out = []
    for name in list_scenarios():
        cfg = load_scenario(name).cases[0].config
        for table in TABLES:
            for key, value in (cfg.get(table) or {}).items():
                if key != "type" and not isinstance(value, (str, bool, dict)):
                    out.append((name, f"{table}.{key}"))
    return out


def _perturbed(value):
    """Another valid-looking value: scalars × 1.3 (integers + 1), vectors with 0.1 added to their smallest
    entry (so that a direction turns), matrices with 0.1 added to their diagonal."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value * 1.3 if value != 0.0 else 0.1
    v = copy.deepcopy(value)
    if v and isinstance(v[0], list):
        for i in range(min(len(v), len(v[0]))):
            v[i][i] += 0.1
        return v
    i = int(np.argmin(np.abs(np.asarray(v, dtype=float))))
    v[i] += 0.1
    return v


_SHARED = {"robot", "_spatial", "model", "data", "_pin", "_pinocchio"}  # the robot is the [robot] table's part


def _state(obj, depth: int = 0):
    """A comparable snapshot of an object's data (arrays by value; modules, functions and the robot skipped)."""
    if depth > 6 or isinstance(obj, (types.ModuleType, types.FunctionType, types.BuiltinFunctionType)):
        return None
    if isinstance(obj, np.ndarray):
        return ("array", obj.shape, np.ascontiguousarray(obj).tobytes())
    if obj is None or isinstance(obj, (bool, int, float, str, np.number)):
        return obj
    if isinstance(obj, (list, tuple)):
        return tuple(_state(x, depth + 1) for x in obj)
    if isinstance(obj, dict):
        return tuple(sorted((str(k), _state(v, depth + 1)) for k, v in obj.items() if str(k) not in _SHARED))
    fields = dict(vars(obj)) if hasattr(obj, "__dict__") else {}
    for cls in type(obj).__mro__:
        for name in getattr(cls, "__slots__", ()):
            if hasattr(obj, name):
                fields[name] = getattr(obj, name)
    return (type(obj).__qualname__, _state(fields, depth + 1)) if fields else repr(type(obj))


def _signature(job, table: str):
    """What a prepared case built for one table: the packed arrays of a compiled case, else the part itself."""
    if not job.fast:
        return _state(job.parts[table])
    if table == "reference":
        return job.ref_key, _state(job.reference.describe())
    if table == "sensor":
        return _state(job.sensor)
    if table == "controller":
        return _state((job.ctrl_p, job.ctrl_s))
    return _state(job.env_p)


def _prepare(name: str, path: str, values: list) -> list:
    d = SweepDefinition.from_options({path: values}, cases=["1"])
    return prepare_sweep(name, d).jobs


@pytest.mark.parametrize(("name", "path"), _keys(), ids=[f"{n}:{p}" for n, p in _keys()])
def test_a_swept_key_changes_the_part_it_names(name, path):
    table, key = path.split(".", 1)
    value = load_scenario(name).cases[0].config[table][key]
    same = _prepare(name, path, [value, value])
    assert _signature(same[0], table) == _signature(same[1], table)
    try:
        jobs = _prepare(name, path, [value, _perturbed(value)])
    except SweepError as exc:  # refused before anything runs, naming what was swept
        assert path in str(exc) or key in str(exc)
        return
    assert _signature(jobs[0], table) != _signature(jobs[1], table), f"sweeping {path} changed nothing"
    for other in TABLES:
        if other != table and other != "sensor" and not (table == "environment" and other == "controller"):
            # (a controller may be built for the environment's stiffness, e.g. the direct force schemes)
            assert _signature(jobs[0], other) == _signature(jobs[1], other), f"sweeping {path} changed [{other}]"
