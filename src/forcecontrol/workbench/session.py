"""What the tuning page computes, without the web stack: knobs, re-simulation, poles, stability curve.

A :class:`TuneSession` holds one case of a scenario. Its knobs are discovered from the scenario
schema: every gain of the case's controller (one knob per component of a diagonal gain) and the
environment's stiffness and damping. :meth:`TuneSession.evaluate` rebuilds the case with the
knobs' values, simulates it with the compiled simulator and returns the responses with what the
analysis gives for the scheme: the closed-loop poles (direct force schemes: the per-axis loops of
:func:`forcecontrol.analysis.force_loop_axes`; impedance and hybrid loops: the second-order modes
of their scenario analyses) and, for the direct force schemes, the spectral radius of the sampled
loop against the environment stiffness with its limit (:func:`forcecontrol.analysis.sampled_stability_limit`).
"""

from __future__ import annotations

import copy
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ForceControlError, ParameterError, ScenarioError

__all__ = ["Knob", "Evaluation", "StabilityCurve", "TuneSession", "discover_knobs"]

#: controller fields that are structure, limits or geometry, not gains to tune.
_NOT_GAINS = ("selection", "directions", "angle", "limit", "max_", "release", "contact_force", "orientation")
_UNITS = {
    "inertia": "kg", "damping": "N s/m", "stiffness": "N/m", "force_gain": "m/N", "integral_gain": "m/(N s)",
    "compliance": "m/N", "velocity_gain": "1/s", "velocity_integral_gain": "1/s²", "position_gain": "1/s²",
    "force_rate_gain": "1/s", "force_integral_gain": "1/s", "posture_stiffness": "N m/rad",
    "posture_damping": "N m s/rad", "motion_stiffness": "N/m", "motion_damping": "N s/m",
    "environment_stiffness": "N/m", "force_stiffness": "N/m", "force_damping": "N s/m",
}
#: typical scale of a knob whose value is zero (its slider then runs from 0 to 10x this).
_ZERO_SCALE = {"damping": 100.0}


@dataclass(frozen=True)
class Knob:
    """One tunable number of a case: ``table.key`` or one component ``table.key[i]`` of a diagonal gain.

    Attributes:
        table: ``"controller"``, ``"environment"`` or a nested controller's path (``"controller.contact"``);
            key: the field; index: the component (None: a scalar).
        value: the case's value; options: the slider's values (log-spaced over two decades around
            ``value``, which is one of them; from 0 when ``value`` is 0); unit: SI unit text.
    """

    table: str
    key: str
    index: int | None
    value: float
    options: tuple[float, ...]
    unit: str = ""

    @property
    def name(self) -> str:
        """``table.key`` or ``table.key[i]``."""
        return f"{self.table}.{self.key}" + ("" if self.index is None else f"[{self.index}]")


def _options(value: float, scale: float) -> tuple[float, ...]:
    if value > 0:
        lo = np.geomspace(value / 10.0, value, 21)
        hi = np.geomspace(value, value * 10.0, 21)[1:]
        opts = np.concatenate([lo[:-1], [value], hi])
    else:
        opts = np.concatenate([[0.0], np.geomspace(scale / 100.0, scale * 10.0, 31)])
    return tuple(float(f"{v:.6g}") if v != value else float(v) for v in opts)


def discover_knobs(config: dict[str, Any]) -> list[Knob]:
    """The knobs of a case configuration (``CaseSpec.config``): controller gains, environment stiffness and damping.

    Scalars give one knob; vectors one per component; matrices one per diagonal entry when the
    matrix is diagonal (else none: a coupled gain is not tuned entry by entry). Controllers nested
    in the controller (a contact supervisor's phases, a safety layer's wrapped law) give their
    gains too, named by their path (``controller.contact.force_gain[0]``). Fields the case
    does not set take their schema default; unset fields without a default are left out.

    Raises:
        ScenarioError: the controller or environment type is not registered.
    """
    from ..scenarios import CONTROLLERS, ENVIRONMENTS

    out: list[Knob] = []
    _table_knobs(config.get("controller") or {}, "controller", CONTROLLERS, None, out)
    _table_knobs(config.get("environment") or {}, "environment", ENVIRONMENTS, ("stiffness", "damping"), out)
    return out


