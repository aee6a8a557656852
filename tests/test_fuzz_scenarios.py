"""Fuzz: every built-in scenario mutated into hostile or careless files ends in success or a library error.

A generator with a fixed seed turns each built-in scenario into ``PER_SCENARIO`` mutated files
(deleted keys, wrong types, NaN/inf/negative/huge values, wrong shapes, indefinite matrices,
unknown keys, bad encodings, truncated text, garbage bytes, deep nesting). Each file is loaded;
a fixed random subset of the loadable ones is also run for ``RUN_DURATION`` seconds and its
``--json`` document is checked to be standard JSON. The only acceptable outcomes are success and
an error derived from :class:`forcecontrol.errors.ForceControlError`; a hang is caught by a
generous ``signal.alarm`` guard (a hang check, not a speed test). ``pytest -s`` prints the counts
by mutation kind (``tools/fuzz_report.py`` prints the same table).
"""

from __future__ import annotations

import copy
import json
import math
import random
import signal
import sys
import time
import warnings
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

import pytest

from forcecontrol.errors import ForceControlError, ScenarioError
from forcecontrol.scenarios import list_scenarios, load_scenario, run_scenario, scenario_source

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

SEED = 20261124
PER_SCENARIO = 60  # 13 built-in scenarios -> 780 files
RUN_SUBSET = 40  # loadable files also simulated (a fixed random subset)
RUN_DURATION = 0.05  # [s] simulated per run
HANG_SECONDS = 20  # per file: a hang detector only

KINDS = (
    "delete_key", "wrong_type", "nonfinite", "negative", "huge", "zero", "wrong_shape", "indefinite",
    "unknown_key", "encoding", "truncate", "garbage", "deep_nesting", "case_table",
)

# ----------------------------------------------------------------------------- a small TOML writer


def _toml_str(s: str) -> str:
    return json.dumps(s, ensure_ascii=False)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_str(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))  # pragma: no cover


