"""Loading, validating and running scenarios."""

from __future__ import annotations

import copy
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ForceControlError, ParameterError, SampledLoopWarning, ScenarioError
from ..sim.simulation import simulate
from .build import _actuator, _allow_contact_loss, _part, build_case  # noqa: F401
from .checks import (  # noqa: F401
    _ANALYSES,
    _RESPONSES,
    METRICS,
    _check,
    _check_expected_specs,
    _column_metric,
    _penetration,
    case_analysis,
    case_analysis_warnings,
    case_response,
    check_expected,
    check_no_empty_tables,
    register_analysis,
    register_metric,
    register_response,
)
from .model import (  # noqa: F401
    _RICH_SENSOR_KEYS,
    ACTUATOR_FIELDS,
    CASE_FIELDS,
    FIGURE_FIELDS,
    ROBOT_FIELDS,
    SENSOR_FIELDS,
    TOP_FIELDS,
    CaseResult,
    CaseSpec,
    ScenarioRun,
    UnusedKeyNote,
    check_mathtext,
    note_settle_window,
    unused_key_notes,
)
from .schema import check_table

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
    "register_response",
    "case_response",
    "case_analysis",
    "check_expected",
    "METRICS",
]


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


# ----------------------------------------------------------------------------- metrics & analysis


for _c in ("x", "y", "z", "rx", "ry", "rz", "vx", "vy", "vz", "fx", "fy", "fz", "mx", "my", "mz"):
    register_metric(_c, _column_metric(_c))


register_metric("penetration", _penetration)
register_metric("contact_force_norm", lambda r, p, w: float(np.linalg.norm(r.settled("wrench", w))))
register_metric("peak_contact_force_norm", lambda r, p, w: r.peak_contact_force_norm())

# ----------------------------------------------------------------------------- loading


#: the largest scenario file read [bytes] (a scenario is a few kB; a sampled reference goes in its own file)
MAX_SCENARIO_BYTES = 16 * 2**20


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
    if isinstance(name_or_path, str) and not name_or_path.strip():  # Path("") is the current folder
        raise ScenarioError(f"the scenario name is empty ({name_or_path!r}); expected a built-in name "
                            f"({', '.join(list_scenarios())}) or a .toml file")
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
    from ..core.files import read_bytes_limited

    try:  # a regular file within the size limit: a FIFO or /dev/zero is refused, not read forever
        raw = read_bytes_limited(path, "scenario file", MAX_SCENARIO_BYTES)
    except ParameterError as exc:  # "cannot read scenario file '<path>': <problem>"
        raise ScenarioError(f"{where}: cannot be read: {str(exc).split(f'{str(path)!r}: ', 1)[-1]}") from None
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
        hint = ""
        if Path(where).suffix.lower() in (".yaml", ".yml", ".cfg", ".script", ".urscript"):  # a controller's own file?
            hint = (f" (a controller's configuration file? `forcecontrol import-config {Path(where).name}` prints the "
                    "scenario that runs it)")
        raise ScenarioError(f"{where}: not valid TOML: {exc}{hint}") from exc
    except RecursionError as exc:
        raise ScenarioError(f"{where}: arrays or tables nested too deeply (at most {MAX_NESTING} levels)") from exc
    if _depth(data, MAX_NESTING) > MAX_NESTING:
        raise ScenarioError(f"{where}: arrays or tables nested too deeply (at most {MAX_NESTING} levels)")
    return data


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
        check_no_empty_tables(cw, {k: v for k, v in c.items() if k not in CASE_FIELDS})
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
        signals = list(dict.fromkeys([*signals, *getattr(built["controller"], "SIGNALS", ()),
                                      *getattr(built["environment"], "SIGNALS", ())]))  # and an environment's (friction)
        cases.append(spec)
    if not single:
        _check_shadowed(where, base, cases)
    figures = _check_figures(where, figures_raw, [c.label for c in cases], signals)
    return Scenario(
        name=top["name"], title=top["title"], description=top["description"], source=where,
        cases=tuple(cases), figure=figures[0] if figures else None, figures=tuple(figures), raw=data,
    )


def _resolve_reference_files(data: dict[str, Any], folder: Path) -> None:
    """A relative ``[reference] file`` (and a case's ``reference.file``), and a mesh's ``[environment] file``, are relative
    to the scenario file's folder."""

    def fix(value: Any) -> Any:
        if isinstance(value, str) and value and not Path(value).is_absolute():
            return str(folder / value)
        return value

    ref = data.get("reference")
    if isinstance(ref, dict) and "file" in ref:
        ref["file"] = fix(ref["file"])
    env = data.get("environment") if isinstance(data.get("environment"), dict) else {}
    if env.get("type") == "mesh" and "file" in env:  # a mesh's file too (a height field's: the working folder)
        env["file"] = fix(env["file"])
    cases = data.get("case")
    for case in cases if isinstance(cases, list) else []:  # a malformed [[case]] is reported by the loader
        if not isinstance(case, dict):
            continue
        if isinstance(case.get("reference"), dict) and "file" in case["reference"]:
            case["reference"]["file"] = fix(case["reference"]["file"])
        if "reference.file" in case:
            case["reference.file"] = fix(case["reference.file"])
        cenv = case.get("environment") if isinstance(case.get("environment"), dict) else {}
        if cenv.get("type", case.get("environment.type", env.get("type"))) == "mesh":
            for holder, key in ((cenv, "file"), (case, "environment.file")):
                if key in holder:
                    holder[key] = fix(holder[key])


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
    from ..core.axes import axis_names as _axis_names

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
        if fig.get("mathtext"):
            check_mathtext(fw, fig, labels)
        if isinstance(raw, list) and len(items) > 1 and not fig["name"]:
            raise ScenarioError(f"{fw}: missing key 'name' (several figures need distinct file names)")
        out.append(fig)
    names = [f["name"] for f in out]
    if len(set(names)) != len(names):
        raise ScenarioError(f"{where}: [[figure]] names must be distinct; got {names}")
    return out


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
    key_notes = unused_key_notes(scn.cases, scn.source)
    for _, text, _ in key_notes:
        warnings.warn(text, UnusedKeyNote, stacklevel=2)
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
        notes = [text for _, text, cases in key_notes if i in cases]
        if notes:
            res.metadata["key_notes"] = notes  # run --json: the case's warnings (kind "unused-key")
        res.metadata["settle_window"] = float(window)  # what the settled values average (summary.not_settled)
        note_settle_window(res, window, parts["duration"], f"{scn.source}: [[case]] #{i + 1} ({case.label})")
        metrics = {}
        for name in ("x", "y", "fx", "fy"):
            metrics[name] = METRICS[name](res, parts, window)
        analysis = case_analysis(parts)
        # a sampled loop that cannot settle is said here too, not only by 'analyze': on stderr and in run --json
        unstable = case_analysis_warnings(parts, analysis, case.label)
        for w in unstable:
            warnings.warn(w["text"], SampledLoopWarning, stacklevel=2)
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
        out.append(CaseResult(case.label, res, metrics, analysis, checks, unstable))
        if progress is not None:
            progress(i + 1, len(scn.cases), case.label)
    return ScenarioRun(scn, out)
