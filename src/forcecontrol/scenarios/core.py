"""Loading, validating and running scenarios."""

from __future__ import annotations

import copy
import sys
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .._json import json_safe
from ..actuators import Actuator
from ..errors import ForceControlError, ScenarioError
from ..robots import PlanarTwoLink, PlanarTwoLinkParameters
from ..sensors import ForceSensor
from ..simulation import SimulationResult, simulate
from .schema import CONTROLLERS, ENVIRONMENTS, REFERENCES, Field, check_table, check_value

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "Scenario",
    "CaseSpec",
    "CaseResult",
    "ScenarioRun",
    "load_scenario",
    "list_scenarios",
    "scenario_source",
    "run_scenario",
    "register_metric",
    "register_analysis",
    "case_analysis",
    "check_expected",
    "METRICS",
]

TOP_FIELDS: dict[str, Field] = {
    "name": Field("str", True, doc="scenario name"),
    "title": Field("str", default="", doc="one-line title"),
    "description": Field("str", default="", doc="what the scenario shows"),
    "duration": Field("number", True, doc="simulated time [s]"),
    "sample_time": Field("number", default=1e-3, doc="control period Ts [s]"),
    "substeps": Field("int", doc="RK4 steps per sample (automatic by default)"),
    "settle_window": Field("number", default=0.1, doc="window for settled values [s]"),
    "tolerance": Field("number", default=0.005, doc="relative tolerance against expected values"),
    "allow_contact_loss": Field(
        "bool", default=False,
        doc="the case may lose contact after touching (bounces): reported, not an error (else --check fails)",
    ),
    "robot": Field("table", True),
    "environment": Field("table", True),
    "controller": Field("table", True),
    "reference": Field("table", True),
    "sensor": Field("table", default=None),
    "actuator": Field("table", default=None),
    "figure": Field("table", default=None),  # a table or an array of tables, checked below
    "expected": Field("table", default=None),
    "case": Field("table", default=None),  # checked separately (array of tables)
}

ROBOT_FIELDS: dict[str, Field] = {
    "model": Field("str", default="chapter-arm", choices=("chapter-arm", "planar-2r", "panda", "ur5", "urdf")),
    "urdf": Field("str", doc="model = 'urdf': path of the URDF file"),
    "frame": Field("str", doc="panda/ur5/urdf: the controlled frame (default panda_hand_tcp / tool0)"),
    "locked_joints": Field("strlist", doc="model = 'urdf': joints fixed at zero"),
    "q0": Field("vector", doc="initial joint positions [rad]"),
    "start_position": Field("vector", doc="initial tip position [m] (IK with elbow)"),
    "elbow": Field("str", default="up", choices=("up", "down")),
    "qd0": Field("vector", doc="initial joint velocities [rad/s]"),
    "parameters": Field("table", doc="planar-2r: overrides of PlanarTwoLinkParameters"),
}

SENSOR_FIELDS: dict[str, Field] = {
    "noise_std": Field("gain", default=0.0, doc="noise standard deviation [N]"),
    "bias": Field("gain", default=0.0, doc="constant bias [N]"),
    "cutoff": Field("number", doc="first-order low-pass cut-off [Hz]"),
    "seed": Field("int", default=0),
    # realistic sensor (RealisticForceSensor, Python loop) when any of these is given
    "filter": Field("str", choices=("none", "first-order", "butterworth"), doc="digital filter kind"),
    "drift": Field("gain", doc="bias drift rate in the sensor frame [N/s]"),
    "resolution": Field("number", doc="quantisation step [N]"),
    "delay_samples": Field("int", doc="transport delay [samples]"),
    "zeroing_samples": Field("int", doc="readings averaged at start to estimate the bias"),
    "tool_mass": Field("number", doc="mass of the tool after the sensor [kg] (compensated: known tool)"),
}
_RICH_SENSOR_KEYS = ("filter", "drift", "resolution", "delay_samples", "zeroing_samples", "tool_mass")

#: ``[actuator]``: joint friction, actuation delay and torque quantisation (:class:`~forcecontrol.actuators.Actuator`,
#: Python engine). Per-joint keys take a number (every joint) or a list with one entry per joint.
ACTUATOR_FIELDS: dict[str, Field] = {
    "coulomb": Field("gain", default=0.0, doc="Coulomb friction torque per joint [N m] (smooth sign tanh(qd / coulomb_band))"),
    "viscous": Field("gain", default=0.0, doc="viscous friction per joint, added to the robot's own [N m s/rad]"),
    "coulomb_band": Field("gain", default=1e-2, doc="velocity scale of the smooth Coulomb sign per joint [rad/s], > 0"),
    "delay_samples": Field("int", default=0, doc="actuation delay [whole samples]: the torque commanded k samples ago"),
    "resolution": Field("gain", default=0.0, doc="torque quantum per joint [N m] (0: none)"),
}

