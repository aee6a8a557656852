"""Preparing a sweep: the scenario and its [sweep] table, every case validated and built into a job.

Cases of the chapter's arm with a built-in environment and a controller with a compiled law run
in the compiled batch kernel (:func:`forcecontrol.sim.batch.run_batch`, grouped by law); other
cases go through :func:`forcecontrol.sim.simulation.simulate` one by one (:mod:`.block`).
"""

from __future__ import annotations

import copy
import gc
import json
import math
import os
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .. import __version__
from ..errors import DriftWarning, ForceControlError, ScenarioError
from ..sim.limits import MAX_SWEEP_VALUES
from .cases import CaseJob, _batch_sensor, _first_sample, _job, _Plant, _plant
from .paths import _apply, _check_path, check_only_note, copy_tree, set_values, sweep_label
from .spec import SweepDefinition, SweepError, SweepWarning, definition_hash

__all__ = ["PreparedSweep", "CaseJob", "load_sweep_scenario", "prepare_sweep", "sweep_label", "METRIC_COLUMNS", "MAX_JOINT_SPEED"]

#: metric columns of the table, in order (units in the docs of :func:`run_sweep`).
METRIC_COLUMNS = (
    "settling_time", "overshoot", "steady_state_force_error", "peak_force", "settled_force",
    "stable", "contact_lost",
)
_CAUSES = {0: "ok", 1: "non-finite state", 2: "runaway", 3: "singular jacobian", 4: "non-finite torque",
           5: "unresolved contact"}
_CAUSE_CODES = {v: k for k, v in _CAUSES.items()}
META_KEY = b"forcecontrol.sweep"
MAX_JOINT_SPEED = 50.0  # [rad/s], simulate()'s default
#: the compiled batches a sweep's kernel cases can run on (:func:`sweep_kernel`).
KERNELS = ("lanes8", "scalar")
KERNEL_NOTE = ("lanes8: 8 cases per instruction (forcecontrol.sim.batch_lanes), the scalar kernel's arithmetic with "
               "a vectorised sin/cos within 1 ulp of libm's; a stable case's metrics equal the scalar kernel's (and "
               "`forcecontrol run`'s) within 1e-7 relative (measured up to 2e-8), an unstable or bouncing case amplifies "
               "that last-digit difference and its force metrics can differ by O(1); status, stable and contact_lost "
               "equal; a case on the edge of a threshold may move by one sample; FORCECONTROL_SWEEP_KERNEL=scalar "
               "gives run's numbers")


def sweep_kernel(law: Any = None) -> str:
    """The compiled batch that runs a law's kernel cases: ``"lanes8"`` (every compiled law), or ``"scalar"``
    when the environment variable ``FORCECONTROL_SWEEP_KERNEL=scalar`` asks for the one-case-at-a-time kernel
    (comparisons, benchmarks). The choice is recorded in the sweep's metadata (``"kernel"``).

    Raises:
        SweepError: ``FORCECONTROL_SWEEP_KERNEL`` is set to another value.
    """
    want = os.environ.get("FORCECONTROL_SWEEP_KERNEL", "").strip() or "lanes8"
    if want not in KERNELS:
        raise SweepError(f"FORCECONTROL_SWEEP_KERNEL must be one of {', '.join(KERNELS)}; got {want!r}")
    return want


# ----------------------------------------------------------------------------- scenario + [sweep]


def load_sweep_scenario(source: Any):
    """A scenario (built-in name, TOML path or dict) and its ``[sweep]`` table, if any.

    Returns:
        ``(Scenario, SweepDefinition | None)``.
    """
    from ..scenarios import load_scenario
    from ..scenarios.core import _read_toml, scenario_source

    if isinstance(source, dict):
        data, where = copy.deepcopy(source), None
    else:
        path = scenario_source(source)
        where = str(path)
        data = _read_toml(path, where)  # the scenario loader's reading: UTF-8, nesting, readable
    table = data.pop("sweep", None)
    try:
        scn = load_scenario(data)
    except ScenarioError as exc:
        if where is None:
            raise
        raise ScenarioError(str(exc).replace("<dict>", where)) from exc
    if where is not None:
        scn = replace(scn, source=where)
    definition = None if table is None else SweepDefinition.from_table(table, f"{scn.source}: [sweep]")
    return scn, definition


