"""Kind (a): scenario files mutated from every built-in scenario, for ``load``, ``run``, ``analyze`` and ``sweep``.

The 14 mutation kinds of ``tests/test_fuzz_scenarios.py`` plus the issue-28 kinds: integers of 401
digits, absurd magnitudes, numbers given as text, values replaced by empty tables, path traversal in
the names that become files, mathtext and terminal escapes in titles and labels, huge arrays.
Every file is first shortened to :data:`RUN_DURATION` seconds (so that a run is quick); the
mutation may then change that too.
"""

from __future__ import annotations

import json
import random
import sys
from pathlib import Path
from typing import Any

from test_fuzz_scenarios import KINDS as BASE_KINDS
from test_fuzz_scenarios import _get, _numeric_paths, _paths, _set, mutate, to_toml

from .core import Case, invoke

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

RUN_DURATION = 0.05  # [s]
NEW_KINDS = ("int401", "absurd", "number_as_text", "empty_table", "traversal", "text", "huge_array")
SUBS = BASE_KINDS + NEW_KINDS
COMMANDS = ("load", "run", "analyze", "sweep")
COMMAND_WEIGHTS = (55, 25, 17, 3)

TEXTS = ("$\\frac{$", "$x^{", "\x1b]0;pwned\x07\x1b[31mred\x1b[0m", "\x1b[2J\x1b[H cleared", "[red]markup[/red] [link=x]y[/link]",
         "\u202eevil\u202c", "%s %n {0} {x}", "a" * 20000, "line\nbreak\r\x08\x07bell", "<b>bold</b><script>x</script>")


def _traversals(sentinel: Path) -> tuple[str, ...]:
    s = str(sentinel)
    up = "../" * 40
    return (up + s.lstrip("/") + "/x", s + "/abs", "..\\..\\..\\x", "a/" + up + s.lstrip("/") + "/y", "~/" + "x",
            "/dev/null", "", ".", "..", "con:", "x\x00y")


def _shortened(text: str) -> dict[str, Any]:
    data = tomllib.loads(text)
    data["duration"] = RUN_DURATION
    for c in data.get("case", []) if isinstance(data.get("case"), list) else []:
        if isinstance(c, dict):
            c.pop("duration", None)
    return data


def _leaf_paths(data: dict[str, Any]) -> list[tuple]:
    return [p for p in _paths(data) if not isinstance(_get(data, p), (dict, list))]


def _new_mutation(rng: random.Random, sub: str, data: dict[str, Any], sentinel: Path) -> tuple[bool, bool, str]:
    """Apply a new-kind mutation in place; ``(invalid, escapes, what)``."""
    nums = _numeric_paths(data)
    if sub == "int401":
        p = rng.choice(nums)
        _set(data, p, rng.choice((10**400, -(10**400))))
        return True, False, f"{p} = <401 digits>"
    if sub == "absurd":
        p = rng.choice(nums)
        v = rng.choice((1e300, -1e300, 1e308, -1e308, 1.7e308))
        _set(data, p, v)
        # an expected value is a check's target: an absurd one is reported as missed, not accepted
        return "expected" not in p, False, f"{p} = {v}"
    if sub == "number_as_text":
        p = rng.choice(nums)
        _set(data, p, rng.choice(("abc", "1e3 N", "", "nan", "0x10")))
        return True, False, f"{p} = text"
    if sub == "empty_table":
        leaves = _leaf_paths(data)
        p = rng.choice(leaves)
        _set(data, p, {})
        return True, False, f"{p} = {{}}"
    if sub == "traversal":
        where = rng.choice(("figure", "label", "name"))
        v = rng.choice(_traversals(sentinel))
        if where == "figure":
            fig = data.setdefault("figure", {})
            if isinstance(fig, dict):
                fig["name"] = v
        elif where == "label" and isinstance(data.get("case"), list) and data["case"]:
            data["case"][0]["label"] = v
        else:
            data["name"] = v
        return False, False, f"{where} = {v[:60]!r}"
    if sub == "text":
        v = rng.choice(TEXTS)
        where = rng.choice(("title", "label", "description"))
        if where == "label" and isinstance(data.get("case"), list) and data["case"]:
            data["case"][0]["label"] = v
        else:
            data[where] = v
        return False, "\x1b" in v, f"{where} = {v[:30]!r}"
    # huge_array
    lists = [p for p in _paths(data) if isinstance(_get(data, p), list)
             and all(isinstance(x, (int, float)) for x in _get(data, p))]
    p = rng.choice(lists or nums)
    _set(data, p, [1.0] * rng.choice((1000, 100_000)))
    return True, False, f"{p} = [1.0] * N"