FIGURE_FIELDS: dict[str, Field] = {
    "name": Field("str", default="", doc="suffix of the figure's file name (several figures)"),
    "cases": Field("strlist", doc="labels of the cases drawn (all by default)"),
    "title": Field("str", default=""),
    "signals": Field("strlist", default=["x", "fx"], doc="columns to plot against time"),
    "t_max": Field("number", doc="time axis limit [s]"),
    "zoom": Field("number", doc="inset on each force panel with the first `zoom` seconds, one dot per sample [s]"),
    "note": Field("str", default="", doc="caption printed under the figure (what the reader needs to read it)"),
}

CASE_FIELDS = ("label", "expected")


@dataclass(frozen=True)
class CaseSpec:
    """One case of a scenario: its label, full configuration and expected values."""

    label: str
    config: dict[str, Any]
    expected: dict[str, Any]
    #: the dotted keys the case's own ``[[case]]`` table sets (what its label usually describes).
    overrides: tuple[str, ...] = ()


@dataclass(frozen=True)
class Scenario:
    """A validated scenario: one or more cases, drawn in one or more figures."""

    name: str
    title: str
    description: str
    source: str
    cases: tuple[CaseSpec, ...]
    figure: dict[str, Any] | None
    figures: tuple[dict[str, Any], ...] = ()
    raw: dict[str, Any] = field(repr=False, default_factory=dict)

    def run(self, *, engine: str = "auto") -> ScenarioRun:
        """Simulate every case (:func:`run_scenario`)."""
        return run_scenario(self, engine=engine)

    def with_(self, changes: dict[str, Any] | None = None, **kwargs: Any) -> Scenario:
        """A copy with some keys changed in every case, validated like a file.

        Keys are dotted paths of the scenario's tables, e.g.
        ``scn.with_({"controller.stiffness": [3000, 3000], "duration": 2.0})``; keyword
        arguments set top-level keys (``scn.with_(duration=2.0)``).

        Raises:
            ScenarioError: a changed value is invalid for a case (named, with the key).
        """
        flat = {**(changes or {}), **kwargs}
        cases = []
        for i, c in enumerate(self.cases):
            cfg = copy.deepcopy(c.config)
            where = f"{self.source} (edited): [[case]] #{i + 1}"
            for k, v in flat.items():
                _set_dotted(where, cfg, k, copy.deepcopy(v))
            spec = CaseSpec(c.label, cfg, dict(c.expected), c.overrides)
            build_case(spec, where=where)
            cases.append(spec)
        return replace(self, cases=tuple(cases))


@dataclass
class CaseResult:
    """A simulated case with its settled metrics, analysis and comparisons."""

    label: str
    result: SimulationResult
    metrics: dict[str, float]
    analysis: dict[str, Any]
    checks: list[dict[str, Any]]