def to_toml(data: dict[str, Any]) -> str:
    """Top-level keys first, then one ``[table]`` per table and ``[[name]]`` per array of tables."""
    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)):
            tables.append((k, v))
        else:
            lines.append(f"{_toml_str(k)} = {_toml_value(v)}")
    for k, v in tables:
        for item, header in ([(v, f"[{_toml_str(k)}]")] if isinstance(v, dict) else [(x, f"[[{_toml_str(k)}]]") for x in v]):
            lines.append("")
            lines.append(header)
            lines.extend(f"{_toml_str(a)} = {_toml_value(b)}" for a, b in item.items())
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- mutations


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path to a value (tables, arrays and leaves) below the root."""
    out = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        out.append(prefix + (k,))
        out.extend(_paths(v, prefix + (k,)))
    return out


def _get(node: Any, path: tuple) -> Any:
    for k in path:
        node = node[k]
    return node


def _set(node: Any, path: tuple, value: Any) -> None:
    _get(node, path[:-1])[path[-1]] = value


def _delete(node: Any, path: tuple) -> None:
    parent = _get(node, path[:-1])
    del parent[path[-1]]


def _numeric_paths(data: dict[str, Any]) -> list[tuple]:
    return [p for p in _paths(data) if isinstance(_get(data, p), (int, float)) and not isinstance(_get(data, p), bool)]


def _matrix_paths(data: dict[str, Any]) -> list[tuple]:
    out = []
    for p in _paths(data):
        v = _get(data, p)
        if isinstance(v, list) and v and (all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
                                          or all(isinstance(r, list) for r in v)):
            out.append(p)
    return out


def _indefinite(n: int, rng: random.Random) -> list[list[float]]:
    """A symmetric indefinite, a non-symmetric or a negative-definite n x n matrix."""
    which = rng.choice(("indefinite", "nonsymmetric", "negative", "singular"))
    m = [[0.0] * n for _ in range(n)]
    for i in range(n):
        m[i][i] = 100.0
    if which == "indefinite":
        m[0][0] = -100.0 if n > 1 else -1.0
        if n > 1:
            m[0][1] = m[1][0] = 50.0
    elif which == "nonsymmetric" and n > 1:
        m[0][1] = 500.0
    elif which == "negative":
        m = [[-x for x in row] for row in m]
    else:
        m[0][0] = 0.0
    return m


def mutate(rng: random.Random, text: str) -> tuple[str, bytes]:
    """One mutated file of a scenario's TOML text: ``(kind, bytes)``."""
    kind = rng.choice(KINDS)
    data = tomllib.loads(text)
    if kind == "encoding":
        how = rng.choice(("utf-16", "utf-16-le", "utf-32", "latin-1", "bom", "cp1252-quote"))
        if how in ("utf-16", "utf-16-le", "utf-32"):
            return kind, text.encode(how)
        if how == "bom":
            return kind, b"\xef\xbb\xbf" + text.encode("utf-8")
        marked = text.replace("title = \"", "title = \"caf\u00e9 \u2019 ", 1)
        return kind, marked.encode("latin-1" if how == "latin-1" else "cp1252", errors="replace")
    if kind == "truncate":
        raw = text.encode("utf-8")
        return kind, raw[: rng.randrange(0, len(raw))]
    if kind == "garbage":
        raw = bytearray(text.encode("utf-8"))
        how = rng.choice(("random-file", "splice", "flip", "nul"))
        if how == "random-file":
            return kind, bytes(rng.getrandbits(8) for _ in range(rng.randrange(1, 400)))
        i = rng.randrange(len(raw))
        if how == "splice":
            raw[i:i] = bytes(rng.getrandbits(8) for _ in range(rng.randrange(1, 20)))
        elif how == "flip":
            for _ in range(rng.randrange(1, 8)):
                j = rng.randrange(len(raw))
                raw[j] = rng.getrandbits(8)
        else:
            raw[i:i] = b"\x00"
        return kind, bytes(raw)
    if kind == "deep_nesting":
        depth = rng.choice((17, 40, 200, 1000, 5000))
        p = rng.choice(_paths(data))
        inner = "1.0"  # built as text: the writer itself must not recurse 5000 deep
        for _ in range(depth):
            inner = f"[{inner}]" if rng.random() < 0.7 else f"{{k = {inner}}}"
        _set(data, p, "@@DEEP@@")
        return kind, to_toml(data).replace('"@@DEEP@@"', inner).encode("utf-8")
    if kind == "case_table":
        how = rng.choice(("not-a-list", "empty", "label-type", "unknown-dotted", "non-table"))
        if how == "not-a-list":
            data["case"] = rng.choice((1, "x", True, 2.5))
        elif how == "empty":
            data["case"] = []
        elif how == "label-type":
            data.setdefault("case", [{}])[0]["label"] = rng.choice((1, 2.5, True, ["a"]))
        elif how == "unknown-dotted":
            data.setdefault("case", [{}])[0]["nosuchtable"] = {"k": 1}
        else:
            data["case"] = [1, 2]
        try:
            return kind, to_toml(data).encode("utf-8")
        except TypeError:  # pragma: no cover
            return kind, text.encode("utf-8")
    if kind == "delete_key":
        for _ in range(rng.choice((1, 1, 2, 3))):
            paths = [p for p in _paths(data) if isinstance(_get(data, p[:-1]), dict)]
            if paths:
                _delete(data, rng.choice(paths))
    elif kind == "unknown_key":
        tables = [()] + [p for p in _paths(data) if isinstance(_get(data, p), dict)]
        t = rng.choice(tables)
        _get(data, t)[rng.choice(("stifness", "gain", "Kp", "extra", "type2", "q_0"))] = rng.choice((1.0, "x", [1, 2]))
    elif kind == "indefinite":
        cands = _matrix_paths(data)
        if cands:
            p = rng.choice(cands)
            v = _get(data, p)
            _set(data, p, _indefinite(len(v), rng))
    else:
        cands = _numeric_paths(data) if kind in ("nonfinite", "negative", "huge", "zero") else _paths(data)
        if kind == "wrong_shape":
            cands = _matrix_paths(data) or cands
        if cands:
            p = rng.choice(cands)
            v = _get(data, p)
            if kind == "wrong_type":
                new = rng.choice(("100", "abc", True, False, [], {}, [1, "a"], {"value": 1}, 7, 2.5, ["x"]))
            elif kind == "nonfinite":
                new = rng.choice((math.nan, math.inf, -math.inf))
            elif kind == "negative":
                new = -abs(v) if v else -1.0
            elif kind == "huge":
                new = rng.choice((1e12, 1e300, -1e300, 10**30, 2**63 - 1, 1e-300, 1e-12))
            elif kind == "zero":
                new = rng.choice((0, 0.0, -0.0))
            else:  # wrong_shape
                if isinstance(v, list) and v and isinstance(v[0], list):
                    ragged = [v[0], v[1][:1]] if len(v) > 1 else []
                    new = rng.choice((v[:-1], [r + [0.0] for r in v], [r[:-1] for r in v], v[0], ragged))
                elif isinstance(v, list):
                    new = rng.choice((v + [0.0], v[:-1], [v], [[x] for x in v], [v, v, v]))
                else:
                    new = rng.choice(([v, v, v], [[v]], []))
            _set(data, p, new)
    return kind, to_toml(data).encode("utf-8")


