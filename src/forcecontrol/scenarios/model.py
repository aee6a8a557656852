"""The scenario's data model: the keys each table accepts, a case, a scenario and the results of a run."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core.jsonsafe import json_safe
from ..errors import ScenarioError
from ..sim.limits import (
    MAX_DELAY_SAMPLES,
    MAX_FORCE,
    MAX_FORCE_RESOLUTION,
    MAX_JOINT_POSITION,
    MAX_JOINT_SPEED,
    MAX_SWEEP_VALUES,
    MAX_TOOL_MASS,
    MAX_TORQUE,
    MAX_TORQUE_RESOLUTION,
    MAX_ZEROING_SAMPLES,
)
from ..sim.simulation import SimulationResult
from .schema import MAX_TIME, Field, unused_keys
from .servo_robot import SERVO_FIELDS

if TYPE_CHECKING:
    from .core import Scenario

__all__ = [
    "SWEEP_FIELDS",
    "scenario_model",
    "scenario_json_schema",
    "TOP_FIELDS",
    "ROBOT_FIELDS",
    "SENSOR_FIELDS",
    "ACTUATOR_FIELDS",
    "FIGURE_FIELDS",
    "CASE_FIELDS",
    "CaseSpec",
    "CaseResult",
    "ScenarioRun",
    "UnusedKeyNote",
    "unused_key_notes",
]


TOP_FIELDS: dict[str, Field] = {
    "name": Field("str", True, doc="scenario name"),
    "title": Field("str", default="", doc="one-line title"),
    "description": Field("str", default="", doc="what the scenario shows"),
    "duration": Field("number", True, high=MAX_TIME, doc="simulated time [s]"),
    "sample_time": Field("number", default=1e-3, high=MAX_TIME, doc="control period Ts [s]"),
    "substeps": Field("int", doc="RK4 steps per sample (automatic by default)"),
    "settle_window": Field("number", default=0.1, high=MAX_TIME, doc="window for settled values [s]"),
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


class UnusedKeyNote(UserWarning):
    """A key the scenario sets that its part does not use in any case that sets it (:attr:`.schema.Field.used_when`):
    accepted, and said (stderr and ``run --json``), not silently ignored."""


def unused_key_notes(cases: Any, source: str) -> list[tuple[str, str, list[int]]]:
    """The keys of the environment, controller and reference that no case setting them uses: ``(path, text, cases)``,
    the key's dotted path (``"controller.stiffness_high"``), the note, and the cases (0-based) that set the key.

    A key one case uses and another does not (a ``[[case]]`` switching the law) is used: no note.
    """
    from .schema import part_registries

    registries = part_registries()
    setting: dict[tuple[str, str], list[int]] = {}
    unused: dict[tuple[str, str], dict[int, str]] = {}
    for i, case in enumerate(cases):
        for table, registry in registries.items():
            cfg = case.config.get(table)
            spec = registry.get(cfg.get("type")) if isinstance(cfg, dict) else None
            if spec is None:
                continue
            for key, f in spec.fields.items():
                if f.used_when is not None and cfg.get(key) is not None:
                    setting.setdefault((table, key), []).append(i)
            for key, why in unused_keys(spec.fields, cfg):
                unused.setdefault((table, key), {})[i] = why
    out = []
    for (table, key), where in unused.items():
        if len(where) == len(setting[(table, key)]):  # unused by every case that sets it
            reasons = sorted(set(where.values()))
            scope = "in every case" if len(where) == len(cases) else f"in case(s) {', '.join(str(i + 1) for i in where)}"
            out.append((f"{table}.{key}", f"{source}: [{table}] key '{key}' is not used and its value is ignored: "
                        f"{'; '.join(reasons)} "
                        f"({scope})", sorted(where)))
    return out


class SettleWindowNote(UserWarning):
    """A case's ``settle_window`` is longer than its run: its settled values average the whole run (said, not silent)."""


