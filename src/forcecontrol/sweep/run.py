"""Running a sweep: validate and build every case, simulate them in blocks, store each block as it ends.

Cases of the chapter's arm with a built-in environment and controller (the Example 9.1-9.3
schemes) run in the allocation-free compiled kernel :func:`forcecontrol._batch.run_batch`, a
block of cases per call; other cases go through :func:`forcecontrol.simulation.simulate` one by
one. Locally the blocks run on a thread pool with one thread per core (the kernel releases the
GIL), so no server is needed; with a Dask scheduler address they run as tasks on the cluster's
workers. The kernel and the block function are the same in both, so the tables are identical.

Storage: the table ``OUT.parquet`` is assembled at the end from parts written atomically as each
block finishes (``OUT.parquet.parts/part-*.parquet``, written to a temporary name and renamed). An
interrupted sweep (Ctrl-C, a killed process or worker) keeps every finished block; running the
same command again reads the parts, runs only the missing cases and assembles the same table.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import math
import os
import shutil
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..errors import DriftWarning, ForceControlError, ScenarioError, SimulationDivergedError
from .spec import SweepDefinition, SweepError, SweepParameter, SweepWarning, definition_hash

if sys.version_info >= (3, 11):
    pass
else:  # pragma: no cover
    pass

__all__ = [
    "PreparedSweep",
    "SweepResult",
    "CaseJob",
    "load_sweep_scenario",
    "prepare_sweep",
    "run_sweep",
    "run_block",
    "read_sweep",
    "METRIC_COLUMNS",
]

#: metric columns of the table, in order (units in the docs of :func:`run_sweep`).
METRIC_COLUMNS = (
    "settling_time", "overshoot", "steady_state_force_error", "peak_force", "settled_force",
    "stable", "contact_lost",
)
_CAUSES = {0: "ok", 1: "non-finite state", 2: "runaway", 3: "singular jacobian", 4: "non-finite torque"}
_CAUSE_CODES = {v: k for k, v in _CAUSES.items()}
META_KEY = b"forcecontrol.sweep"
MAX_JOINT_SPEED = 50.0  # [rad/s], simulate()'s default


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


# ----------------------------------------------------------------------------- path checks


def _sweepable_top() -> list[str]:
    from ..scenarios.core import TOP_FIELDS

    return [k for k, f in TOP_FIELDS.items() if f.kind != "table" and k not in ("name", "title", "description")]


def _check_path(p: SweepParameter, cfg: dict[str, Any], label: str) -> None:
    """Reject a path the scenario schema does not know, naming the valid choices."""
    from ..robots import PlanarTwoLinkParameters
    from ..scenarios.core import ROBOT_FIELDS, SENSOR_FIELDS
    from ..scenarios.schema import CONTROLLERS, ENVIRONMENTS, REFERENCES

    keys = p.keys
    top = keys[0]
    tables = {"environment": ENVIRONMENTS, "controller": CONTROLLERS, "reference": REFERENCES}
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


def _apply(cfg: dict[str, Any], p: SweepParameter, value: Any, label: str) -> None:
    """Set ``p.path = value`` in a case configuration (creating missing [sensor]/parameters tables)."""
    keys = p.keys
    node = cfg
    for k in keys[:-1]:
        if k not in node or node[k] is None:
            node[k] = {}
        node = node[k]
    last = keys[-1]
    idx = p.indices
    if not idx:
        node[last] = copy.deepcopy(value)
        return
    if last not in node:
        raise SweepError(
            f"parameter '{p.path}' (case '{label}'): '{'.'.join(keys)}' is not set in the scenario, so it has no "
            "entries to index; sweep the whole value instead"
        )
    cur = copy.deepcopy(node[last])
    target = cur
    for depth, i in enumerate(idx):
        if not isinstance(target, list) or i >= len(target):
            raise SweepError(
                f"parameter '{p.path}' (case '{label}'): index [{i}] needs a list of more than {i} entries at "
                f"'{'.'.join(keys)}{''.join(f'[{j}]' for j in idx[:depth])}'; the scenario has {target!r}"
            )
        if depth == len(idx) - 1:
            target[i] = copy.deepcopy(value)
        else:
            target = target[i]
    node[last] = cur


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


@dataclass
class CaseJob:
    """One case, ready to simulate (picklable: it travels to Dask workers).

    ``fast`` cases carry the kernel's packed arrays; the others carry their parts for
    :func:`forcecontrol.simulation.simulate`.
    """

    case_id: int
    label: str
    values: dict[str, Any]
    fast: bool
    Ts: float
    N: int
    nsub: int
    window: int
    d: np.ndarray
    f_ref: float
    reference: Any
    sensor: Any
    ref_key: str
    K: np.ndarray | None = None
    env_kind: int = 0
    env_p: np.ndarray | None = None
    law: Any = None
    ctrl_p: np.ndarray | None = None
    ctrl_s: np.ndarray | None = None
    q0: np.ndarray | None = None
    qd0: np.ndarray | None = None
    alpha: float = 1.0
    parts: dict[str, Any] | None = None
    #: the label its table row carries (``label`` marked when the sweep replaces what the case set).
    row_label: str = ""

    @property
    def steps(self) -> int:
        """Control samples times integration substeps (the cost of the case)."""
        return self.N * self.nsub


def _force_direction(env: Any, ref: Any, duration: float) -> tuple[np.ndarray, float]:
    """Unit direction d of the force metrics and the reference force along it."""
    f_d = np.asarray(ref.at(duration).force, dtype=np.float64)
    norm = float(np.linalg.norm(f_d))
    if norm > 0.0:
        return f_d / norm, norm
    if hasattr(env, "normal"):
        return -np.asarray(env.normal, dtype=np.float64), 0.0
    d = np.zeros(len(f_d))
    d[0] = 1.0
    return d, 0.0


def _make_job(case_id: int, label: str, values: dict[str, Any], parts: dict[str, Any]) -> CaseJob:
    from ..controllers.base import Measurement
    from ..errors import ParameterError
    from ..limits import check_run_size, check_substeps
    from ..robots import PlanarTwoLink
    from ..simulation import choose_substeps, pre_start_wrench

    robot, env, ctl, ref, sensor = (parts[k] for k in ("robot", "environment", "controller", "reference", "sensor"))
    Ts = float(ctl.sample_time)
    duration = float(parts["duration"])
    try:  # the same limits as simulate(), before anything is allocated
        N = check_run_size(duration, Ts, int(robot.nq), int(robot.task_dim))
    except ParameterError as exc:
        raise SweepError(f"case {label!r}: {exc}") from exc
    if N < 1:
        raise SweepError(f"duration must be at least one sample time ({Ts:.6g} s); got {duration:.6g} s")
    q0 = np.asarray(parts["q0"], dtype=np.float64)
    qd0 = np.zeros(robot.nq) if parts["qd0"] is None else np.asarray(parts["qd0"], dtype=np.float64)
    nsub = int(parts["substeps"]) if parts["substeps"] is not None else choose_substeps(robot, env, q0, Ts)
    d, f_ref = _force_direction(env, ref, N * Ts)
    window = max(1, int(round(float(parts["settle_window"]) / Ts)))
    fast = (
        isinstance(robot, PlanarTwoLink) and getattr(env, "kind", 0) in (1, 2) and getattr(ctl, "compiled_law", None) is not None
        and robot.task_dim == 2 and bool(getattr(sensor, "compiled_ok", True))  # realistic sensors: simulate()
        and parts.get("actuator") is None  # friction, delay, quantisation: simulate() on the Python engine
    )
    # cases share a sampled reference only when the samples themselves are equal (a describe()
    # of a user's reference type need not say everything that shapes it)
    try:
        check_substeps(nsub, N, Ts, float(env.max_stiffness()), "compiled" if fast else "python")
    except ParameterError as exc:
        raise SweepError(f"case {label!r}: {exc}") from exc
    samples = np.ascontiguousarray(ref.sample(np.arange(N + 1) * Ts), dtype=np.float64)
    job = CaseJob(
        case_id, label, values, fast, Ts, N, nsub, window, d, f_ref, ref, sensor,
        hashlib.sha256(samples.tobytes()).hexdigest(),
    )
    if not fast:
        job.parts = {k: parts[k] for k in ("robot", "environment", "controller", "reference", "sensor", "q0", "qd0", "actuator")}
        return job
    # the controller's reset exactly as simulate() does it (same first noise sample)
    bias, noise0 = sensor.sequences(1, robot.task_dim)
    h0 = pre_start_wrench(robot, env, q0, qd0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DriftWarning)
        ctl.reset(Measurement(q0, qd0, h0 + bias + noise0[0]), ref.at(0.0))
    job.K = np.array(robot._K, dtype=np.float64)
    job.env_kind = int(env.kind)
    job.env_p = np.array(env.packed(), dtype=np.float64)
    job.law = ctl.compiled_law
    job.ctrl_p = np.array(ctl._params, dtype=np.float64)
    job.ctrl_s = np.array(ctl.state, dtype=np.float64)
    job.q0, job.qd0 = q0.copy(), qd0.copy()
    job.alpha = float(sensor.alpha(Ts))
    return job


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
        progress: ``progress(built, total)`` every 100 cases (building costs about 1 ms a case).

    Raises:
        SweepError: no definition, unknown parameter path, empty range, malformed value, a case
            that fails the scenario's validation (the message names the case and its values).
    """
    from ..scenarios import CaseSpec, Scenario, build_case

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
    for _, case in selected:
        for p in definition.parameters:
            _check_path(p, case.config, case.label)
    assignments = definition.assignments()
    columns = {p.path: _column_kind([a[p.path] for a in assignments]) for p in definition.parameters}
    jobs: list[CaseJob] = []
    cid = 0
    total = len(selected) * len(assignments)
    for _, case in selected:
        row_label = sweep_label(case.label, case.overrides, list(definition.parameters))
        for values in assignments:
            cfg = copy.deepcopy(case.config)
            for p in definition.parameters:
                _apply(cfg, p, values[p.path], case.label)
            shown = ", ".join(f"{k}={v!r}" for k, v in values.items())
            where = f"sweep case {cid} ('{case.label}', {shown})"
            try:
                parts = build_case(CaseSpec(case.label, cfg, {}), where=where)
                job = _make_job(cid, case.label, values, parts)
                job.row_label = row_label
                jobs.append(job)
            except SweepError:
                raise
            except ForceControlError as exc:
                raise SweepError(str(exc) if str(exc).startswith(where) else f"{where}: {exc}") from exc
            cid += 1
            if progress is not None and (cid % 100 == 0 or cid == total):
                progress(cid, total)
    payload = {
        "scenario": scn.name,
        "cases": [{"index": ci + 1, "label": c.label, "config": c.config} for ci, c in selected],
        "sweep": definition.describe(),
        "forcecontrol": __version__,
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
            "direction": "force metrics use y = d · h_e, d the unit final reference force (or the plane's push "
                         "direction when f_d = 0)",
            "settling_time": "[s] first time after which |y − y_final| <= settle_band |y_final − y_0|",
            "overshoot": "[%] 100 max(0, max sign(s) (y − y_final)) / |s|, s = y_final − y_0",
            "steady_state_force_error": "[N] y_final − d · f_d",
            "peak_force": "[N] max ||h_e||",
            "settled_force": "[N] y_final, mean of y over the scenario's settle_window",
            "stable": "no divergence, and the late residual |y − y_final| is within stable_band |s| or still decaying",
            "contact_lost": "h_e = 0 at a sample after contact was made",
        },
        "forcecontrol": __version__,
    }
    return PreparedSweep(scn, definition, jobs, columns, metadata, sweep_id)