def corpus(seed: int = SEED, per_scenario: int = PER_SCENARIO) -> list[tuple[str, str, bytes]]:
    """``(scenario, kind, bytes)`` for every mutated file, in a fixed order."""
    rng = random.Random(seed)
    out = []
    for name in list_scenarios():
        text = scenario_source(name).read_text(encoding="utf-8")
        for _ in range(per_scenario):
            kind, raw = mutate(rng, text)
            out.append((name, kind, raw))
    return out


# ----------------------------------------------------------------------------- the run


class Hang(Exception):
    """A file took longer than the hang guard."""


def _alarm(signum, frame):
    raise Hang


def fuzz(folder: Path, seed: int = SEED, per_scenario: int = PER_SCENARIO, run_subset: int = RUN_SUBSET) -> dict[str, Any]:
    """Load every mutated file (and run a fixed subset of the loadable ones); count the outcomes.

    Returns:
        ``{"rows": {kind: Counter}, "bad": [(scenario, kind, file, exception)], "seconds": float}``;
        the outcomes counted are ``tried``, ``load_error`` (a library error at load), ``loaded``,
        ``run``, ``run_ok``, ``run_error`` (a library error while running) and ``bad`` (anything else).
    """
    files = corpus(seed, per_scenario)
    rows: dict[str, Counter] = defaultdict(Counter)
    bad: list[tuple[str, str, str, str]] = []
    loaded: list[tuple[str, str, Path, Any]] = []
    previous = signal.signal(signal.SIGALRM, _alarm)
    t0, warmup = time.perf_counter(), 0.0
    try:
        for i, (name, kind, raw) in enumerate(files):
            p = folder / f"{i:04d}-{name}-{kind}.toml"
            p.write_bytes(raw)
            rows[kind]["tried"] += 1
            signal.alarm(HANG_SECONDS)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    scn = load_scenario(p)
            except ForceControlError:
                rows[kind]["load_error"] += 1
                continue
            except BaseException as exc:  # noqa: BLE001 - the very thing under test
                rows[kind]["bad"] += 1
                bad.append((name, kind, p.name, f"load: {type(exc).__name__}: {str(exc)[:200]}"))
                continue
            finally:
                signal.alarm(0)
            rows[kind]["loaded"] += 1
            loaded.append((name, kind, p, scn))
        chosen = random.Random(seed + 1).sample(loaded, min(run_subset, len(loaded)))
        # warm-up, unguarded: each chosen scenario unmutated, so that compiling the kernels (Numba, after a
        # source change: up to a minute on a loaded machine) is never taken for a hang nor interrupted by it
        t1 = time.perf_counter()
        for name in sorted({c[0] for c in chosen}):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                run_scenario(load_scenario(name).with_(duration=RUN_DURATION))
        warmup = time.perf_counter() - t1
        for name, kind, p, scn in chosen:
            rows[kind]["run"] += 1
            signal.alarm(HANG_SECONDS)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    run = run_scenario(scn.with_(duration=RUN_DURATION))
                    json.dumps(run.to_json(), allow_nan=False)
            except ForceControlError:
                rows[kind]["run_error"] += 1
                continue
            except BaseException as exc:  # noqa: BLE001
                rows[kind]["bad"] += 1
                bad.append((name, kind, p.name, f"run: {type(exc).__name__}: {str(exc)[:200]}"))
                continue
            finally:
                signal.alarm(0)
            rows[kind]["run_ok"] += 1
    finally:
        signal.signal(signal.SIGALRM, previous)
    return {"rows": dict(rows), "bad": bad, "seconds": time.perf_counter() - t0 - warmup, "warmup": warmup}