def settle_window_note(window: float, duration: float) -> str | None:
    """The note for a ``settle_window`` longer than the run (``None`` when it fits): stderr and the case's ``--json`` warnings.

    A window longer than the run is clamped, not refused: shortened runs (``--set duration=...``, the fuzz
    campaign's 0.05-s runs of example-9.1 with its 0.2-s window) keep working and say what they average.
    """
    if window > duration:
        return f"settle_window {window:g} s is longer than the run ({duration:g} s): the whole run is averaged"
    return None


def note_settle_window(res: SimulationResult, window: float, duration: float, where: str) -> None:
    """Say (a :class:`SettleWindowNote` on stderr, ``res.metadata["run_notes"]`` for ``--json``) a window longer than the run."""
    note = settle_window_note(window, duration)
    if note is not None:
        import warnings

        warnings.warn(f"{where}: {note}", SettleWindowNote, stacklevel=3)
        res.metadata.setdefault("run_notes", []).append(note)


ROBOT_FIELDS: dict[str, Field] = {
    "model": Field("str", default="chapter-arm", choices=("chapter-arm", "planar-2r", "panda", "ur5", "ur10", "urdf")),
    "urdf": Field("str", doc="model = 'urdf': path of the URDF file"),
    "frame": Field("str", doc="panda/ur5/urdf: the controlled frame (default panda_hand_tcp / tool0)"),
    "frame_type": Field("str", choices=("BODY", "JOINT", "FIXED_JOINT", "OP_FRAME"),
                        doc="urdf: which frame when a link and a joint share the name"),
    "locked_joints": Field("strlist", doc="model = 'urdf': joints fixed at zero"),
    "q0": Field("vector", low=-MAX_JOINT_POSITION, high=MAX_JOINT_POSITION,
               bound="within the robot's joint limits when it has them", doc="initial joint positions [rad]"),
    "start_position": Field("vector", doc="initial tip position [m] (IK with elbow)"),
    "elbow": Field("str", default="up", choices=("up", "down")),
    "qd0": Field("vector", low=-MAX_JOINT_SPEED, high=MAX_JOINT_SPEED, doc="initial joint velocities [rad/s]"),
    "parameters": Field("table", doc="planar-2r: overrides of PlanarTwoLinkParameters"),
    "payload_mass": Field("number", high=1e3,
                          doc="ur5, ur10: a payload on the controlled frame [kg] (the sensor reads its inertia)"),
    "payload_com": Field("vector", doc="its centre of mass in the controlled frame [m]"),
    "payload_weight_in_reading": Field(
        "bool", default=False,
        doc="the force sensor reads the payload's weight too (a raw F/T sensor; the controller compensates it), "
            "instead of leaving it out (the arm's own payload setting)"),
    "servo": Field("table", fields=SERVO_FIELDS, doc="the joint servo of a position/velocity-interface arm: see [robot.servo]"),
}


SENSOR_FIELDS: dict[str, Field] = {
    "noise_std": Field("gain", default=0.0, high=MAX_FORCE, doc="noise standard deviation [N]"),
    "bias": Field("gain", default=0.0, low=-MAX_FORCE, high=MAX_FORCE, doc="constant bias [N]"),
    "cutoff": Field("number", doc="first-order low-pass cut-off [Hz]"),
    "seed": Field("int", default=0),
    # realistic sensor (RealisticForceSensor, Python loop) when any of these is given
    "filter": Field("str", choices=("none", "first-order", "butterworth"), doc="digital filter kind"),
    "drift": Field("gain", low=-MAX_FORCE, high=MAX_FORCE, doc="bias drift rate in the sensor frame [N/s]"),
    "resolution": Field("number", high=MAX_FORCE_RESOLUTION, doc="quantisation step [N]"),
    "delay_samples": Field("int", high=MAX_DELAY_SAMPLES, bound="at most the run's samples",
                           doc="transport delay [samples]"),
    "zeroing_samples": Field("int", high=MAX_ZEROING_SAMPLES, doc="readings averaged at start to estimate the bias"),
    "tool_mass": Field("number", high=MAX_TOOL_MASS,
                       doc="mass of the tool after the sensor [kg] (compensated: known tool)"),
}