# ----------------------------------------------------------------------------- one block


def run_block(jobs: list[CaseJob], settle_band: float, stable_band: float) -> list[dict[str, Any]]:
    """Simulate a block of cases; one row (metrics, status) per case, in the jobs' order.

    This is what a local thread or a Dask worker runs; the numbers do not depend on where.
    """
    from .._batch import OUT_COLUMNS, run_batch

    rows: dict[int, dict[str, Any]] = {}
    groups: dict[Any, list[CaseJob]] = {}
    for j in jobs:
        if j.fast:
            groups.setdefault(j.law, []).append(j)
    for law, fast in groups.items():  # the batch kernel is specialised per law
        C = len(fast)
        nmax = max(j.N for j in fast)
        ref_index: dict[tuple[str, int, float], int] = {}
        refs: list[np.ndarray] = []
        noise_index: dict[tuple[Any, ...], int] = {(): 0}
        noises = [np.zeros((nmax + 1, 2))]
        ref_id = np.empty(C, np.int64)
        noise_id = np.empty(C, np.int64)
        bias = np.empty((C, 2))
        for i, j in enumerate(fast):
            key = (j.ref_key, j.N, j.Ts)
            if key not in ref_index:
                r = np.zeros((nmax + 1, 12))
                r[: j.N + 1] = j.reference.sample(np.arange(j.N + 1) * j.Ts)
                ref_index[key] = len(refs)
                refs.append(r)
            ref_id[i] = ref_index[key]
            b, noise = j.sensor.sequences(j.N + 1, 2)
            bias[i] = b
            if np.any(noise):
                nkey = (j.sensor.seed, tuple(np.broadcast_to(j.sensor.noise_std, (2,)).tolist()), j.N)
                if nkey not in noise_index:
                    nz = np.zeros((nmax + 1, 2))
                    nz[: j.N + 1] = noise
                    noise_index[nkey] = len(noises)
                    noises.append(nz)
                noise_id[i] = noise_index[nkey]
            else:
                noise_id[i] = 0

        def stack(name: str, fast: list[CaseJob] = fast, C: int = C) -> np.ndarray:
            arrs = [np.atleast_1d(getattr(j, name)) for j in fast]
            width = max(a.shape[0] for a in arrs)
            out = np.zeros((C, width))
            for i, a in enumerate(arrs):
                out[i, : a.shape[0]] = a
            return out

        out = np.empty((C, len(OUT_COLUMNS)))
        run_batch(
            law, stack("K"), np.array([j.env_kind for j in fast], np.int64), stack("env_p"),
            stack("ctrl_p"), stack("ctrl_s"),
            np.stack(refs), ref_id, bias, np.stack(noises), noise_id,
            np.array([j.alpha for j in fast]), stack("q0"), stack("qd0"), np.array([j.Ts for j in fast]),
            np.array([j.nsub for j in fast], np.int64), np.array([j.N for j in fast], np.int64),
            np.full(C, MAX_JOINT_SPEED), stack("d"), np.array([j.f_ref for j in fast]),
            np.array([j.window for j in fast], np.int64), float(settle_band), float(stable_band), out,
        )
        for i, j in enumerate(fast):
            rows[j.case_id] = _row(j, dict(zip(OUT_COLUMNS, out[i].tolist())), "batch")
    for j in jobs:
        if not j.fast:
            rows[j.case_id] = _row(j, _simulate_one(j, settle_band, stable_band), "simulate")
    return [rows[j.case_id] for j in jobs]