def _table_knobs(tbl: dict[str, Any], path: str, registry: dict[str, Any], wanted: tuple[str, ...] | None,
                 out: list[Knob]) -> None:
    """Knobs of one part's table; a controller nested in a controller (``[controller.contact]``,
    ``[controller.wrapped]``) gives its own, named by its path."""
    from ..scenarios import CONTROLLERS

    kind = tbl.get("type")
    if kind not in registry:
        raise ScenarioError(f"[{path}] key 'type' must be one of {', '.join(sorted(registry))}; got {kind!r}")
    for key, fld in registry[kind].fields.items():
        value = tbl.get(key, fld.default)
        if fld.kind == "table" and registry is CONTROLLERS and isinstance(value, dict) and value.get("type") in CONTROLLERS:
            _table_knobs(value, f"{path}.{key}", CONTROLLERS, None, out)
            continue
        if fld.kind not in ("gain", "number"):
            continue
        if wanted is not None and key not in wanted:
            continue
        if wanted is None and any(s in key for s in _NOT_GAINS):
            continue
        if value is None:
            continue
        unit = _UNITS.get(key, "")
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            scale = _ZERO_SCALE.get(key, 1.0)
            out.append(Knob(path, key, None, float(value), _options(float(value), scale), unit))
            continue
        arr = np.asarray(value, dtype=float)
        if arr.ndim == 2:
            if np.any(arr - np.diag(np.diag(arr))):
                continue
            arr = np.diag(arr)
        nonzero = arr[arr > 0]
        scale = float(np.max(nonzero)) if nonzero.size else _ZERO_SCALE.get(key, 1.0)
        for i, v in enumerate(arr.tolist()):
            if v < 0:
                continue
            out.append(Knob(path, key, i, float(v), _options(float(v), scale), unit))


def _apply_knob(config: dict[str, Any], knob: Knob, value: float) -> None:
    tbl = config
    for part in knob.table.split("."):
        tbl = tbl[part]
    if knob.index is None:
        tbl[knob.key] = float(value)
        return
    current = tbl.get(knob.key)
    if isinstance(current, (int, float)):  # a scalar gain stands for c I: make it a diagonal list
        current = [float(current)] * (knob.index + 1)
    current = copy.deepcopy(current)
    if current and isinstance(current[0], list):
        current[knob.index][knob.index] = float(value)
    else:
        current[knob.index] = float(value)
    tbl[knob.key] = current


@dataclass(frozen=True)
class StabilityCurve:
    """Spectral radius ρ of the sampled force loop against the environment stiffness (Sect. 9.4 schemes).

    Attributes:
        axis: the force axis (``"x"``, ...); stiffness: the k grid [N/m]; radius: ρ(k) (< 1: stable);
        current: (k, ρ) of the case; limit: the largest stable k [N/m] (``inf``: stable everywhere).
    """

    axis: str
    stiffness: np.ndarray
    radius: np.ndarray
    current: tuple[float, float]
    limit: float


@dataclass
class Evaluation:
    """One evaluation of a case: the run, the analysis, poles and stability curve, and timings.

    Attributes:
        result: the :class:`~forcecontrol.sim.simulation.SimulationResult`; analysis: the scenario
            analysis of the case (steady values, ω_n, ζ, ...); poles: continuous closed-loop poles
            per axis (``{"x": array}``; empty when no analysis gives them); stability: the curve or
            None; notes: what is not available for this scheme; seconds: wall time per part.
        error: the message when the case could not be built or diverged (result None then).
        parts: the built case (:func:`~forcecontrol.scenarios.build_case`); loop: the force axis's
            (:class:`~forcecontrol.analysis.force.ForceLoopAxis`, arm mass m_x [kg], Ts [s]) when
            the scheme has the sampled-loop analysis (its margins are the page's).
    """

    result: Any
    analysis: dict[str, Any]
    poles: dict[str, np.ndarray]
    stability: StabilityCurve | None
    notes: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)
    error: str | None = None
    parts: dict[str, Any] | None = None
    loop: tuple[Any, float, float] | None = None


