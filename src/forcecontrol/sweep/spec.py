"""Sweep definitions: which scenario parameters vary, over which values, in which design.

A sweep varies parameters of a scenario, named by their dotted path in the scenario file
(``environment.stiffness``, ``controller.force_gain[0]``, ``sensor.seed``, ``duration``), over

* a **grid** (full factorial): each parameter gets a list of values, written
  ``logspace(3, 6, 40)`` (40 values from 10³ to 10⁶), ``linspace(a, b, n)``,
  ``geomspace(a, b, n)``, ``range(a, b[, step])`` (integers, b excluded), a list ``[1, 2, 3]`` or
  ``1e3, 1e4`` (numbers, strings or lists: ``[[0.001, 0], [0.002, 0]]``), or one value;
* a **random** design (Monte Carlo): ``samples`` draws from a seeded generator, each parameter a
  distribution ``uniform(a, b)``, ``loguniform(a, b)``, ``normal(mean, std)``,
  ``randint(a, b)`` (b excluded) or a list (one of its values, equally likely).

Every selected scenario case (``[[case]]``) is swept: a sweep of Example 9.3 over the
environment stiffness runs each of its schemes over the whole range. The definition is checked
whole before any case runs: unknown parameter paths, empty ranges, malformed specifications and
values that fail the scenario's own validation raise :class:`SweepError`.
"""

from __future__ import annotations

import ast
import copy
import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ScenarioError
from ..sim.limits import MAX_EXPRESSION_CHARS, MAX_SWEEP_VALUES

__all__ = ["SweepError", "SweepWarning", "SweepParameter", "SweepDefinition", "parse_parameter", "parse_values"]

DESIGNS = ("grid", "random")
_FUNC = re.compile(r"^\s*([a-z_]+)\s*\((.*)\)\s*$", re.S)
_PATH = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)((?:\[\d+\])*)$")
_GRID_FUNCS = ("logspace", "linspace", "geomspace", "range")
_RANDOM_FUNCS = ("uniform", "loguniform", "normal", "randint")


class SweepWarning(UserWarning):
    """A sweep recovered from something (a corrupt part moved aside and re-run, a stale lock taken over)."""


class SweepError(ScenarioError):
    """A sweep definition is malformed: unknown parameter, empty range, bad value, wrong design.

    The message names the parameter, what was expected and what was given.
    """


def _plain(v: Any) -> Any:
    """NumPy scalars and arrays as plain Python values (TOML/JSON types)."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    return v


def _check_length(path: str, text: str) -> None:
    """Refuse a value's text longer than MAX_EXPRESSION_CHARS before it is parsed (no MemoryError in the parser)."""
    if len(text) > MAX_EXPRESSION_CHARS:
        raise SweepError(
            f"parameter '{path}': the value is {len(text):,} characters long, more than the {MAX_EXPRESSION_CHARS:,} "
            "allowed; give a range (logspace/linspace/geomspace/range) or a shorter list"
        )


def _literal(path: str, text: str) -> Any:
    """A number, string or (nested) list written in TOML/Python syntax; bare words are strings."""
    t = text.strip()
    if not t:
        raise SweepError(f"parameter '{path}': empty value; expected a number, a string or a list")
    _check_length(path, t)
    low = t.lower()
    if low in ("true", "false"):
        return low == "true"
    try:
        return _plain(ast.literal_eval(t))
    except (ValueError, SyntaxError, MemoryError, RecursionError):  # the parser's own depth limits
        if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_\-]*", t):
            return t
        raise SweepError(f"parameter '{path}': cannot read value {t[:200]!r}; expected a number, a string or a list") from None


def _args(path: str, name: str, body: str, counts: tuple[int, ...]) -> list[float]:
    _check_length(path, body)
    try:
        vals = ast.literal_eval(f"[{body}]")
    except (ValueError, SyntaxError, MemoryError, RecursionError):
        vals = None
    if vals is None or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
        raise SweepError(f"parameter '{path}': {name}(...) takes numbers; got {name}({body[:200]})")
    if any(isinstance(v, int) and v.bit_length() > 63 for v in vals):  # before float(): no OverflowError
        raise SweepError(f"parameter '{path}': {name}(...) takes numbers of magnitude at most 2**63 - 1; "
                         f"got an integer of {max(v.bit_length() for v in vals if isinstance(v, int))} bits")
    if len(vals) not in counts:
        want = " or ".join(str(c) for c in counts)
        raise SweepError(f"parameter '{path}': {name}(...) takes {want} numbers; got {len(vals)}: {name}({body})")
    if not all(math.isfinite(v) for v in vals):
        raise SweepError(f"parameter '{path}': {name}(...) needs finite numbers; got {name}({body})")
    return vals