def _simulate_one(j: CaseJob, settle_band: float, stable_band: float) -> dict[str, float]:
    """A case outside the kernel's reach: simulate() and the same metrics."""
    from .._batch import case_metrics
    from ..simulation import simulate

    p = j.parts or {}
    status = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DriftWarning)
        try:
            res = simulate(
                p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], qd0=p["qd0"],
                duration=j.N * j.Ts, sensor=p["sensor"], substeps=j.nsub, max_joint_speed=MAX_JOINT_SPEED,
                **({} if p.get("actuator") is None else {"actuator": p["actuator"]}),
            )
        except SimulationDivergedError as exc:
            res = exc.partial  # type: ignore[attr-defined]
            status = _CAUSE_CODES.get(exc.cause, 1)
    last = len(res.t) - 1
    y = np.ascontiguousarray(res.wrench @ j.d)
    norms = np.linalg.norm(res.wrench, axis=1)
    touched = np.flatnonzero(norms != 0.0)
    lost = bool(touched.size and np.any(norms[touched[0]:] == 0.0))
    st, ov, err, stable, yf = case_metrics(y, last, status, j.Ts, j.window, j.f_ref, settle_band, stable_band)
    return {
        "status": float(status), "last_sample": float(last), "peak_force": float(np.nanmax(norms)),
        "contact_lost": float(lost), "settling_time": st, "overshoot": ov, "steady_state_force_error": err,
        "stable": stable, "settled_force": yf,
    }