def _second_order_poles(wn: float, zeta: float) -> np.ndarray:
    """Roots of s² + 2 ζ ω_n s + ω_n²."""
    return np.roots([1.0, 2.0 * zeta * wn, wn * wn]).astype(complex)


class TuneSession:
    """One case of a scenario, its knobs, and evaluations of the case with other knob values.

    Args:
        scenario: a loaded :class:`~forcecontrol.scenarios.Scenario`, a built-in name or a TOML path.
        case: the case's label or 0-based index.

    Raises:
        ScenarioError: unknown case, or a scenario that cannot be loaded.
    """

    def __init__(self, scenario: Any, case: int | str = 0) -> None:
        from ..scenarios import Scenario, load_scenario

        self.scenario = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
        labels = [c.label for c in self.scenario.cases]
        if isinstance(case, str):
            if case not in labels:
                raise ScenarioError(f"case must be one of {labels}; got {case!r}")
            case = labels.index(case)
        if not isinstance(case, int) or isinstance(case, bool) or not 0 <= case < len(labels):
            raise ScenarioError(f"case must be a label or an index in 0..{len(labels) - 1}; got {case!r}")
        self.index = case
        self.case = self.scenario.cases[case]
        self.knobs = discover_knobs(self.case.config)
        self.values: dict[str, float] = {k.name: k.value for k in self.knobs}
        fig = self._figure()
        self.signals: list[str] = list(fig.get("signals") or ["x", "fx"])
        self.t_max: float | None = fig.get("t_max")

    def _figure(self) -> dict[str, Any]:
        for fig in self.scenario.figures:
            if not fig.get("cases") or self.case.label in fig["cases"]:
                return fig
        return {}

    @property
    def labels(self) -> list[str]:
        """The scenario's case labels."""
        return [c.label for c in self.scenario.cases]

    @property
    def book_values(self) -> dict[str, float]:
        """The case's expected settled values of logged signals (the book's printed numbers)."""
        out = {}
        for k, spec in self.case.expected.items():
            if "." in k:
                continue
            out[k] = float(spec["value"] if isinstance(spec, dict) else spec)
        return out

    def config(self, values: dict[str, float] | None = None) -> dict[str, Any]:
        """The case configuration with the knobs set to ``values`` (default: the session's values).

        Raises:
            ParameterError: a name that is not a knob, or a value that is not a finite number >= 0.
        """
        vals = dict(self.values)
        for name, v in (values or {}).items():
            if name not in vals:
                raise ParameterError(f"knob must be one of {', '.join(vals)}; got {name!r}")
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v) or v < 0:
                raise ParameterError(f"knob {name!r} must be a finite number >= 0; got {v!r}")
            vals[name] = float(v)
        cfg = copy.deepcopy(self.case.config)
        for k in self.knobs:
            if vals[k.name] != k.value:
                _apply_knob(cfg, k, vals[k.name])
        return cfg

    def has_stability_curve(self) -> bool:
        """True when the case's scheme has the sampled-loop stability analysis (no simulation: the page's layout)."""
        from ..analysis.force_design import force_loop_axes
        from ..scenarios import CaseSpec, build_case

        try:
            parts = build_case(CaseSpec(self.case.label, self.config(), {}), where=f"{self.scenario.name} (tuned)")
            env = parts["environment"]
            if not hasattr(env, "stiffness_matrix"):
                return False
            axes = force_loop_axes(parts["controller"], env.stiffness_matrix())
        except ForceControlError:
            return False
        f_d = np.asarray(parts["reference"].at(float(parts["duration"])).force, dtype=float)
        return axes[int(np.argmax(np.abs(f_d))) if np.any(f_d) else 0].environment_stiffness > 0

    def set(self, name: str, value: float) -> None:
        """Set one knob (checked as in :meth:`config`)."""
        self.config({name: value})
        self.values[name] = float(value)

    def evaluate(self, values: dict[str, float] | None = None, *, stability_points: int = 60) -> Evaluation:
        """Build, simulate (compiled engine where it applies) and analyse the case with the knobs at ``values``.

        A case the scenario rejects or a run that diverges gives an Evaluation with ``error`` set
        (what the page shows) rather than an exception.
        """
        from ..scenarios import CaseSpec, build_case, case_analysis
        from ..sim.simulation import simulate

        seconds: dict[str, float] = {}
        t0 = time.perf_counter()
        try:
            cfg = self.config(values)
            parts = build_case(CaseSpec(self.case.label, cfg, {}), where=f"{self.scenario.name} (tuned)")
        except ForceControlError as exc:
            return Evaluation(None, {}, {}, None, error=str(exc))
        t1 = time.perf_counter()
        try:
            res = simulate(
                parts["robot"], parts["environment"], parts["controller"], parts["reference"], q0=parts["q0"],
                qd0=parts["qd0"], duration=parts["duration"], sensor=parts["sensor"], substeps=parts["substeps"],
                label=self.case.label, metadata={"scenario": self.scenario.name},
                **({} if parts.get("actuator") is None else {"actuator": parts["actuator"]}),
            )
        except ForceControlError as exc:
            partial = getattr(exc, "partial", None)
            ev = Evaluation(partial, {}, {}, None, error=str(exc))
            ev.seconds = {"build": t1 - t0, "simulate": time.perf_counter() - t1}
            return ev
        t2 = time.perf_counter()
        notes: list[str] = []
        try:
            analysis = case_analysis(parts)
        except ForceControlError as exc:
            analysis = {}
            notes.append(f"analysis failed: {exc}")
        loop: list[Any] = []
        poles, stability = self._poles_and_stability(parts, analysis, notes, stability_points, loop)
        t3 = time.perf_counter()
        seconds.update({"build": t1 - t0, "simulate": t2 - t1, "analysis": t3 - t2})
        return Evaluation(res, analysis, poles, stability, notes, seconds, parts=parts, loop=tuple(loop) or None)

    def _poles_and_stability(self, parts: dict[str, Any], analysis: dict[str, Any], notes: list[str],
                             n: int, loop: list[Any]) -> tuple[dict[str, np.ndarray], StabilityCurve | None]:
        from ..analysis.force_design import force_loop_axes, operational_mass, sampled_stability_limit

        ctl, env = parts["controller"], parts["environment"]
        poles: dict[str, np.ndarray] = {}
        axes = None
        if hasattr(env, "stiffness_matrix"):
            try:
                axes = force_loop_axes(ctl, env.stiffness_matrix())
            except ForceControlError:
                axes = None
        if axes is not None:
            for a, ax in zip("xyz", axes):
                poles[a] = np.asarray(ax.poles(), dtype=complex)
        else:
            for key in sorted(analysis):
                if key.startswith("omega_n_") or key.endswith("_omega_n"):
                    tag = key.replace("omega_n_", "") if key.startswith("omega_n_") else key[: -len("_omega_n")]
                    zkey = f"zeta_{tag}" if key.startswith("omega_n_") else f"{tag}_zeta"
                    if zkey in analysis:
                        poles[tag] = _second_order_poles(float(analysis[key]), float(analysis[zkey]))
            if not poles:
                notes.append("no pole analysis for this scheme")
        if axes is None:
            notes.append("no sampled-loop stability analysis for this scheme (the direct force schemes of Sect. 9.4 have one)")
            return poles, None
        f_d = np.asarray(parts["reference"].at(float(parts["duration"])).force, dtype=float)
        i = int(np.argmax(np.abs(f_d))) if np.any(f_d) else 0
        ax = axes[i]
        if ax.environment_stiffness <= 0:
            notes.append("no sampled-loop stability analysis: the force axis has no environment stiffness")
            return poles, None
        nu = np.zeros(ctl.m)
        nu[i] = 1.0
        mx = operational_mass(parts["robot"], parts["q0"], nu)
        Ts = ctl.sample_time
        k_now = ax.environment_stiffness
        rho_now = ax.spectral_radius(Ts, mx)
        loop += [ax, mx, Ts]
        try:
            limit = sampled_stability_limit(ax, Ts, arm_inertia=mx, rtol=1e-4)
        except ForceControlError:
            limit = math.nan  # unstable already at the lowest stiffness
        hi = max(k_now, limit if math.isfinite(limit) else k_now) * 10.0
        ks = np.geomspace(min(k_now, limit if math.isfinite(limit) else k_now) / 100.0, hi, n)
        rho = np.array([ax.with_environment_stiffness(float(k)).spectral_radius(Ts, mx) for k in ks])
        return poles, StabilityCurve("xyz"[i], ks, rho, (k_now, rho_now), limit)

    def tuned_scenario(self, values: dict[str, float] | None = None, name: str | None = None) -> dict[str, Any]:
        """The tuned case as a scenario document (a dict ready for :func:`dumps_toml`).

        One ``[[case]]`` carries the case's label; the book's expected values are left out (they
        hold for the book's gains); the figure keeps its signals and time axis.
        """
        cfg = self.config(values)
        changed = {k.name: (k.value, (values or self.values)[k.name]) for k in self.knobs
                   if (values or self.values)[k.name] != k.value}
        desc = (f"Tuned from {self.scenario.name!r}, case {self.case.label!r}"
                + (": " + ", ".join(f"{n} {a:.6g} -> {b:.6g}" for n, (a, b) in changed.items()) if changed else " (unchanged)")
                + ".")
        doc: dict[str, Any] = {
            "name": name or f"{self.scenario.name}-tuned",
            "title": f"{self.scenario.title} (tuned)" if self.scenario.title else f"{self.scenario.name} (tuned)",
            "description": desc,
        }
        for k, v in cfg.items():
            if not isinstance(v, dict):
                doc[k] = v
        for k in ("robot", "environment", "controller", "reference", "sensor"):
            if cfg.get(k):
                doc[k] = cfg[k]
        fig = {"signals": self.signals}
        if self.t_max is not None:
            fig["t_max"] = self.t_max
        doc["figure"] = fig
        doc["case"] = [{"label": f"{self.case.label} (tuned)"}]
        return doc

    def save(self, path: str | Path, values: dict[str, float] | None = None, *, overwrite: bool = True) -> Path:
        """Write :meth:`tuned_scenario` as TOML to ``path`` and check that it loads back.

        Args:
            overwrite: False: refuse (OutputError) when ``path`` exists (checked atomically at creation).

        Raises:
            OutputError: the file cannot be written, or exists and ``overwrite`` is False.
            ScenarioError: the written file does not load (a bug: it is removed).
        """
        from ..errors import OutputError
        from ..scenarios import load_scenario
        from .toml_writer import dumps_toml

        path = Path(path)
        text = dumps_toml(self.tuned_scenario(values))
        # written whole beside the target, checked, then moved into place: whoever watches ``path`` (a test, the
        # user's editor, a script waiting for it) never reads a half-written file, and a file that does not load
        # never appears (found by a browser test reading the file as soon as it existed: an empty table)
        tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp.write_text(text, encoding="utf-8")
        except OSError as exc:
            raise OutputError(f"cannot write the tuned scenario to {str(path)!r}: {exc.strerror or exc}") from exc
        try:
            load_scenario(tmp)
            if overwrite:
                os.replace(tmp, path)
            else:
                os.link(tmp, path)  # atomic: fails when path exists
        except FileExistsError as exc:
            raise OutputError(f"save: {str(path)!r} exists and this server did not write it; expected a new file "
                              "(pass --overwrite to replace it, or choose another --save)") from exc
        except OSError as exc:
            raise OutputError(f"cannot write the tuned scenario to {str(path)!r}: {exc.strerror or exc}") from exc
        finally:
            tmp.unlink(missing_ok=True)
        return path