def _check_count(path: str, name: str, body: str, n: float) -> None:
    if n > MAX_SWEEP_VALUES:
        raise SweepError(
            f"parameter '{path}': {name}({body}) gives {n:,.0f} values, more than the {MAX_SWEEP_VALUES:,} one "
            f"parameter may have (allowed: 1 to {MAX_SWEEP_VALUES:,}); use fewer points"
        )


def parse_values(path: str, spec: Any) -> list[Any]:
    """The list of grid values of a specification (string or already a list/value).

    Raises:
        SweepError: malformed specification or an empty range.
    """
    if isinstance(spec, list):
        values = [_plain(v) for v in spec]
    elif isinstance(spec, (int, float, bool)) and not isinstance(spec, str):
        values = [spec]
    elif isinstance(spec, str):
        _check_length(path, spec)
        m = _FUNC.match(spec)
        if m and m.group(1) in _GRID_FUNCS:
            name, body = m.group(1), m.group(2)
            if name == "range":
                r = _args(path, name, body, (1, 2, 3))
                if not all(float(v).is_integer() for v in r):
                    raise SweepError(f"parameter '{path}': range(...) takes integers; got range({body})")
                ints = [int(v) for v in r]
                if len(ints) == 3 and ints[2] == 0:
                    raise SweepError(f"parameter '{path}': range(...) step must not be 0; got range({body})")
                r = range(*ints)  # its length is known before the list is made (len() overflows past 2**63)
                _check_count(path, name, body, max(0, (r.stop - r.start + r.step - (1 if r.step > 0 else -1)) // r.step))
                values = list(range(*ints))
            else:
                lo, hi, n = _args(path, name, body, (3,))
                if not float(n).is_integer() or n < 1:
                    raise SweepError(
                        f"parameter '{path}': {name}(start, stop, num) needs a positive integer num; got {n!r}"
                    )
                _check_count(path, name, body, n)  # the count is known: refused before materialising
                if name == "geomspace" and (lo <= 0 or hi <= 0):
                    raise SweepError(f"parameter '{path}': geomspace(...) needs positive ends; got geomspace({body})")
                if name == "logspace":
                    spaced = np.logspace(lo, hi, int(n))
                elif name == "linspace":
                    spaced = np.linspace(lo, hi, int(n))
                else:
                    spaced = np.geomspace(lo, hi, int(n))
                values = [float(v) for v in spaced]
        elif m and m.group(1) in _RANDOM_FUNCS:
            raise SweepError(
                f"parameter '{path}': {m.group(1)}(...) is a distribution and needs design = 'random'; "
                f"for a grid give values (logspace, linspace, geomspace, range or a list)"
            )
        elif m and not spec.strip().startswith("["):
            raise SweepError(
                f"parameter '{path}': unknown function {m.group(1)!r}; expected one of "
                f"{', '.join(_GRID_FUNCS + _RANDOM_FUNCS)} or a list"
            )
        else:
            v = _literal(path, spec) if spec.strip().startswith("[") else None
            if isinstance(v, list):
                values = v
            else:
                values = [_literal(path, part) for part in _split_top(spec)]
    else:
        raise SweepError(f"parameter '{path}': expected a string or a list of values; got {spec!r}")
    if not values:
        raise SweepError(f"parameter '{path}': empty range {spec!r}; expected at least one value")
    return values


def _split_top(text: str) -> list[str]:
    """Split on commas outside brackets."""
    out, depth, cur = [], 0, ""
    for ch in text:
        if ch in "[(":
            depth += 1
        elif ch in "])":
            depth -= 1
        if ch == "," and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    out.append(cur)
    return out


@dataclass(frozen=True)
class SweepParameter:
    """One swept parameter.

    Attributes:
        path: dotted path in the scenario (``environment.stiffness``), with optional indices into
            a list value (``controller.force_gain[0]``).
        spec: the specification as written (for the table's metadata).
        values: grid values (grid design) or the choices of a list (random design).
        distribution: ``(name, args)`` of a random distribution, or None.
    """

    path: str
    spec: Any
    values: tuple[Any, ...] = ()
    distribution: tuple[str, tuple[float, ...]] | None = None

    @property
    def keys(self) -> list[str]:
        """The dotted keys without indices."""
        return _PATH.match(self.path).group(1).split(".")  # type: ignore[union-attr]

    @property
    def indices(self) -> list[int]:
        """Indices into the value (``[0]`` of ``force_gain[0]``)."""
        return [int(i) for i in re.findall(r"\[(\d+)\]", self.path)]

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """n random values (random design)."""
        if self.distribution is None:
            idx = rng.integers(0, len(self.values), n)
            return [copy.deepcopy(self.values[i]) for i in idx]
        name, a = self.distribution
        if name == "uniform":
            return [float(v) for v in rng.uniform(a[0], a[1], n)]
        if name == "loguniform":
            return [float(v) for v in np.exp(rng.uniform(math.log(a[0]), math.log(a[1]), n))]
        if name == "normal":
            return [float(v) for v in rng.normal(a[0], a[1], n)]
        return [int(v) for v in rng.integers(int(a[0]), int(a[1]), n)]  # randint

    def describe(self) -> dict[str, Any]:
        d: dict[str, Any] = {"path": self.path, "spec": _plain(self.spec)}
        if self.distribution is not None:
            d["distribution"] = [self.distribution[0], list(self.distribution[1])]
        else:
            d["values"] = _plain(list(self.values))
        return d


def parse_parameter(path: str, spec: Any, design: str = "grid") -> SweepParameter:
    """Read one ``path=spec`` into a :class:`SweepParameter` for the design.

    Raises:
        SweepError: malformed path or specification, empty range, a distribution in a grid.
    """
    path = str(path).strip()
    if not _PATH.match(path):
        raise SweepError(
            f"parameter path {path!r} is malformed; expected dotted keys with optional indices, "
            "e.g. 'environment.stiffness' or 'controller.force_gain[0]'"
        )
    if isinstance(spec, str):
        _check_length(path, spec)
    if design == "random" and isinstance(spec, str):
        m = _FUNC.match(spec)
        if m and m.group(1) in _RANDOM_FUNCS:
            name = m.group(1)
            a = _args(path, name, m.group(2), (2,))
            if name in ("uniform", "loguniform", "randint") and not a[0] < a[1]:
                raise SweepError(f"parameter '{path}': empty range {spec!r}; expected low < high")
            if name == "loguniform" and a[0] <= 0:
                raise SweepError(f"parameter '{path}': loguniform(...) needs a positive low end; got {spec!r}")
            if name == "normal" and a[1] < 0:
                raise SweepError(f"parameter '{path}': normal(mean, std) needs std >= 0; got {spec!r}")
            if name == "randint" and not all(float(v).is_integer() for v in a):
                raise SweepError(f"parameter '{path}': randint(...) takes integers; got {spec!r}")
            return SweepParameter(path, spec, (), (name, tuple(float(v) for v in a)))
    return SweepParameter(path, spec, tuple(parse_values(path, spec)), None)


@dataclass(frozen=True)
class SweepDefinition:
    """What to sweep: parameters, design, cases of the scenario and metric settings.

    Attributes:
        parameters: the swept parameters.
        design: ``"grid"`` (full factorial) or ``"random"`` (Monte Carlo).
        samples: number of random draws (random design).
        seed: seed of the random design's generator.
        cases: scenario case labels (or 1-based indices as strings) to sweep; empty = all.
        settle_band: settling band, fraction of the force step (default 2 %).
        stable_band: residual oscillation accepted as stable, fraction of the step (5 %).
    """

    parameters: tuple[SweepParameter, ...]
    design: str = "grid"
    samples: int = 0
    seed: int = 0
    cases: tuple[str, ...] = ()
    settle_band: float = 0.02
    stable_band: float = 0.05

    def __post_init__(self) -> None:
        if self.design not in DESIGNS:
            raise SweepError(f"design must be one of {list(DESIGNS)}; got {self.design!r}")
        if not self.parameters:
            raise SweepError("a sweep needs at least one parameter (path=values); got none")
        paths = [p.path for p in self.parameters]
        dup = sorted({p for p in paths if paths.count(p) > 1})
        if dup:
            raise SweepError(f"parameter '{dup[0]}' is given more than once")
        if self.design == "random":
            if not isinstance(self.samples, int) or isinstance(self.samples, bool) or not 1 <= self.samples <= MAX_SWEEP_VALUES:
                shown = repr(self.samples) if not isinstance(self.samples, int) or self.samples.bit_length() <= 64 else \
                    f"an integer of {self.samples.bit_length()} bits"
                raise SweepError(f"samples must be an integer in [1, {MAX_SWEEP_VALUES:,}] for design = 'random'; got {shown}")
        elif self.samples:
            raise SweepError(f"samples is only used by design = 'random'; got samples = {self.samples!r} with a grid")
        else:  # a grid is the product of its parameters' values: bounded as a random design's samples are
            sizes = [len(p.values) for p in self.parameters]
            if math.prod(sizes) > MAX_SWEEP_VALUES:
                raise SweepError(
                    f"the grid has {' x '.join(f'{n:,}' for n in sizes)} = {math.prod(sizes):,} variations, more than the "
                    f"{MAX_SWEEP_VALUES:,} a sweep may have; use fewer points, or design = 'random' with samples"
                )
        for name in ("settle_band", "stable_band"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0.0 < v < 1.0):
                raise SweepError(f"{name} must be a fraction in (0, 1); got {v!r}")

    @classmethod
    def from_options(
        cls,
        params: dict[str, Any] | list[str],
        *,
        design: str = "grid",
        samples: int = 0,
        seed: int = 0,
        cases: list[str] | tuple[str, ...] = (),
        settle_band: float = 0.02,
        stable_band: float = 0.05,
    ) -> SweepDefinition:
        """Build from ``{path: spec}`` or a list of ``"path=spec"`` strings (the CLI's ``--param``)."""
        if design not in DESIGNS:
            raise SweepError(f"design must be one of {list(DESIGNS)}; got {design!r}")
        items: list[tuple[str, Any]] = []
        if isinstance(params, dict):
            items = list(params.items())
        else:
            for text in params:
                if "=" not in text:
                    raise SweepError(f"--param {text!r} must read PATH=VALUES, e.g. environment.stiffness=logspace(3,6,40)")
                k, v = text.split("=", 1)
                items.append((k.strip(), v.strip()))
        parsed = tuple(parse_parameter(k, v, design) for k, v in items)
        return cls(parsed, design, int(samples), int(seed), tuple(str(c) for c in cases),
                   float(settle_band), float(stable_band))

    @classmethod
    def from_table(cls, table: Any, where: str = "[sweep]") -> SweepDefinition:
        """Build from a scenario file's ``[sweep]`` table.

        Keys: ``design``, ``samples``, ``seed``, ``cases``, ``settle_band``, ``stable_band`` and
        ``[sweep.parameters]`` (``"environment.stiffness" = "logspace(3, 6, 40)"``).
        """
        from ..scenarios.model import SWEEP_FIELDS
        from ..scenarios.schema import check_table

        try:  # the keys' types by the [sweep] table's pydantic model
            checked = check_table(where, table, SWEEP_FIELDS, extra_ok=("cases", "parameters"))
        except ScenarioError as exc:
            raise SweepError(str(exc)) from None
        params = table.get("parameters")
        if not isinstance(params, dict) or not params:
            raise SweepError(f"{where}: key 'parameters' must be a non-empty table of path = values; got {params!r}")
        flat: dict[str, Any] = {}
        _flatten_params("", params, flat)
        cases = table.get("cases", [])
        if isinstance(cases, str):
            cases = [cases]
        return cls.from_options(
            flat, design=checked["design"], samples=checked["samples"], seed=checked["seed"],
            cases=[str(c) for c in cases], settle_band=checked["settle_band"], stable_band=checked["stable_band"],
        )

    def assignments(self, n_cases: int = 1) -> list[dict[str, Any]]:
        """The parameter assignments of the design, in order (one dict per variation)."""
        if self.design == "grid":
            return [
                {p.path: copy.deepcopy(v) for p, v in zip(self.parameters, combo)}
                for combo in itertools.product(*(p.values for p in self.parameters))
            ]
        rng = np.random.default_rng(self.seed)
        draws = [p.draw(rng, self.samples) for p in self.parameters]
        return [{p.path: draws[j][i] for j, p in enumerate(self.parameters)} for i in range(self.samples)]

    def describe(self) -> dict[str, Any]:
        """Plain-JSON description (stored in the table's metadata)."""
        return {
            "design": self.design,
            "samples": self.samples,
            "seed": self.seed,
            "cases": list(self.cases),
            "parameters": [p.describe() for p in self.parameters],
            "settle_band": self.settle_band,
            "stable_band": self.stable_band,
        }


def _flatten_params(prefix: str, d: dict[str, Any], out: dict[str, Any]) -> None:
    """TOML turns ``environment.stiffness = ...`` (bare dotted keys) into nested tables; undo that."""
    for k, v in d.items():
        if isinstance(v, dict):
            _flatten_params(f"{prefix}{k}.", v, out)
        else:
            out[prefix + k] = v


def definition_hash(payload: dict[str, Any]) -> str:
    """A short stable hash of a JSON-serialisable payload."""
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()[:16]