def _row(j: CaseJob, r: dict[str, float], engine: str) -> dict[str, Any]:
    status = int(r["status"])
    return {
        "case_id": j.case_id,
        "case": j.row_label or j.label,
        **{f"param:{k}": v for k, v in j.values.items()},
        "settling_time": r["settling_time"],
        "overshoot": r["overshoot"],
        "steady_state_force_error": r["steady_state_force_error"],
        "peak_force": r["peak_force"],
        "settled_force": r["settled_force"],
        "stable": bool(r["stable"]),
        "contact_lost": bool(r["contact_lost"]),
        "status": _CAUSES.get(status, "unknown"),
        "diverged_at": math.nan if status == 0 else int(r["last_sample"]) * j.Ts,
        "samples": j.N,
        "integration_substeps": j.nsub,
        "engine": engine,
        "_steps": int(r["last_sample"]) if status == 0 else int(r["last_sample"]) + 1,
    }


# ----------------------------------------------------------------------------- storage


def _schema(prep: PreparedSweep):
    import pyarrow as pa  # type: ignore[import-untyped]

    kinds = {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_(), "str": pa.string(), "json": pa.string()}
    fields = [pa.field("case_id", pa.int64()), pa.field("case", pa.string())]
    fields += [pa.field(path, kinds[k]) for path, k in prep.columns.items()]
    fields += [pa.field(c, pa.float64()) for c in METRIC_COLUMNS[:5]]
    fields += [pa.field("stable", pa.bool_()), pa.field("contact_lost", pa.bool_())]
    fields += [pa.field("status", pa.string()), pa.field("diverged_at", pa.float64()),
               pa.field("samples", pa.int64()), pa.field("integration_substeps", pa.int64()),
               pa.field("engine", pa.string())]
    meta = {META_KEY: json.dumps(prep.metadata, default=str).encode()}
    return pa.schema(fields, metadata=meta)