COLUMNS = ("tried", "load_error", "loaded", "run", "run_ok", "run_error", "bad")


def format_table(report: dict[str, Any]) -> str:
    """The counts by mutation kind as a Markdown table (with a total row)."""
    rows = report["rows"]
    total: Counter = Counter()
    lines = ["| mutation | " + " | ".join(COLUMNS) + " |", "|---" * (len(COLUMNS) + 1) + "|"]
    for kind in KINDS:
        if kind in rows:
            total.update(rows[kind])
            lines.append(f"| {kind} | " + " | ".join(str(rows[kind][c]) for c in COLUMNS) + " |")
    lines.append("| **total** | " + " | ".join(str(total[c]) for c in COLUMNS) + " |")
    lines.append(f"\n{total['tried']} files, {total['load_error']} clean errors at load, {total['loaded']} loaded; "
                 f"{total['run']} run ({total['run_ok']} ok, {total['run_error']} clean errors); "
                 f"{total['bad']} other exceptions or hangs; {report['seconds']:.1f} s "
                 f"(+ {report['warmup']:.1f} s warm-up of the unmutated scenarios)")
    return "\n".join(lines)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    return fuzz(tmp_path_factory.mktemp("fuzz"))


def test_fuzz_every_file_ends_in_success_or_a_library_error(report):
    """>= 500 mutated files of every built-in scenario: no raw exception, no hang; every mutation kind tried."""
    print("\n" + format_table(report))
    total = sum(r["tried"] for r in report["rows"].values())
    assert total >= 500
    assert set(report["rows"]) == set(KINDS)
    assert report["bad"] == [], "\n".join(map(str, report["bad"]))
    assert sum(r["run"] for r in report["rows"].values()) >= min(RUN_SUBSET, sum(r["loaded"] for r in report["rows"].values()))
    # the generator is not vacuous: most files fail to load, some load and run
    assert sum(r["load_error"] for r in report["rows"].values()) > total // 2
    assert sum(r["run_ok"] for r in report["rows"].values()) > 0


def test_fuzz_corpus_is_deterministic():
    """The fixed seed gives the same files every time (a failure is reproducible from its index)."""
    a, b = corpus(per_scenario=3), corpus(per_scenario=3)
    assert a == b and len({raw for _, _, raw in a}) > 1


def test_unmutated_round_trip_loads_every_builtin(tmp_path):
    """The fuzzer's TOML writer is faithful: every built-in scenario written back loads with the same cases."""
    for name in list_scenarios():
        src = scenario_source(name).read_text(encoding="utf-8")
        p = tmp_path / f"{name}.toml"
        p.write_text(to_toml(tomllib.loads(src)), encoding="utf-8")
        a, b = load_scenario(name), load_scenario(p)
        assert [c.config for c in a.cases] == [c.config for c in b.cases]
        assert [c.label for c in a.cases] == [c.label for c in b.cases]


def test_mutated_value_reaches_the_error_message(tmp_path):
    """A clean error from the fuzzer's kind of mutation names the key (a check of the generator, on one known case)."""
    data = tomllib.loads(scenario_source("example-9.2").read_text(encoding="utf-8"))
    bad = copy.deepcopy(data)
    bad["duration"] = "4"
    p = tmp_path / "dur.toml"
    p.write_text(to_toml(bad), encoding="utf-8")
    with pytest.raises(ScenarioError, match="key 'duration' must be a finite number"):
        load_scenario(p)


# ----------------------------------------------------------------------------- regressions: defects the fuzzer found
# Each was a raw exception (or a silent acceptance) before; the message must name the key.


def _edited(tmp_path, name: str, old: str, new: str, count: int = 1) -> Path:
    src = scenario_source(name).read_text(encoding="utf-8")
    assert old in src, old
    p = tmp_path / f"{name}-edited.toml"
    p.write_text(src.replace(old, new, count), encoding="utf-8")
    return p


@pytest.mark.parametrize("table", ["controller", "reference", "environment"])
def test_part_type_given_as_a_list_is_a_scenario_error(tmp_path, table):
    """type = ["x"] in a part table: ScenarioError naming 'type' (was TypeError: unhashable type: 'list')."""
    data = tomllib.loads(scenario_source("example-9.2").read_text(encoding="utf-8"))
    data[table]["type"] = ["x"]
    p = tmp_path / "t.toml"
    p.write_text(to_toml(data), encoding="utf-8")
    with pytest.raises(ScenarioError, match=rf"\[{table}\]: key 'type' must be one of .*got \['x'\]"):
        load_scenario(p)