_RICH_SENSOR_KEYS = ("filter", "drift", "resolution", "delay_samples", "zeroing_samples", "tool_mass")


#: ``[actuator]``: joint friction, actuation delay and torque quantisation (:class:`~forcecontrol.sim.actuators.Actuator`,
#: Python engine). Per-joint keys take a number (every joint) or a list with one entry per joint.
ACTUATOR_FIELDS: dict[str, Field] = {
    "coulomb": Field("gain", default=0.0, high=MAX_TORQUE,
                     doc="Coulomb friction torque per joint [N m] (smooth sign tanh(qd / coulomb_band))"),
    "viscous": Field("gain", default=0.0, high=MAX_TORQUE,
                     doc="viscous friction per joint, added to the robot's own [N m s/rad]"),
    "coulomb_band": Field("gain", default=1e-2, high=MAX_JOINT_SPEED,
                          doc="velocity scale of the smooth Coulomb sign per joint [rad/s], > 0"),
    "delay_samples": Field("int", default=0, high=MAX_DELAY_SAMPLES, bound="at most the run's samples",
                           doc="actuation delay [whole samples]: the torque commanded k samples ago"),
    "resolution": Field("gain", default=0.0, high=MAX_TORQUE_RESOLUTION, doc="torque quantum per joint [N m] (0: none)"),
}


FIGURE_FIELDS: dict[str, Field] = {
    "name": Field("str", default="", doc="suffix of the figure's file name (several figures)"),
    "cases": Field("strlist", doc="labels of the cases drawn (all by default)"),
    "title": Field("str", default=""),
    "signals": Field("strlist", default=["x", "fx"], doc="columns to plot against time"),
    "t_max": Field("number", doc="time axis limit [s]"),
    "zoom": Field("number", doc="inset on each force panel with the first `zoom` seconds, one dot per sample [s]"),
    "note": Field("str", default="", doc="caption printed under the figure (what the reader needs to read it)"),
    "mathtext": Field("bool", default=False, doc="draw $...$ in the title, note and case labels as matplotlib mathtext "
                      "(checked on load); false: every character as written"),
}


def check_mathtext(where: str, fig: dict[str, Any], labels: list[str]) -> None:
    """With ``mathtext = true``: the figure's title, note and drawn case labels parse as matplotlib mathtext.

    Raises:
        ScenarioError: a text whose ``$...$`` matplotlib cannot parse (named, with the parser's reason).
    """
    from ..core.text import LABEL_LIMIT, TITLE_LIMIT, figure_safe

    try:
        from matplotlib.mathtext import MathTextParser
    except ImportError:  # no figure can be drawn anyway
        return
    texts = [("title", fig.get("title") or "", TITLE_LIMIT), ("note", fig.get("note") or "", 4 * TITLE_LIMIT)]
    texts += [("case label", lab, LABEL_LIMIT) for lab in (fig.get("cases") or labels)]
    for what, text, limit in texts:
        s = figure_safe(text, limit, mathtext=True)
        dollars = s.count("$") - s.count("\\$")
        if dollars == 0 or dollars % 2:  # matplotlib draws such a text as plain text
            continue
        try:
            MathTextParser("path").parse(s, 72)
        except ValueError as exc:
            reason = " ".join(str(exc).split())[:200]
            raise ScenarioError(f"{where}: mathtext = true, but the {what} {s!r} is not valid mathtext ({reason}); write a "
                                "literal dollar as \\$, or set mathtext = false") from None