@dataclass
class ScenarioRun:
    """The results of all cases of a scenario."""

    scenario: Scenario
    cases: list[CaseResult]
    files: dict[str, str] = field(default_factory=dict)

    @property
    def all_checks_pass(self) -> bool:
        """True when every expected value is met within tolerance."""
        return all(c["ok"] for case in self.cases for c in case.checks)

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` contract: scenario, cases (label, final, peak_contact_force_norm, ...).

        Standard JSON only: a NaN or infinite number is written as null, and ``notes`` lists
        where (e.g. a metric of a case that did not settle).
        """
        notes: list[str] = []
        out = json_safe(self._json_body(), notes)
        if notes:
            out["notes"] = ["non-finite values written as null: " + ", ".join(notes)]
        return out

    def _json_body(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario.name,
            "title": self.scenario.title,
            "source": self.scenario.source,
            "cases": [
                {
                    "label": c.label,
                    "final": c.result.final(),
                    "peak_contact_force_norm": c.result.peak_contact_force_norm(),
                    "settled": c.metrics,
                    "analysis": c.analysis,
                    "checks": c.checks,
                    "engine": c.result.metadata.get("engine"),
                }
                for c in self.cases
            ],
            "all_checks_pass": self.all_checks_pass,
            "files": self.files,
        }


# ----------------------------------------------------------------------------- metrics & analysis

#: name -> fn(result, parts, window) giving a settled value; parts has robot, environment,...
METRICS: dict[str, Callable[[SimulationResult, dict[str, Any], float], float]] = {}
#: list of (predicate(parts), fn(parts) -> dict) giving analytic predictions for a case.
_ANALYSES: list[tuple[Callable[[dict[str, Any]], bool], Callable[[dict[str, Any]], dict[str, Any]]]] = []


def register_metric(name: str, fn: Callable[[SimulationResult, dict[str, Any], float], float]) -> None:
    """Add a settled metric usable in ``expected`` tables."""
    METRICS[name] = fn


def register_analysis(applies: Callable[[dict[str, Any]], bool], fn: Callable[[dict[str, Any]], dict[str, Any]]) -> None:
    """Add an analytic prediction shown beside the simulation (and usable in ``expected``)."""
    _ANALYSES.append((applies, fn))


def case_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Every registered analytic prediction that applies to a built case (see :func:`build_case`)."""
    out: dict[str, Any] = {}
    for applies, fn in _ANALYSES:
        if applies(parts):
            out.update(fn(parts))
    return out


def check_expected(name: str, value: float, spec: Any, rel_tol: float) -> dict[str, Any]:
    """Compare a value with an expected ``spec`` (a number, or ``{value, tol}``).

    Returns:
        ``{"metric", "value", "expected", "tolerance", "relative_error", "ok"}``; the tolerance
        is ``tol`` when given, else ``rel_tol · |expected|``.
    """
    return _check(name, value, spec, rel_tol)


def _column_metric(col: str):
    def fn(res: SimulationResult, parts: dict[str, Any], window: float) -> float:
        cols = res.columns()
        sel = res.t >= res.t[-1] - window - 1e-12
        if col not in cols:
            raise ScenarioError(f"metric {col!r} is not logged for a {res.m}-dimensional task space")
        return float(np.mean(cols[col][sel]))

    return fn


for _c in ("x", "y", "z", "rx", "ry", "rz", "vx", "vy", "vz", "fx", "fy", "fz", "mx", "my", "mz"):
    register_metric(_c, _column_metric(_c))


def _penetration(res: SimulationResult, parts: dict[str, Any], window: float) -> float:
    env = parts["environment"]
    if not hasattr(env, "penetration"):
        raise ScenarioError("metric 'penetration' needs an elastic plane")
    sel = res.t >= res.t[-1] - window - 1e-12
    return float(np.mean([env.penetration(x) for x in res.x[sel]]))


register_metric("penetration", _penetration)
register_metric("contact_force_norm", lambda r, p, w: float(np.linalg.norm(r.settled("wrench", w))))
register_metric("peak_contact_force_norm", lambda r, p, w: r.peak_contact_force_norm())

# ----------------------------------------------------------------------------- loading


def _builtin_dir() -> Path:
    return Path(str(resources.files("forcecontrol.scenarios")))


def list_scenarios() -> dict[str, str]:
    """Built-in scenarios: name -> title."""
    out = {}
    for p in sorted(_builtin_dir().glob("*.toml")):
        with p.open("rb") as f:
            data = tomllib.load(f)
        out[data.get("name", p.stem)] = data.get("title", "")
    return out


def scenario_source(name_or_path: str | Path) -> Path:
    """The TOML file of a built-in scenario name or a path."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        if not p.exists():
            raise ScenarioError(f"scenario file {str(p)!r} does not exist")
        return p
    builtin = _builtin_dir() / f"{name_or_path}.toml"
    if builtin.exists():
        return builtin
    names = ", ".join(list_scenarios())
    raise ScenarioError(f"unknown scenario {str(name_or_path)!r}; expected a built-in name ({names}) or a .toml file")


def _set_dotted(where: str, cfg: dict[str, Any], key: str, value: Any) -> None:
    parts = key.split(".")
    node = cfg
    for p in parts[:-1]:
        if p not in node or not isinstance(node[p], dict):
            raise ScenarioError(f"{where}: override '{key}' names no table '{p}'")
        node = node[p]
    node[parts[-1]] = value


def _flatten(prefix: str, d: dict[str, Any], out: dict[str, Any]) -> None:
    for k, v in d.items():
        if isinstance(v, dict) and k not in ("expected",):
            _flatten(f"{prefix}{k}.", v, out)
        else:
            out[prefix + k] = v


#: deepest nesting of tables and arrays a scenario may have (a gain matrix needs 2).
MAX_NESTING = 16


def _depth(v: Any, limit: int) -> int:
    """Nesting depth of dicts and lists, counting no further than ``limit + 1`` (no recursion)."""
    deepest, stack = 0, [(v, 0)]
    while stack:
        x, d = stack.pop()
        if d > limit:
            return d
        deepest = max(deepest, d)
        if isinstance(x, dict):
            stack.extend((y, d + 1) for y in x.values())
        elif isinstance(x, list):
            stack.extend((y, d + 1) for y in x)
    return deepest


def _read_toml(path: Path, where: str) -> dict[str, Any]:
    """The TOML table of a scenario file: UTF-8 required, nesting bounded, every failure a ScenarioError."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{where}: cannot be read: {exc.strerror or exc}") from exc
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        hint = " (it looks like UTF-16)" if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else ""
        raise ScenarioError(
            f"{where}: not UTF-8 text{hint}: byte {exc.start} is {raw[exc.start:exc.start + 1]!r}; "
            "scenario files must be saved as UTF-8"
        ) from exc
    if text.startswith("\ufeff"):  # a UTF-8 byte-order mark is harmless
        text = text[1:]
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{where}: not valid TOML: {exc}") from exc
    except RecursionError as exc:
        raise ScenarioError(f"{where}: arrays or tables nested too deeply (at most {MAX_NESTING} levels)") from exc
    if _depth(data, MAX_NESTING) > MAX_NESTING:
        raise ScenarioError(f"{where}: arrays or tables nested too deeply (at most {MAX_NESTING} levels)")
    return data


def _allow_contact_loss(where: str, v: Any) -> bool:
    if not isinstance(v, bool):
        raise ScenarioError(f"{where}: key 'allow_contact_loss' must be true or false; got {v!r}")
    return v


def contact_losses(wrench: np.ndarray) -> int:
    """How many times the contact is lost after the first touch: a sample with h_e ≠ 0 followed by h_e = 0."""
    on = np.any(np.asarray(wrench) != 0.0, axis=1)
    touched = np.cumsum(on) > 0
    return int(np.sum(on[:-1] & ~on[1:] & touched[:-1]))


def load_scenario(source: str | Path | dict[str, Any]) -> Scenario:
    """Load and validate a scenario from a built-in name, a TOML path or a dict.

    Every case is fully checked (keys, types, and by building its parts) before anything runs.

    Raises:
        ScenarioError: with the file, the key, what was expected and what was given.
    """
    if isinstance(source, dict):
        data, where = copy.deepcopy(source), "<dict>"
    else:
        path = scenario_source(source)
        where = str(path)
        data = _read_toml(path, where)
        _resolve_reference_files(data, path.parent)
    cases_raw = data.pop("case", None)
    figures_raw = data.pop("figure", None)
    top = check_table(where, data, TOP_FIELDS)
    single = cases_raw is None
    if single:
        cases_raw = [{}]
    if not isinstance(cases_raw, list) or not cases_raw:
        raise ScenarioError(f"{where}: key 'case' must be a non-empty array of tables ([[case]]); got {cases_raw!r}")
    base = {k: copy.deepcopy(v) for k, v in data.items() if k not in ("name", "title", "description", "figure")}
    cases = []
    for i, c in enumerate(cases_raw):
        cw = where if single else f"{where}: [[case]] #{i + 1}"
        if not isinstance(c, dict):
            raise ScenarioError(f"{cw}: must be a table; got {c!r}")
        cfg = copy.deepcopy(base)
        label = c.get("label", f"case {i + 1}")
        if not isinstance(label, str):
            raise ScenarioError(f"{cw}: key 'label' must be a string; got {label!r}")
        flat: dict[str, Any] = {}
        _flatten("", {k: v for k, v in c.items() if k not in CASE_FIELDS}, flat)
        for k, v in flat.items():
            _set_dotted(cw, cfg, k, v)
        expected = dict(top["expected"] or {})
        case_expected = c.get("expected", {}) or {}
        if not isinstance(case_expected, dict):
            raise ScenarioError(f"{cw}: key 'expected' must be a table of metric = value; got {case_expected!r}")
        expected.update(case_expected)
        spec = CaseSpec(label, cfg, expected, tuple(flat))
        built = build_case(spec, where=cw)  # validate now, before anything runs
        if not cases:
            signals = _signal_names(int(built["robot"].nq), int(built["robot"].task_dim))
        # a controller may log signals of its own (``SIGNALS``, e.g. a tank's energy): plottable too
        signals = list(dict.fromkeys([*signals, *getattr(built["controller"], "SIGNALS", ())]))
        cases.append(spec)
    if not single:
        _check_shadowed(where, base, cases)
    figures = _check_figures(where, figures_raw, [c.label for c in cases], signals)
    return Scenario(
        name=top["name"], title=top["title"], description=top["description"], source=where,
        cases=tuple(cases), figure=figures[0] if figures else None, figures=tuple(figures), raw=data,
    )


def _resolve_reference_files(data: dict[str, Any], folder: Path) -> None:
    """A relative ``[reference] file`` (and a case's ``reference.file``) is relative to the scenario file's folder."""

    def fix(value: Any) -> Any:
        if isinstance(value, str) and value and not Path(value).is_absolute():
            return str(folder / value)
        return value

    ref = data.get("reference")
    if isinstance(ref, dict) and "file" in ref:
        ref["file"] = fix(ref["file"])
    cases = data.get("case")
    for case in cases if isinstance(cases, list) else []:  # a malformed [[case]] is reported by the loader
        if not isinstance(case, dict):
            continue
        if isinstance(case.get("reference"), dict) and "file" in case["reference"]:
            case["reference"]["file"] = fix(case["reference"]["file"])
        if "reference.file" in case:
            case["reference.file"] = fix(case["reference.file"])


def _get_dotted(cfg: dict[str, Any], key: str) -> Any:
    node: Any = cfg
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            return _UNSET
        node = node[part]
    return node


_UNSET = object()


def _check_shadowed(where: str, base: dict[str, Any], cases: list[CaseSpec]) -> None:
    """Top-level values that every case overrides are still checked: each is put back into the
    first case and the case is built with it (a wrong value there would otherwise never be seen)."""
    common = set(cases[0].overrides)
    for c in cases[1:]:
        common &= set(c.overrides)
    for key in sorted(common):
        value = _get_dotted(base, key)
        if value is _UNSET or value == _get_dotted(cases[0].config, key):
            continue
        cfg = copy.deepcopy(cases[0].config)
        _set_dotted(where, cfg, key, copy.deepcopy(value))
        try:
            build_case(CaseSpec(cases[0].label, cfg, {}), where=f"{where}: top-level '{key}' (every [[case]] overrides it)")
        except ScenarioError:
            raise
        except ForceControlError as exc:  # pragma: no cover - build_case wraps its errors
            raise ScenarioError(f"{where}: top-level '{key}': {exc}") from exc


def _signal_names(n: int, m: int) -> list[str]:
    """The plottable columns of a run with n joints in an m-dimensional task space (``SimulationResult.columns``)."""
    from .._axes import axis_names as _axis_names

    pose, twist, wrench = _axis_names(m)
    out = ["t"] + [f"{s}{i + 1}" for i in range(n) for s in ("q", "qd", "u")] + pose + twist + wrench
    return out + [f"{w}_measured" for w in wrench]


def _check_figures(where: str, raw: Any, labels: list[str], signals: list[str] | None = None) -> list[dict[str, Any]]:
    """``[figure]`` (one) or ``[[figure]]`` (several), each checked; case filters must name cases,
    signals must be columns the robot's runs have (before anything is simulated)."""
    if raw is None:
        return []
    items = raw if isinstance(raw, list) else [raw]
    out = []
    for i, item in enumerate(items):
        fw = f"{where}: [figure]" if not isinstance(raw, list) else f"{where}: [[figure]] #{i + 1}"
        fig = check_table(fw, item, FIGURE_FIELDS)
        for lab in fig["cases"] or []:
            if lab not in labels:
                raise ScenarioError(f"{fw}: key 'cases' names no case {lab!r}; expected labels among {labels}")
        for sig in fig["signals"] or []:
            if signals is not None and sig not in signals and not sig.startswith("ref_"):
                raise ScenarioError(f"{fw}: key 'signals' names no signal {sig!r} of this robot; expected one of {signals}")
        for key in ("t_max", "zoom"):
            if fig.get(key) is not None and not fig[key] > 0:
                raise ScenarioError(f"{fw}: key {key!r} must be a positive time [s]; got {fig[key]!r}")
        if isinstance(raw, list) and len(items) > 1 and not fig["name"]:
            raise ScenarioError(f"{fw}: missing key 'name' (several figures need distinct file names)")
        out.append(fig)
    names = [f["name"] for f in out]
    if len(set(names)) != len(names):
        raise ScenarioError(f"{where}: [[figure]] names must be distinct; got {names}")
    return out


def _part(where: str, table_name: str, table: Any, registry, ctx: dict[str, Any]):
    tw = f"{where}: [{table_name}]"
    if not isinstance(table, dict):
        raise ScenarioError(f"{tw}: must be a table; got {table!r}")
    kind = table.get("type")
    if not isinstance(kind, str) or kind not in registry:  # a list or table is not hashable: no TypeError
        raise ScenarioError(f"{tw}: key 'type' must be one of {', '.join(sorted(registry))}; got {kind!r}")
    spec = registry[kind]
    params = check_table(f"{tw} (type '{kind}')", table, spec.fields, extra_ok=("type",))
    try:
        return spec.build(params, ctx)
    except ScenarioError:
        raise
    except ForceControlError as exc:
        raise ScenarioError(f"{tw} (type '{kind}'): {exc}") from exc


def build_case(case: CaseSpec, where: str = "<scenario>") -> dict[str, Any]:
    """Build a case's parts: robot, environment, controller, reference, sensor, q0, settings."""
    cfg = case.config
    unknown = sorted(k for k in cfg if k not in TOP_FIELDS or k in ("name", "title", "description", "figure", "case"))
    if unknown:  # e.g. a misspelt top-level key in a [[case]] table, which nothing else would read
        allowed = sorted(k for k in TOP_FIELDS if k not in ("name", "title", "description", "figure", "case"))
        raise ScenarioError(f"{where}: unknown key '{unknown[0]}'; expected one of: {', '.join(allowed)}")
    for key in ("robot", "environment", "controller", "reference"):
        if key not in cfg:
            raise ScenarioError(f"{where}: missing table [{key}]")
    for key, low, what in (("substeps", 1, "a positive integer"), ("settle_window", 0.0, "a positive time [s]"),
                           ("tolerance", 0.0, "a non-negative number")):
        if cfg.get(key) is not None:
            v = check_value(where, key, TOP_FIELDS[key], cfg[key])
            if v < low or (key == "settle_window" and v == 0.0):
                raise ScenarioError(f"{where}: key '{key}' must be {what}; got {v!r}")
    _check_expected_specs(where, case.expected)
    rt = check_table(f"{where}: [robot]", cfg["robot"], ROBOT_FIELDS)
    if rt["model"] in ("panda", "ur5", "urdf"):
        from .parts_spatial import pinocchio_robot  # the 6-D robots (optional extra 'pinocchio')

        robot = pinocchio_robot(where, rt)
    else:
        try:
            if rt["model"] == "chapter-arm" and rt["parameters"]:
                raise ScenarioError(f"{where}: [robot]: key 'parameters' needs model = 'planar-2r'")
            params = PlanarTwoLinkParameters(**(rt["parameters"] or {}))
            robot = PlanarTwoLink(params)
        except TypeError as exc:
            raise ScenarioError(f"{where}: [robot.parameters]: {exc}") from exc
        except ForceControlError as exc:
            raise ScenarioError(f"{where}: [robot.parameters]: {exc}") from exc
    try:
        if rt["q0"] is not None and rt["start_position"] is not None:
            raise ScenarioError(f"{where}: [robot]: give q0 or start_position, not both")
        if rt["q0"] is not None:
            q0 = np.array(rt["q0"], dtype=float)
            if q0.shape != (robot.nq,):
                raise ScenarioError(f"{where}: [robot]: key 'q0' must have {robot.nq} entries; got {len(q0)}")
            if not np.all(np.isfinite(q0)):
                raise ScenarioError(f"{where}: [robot]: key 'q0' must be finite [rad]; got {rt['q0']!r}")
        elif rt["start_position"] is not None:
            if not hasattr(robot, "inverse_kinematics"):
                raise ScenarioError(f"{where}: [robot]: model '{rt['model']}' needs q0 (no closed-form inverse kinematics)")
            q0 = robot.inverse_kinematics(rt["start_position"], elbow=rt["elbow"])
        else:
            raise ScenarioError(f"{where}: [robot]: missing key 'q0' or 'start_position'")
        if rt["qd0"] is not None:
            qd0 = np.array(rt["qd0"], dtype=float)
            if qd0.shape != (robot.nq,) or not np.all(np.isfinite(qd0)):
                raise ScenarioError(
                    f"{where}: [robot]: key 'qd0' must be {robot.nq} finite joint velocities [rad/s]; got {rt['qd0']!r}"
                )
    except ScenarioError:
        raise
    except ForceControlError as exc:
        raise ScenarioError(f"{where}: [robot]: {exc}") from exc
    Ts = check_value(where, "sample_time", TOP_FIELDS["sample_time"], cfg.get("sample_time", 1e-3))
    if Ts <= 0:
        raise ScenarioError(f"{where}: key 'sample_time' must be a positive number [s]; got {Ts!r}")
    duration = check_value(where, "duration", TOP_FIELDS["duration"], cfg["duration"])
    if duration <= 0:
        raise ScenarioError(f"{where}: key 'duration' must be a positive number [s]; got {duration!r}")
    ctx: dict[str, Any] = {"robot": robot, "sample_time": Ts, "q0": q0}
    env = _part(where, "environment", cfg["environment"], ENVIRONMENTS, ctx)
    ctx["environment"] = env
    ctl = _part(where, "controller", cfg["controller"], CONTROLLERS, ctx)
    ref = _part(where, "reference", cfg["reference"], REFERENCES, ctx)
    st = check_table(f"{where}: [sensor]", cfg.get("sensor") or {}, SENSOR_FIELDS)
    sensor: ForceSensor
    try:
        if any(st[k] is not None for k in _RICH_SENSOR_KEYS):
            from ..sensors import RealisticForceSensor, ToolGravity

            tool = None if st["tool_mass"] is None else ToolGravity(st["tool_mass"])
            sensor = RealisticForceSensor(
                st["noise_std"], st["bias"], st["cutoff"], st["seed"], filter=st["filter"],
                drift=0.0 if st["drift"] is None else st["drift"], resolution=st["resolution"] or 0.0,
                delay_samples=st["delay_samples"] or 0, zeroing_samples=st["zeroing_samples"] or 0,
                tool=tool, tool_estimate=tool,
            )
            sensor.filter_coefficients(Ts)
        else:
            sensor = ForceSensor(st["noise_std"], st["bias"], st["cutoff"], st["seed"])
        sensor.alpha(Ts)
    except ForceControlError as exc:
        raise ScenarioError(f"{where}: [sensor]: {exc}") from exc
    actuator = _actuator(where, cfg.get("actuator"), robot.nq)
    for name, part in (("environment", env), ("reference", ref)):
        if part.dim != robot.task_dim:
            raise ScenarioError(
                f"{where}: [{name}] must be {robot.task_dim}-dimensional like the robot's task space; got {part.dim}"
            )
    for key in case.expected:
        if key not in METRICS and not key.startswith("analysis."):
            raise ScenarioError(
                f"{where}: [expected]: unknown metric '{key}'; expected one of {', '.join(sorted(METRICS))} "
                "or 'analysis.<name>'"
            )
    substeps = cfg.get("substeps")
    return {
        "robot": robot, "environment": env, "controller": ctl, "reference": ref, "sensor": sensor, "actuator": actuator,
        "q0": q0, "qd0": rt["qd0"], "duration": duration, "substeps": substeps,
        "settle_window": cfg.get("settle_window", 0.1), "tolerance": cfg.get("tolerance", 0.005),
        "allow_contact_loss": _allow_contact_loss(where, cfg.get("allow_contact_loss", False)),
    }


def _actuator(where: str, table: Any, n: int) -> Actuator | None:
    """The ``[actuator]`` table as an :class:`~forcecontrol.actuators.Actuator` (None without the table).

    Raises:
        ScenarioError: an unknown key, a value of the wrong type, a negative friction, delay or
            quantum, or a per-joint list without one entry per joint (the message names the key).
    """
    if table is None:
        return None
    at = check_table(f"{where}: [actuator]", table, ACTUATOR_FIELDS)
    if at["delay_samples"] < 0:
        raise ScenarioError(f"{where}: [actuator]: key 'delay_samples' must be a whole number of samples >= 0; "
                            f"got {at['delay_samples']!r}")
    values = {}
    for key in ("coulomb", "viscous", "coulomb_band", "resolution"):
        v = np.asarray(at[key], dtype=float)
        if v.ndim > 1 or (v.ndim == 1 and v.size not in (1, n)):
            raise ScenarioError(f"{where}: [actuator]: key '{key}' must be a number or a list of {n} numbers "
                                f"(one per joint); got {at[key]!r}")
        values[key] = v
    try:
        act = Actuator(values["coulomb"], values["viscous"], values["coulomb_band"], at["delay_samples"], values["resolution"])
        act.check(n)
    except ForceControlError as exc:
        raise ScenarioError(f"{where}: [actuator]: {exc}") from exc
    return act


def _check_expected_specs(where: str, expected: Any) -> None:
    """Each expected value is a finite number or a table ``{value, tol}`` (finite, tol >= 0), checked before running."""
    if not isinstance(expected, dict):
        raise ScenarioError(f"{where}: [expected] must be a table of metric = value; got {expected!r}")
    for key, spec in expected.items():
        if isinstance(spec, dict):
            extra = sorted(set(spec) - {"value", "tol"})
            if extra or "value" not in spec:
                raise ScenarioError(
                    f"{where}: [expected] key '{key}' must be a number or a table {{value, tol}}; "
                    f"got {spec!r} ({'unknown key ' + repr(extra[0]) if extra else 'no value'})"
                )
            items = [("value", spec["value"])] + ([("tol", spec["tol"])] if "tol" in spec else [])
        else:
            items = [("value", spec)]
        for part, v in items:
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) < 1e308 and (part == "value" or v >= 0)
            if not ok:
                what = "a finite number" if part == "value" else "a finite non-negative number"
                raise ScenarioError(f"{where}: [expected] key '{key}': {part} must be {what}; got {v!r}")


def _check(name: str, value: float, spec: Any, rel_tol: float) -> dict[str, Any]:
    if isinstance(spec, dict):
        want, tol = float(spec["value"]), float(spec.get("tol", rel_tol * abs(float(spec["value"]))))
    else:
        want, tol = float(spec), rel_tol * abs(float(spec))
    tol = max(tol, 1e-12)
    err = value - want
    return {
        "metric": name, "value": value, "expected": want, "tolerance": tol,
        "relative_error": err / want if want else err, "ok": bool(abs(err) <= tol),
    }


def run_scenario(
    scenario: Scenario | str | Path,
    *,
    engine: str = "auto",
    progress: Callable[[int, int, str], None] | None = None,
) -> ScenarioRun:
    """Simulate every case of a scenario and compare with its expected values.

    Args:
        scenario: a loaded scenario, a built-in name or a TOML path.
        engine: simulator engine (``"auto"``, ``"python"``, ``"compiled"``), or ``"mujoco"``: MuJoCo as
            the plant (optional extra; elastic planes and tables; exact force sensor).
        progress: called as ``progress(done, total, label)`` after each case.
    """
    scn = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    out = []
    for i, case in enumerate(scn.cases):
        parts = build_case(case, where=f"{scn.source}: [[case]] #{i + 1}")
        if engine == "mujoco":
            from ..engines.mujoco import MujocoPlant

            if parts["actuator"] is not None:
                raise ScenarioError(f"{scn.source}: [actuator] needs the python engine (MuJoCo models its own actuation)")

            plant = MujocoPlant(parts["robot"], parts["environment"], sample_time=parts["controller"].sample_time)
            res = plant.run(
                parts["controller"], parts["reference"], q0=parts["q0"], qd0=parts["qd0"], duration=parts["duration"],
                label=case.label,
            )
            res.metadata.update({"scenario": scn.name, "source": scn.source})
        else:
            res = simulate(
                parts["robot"], parts["environment"], parts["controller"], parts["reference"],
                q0=parts["q0"], qd0=parts["qd0"], duration=parts["duration"], sensor=parts["sensor"],
                substeps=parts["substeps"], engine=engine, label=case.label,  # type: ignore[arg-type]
                **({} if parts["actuator"] is None else {"actuator": parts["actuator"]}),
                metadata={"scenario": scn.name, "source": scn.source},
            )
        window = parts["settle_window"]
        metrics = {}
        for name in ("x", "y", "fx", "fy"):
            metrics[name] = METRICS[name](res, parts, window)
        analysis = case_analysis(parts)
        checks = []
        lost = contact_losses(res.wrench)
        metrics["contact_losses"] = lost
        if lost and not parts["allow_contact_loss"]:
            # an unexpected bounce is a failed check (the scenario may declare allow_contact_loss)
            checks.append({
                "metric": "contact_losses", "value": lost, "expected": 0, "tolerance": 0, "relative_error": float(lost),
                "ok": False, "note": f"contact lost {lost} time(s) after touching (peak |f| = "
                                     f"{res.peak_contact_force_norm():.4g} N); set allow_contact_loss = true if intended",
            })
        for key, spec in case.expected.items():
            if key.startswith("analysis."):
                sub = key.split(".", 1)[1]
                if sub not in analysis:
                    raise ScenarioError(f"{scn.source}: expected '{key}' but no analysis gives '{sub}' for this case")
                value = float(analysis[sub])
            else:
                value = METRICS[key](res, parts, window)
                metrics[key] = value
            checks.append(_check(key, value, spec, parts["tolerance"]))
        out.append(CaseResult(case.label, res, metrics, analysis, checks))
        if progress is not None:
            progress(i + 1, len(scn.cases), case.label)
    return ScenarioRun(scn, out)