def test_nested_controller_type_given_as_a_list_is_a_scenario_error(tmp_path):
    """The safety layer's wrapped controller with type = [1, "a"]: ScenarioError (was TypeError: unhashable)."""
    p = _edited(tmp_path, "impact-safety", 'type = "contact-supervisor"', 'type = [1, "a"]')
    with pytest.raises(ScenarioError, match=r"\[controller.wrapped\]: key 'type' must be one of .*got \[1, 'a'\]"):
        load_scenario(p)


@pytest.mark.parametrize("value, match", [("[1.0, 0.0, inf]", "rotation must be finite"),
                                          ("[1.0, 0.0]", r"rotation must have shape \(3,\)")])
def test_spatial_rotation_non_finite_or_short_is_a_scenario_error(tmp_path, value, match):
    """A 6-D spring's rotation with inf (was LinAlgError: SVD did not converge) or 2 angles (was a broadcast ValueError)."""
    p = _edited(tmp_path, "panda-peg-in-hole", "rotation = [1.0, 0.0, 0.0]", f"rotation = {value}")
    with pytest.raises(ScenarioError, match=rf"\[environment\].*{match}"):
        load_scenario(p)


def test_spatial_offset_of_wrong_length_is_a_scenario_error(tmp_path):
    """A pose line's end_offset with 4 numbers: ScenarioError naming end_offset (was a numpy broadcast ValueError)."""
    p = _edited(tmp_path, "panda-table-line", "end_offset = [0.1, 0.1, 0.0]", "end_offset = [0.1, 0.1, 0.0, 0.0]")
    with pytest.raises(ScenarioError, match=r"\[reference\].*end_offset must have shape \(3,\)"):
        load_scenario(p)


@pytest.mark.parametrize("rows", ["[[0.0, 0.0, 1.0, 0.0, 0.0]]", "[[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]]",
                                  "[[0.0, 0.0, 1.0, 0.0, 0.0, 0.0], [1.0]]"])
def test_force_directions_of_wrong_shape_are_a_scenario_error(tmp_path, rows):
    """force_directions rows of 5 or 7 numbers, or ragged: ScenarioError naming the key (was 'cannot reshape array')."""
    p = _edited(tmp_path, "panda-table-line", "force_directions = [[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]", f"force_directions = {rows}")
    with pytest.raises(ScenarioError, match=r"\[controller\].*force_directions"):
        load_scenario(p)


@pytest.mark.parametrize("name", ["panda-peg-in-hole", "example-9.4"])
def test_non_finite_q0_is_a_scenario_error(tmp_path, name):
    """q0 with NaN: ScenarioError naming q0 (on the Panda it was LinAlgError: SVD did not converge)."""
    data = tomllib.loads(scenario_source(name).read_text(encoding="utf-8"))
    if "q0" not in data["robot"]:
        data["robot"].pop("start_position", None)
        data["robot"]["q0"] = [0.5, 0.5]
    data["robot"]["q0"][1] = math.nan
    p = tmp_path / "q0.toml"
    p.write_text(to_toml(data), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"\[robot\]: key 'q0' must be finite"):
        load_scenario(p)


def test_qd0_of_wrong_length_or_non_finite_is_a_scenario_error(tmp_path):
    """qd0 is checked at load like q0 (shape and finiteness)."""
    for qd0 in ("[0.0]", "[0.0, inf]"):
        p = _edited(tmp_path, "example-9.2", "[robot]\n", f"[robot]\nqd0 = {qd0}\n")
        with pytest.raises(ScenarioError, match=r"\[robot\]: key 'qd0' must be 2 finite joint velocities"):
            load_scenario(p)