#: keys of a scenario's ``[sweep]`` table (besides ``cases`` and ``[sweep.parameters]``); see
#: :class:`forcecontrol.sweep.SweepDefinition`.
SWEEP_FIELDS: dict[str, Field] = {
    "design": Field("str", default="grid", doc="'grid' (every combination) or 'random' (samples draws)",
                    choices=("grid", "random")),
    "samples": Field("int", default=0, low=0, high=MAX_SWEEP_VALUES, doc="design = 'random': number of cases drawn"),
    "seed": Field("int", default=0, doc="design = 'random': seed of the draws"),
    "settle_band": Field("number", default=0.02, doc="settling band, fraction of the force step"),
    "stable_band": Field("number", default=0.05, doc="residual oscillation accepted as stable, fraction of the step"),
}

CASE_FIELDS = ("label", "expected")

#: the resolution of the PNG files plot_results writes (the CLI's figures); tests/test_python_parity.py
#: compares ScenarioRun.plot(path=...) with the CLI's file pixel by pixel.
_PNG_DPI = 120


@dataclass(frozen=True)
class CaseSpec:
    """One case of a scenario: its label, full configuration and expected values."""

    label: str
    config: dict[str, Any]
    expected: dict[str, Any]
    #: the dotted keys the case's own ``[[case]]`` table sets (what its label usually describes).
    overrides: tuple[str, ...] = ()