def _to_table(rows: list[dict[str, Any]], prep: PreparedSweep):
    import pyarrow as pa  # type: ignore[import-untyped]

    schema = _schema(prep)
    cols: dict[str, list[Any]] = {f.name: [] for f in schema}
    for r in rows:
        for name in cols:
            if name in prep.columns:
                v = r[f"param:{name}"]
                if prep.columns[name] == "json":
                    v = json.dumps(v)
                elif prep.columns[name] == "float":
                    v = float(v)
                cols[name].append(v)
            else:
                cols[name].append(r[name])
    return pa.Table.from_pydict(cols, schema=schema)


@contextlib.contextmanager
def _sigint_deferred():
    """Hold SIGINT (Ctrl-C) back until the block ends, then raise KeyboardInterrupt (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def _write_atomic(table, path: Path) -> None:
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    pq.write_table(table, tmp)
    with open(tmp, "rb") as f:
        os.fsync(f.fileno())
    os.replace(tmp, path)


def read_sweep(path: str | Path):
    """A sweep table and its definition: ``(pandas.DataFrame, dict)``."""
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    table = pq.read_table(path)
    meta = json.loads((table.schema.metadata or {}).get(META_KEY, b"{}"))
    return table.to_pandas(), meta


@dataclass
class SweepResult:
    """A finished sweep.

    Attributes:
        path: the Parquet table; table: it, as a pandas DataFrame (one row per case).
        metadata: the sweep definition stored with it.
        ran: cases simulated by this call; resumed: cases found already done.
        seconds: wall time of the simulation phase; steps: arm-steps (control samples, all cases)
            simulated by this call; a diverged case counts the samples up to its divergence.
    """

    path: Path
    table: Any
    metadata: dict[str, Any]
    ran: int = 0
    resumed: int = 0
    seconds: float = 0.0
    steps: int = 0
    scheduler: str = "local"
    extra: dict[str, Any] = field(default_factory=dict)


def _blocks(jobs: list[CaseJob], workers: int, block_size: int | None) -> list[list[CaseJob]]:
    if not jobs:
        return []
    if block_size is not None:
        size = max(1, int(block_size))
    else:
        mean_steps = sum(j.steps for j in jobs) / len(jobs)
        target = 2_000_000  # arm-steps per block: about half a second
        size = max(1, min(int(target // max(mean_steps, 1.0)), math.ceil(len(jobs) / (2 * workers))))
    return [jobs[i : i + size] for i in range(0, len(jobs), size)]


def run_sweep(
    sweep: PreparedSweep | Any,
    out: str | Path,
    definition: SweepDefinition | None = None,
    *,
    scheduler: Any = None,
    workers: int | None = None,
    block_size: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    overwrite: bool = False,
) -> SweepResult:
    """Run (or resume) a sweep and write its table to ``out`` (Parquet).

    Table: one row per case, sorted by ``case_id``: ``case`` (scenario case label), one column
    per swept parameter (named by its path), ``settling_time`` [s], ``overshoot`` [%],
    ``steady_state_force_error`` [N], ``peak_force`` [N], ``settled_force`` [N], ``stable``,
    ``contact_lost``, ``status`` (``"ok"`` or the divergence cause), ``diverged_at`` [s],
    ``samples``, ``integration_substeps`` (RK4 steps per sample), ``engine`` (``"batch"``: the
    compiled kernel, ``"simulate"``: one by one). The definition is in the schema metadata
    (:func:`read_sweep`).

    Args:
        sweep: a :class:`PreparedSweep`, or a scenario (name, path, dict) with ``definition``.
        out: the table's path; finished blocks go to ``<out>.parts/`` until the end.
        scheduler: a Dask scheduler address (``"tcp://host:8786"``) or a ``dask.distributed.Client``;
            None runs locally on ``workers`` threads (default: all cores).
        block_size: cases per block (default: about 2·10⁶ arm-steps per block).
        progress: ``progress(done, total)`` after each stored block (done includes resumed cases).
        overwrite: discard a previous table or parts of a *different* sweep at ``out``.

    Raises:
        SweepError: ``out`` holds a different sweep (and not ``overwrite``).
    """
    prep = sweep if isinstance(sweep, PreparedSweep) else prepare_sweep(sweep, definition)
    out = Path(out)
    parts_dir = out.with_name(out.name + ".parts")
    stamp = parts_dir / "sweep.json"
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepError(f"cannot create the folder of {str(out)!r}: {exc.strerror or exc}; choose another --out") from exc
    with _output_lock(out):
        return _run_locked(prep, out, parts_dir, stamp, scheduler, workers, block_size, progress, overwrite)


@contextlib.contextmanager
def _output_lock(out: Path):
    """One sweep at a time on an output: ``<out>.lock`` holds the owner's pid (a dead owner's lock is taken over)."""
    lock = out.with_name(out.name + ".lock")
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                pid = int(lock.read_text().strip() or "0")
            except (OSError, ValueError):
                pid = 0
            if pid and pid != os.getpid() and _alive(pid):
                raise SweepError(
                    f"another sweep (process {pid}) is writing {str(out)!r}; wait for it or choose another --out "
                    f"(remove {str(lock)!r} if that process is gone)"
                ) from None
            warnings.warn(f"taking over the stale lock {lock} (process {pid} is gone)", SweepWarning, stacklevel=4)
            lock.unlink(missing_ok=True)
            continue
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
        break
    try:
        yield
    finally:
        lock.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # pragma: no cover - another user's process
        return True
    return True


def _set_aside(path: Path, why: str) -> None:
    """Move a damaged file out of the way (kept for inspection) and say so."""
    aside = path.with_name(f"{path.name}.corrupt-{int(time.time())}")
    os.replace(path, aside)
    warnings.warn(f"{path} is unreadable ({why}); moved to {aside.name}, its cases run again", SweepWarning, stacklevel=5)


def _run_locked(prep, out, parts_dir, stamp, scheduler, workers, block_size, progress, overwrite) -> SweepResult:
    if out.exists():
        try:
            _, meta = read_sweep(out)
        except Exception as exc:  # a truncated or corrupt table: rebuild it from parts or runs
            _set_aside(out, f"{type(exc).__name__}: {str(exc)[:80]}")
            meta = None
        if meta is not None and meta.get("sweep_id") == prep.sweep_id:
            table, meta = read_sweep(out)
            if progress is not None:
                progress(prep.n_cases, prep.n_cases)
            return SweepResult(out, table, meta, 0, prep.n_cases)
        if meta is not None:
            if not overwrite:
                raise SweepError(
                    f"{out} holds a different sweep (id {meta.get('sweep_id')}, this one {prep.sweep_id}); "
                    "choose another output path or overwrite it"
                )
            out.unlink()
    if parts_dir.exists():
        old = None
        if stamp.exists():
            try:
                old = json.loads(stamp.read_text()).get("sweep_id")
            except (ValueError, OSError, AttributeError) as exc:  # corrupt stamp: the parts' own metadata decides
                _set_aside(stamp, f"{type(exc).__name__}")
        if old is None:
            old = prep.sweep_id  # no readable stamp: each part is verified against this sweep below
        if old != prep.sweep_id:
            if not overwrite:
                raise SweepError(
                    f"{parts_dir} holds parts of a different sweep (id {old}, this one {prep.sweep_id}); "
                    "choose another output path or overwrite it"
                )
            shutil.rmtree(parts_dir)
    parts_dir.mkdir(parents=True, exist_ok=True)
    if not stamp.exists():
        tmp = stamp.with_name(".sweep.json.tmp")
        tmp.write_text(json.dumps(prep.metadata, indent=2, default=str))
        os.replace(tmp, stamp)
    for t in parts_dir.glob(".*.tmp"):  # left by a killed run (the lock says no one else writes here)
        t.unlink()
    done = _done_ids(parts_dir, prep)
    todo = [j for j in prep.jobs if j.case_id not in done]
    resumed = prep.n_cases - len(todo)
    total = prep.n_cases
    if progress is not None:
        progress(resumed, total)
    counter = {"done": resumed, "steps": 0}

    def store(block: list[CaseJob], rows: list[dict[str, Any]]) -> None:
        ids = [j.case_id for j in block]
        name = f"part-{min(ids):08d}-{max(ids):08d}-{len(ids)}.parquet"
        with _sigint_deferred():  # a Ctrl-C during the write takes effect once the part is in place
            _write_atomic(_to_table(rows, prep), parts_dir / name)
        counter["done"] += len(block)
        counter["steps"] += sum(r["_steps"] for r in rows)
        if progress is not None:
            progress(counter["done"], total)

    t0 = time.perf_counter()
    band = (prep.definition.settle_band, prep.definition.stable_band)
    where = "local"
    if scheduler is None:
        n = workers or os.cpu_count() or 1
        _run_local(_blocks(todo, n, block_size), n, band, store)
    else:
        where = _run_dask(scheduler, todo, block_size, band, store)
    seconds = time.perf_counter() - t0
    table = _assemble(parts_dir, prep)
    _write_atomic(table, out)
    shutil.rmtree(parts_dir, ignore_errors=True)
    df, meta = read_sweep(out)
    return SweepResult(out, df, meta, len(todo), resumed, seconds, counter["steps"], where)


def _done_ids(parts_dir: Path, prep: PreparedSweep) -> set[int]:
    """Case ids stored in verified parts; a part that cannot be read whole, or belongs to another
    sweep, or holds other cases than its name says, is moved aside (its cases run again)."""
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    done: set[int] = set()
    for p in sorted(parts_dir.glob("part-*.parquet")):
        try:
            table = pq.read_table(p)
            meta = json.loads((table.schema.metadata or {}).get(META_KEY, b"{}"))
            ids = table.column("case_id").to_pylist()
            lo, hi, n = (int(v) for v in p.stem.split("-")[1:4])
        except Exception as exc:
            _set_aside(p, f"{type(exc).__name__}: {str(exc)[:80]}")
            continue
        if meta.get("sweep_id") != prep.sweep_id:
            _set_aside(p, f"it belongs to sweep {meta.get('sweep_id')}")
            continue
        if len(ids) != n or (ids and (min(ids) != lo or max(ids) != hi)):
            _set_aside(p, f"it holds {len(ids)} cases, its name says {n} from {lo} to {hi}")
            continue
        done.update(ids)
    return done


def _assemble(parts_dir: Path, prep: PreparedSweep):
    import pyarrow as pa  # type: ignore[import-untyped]
    import pyarrow.compute as pc  # type: ignore[import-untyped]
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    schema = _schema(prep)
    tables = [pq.read_table(p).cast(schema) for p in sorted(parts_dir.glob("part-*.parquet"))]
    table = pa.concat_tables(tables) if tables else schema.empty_table()
    table = table.take(pc.sort_indices(table, [("case_id", "ascending")]))
    ids = table.column("case_id").to_pylist()
    if len(set(ids)) != len(ids):  # a block stored twice (a retried task): keep one copy
        keep, seen = [], set()
        for i, c in enumerate(ids):
            if c not in seen:
                seen.add(c)
                keep.append(i)
        table = table.take(pa.array(keep))
        ids = table.column("case_id").to_pylist()
    missing = sorted(set(range(prep.n_cases)) - set(ids))
    if missing:
        raise SweepError(f"the sweep's parts lack {len(missing)} cases (first: {missing[:5]}); run it again to finish")
    return table.replace_schema_metadata(schema.metadata)


def _run_local(blocks, workers: int, band, store) -> None:
    """Blocks on a thread pool (the kernel releases the GIL); each block stored as it ends."""
    if not blocks:
        return
    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="fc-sweep")
    pending: dict[Future, list[CaseJob]] = {}
    queue = list(blocks)
    try:
        while queue or pending:
            while queue and len(pending) < 2 * workers:
                b = queue.pop(0)
                pending[pool.submit(run_block, b, *band)] = b
            finished, _ = wait(list(pending), return_when=FIRST_COMPLETED)
            for f in finished:
                store(pending.pop(f), f.result())
    except BaseException:
        # Ctrl-C: keep what the running blocks finish, start nothing new
        for f in list(pending):
            if f.cancel():
                pending.pop(f)
        for f, b in pending.items():
            try:
                store(b, f.result())
            except Exception:  # pragma: no cover - the block itself failed
                pass
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _client(scheduler: Any):
    from dask.distributed import Client

    if isinstance(scheduler, Client):
        return scheduler, False
    return Client(scheduler, set_as_default=False), True


#: times a block lost with its worker (``KilledWorker``, a cancelled future) is submitted again.
MAX_RESUBMITS = 3


def _lost_errors() -> tuple[type[BaseException], ...]:
    """The exceptions by which Dask reports a task lost with its worker (not an error of the task itself)."""
    from concurrent.futures import CancelledError

    from dask.distributed import KilledWorker

    return (KilledWorker, CancelledError)


def _run_dask(scheduler: Any, todo: list[CaseJob], block_size: int | None, band, store) -> str:
    """Blocks as tasks on a Dask cluster; each block stored as it ends.

    A worker that dies takes its running task with it: the scheduler reruns the task elsewhere
    until ``distributed.scheduler.allowed-failures`` is spent, then reports ``KilledWorker``.
    Such a block (or one whose future was cancelled) is submitted again, up to
    :data:`MAX_RESUBMITS` times, with a :class:`SweepWarning` naming its cases; a block that is
    already stored is never stored twice.

    Raises:
        SweepError: a block was lost more than :data:`MAX_RESUBMITS` times.
    """
    from dask.distributed import as_completed

    lost = _lost_errors()
    client, own = _client(scheduler)
    try:
        workers = max(1, sum(client.nthreads().values()))
        futures: dict[Any, list[CaseJob]] = {}
        for b in _blocks(todo, workers, block_size):
            f = client.submit(run_block, b, *band, pure=False, retries=2)
            futures[f] = b
        stored: set[Any] = set()
        attempts: dict[int, int] = {}
        try:
            pending = as_completed(list(futures), loop=client.loop)
            for f in pending:
                b = futures[f]
                try:
                    rows = f.result()
                except lost as exc:
                    ids = [j.case_id for j in b]
                    n = attempts[ids[0]] = attempts.get(ids[0], 0) + 1
                    what = f"the block of cases {min(ids)}-{max(ids)}"
                    if n > MAX_RESUBMITS:
                        raise SweepError(
                            f"{what} was lost with its Dask worker {n} times ({type(exc).__name__}); "
                            "the cluster keeps losing workers: check their memory and logs, then run again to resume"
                        ) from exc
                    warnings.warn(
                        f"{what} was lost with its Dask worker ({type(exc).__name__}: {str(exc)[:120]}); "
                        f"submitted again (attempt {n + 1} of {MAX_RESUBMITS + 1})",
                        SweepWarning, stacklevel=5,
                    )
                    g = client.submit(run_block, b, *band, pure=False, retries=2)
                    futures[g] = b
                    pending.add(g)
                    continue
                store(b, rows)
                stored.add(f)
        except BaseException:
            # Ctrl-C: keep the blocks the cluster has already finished, cancel the rest
            for f, b in futures.items():
                if f not in stored and f.status == "finished":
                    try:
                        store(b, f.result(timeout=5))
                    except Exception:  # pragma: no cover - result lost with its worker
                        pass
            client.cancel(list(futures))
            raise
        return str(client.scheduler.address)
    finally:
        if own:
            client.close()