@pytest.mark.parametrize("spec, match", [
    ("{ tol = 1e-05 }", "no value"),
    ('{ value = "abc", tol = 0.005 }', "value must be a finite number; got 'abc'"),
    ("[]", r"value must be a finite number; got \[\]"),
    ("nan", "value must be a finite number; got nan"),
    ("{ value = 1.0, tol = -1.0 }", "tol must be a finite non-negative number"),
    ("{ value = 1.0, tol = 0.1, gain = 1.0 }", "unknown key 'gain'"),
])
def test_bad_expected_value_is_refused_at_load(tmp_path, spec, match):
    """A malformed expected value is a ScenarioError at load naming the metric (was KeyError/ValueError/TypeError
    after simulating every case, or silently accepted)."""
    p = _edited(tmp_path, "example-9.2", "fx = 200.0", f"fx = {spec}")
    with pytest.raises(ScenarioError, match=rf"\[expected\] key 'fx'.*{match}"):
        load_scenario(p)


@pytest.mark.parametrize("value", ["7", '["x"]'])
def test_case_expected_that_is_not_a_table_is_refused(tmp_path, value):
    """[[case]] expected = 7 or ["x"]: ScenarioError (was TypeError / 'dictionary update sequence' ValueError)."""
    data = tomllib.loads(scenario_source("example-9.2").read_text(encoding="utf-8"))
    data["case"][0]["expected"] = tomllib.loads(f"v = {value}")["v"]
    p = tmp_path / "e.toml"
    p.write_text(to_toml(data), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"\[\[case\]\] #1: key 'expected' must be a table"):
        load_scenario(p)


def test_unknown_top_level_key_in_a_case_is_refused(tmp_path):
    """A misspelt top-level key in a [[case]] (durationn = 1.0) was silently ignored; now refused, naming it."""
    data = tomllib.loads(scenario_source("example-9.2").read_text(encoding="utf-8"))
    data["case"][1]["durationn"] = 1.0
    p = tmp_path / "u.toml"
    p.write_text(to_toml(data), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"\[\[case\]\] #2: unknown key 'durationn'; expected one of: .*duration"):
        load_scenario(p)
    with pytest.raises(ScenarioError, match="unknown key 'stifness'"):
        load_scenario("example-9.2").with_({"stifness": 1.0})


@pytest.mark.parametrize("key, value, match", [("substeps", 0, "positive integer"), ("substeps", 1.5, "an integer"),
                                               ("settle_window", -0.1, "positive time"), ("tolerance", "x", "finite number")])
def test_case_level_settings_are_checked_at_load(tmp_path, key, value, match):
    """substeps, settle_window and tolerance set in a [[case]] are checked when the case is built, not when run."""
    data = tomllib.loads(scenario_source("example-9.2").read_text(encoding="utf-8"))
    data["case"][0][key] = value
    p = tmp_path / "s.toml"
    p.write_text(to_toml(data), encoding="utf-8")
    with pytest.raises(ScenarioError, match=rf"key '{key}' must be (a |an )?{match}"):
        load_scenario(p)


def test_vanishing_path_duration_is_a_clear_error(tmp_path):
    """A path of duration 1e-300 s: the trapezoidal law's 1/(t_c (t_f − t_c)) overflows; ScenarioError at load naming
    duration (was ZeroDivisionError while simulating)."""
    src = scenario_source("problem-9.10").read_text(encoding="utf-8")
    assert src.count("duration = 1.0") == 1
    p = _edited(tmp_path, "problem-9.10", "duration = 1.0", "duration = 1e-300")
    with pytest.raises(ScenarioError, match=r"\[reference\].*duration 1e-300 s .* too short"):
        load_scenario(p)


def test_absurd_admittance_stiffness_on_the_panda_is_a_library_error(tmp_path):
    """Found by the fuzzer (seed 10, file 566): stiffness = [1000, 1e300, ...] loaded, then the run raised LinAlgError;
    the admittance controller refused gains whose compliant frame cannot be discretised; since issue 28's ranges the
    [controller] key's range (entries of magnitude at most 1e12) refuses it first, naming key, range and value."""
    p = _edited(tmp_path, "panda-admittance-contact", "stiffness = [1000.0, 1000.0, 1000.0, 20.0, 20.0, 20.0]",
                "stiffness = [1000.0, 1e300, 1000.0, 20.0, 20.0, 20.0]")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ForceControlError, match=r"\[controller\].*'stiffness' must have entries in "
                                                    r"\[-1e\+12, 1e\+12\].*got \[1000.0, 1e\+300"):
            run_scenario(load_scenario(p).with_(duration=RUN_DURATION))