@dataclass
class CaseResult:
    """A simulated case with its settled metrics, analysis and comparisons."""

    label: str
    result: SimulationResult
    metrics: dict[str, float]
    analysis: dict[str, Any]
    checks: list[dict[str, Any]]
    #: what the analysis warns of the case (``sampled-unstable``: :func:`.parts_sampled.sampled_loop_warnings`)
    analysis_warnings: list[dict[str, Any]] = field(default_factory=list)

    def __repr__(self) -> str:
        ok = sum(bool(c["ok"]) for c in self.checks)
        return (f"CaseResult({self.label!r}, {self.result.t.shape[0]} samples, {float(self.result.t[-1]):g} s, "
                f"checks {ok}/{len(self.checks)} ok, engine={self.result.metadata.get('engine')!r})")


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

    def __repr__(self) -> str:
        checks = [c["ok"] for case in self.cases for c in case.checks]
        ends = sorted({float(c.result.t[-1]) for c in self.cases})
        span = " / ".join(f"{t:g}" for t in ends) + " s"
        status = "no checks" if not checks else ("all checks pass" if all(checks) else f"{len(checks) - sum(checks)} MISSED")
        return (f"ScenarioRun({self.scenario.name!r}, {len(self.cases)} case(s): "
                f"{', '.join(repr(c.label) for c in self.cases)}; {span}; {status}; {len(self.files)} file(s))")

    def _repr_html_(self) -> str:
        """The summary ``forcecontrol run`` prints (settled values, peak force, the book's values and the
        relative errors, files), as escaped HTML: what a notebook shows for a run."""
        from .summary import html_summary

        return html_summary(self)

    def plot(self, figure: int | str = 0, *, path: str | Path | None = None) -> Any:
        """The figure ``forcecontrol run`` writes: the scenario's ``[figure]`` signals of its cases,
        the expected values marked (matplotlib).

        Args:
            figure: which of the scenario's ``[[figure]]`` tables: its index or its ``name``.
            path: also save it there as a PNG (folders created; the same resolution as the CLI's).

        Returns:
            The matplotlib Figure (also when saved).

        Raises:
            ParameterError: ``figure`` names no figure of the scenario.
        """
        from ..errors import ParameterError
        from ..viz.plotting import _figure_call, plot_results

        figs = self.scenario.figures or ({},)
        names = [f.get("name") or "" for f in figs]
        if isinstance(figure, str):
            if figure not in names:
                raise ParameterError(f"figure must be the name of one of the scenario's figures ({names}); got {figure!r}")
            figure = names.index(figure)
        if isinstance(figure, bool) or not isinstance(figure, int) or not -len(figs) <= figure < len(figs):
            raise ParameterError(f"figure must be an index in [0, {len(figs) - 1}] or a figure's name; got {figure!r}")
        args, kwargs = _figure_call(self, figs[figure], None)
        fig = plot_results(*args, **kwargs)
        if path is not None:
            out = Path(path)
            out.parent.mkdir(parents=True, exist_ok=True)
            fig.savefig(out, dpi=_PNG_DPI)
        return fig

    def to_pandas(self) -> Any:
        """Every case's log in one pandas DataFrame: a ``case`` column (the case's label) then the log's
        columns (:meth:`SimulationResult.columns`: ``t``, ``q1``..., ``x``, ``fx``, ...), the cases' rows one
        after the other (wide in signals, long in cases: ``df[df.case == label]`` is one case's log).

        Units are in ``df.attrs["units"]`` (column -> SI unit, e.g. ``"fx": "N"``; ``""`` for the case
        label and for a signal of unknown unit); ``df.attrs["scenario"]`` is the scenario's name.
        Columns a case lacks (a controller's own signal) are NaN in the other cases' rows.

        Raises:
            ImportError: pandas is not installed (the ``data`` extra).
        """
        try:
            import pandas as pd
        except ImportError as exc:
            raise ImportError("ScenarioRun.to_pandas needs pandas: pip install 'forcecontrol[data]'") from exc

        from .units import unit

        frames = []
        for c in self.cases:
            frame = pd.DataFrame(c.result.columns())
            frame.insert(0, "case", c.label)
            frames.append(frame)
        df = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame({"case": []})
        df.attrs["scenario"] = self.scenario.name
        df.attrs["units"] = {col: "" if col == "case" else unit(col) for col in df.columns}
        return df

    def view3d(self, path: str | Path | None = None, *, case: int = 0) -> Any:
        """Write case ``case``'s 3-D view (as ``run --view3d``) to ``path`` (default: the temporary folder's
        ``view3d-<scenario>-<case>.html``). Returns the path; in a notebook an ``IPython.display.HTML`` of it.
        Raises ImportError without the ``view3d`` extra, ParameterError for an unknown case."""
        import tempfile

        from ..core.paths import safe_name
        from ..errors import ParameterError
        from ..viz.view3d import notebook_view, write_view3d
        from . import build_case  # the package's API at call time (build imports this module)

        if isinstance(case, bool) or not isinstance(case, int) or not 0 <= case < len(self.cases):
            raise ParameterError(f"case must be an index in [0, {len(self.cases) - 1}]; got {case!r}")
        c, name = self.cases[case], safe_name(self.scenario.name)
        out = Path(path) if path is not None else \
            Path(tempfile.gettempdir()) / f"view3d-{name}-{safe_name(c.label, str(case))}.html"
        parts = build_case(self.scenario.cases[case], where=f"{self.scenario.source}: [[case]] #{case + 1}")
        return notebook_view(write_view3d(c.result, parts["robot"], parts["environment"], out,
                                          title=f"{self.scenario.name}: {c.label}")[0])

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
        from .summary import case_events, case_warnings

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
                    # what stderr said about the case (summary.case_warnings), and the run's notes (settle_window)
                    "warnings": case_warnings(c) + [{"kind": "settle-window", "t": None, "text": str(n)}
                                                    for n in c.result.metadata.get("run_notes") or ()]
                    + [{"kind": "engine-note", "t": None, "text": str(n)} for n in c.result.metadata.get("engine_notes") or ()]
                    + [{"kind": "unused-key", "t": None, "text": str(n)} for n in c.result.metadata.get("key_notes") or ()],
                    "events": case_events(c),
                }
                for c in self.cases
            ],
            "all_checks_pass": self.all_checks_pass,
            "files": self.files,
            "units": self._json_units(),
        }

    def _json_units(self) -> dict[str, Any]:
        """The ``units`` map of :meth:`to_json`: settled metrics, checked quantities, the analysis' quantities
        (``analysis.NAME``) and the final sample's fields (a list, one unit per component, for ``tip_position``
        and ``contact_force``)."""
        from ..core.axes import axis_names
        from .units import unit, units_map

        names = {"t", "peak_contact_force_norm"}
        names |= {k for c in self.cases for k in c.metrics} | {ch["metric"] for c in self.cases for ch in c.checks}
        names |= {f"analysis.{k}" for c in self.cases for k in (c.analysis or {})}  # what each case's analysis gives
        out: dict[str, Any] = units_map(names)
        m = max((c.result.m for c in self.cases), default=2)
        pose, _, wrench = axis_names(m)
        out["tip_position"] = [unit(a) for a in pose]
        out["contact_force"] = [unit(f) for f in wrench]
        return dict(sorted(out.items()))