def _base_invalid(sub: str, before: dict[str, Any], raw: bytes) -> bool:
    """The oracle for the 14 older kinds: only where the mutation cannot mean anything."""
    if sub == "nonfinite" or sub == "unknown_key":
        return True
    if sub == "huge":
        try:
            after = tomllib.loads(raw.decode("utf-8"))
        except Exception:  # noqa: BLE001
            return False
        return any(isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) > 1e100
                   for v in (_get(after, p) for p in _numeric_paths(after) if "expected" not in p))
    if sub == "wrong_type":
        try:
            after = tomllib.loads(raw.decode("utf-8"))
        except Exception:  # noqa: BLE001
            return False
        for p in _numeric_paths(before):
            try:
                v = _get(after, p)
            except (KeyError, IndexError, TypeError):
                continue
            if isinstance(v, str):
                return True
    return False


def _changed(before: dict[str, Any], raw: bytes) -> str:
    """Where a mutated file differs from the original (for the failure list): ``: path = value``."""
    try:
        after = tomllib.loads(raw.decode("utf-8"))
    except Exception:  # noqa: BLE001 - not TOML any more: nothing to name
        return ""
    flat = {}
    for label, d in (("a", before), ("b", after)):
        flat[label] = {p: repr(_get(d, p))[:60] for p in _paths(d) if not isinstance(_get(d, p), (dict, list))}
    diff = [p for p in flat["b"] if flat["a"].get(p) != flat["b"][p]] + [p for p in flat["a"] if p not in flat["b"]]
    return f": {diff[0]} = {flat['b'].get(diff[0], '<deleted>')}" if diff else ""


def _action(command: str, name: str):
    def run(d: Path):
        f = d / f"{name}.toml"
        if command == "load":
            from forcecontrol.scenarios import load_scenario

            load_scenario(f)
            return None
        if command == "run":
            return invoke(["run", f.name, "--out", "out", "--json"])
        if command == "run-figure":
            return invoke(["run", f.name, "--out", "out"])
        if command == "analyze":
            return invoke(["analyze", f.name, "--json"])
        return invoke(["sweep", f.name, "-p", "sample_time=0.001,0.002", "--case", "1", "--out", "out/s.parquet",
                       "--no-figure", "--workers", "1", "--json"])

    return run


def make_cases(seed: int, count: int, sentinel: Path) -> list[Case]:
    """``count`` scenario cases, the built-in scenarios in turn, the mutation and command drawn from ``seed``."""
    from forcecontrol.scenarios import list_scenarios, scenario_source

    names = sorted(list_scenarios())
    texts = {n: scenario_source(n).read_text(encoding="utf-8") for n in names}
    rng = random.Random(f"scenario-{seed}")
    out = []
    for i in range(count):
        name = names[i % len(names)]
        data = _shortened(texts[name])
        sub = SUBS[rng.randrange(len(SUBS))]
        escapes = False
        if sub in BASE_KINDS:
            text = to_toml(data)
            while True:
                kind, raw = mutate(rng, text)
                if kind == sub or rng.random() < 0.02:
                    break
            sub = kind
            invalid, what = _base_invalid(sub, data, raw), f"{sub} of {name}{_changed(data, raw)}"
        else:
            invalid, escapes, what = _new_mutation(rng, sub, data, sentinel)
            try:
                raw = to_toml(data).encode("utf-8")
            except (TypeError, ValueError):  # pragma: no cover
                raw = json.dumps(data, default=str).encode()
        command = rng.choices(COMMANDS, COMMAND_WEIGHTS)[0]
        if sub in ("traversal", "text") and command in ("load", "run"):
            command = "run-figure"
        if sub == "huge_array" and command == "sweep":
            command = "load"

        def prepare(d: Path, raw=raw, name=name):
            (d / f"{name}.toml").write_bytes(raw)

        out.append(Case("scenario", f"{command}:{sub}", i, f"{command} {name}.toml ({what})", prepare=prepare,
                        action=_action(command, name), invalid=invalid, check_escapes=escapes))
    return out