# ----------------------------------------------------------------------------- prepared sweep


@dataclass
class PreparedSweep:
    """A validated sweep: every case built and packed, nothing run yet.

    Attributes:
        scenario: the scenario; definition: the sweep definition.
        jobs: one :class:`CaseJob` per case, in case-id order.
        columns: parameter columns and their kind (``"int"``, ``"float"``, ``"bool"``, ``"str"``, ``"json"``).
        metadata: the definition stored with the table (JSON-serialisable).
        sweep_id: hash of what determines the results (scenario cases, definition, version).
    """

    scenario: Any
    definition: SweepDefinition
    jobs: list[CaseJob]
    columns: dict[str, str]
    metadata: dict[str, Any]
    sweep_id: str

    @property
    def n_cases(self) -> int:
        return len(self.jobs)


def _column_kind(values: list[Any]) -> str:
    if all(isinstance(v, bool) for v in values):
        return "bool"
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return "int"
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return "float"
    if all(isinstance(v, str) for v in values):
        return "str"
    return "json"


def _select_cases(scn: Any, wanted: tuple[str, ...]) -> list[tuple[int, Any]]:
    cases = list(enumerate(scn.cases))
    if not wanted:
        return cases
    labels = [c.label for c in scn.cases]
    out = []
    for w in wanted:
        if w in labels:
            i = labels.index(w)
        elif w.isdigit() and 1 <= int(w) <= len(labels):
            i = int(w) - 1
        else:
            raise SweepError(
                f"case {w!r} is not in scenario '{scn.name}'; expected a label or a 1-based index among: "
                + "; ".join(f"{i + 1}: {lab}" for i, lab in enumerate(labels))
            )
        if (i, scn.cases[i]) not in out:
            out.append((i, scn.cases[i]))
    return out


@contextmanager
def _collector_paused() -> Iterator[None]:
    """The cyclic garbage collector off while the cases are built (back as it was after).

    Building thousands of cases grows the heap steadily, so the collector's full passes come
    back over an ever larger heap: measured on 5,010 cases, one pass in a few preparations
    added 10–20 µs per case. What the cases allocate and drop is freed by reference counting
    as usual; cycles (if any) are collected after.
    """
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _value_key(v: Any) -> tuple[str, Any]:
    """A hashable key of a swept value (its type kept: 1, 1.0 and True do not build the same case)."""
    return (type(v).__name__, v if isinstance(v, (bool, int, float, str)) else json.dumps(v, sort_keys=True))


#: the tables whose parts a sweep's compiled cases share ("top": the top-level values).
_SHARED_TABLES = ("top", "robot", "environment", "controller", "reference")


def _where(cid: int, label: str, values: dict[str, Any]) -> str:
    shown = ", ".join(f"{k}={v!r}" for k, v in values.items())
    return f"sweep case {cid} ('{label}', {shown})"