def scenario_model() -> Any:
    """The pydantic model of a whole scenario file, generated from the tables' fields and the registries.

    ``environment``, ``controller`` and ``reference`` are unions discriminated by ``type`` over the
    registered part types (a type registered later appears once the model is built again).
    """
    from typing import Annotated, Union

    from pydantic import ConfigDict, create_model
    from pydantic import Field as PField

    from .schema import CONTROLLERS, ENVIRONMENTS, REFERENCES, _annotation, table_model

    def parts(label: str, registry: dict[str, Any]) -> Any:
        models = tuple(
            table_model(f"{label}_{name}".replace("-", "_"), spec.fields, type_name=name) for name, spec in registry.items()
        )
        return Annotated[Union[models], PField(discriminator="part_type")]  # noqa: UP007 - a tuple of models

    defs: dict[str, Any] = {}
    for i, (k, f) in enumerate(TOP_FIELDS.items()):
        if f.kind == "table":
            continue
        ann = _annotation(f) if f.required or f.default is not None else _annotation(f) | None
        defs[f"top{i}"] = (ann, PField(... if f.required else f.default, alias=k, description=f.described() or None))
    defs["robot"] = (table_model("robot", ROBOT_FIELDS), PField(description="the manipulator"))
    defs["sensor"] = (table_model("sensor", SENSOR_FIELDS) | None, PField(None, description="the force sensor"))
    defs["actuator"] = (table_model("actuator", ACTUATOR_FIELDS) | None, PField(None, description="the joints' actuators"))
    defs["environment"] = (parts("environment", ENVIRONMENTS), PField(description="what the arm touches"))
    defs["controller"] = (parts("controller", CONTROLLERS), PField(description="the control law"))
    defs["reference"] = (parts("reference", REFERENCES), PField(description="x_d(t), f_d(t)"))
    figure = table_model("figure", FIGURE_FIELDS)
    defs["figure"] = (figure | list[figure] | None, PField(None, description="the figure, or figures, to draw"))
    defs["expected"] = (dict[str, Any] | None, PField(None, description="values the run is checked against"))
    defs["case"] = (list[dict[str, Any]] | None, PField(None, description="per-case overrides (dotted keys)"))
    from pydantic import StrictInt, StrictStr

    sweep_fields = {
        "cases": (StrictStr | list[StrictStr | StrictInt] | None, PField(None, description="scenario cases to sweep")),
        "parameters": (dict[str, Any], PField(description="path = values (grid) or distribution (random)")),
    }
    sweep = create_model(  # type: ignore[call-overload]
        "sweep", __base__=table_model("sweep", SWEEP_FIELDS), **sweep_fields,
    )
    defs["sweep"] = (sweep | None, PField(None, description="a sweep of this scenario (forcecontrol sweep)"))
    return create_model(  # type: ignore[call-overload]
        "Scenario", __config__=ConfigDict(extra="forbid", title="forcecontrol scenario"), **defs,
    )


def scenario_json_schema() -> dict[str, Any]:
    """The JSON schema of a scenario file (what ``forcecontrol schema --json`` prints), from :func:`scenario_model`."""
    return scenario_model().model_json_schema(by_alias=True)