def prepare_sweep(
    scenario: Any,
    definition: SweepDefinition | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> PreparedSweep:
    """Check a sweep whole and build every case, before anything runs.

    Args:
        scenario: a loaded scenario, a built-in name, a TOML path (may hold a ``[sweep]`` table)
            or a dict.
        definition: the sweep; by default the scenario file's ``[sweep]`` table.
        progress: ``progress(built, total)`` every 100 cases. For the batch kernel's cases each part
            is checked and built once per distinct values of its own table (an environment per
            [environment] values, a controller per [controller] values, or per environment too when
            its builder reads it; :class:`~forcecontrol.scenarios.build.PartShare`), the sensor once
            per [sensor] values: about 20-30 µs a case on a 10⁴-case grid (150 µs when every case
            built its own parts). Cases that ``simulate()`` runs build their own parts.

    Raises:
        SweepError: no definition, unknown parameter path, empty range, malformed value, a case
            that fails the scenario's validation (the message names the case and its values).
    """
    from ..scenarios import CaseSpec, Scenario, build_case
    from ..scenarios.build import PartShare, build_sensor
    from ..scenarios.build_share import warnings_shown
    from ..scenarios.model import unused_key_notes

    if isinstance(scenario, Scenario):
        scn, file_def = scenario, None
    else:
        scn, file_def = load_sweep_scenario(scenario)
    definition = definition or file_def
    if definition is None:
        raise SweepError(
            f"scenario '{scn.name}' has no [sweep] table; give parameters, e.g. "
            "--param environment.stiffness=logspace(3,6,40)"
        )
    selected = _select_cases(scn, definition.cases)
    swept = frozenset(p.path for p in definition.parameters)
    for _, case in selected:
        for p in definition.parameters:
            _check_path(p, case.config, case.label)
            note = check_only_note(p, case.config, case.label, swept)
            if note is not None and len(p.values) != 1:
                warnings.warn(note, SweepWarning, stacklevel=2)
    for path, text, _ in unused_key_notes([case for _, case in selected], scn.source):
        if path not in swept:  # a swept one: said above, with the values that do not change the response
            warnings.warn(text, SweepWarning, stacklevel=2)
    variations = definition.samples if definition.design != "grid" else math.prod(len(p.values) for p in definition.parameters)
    if len(selected) * variations > MAX_SWEEP_VALUES:  # the variations are bounded alone; each runs every case selected
        raise SweepError(f"the sweep has {variations:,} variations x {len(selected)} cases = {len(selected) * variations:,} "
                         f"runs, more than the {MAX_SWEEP_VALUES:,} a sweep may have; use fewer points or select cases "
                         "(--case)")
    assignments = definition.assignments()
    columns = {p.path: _column_kind([a[p.path] for a in assignments]) for p in definition.parameters}
    params = list(definition.parameters)
    jobs: list[CaseJob] = []
    ref_keys: dict[Any, Any] = {}
    memo: dict[Any, Any] = {}  # tables already checked, the planar arm already built (build_case)
    plant_params = [p for p in definition.parameters if p.keys[0] != "sensor"]
    sensor_params = [p for p in definition.parameters if p.keys[0] == "sensor"]
    # the plant's and the sensor's share of each assignment, as hashable keys (once, not per case)
    keys = [(tuple(_value_key(values[p.path]) for p in plant_params), tuple(_value_key(values[p.path]) for p in sensor_params))
            for values in assignments]
    # which of the plant's values set which table (the parts shared between cases: PartShare)
    tables = {t: [i for i, p in enumerate(plant_params) if (p.keys[0] if len(p.keys) > 1 else "top") == t]
              for t in _SHARED_TABLES}
    shareable = sum(len(v) for v in tables.values()) == len(plant_params)
    cid = 0
    total = len(selected) * len(assignments)
    with warnings.catch_warnings(), _collector_paused():
        warnings.simplefilter("ignore", DriftWarning)  # reported when the case runs
        for _, case in selected:
            row_label = sweep_label(case.label, case.overrides, list(definition.parameters))
            # the parts (robot, environment, controller, reference) are built once per distinct
            # set of non-sensor values, the sensor once per distinct sensor values
            plants: dict[tuple[Any, ...], _Plant] = {}
            sensors: dict[tuple[Any, ...], tuple[Any, np.ndarray]] = {}
            # the compiled cases share the parts of equal tables (checked and built once); the first case
            # that the batch kernel cannot run ends the sharing for this row (simulate() owns its parts)
            share = PartShare() if shareable else None
            for values, (pkey, skey) in zip(assignments, keys):
                try:
                    job = None
                    plant = plants.get(pkey)
                    if plant is not None and plant.compiled:
                        sensor_first = sensors.get((skey, plant.Ts))
                        if sensor_first is None:
                            table = {"sensor": copy_tree(case.config.get("sensor") or {})}
                            for p in sensor_params:
                                _apply(table, p, values[p.path], case.label)
                            sensor = build_sensor(_where(cid, case.label, values), table["sensor"], plant.Ts)
                            first = _first_sample(sensor, plant.parts["robot"].task_dim)
                            sensor_first = sensors[(skey, plant.Ts)] = (sensor, first)
                        if _batch_sensor(sensor_first[0]):
                            job = _job(cid, case.label, values, plant, *sensor_first)
                    if job is None:  # a new plant, or a case run by simulate(), which owns its parts
                        cfg = set_values(case.config, params, values, case.label)
                        Ts = cfg.get("sample_time", 1e-3)  # the sensor of these values at this Ts, if built
                        known = sensors.get((skey, Ts)) if type(Ts) is float else None
                        if known is not None and not _batch_sensor(known[0]):
                            known = None  # a stateful sensor (simulate() runs it): each case builds its own
                        spec, where = CaseSpec(case.label, cfg, {}), _where(cid, case.label, values)
                        if share is not None:
                            share.keys = {t: tuple(pkey[i] for i in idx) for t, idx in tables.items()}
                        built = build_case(spec, where=where, memo=memo, sensor=None if known is None else known[0], share=share)
                        own = _plant(case.label, built, ref_keys, memo)
                        if share is not None and not (own.compiled and _batch_sensor(built["sensor"])):
                            share = None  # this case and the row's next ones: their own parts
                            with warnings_shown(swallow=True):  # said once already, by the same build just above
                                built = build_case(spec, where=where, memo=memo, sensor=None if known is None else known[0])
                                own = _plant(case.label, built, ref_keys, memo)
                        plants.setdefault(pkey, own)
                        sensor = built["sensor"]
                        sensor_first = sensors.get((skey, own.Ts)) if own.compiled and _batch_sensor(sensor) else None
                        if sensor_first is None:
                            sensor_first = (sensor, _first_sample(sensor, built["robot"].task_dim))
                            if _batch_sensor(sensor):
                                sensors[(skey, own.Ts)] = sensor_first
                        job = _job(cid, case.label, values, own, *sensor_first)
                except SweepError:
                    raise
                except ForceControlError as exc:
                    where = _where(cid, case.label, values)
                    raise SweepError(str(exc) if str(exc).startswith(where) else f"{where}: {exc}") from exc
                job.row_label = row_label
                jobs.append(job)
                cid += 1
                if progress is not None and (cid % 100 == 0 or cid == total):
                    progress(cid, total)
    kernel = sweep_kernel() if any(j.fast for j in jobs) else None  # chosen here, once: every worker runs it
    for j in jobs:
        if j.fast:
            j.kernel = kernel or ""
    payload = {
        "scenario": scn.name,
        "cases": [{"index": ci + 1, "label": c.label, "config": c.config} for ci, c in selected],
        "sweep": definition.describe(),
        "forcecontrol": __version__,
        **({"kernel": kernel} if kernel else {}),  # its results differ in the last digits: not resumed across kernels
    }
    sweep_id = definition_hash(payload)
    metadata = {
        "sweep_id": sweep_id,
        "scenario": scn.name,
        "source": scn.source,
        "title": scn.title,
        "n_cases": len(jobs),
        "parameters": [p.path for p in definition.parameters],
        "definition": definition.describe(),
        "cases": payload["cases"],
        "metrics": {
            "direction": "force metrics use y = d · h_e, d the unit final reference force (when f_d = 0: the "
                         "environment's push direction, minus its normal; else a 6-D hybrid task's first force-controlled "
                         "direction, S_f's first column turned to the base frame; else the first axis); in 6-D, d and h_e "
                         "have 6 components (force, then moment)",
            "settling_time": "[s] first time after which |y − y_final| <= settle_band |y_final − y_0|",
            "overshoot": "[%] 100 max(0, max sign(s) (y − y_final)) / |s|, s = y_final − y_0",
            "steady_state_force_error": "[N] y_final − d · f_d",
            "peak_force": "[N] max ||h_e|| (6-D: max ||f_e||, the force part of the wrench)",
            "settled_force": "[N] y_final, mean of y over the scenario's settle_window",
            "stable": "no divergence, and the late residual |y − y_final| is within stable_band |s| (with no step, of "
                      "the largest excursion) or still decaying",
            "contact_lost": "h_e = 0 at a sample after contact was made",
        },
        "forcecontrol": __version__,
    }
    if kernel:  # the compiled batch that runs them (the others: simulate())
        metadata["kernel"] = kernel
        if metadata["kernel"] == "lanes8":
            metadata["kernel_note"] = KERNEL_NOTE
    return PreparedSweep(scn, definition, jobs, columns, metadata, sweep_id)
