"""One block of sweep cases: what a local thread or a Dask worker runs (:func:`run_block`)."""

from __future__ import annotations

import math
import sys
import warnings
from typing import Any

import numpy as np

from ..errors import DimensionError, DriftWarning, SimulationDivergedError

if sys.version_info >= (3, 11):
    pass
else:  # pragma: no cover
    pass

from .prepare import _CAUSE_CODES, _CAUSES, MAX_JOINT_SPEED, CaseJob, sweep_kernel

__all__ = ["run_block", "run_fast"]


# ----------------------------------------------------------------------------- one block


def run_block(jobs: list[CaseJob], settle_band: float, stable_band: float, engine: str = "python") -> list[dict[str, Any]]:
    """Simulate a block of cases; one row (metrics, status) per case, in the jobs' order.

    This is what a local thread or a Dask worker runs; the numbers do not depend on where.
    ``engine="compiled"``: the 6-D cases the compiled loop runs (:func:`~forcecontrol.sim.loop_tree.tree_loop_support`)
    go through ``simulate(engine="compiled")`` (row engine ``"simulate-compiled"``; equal to the Python engine to round-off).
    """
    from ..sim.batch import OUT_COLUMNS

    rows: dict[int, dict[str, Any]] = {}
    groups: dict[Any, list[CaseJob]] = {}
    for j in jobs:
        if j.fast:
            groups.setdefault(j.law, []).append(j)
    for law, fast in groups.items():  # the batch kernels are specialised per law
        out = run_fast(law, fast, settle_band, stable_band)
        for i, j in enumerate(fast):
            rows[j.case_id] = _row(j, dict(zip(OUT_COLUMNS, out[i].tolist())), "batch")
    for j in jobs:
        if not j.fast:
            tree = engine == "compiled" and tree_case(j)
            rows[j.case_id] = _row(j, _simulate_one(j, settle_band, stable_band, "compiled" if tree else "auto"),
                                   "simulate-compiled" if tree else "simulate")
    return [rows[j.case_id] for j in jobs]


def run_fast(law: Any, fast: list[CaseJob], settle_band: float, stable_band: float, kernel: str | None = None) -> np.ndarray:
    """The cases ``fast`` (one law) through the compiled batch: rows of ``OUT_COLUMNS`` (:mod:`forcecontrol.sim.batch`).

    ``kernel``: ``"lanes8"`` (:mod:`forcecontrol.sim.batch_lanes`, 8 cases per instruction) or
    ``"scalar"`` (:mod:`forcecontrol.sim.batch`, one case at a time); by default the one the sweep was
    prepared with (the jobs' ``kernel``, so every worker runs the same), else
    :func:`~forcecontrol.sweep.prepare.sweep_kernel`'s.
    """
    from ..sim.batch import OUT_COLUMNS, run_batch
    from ..sim.batch_lanes import run_lanes

    C = len(fast)
    nmax = max(j.N for j in fast)
    ref_index: dict[tuple[str, int, float], int] = {}
    refs: list[np.ndarray] = []
    noise_index: dict[tuple[Any, ...], int] = {(): 0}
    noises = [np.zeros((nmax + 1, 2))]
    ref_id = np.empty(C, np.int64)
    noise_id = np.empty(C, np.int64)
    bias = np.empty((C, 2))
    per_sensor: dict[int, tuple[Any, np.ndarray, tuple[float, ...]]] = {}  # holds the sensor: its id stays its own
    for i, j in enumerate(fast):
        key = (j.ref_key, j.N, j.Ts)
        if key not in ref_index:
            r = np.zeros((nmax + 1, 12))
            r[: j.N + 1] = j.reference.sample(np.arange(j.N + 1) * j.Ts)
            ref_index[key] = len(refs)
            refs.append(r)
        ref_id[i] = ref_index[key]
        sensor = j.sensor  # cases share sensor objects (one per distinct [sensor] values in a sweep)
        got = per_sensor.get(id(sensor))
        if got is None:
            b, _ = sensor.sequences(0, 2)  # the bias (and the shape check)
            got = per_sensor[id(sensor)] = (sensor, b, tuple(np.broadcast_to(sensor.noise_std, (2,)).tolist()))
        _, b, std = got
        bias[i] = b
        if any(std):  # a noise sequence is drawn once per (seed, std, length), not per case
            nkey = (j.sensor.seed, std, j.N)
            if nkey not in noise_index:
                nz = np.zeros((nmax + 1, 2))
                nz[: j.N + 1] = j.sensor.sequences(j.N + 1, 2)[1]
                noise_index[nkey] = len(noises)
                noises.append(nz)
            noise_id[i] = noise_index[nkey]
        else:
            noise_id[i] = 0

    def stack(name: str) -> np.ndarray:
        same = [getattr(j, name) for j in fast]
        try:  # the usual case: vectors of one length, stacked at once
            out = np.array(same, dtype=np.float64)
            if out.ndim == 2:
                return out
        except ValueError:  # lengths differ: padded below
            pass
        arrs = [np.atleast_1d(a) for a in same]
        width = max(a.shape[0] for a in arrs)
        out = np.zeros((C, width))
        for i, a in enumerate(arrs):
            out[i, : a.shape[0]] = a
        return out

    env_kind = np.array([j.env_kind for j in fast], np.int64)
    nsub = np.array([j.nsub for j in fast], np.int64)
    N = np.array([j.N for j in fast], np.int64)
    args = (
        stack("K"), env_kind, stack("env_p"), stack("ctrl_p"), stack("ctrl_s"),
        np.stack(refs), ref_id, bias, np.stack(noises), noise_id,
        np.array([j.alpha for j in fast]), stack("q0"), stack("qd0"), np.array([j.Ts for j in fast]),
        nsub, N, np.full(C, MAX_JOINT_SPEED), stack("d"), np.array([j.f_ref for j in fast]),
        np.array([j.window for j in fast], np.int64), float(settle_band), float(stable_band),
    )
    out = np.empty((C, len(OUT_COLUMNS)))
    if (kernel or (fast[0].kernel if fast else "") or sweep_kernel(law)) == "lanes8":  # the prepared sweep's choice
        # lanes take the cases grouped by sub-steps, environment and length (fewer masked lanes)
        run_lanes(law, np.lexsort((N, env_kind, nsub)), *args, out)
    else:
        run_batch(law, *args, out)
    return out


def tree_case(j: CaseJob) -> bool:
    """A 6-D case the compiled loop runs (sim/loop_tree.py): no actuator, a supported arm, law, environment and sensor."""
    from ..sim.loop_tree import tree_loop_support

    p = j.parts or {}
    return (not j.fast and p.get("actuator") is None and getattr(p.get("robot"), "task_dim", 0) == 6
            and tree_loop_support(p["robot"], p["environment"], p["controller"], p["sensor"]) is None)


def _simulate_one(j: CaseJob, settle_band: float, stable_band: float, engine: str = "auto") -> dict[str, Any]:
    """A case outside the kernel's reach: simulate() and the same metrics."""
    from ..sim.batch import case_metrics
    from ..sim.simulation import simulate

    p = j.parts or {}
    status, cause = 0, None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DriftWarning)
        try:
            res = simulate(
                p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], qd0=p["qd0"],
                duration=j.N * j.Ts, sensor=p["sensor"], substeps=j.nsub, max_joint_speed=MAX_JOINT_SPEED, engine=engine,
                **({} if p.get("actuator") is None else {"actuator": p["actuator"]}),
            )
        except SimulationDivergedError as exc:
            res = exc.partial  # type: ignore[attr-defined]
            status = _CAUSE_CODES.get(exc.cause, 1)
            cause = str(exc.cause)  # the table names the simulator's own cause, also one this module does not list
    last = len(res.t) - 1
    wrench = np.asarray(res.wrench, dtype=np.float64)
    if wrench.shape[1] != len(j.d):  # a direction built for another wrench size: a bug, said plainly
        raise DimensionError(
            f"sweep case {j.case_id} ('{j.label}'): the force direction of the metrics has {len(j.d)} components, "
            f"the simulated wrench {wrench.shape[1]}"
        )
    y = np.ascontiguousarray(wrench @ j.d)
    norms = np.linalg.norm(wrench, axis=1)
    touched = np.flatnonzero(norms != 0.0)
    lost = bool(touched.size and np.any(norms[touched[0]:] == 0.0))
    # peak force [N]: the force part of a 6-D wrench (its moments are N m), the whole planar one
    forces = np.linalg.norm(wrench[:, :3], axis=1) if wrench.shape[1] == 6 else norms
    st, ov, err, stable, yf = case_metrics(y, last, status, j.Ts, j.window, j.f_ref, settle_band, stable_band)
    return {
        "status": float(status), "last_sample": float(last), "peak_force": float(np.nanmax(forces)),
        "contact_lost": float(lost), "settling_time": st, "overshoot": ov, "steady_state_force_error": err,
        "stable": stable, "settled_force": yf, **({} if cause is None else {"cause": cause}),
    }


def _row(j: CaseJob, r: dict[str, Any], engine: str) -> dict[str, Any]:
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
        "status": r.get("cause") or _CAUSES.get(status, "unknown"),
        "diverged_at": math.nan if status == 0 else int(r["last_sample"]) * j.Ts,
        "samples": j.N,
        "integration_substeps": j.nsub,
        "engine": engine,
        "_steps": int(r["last_sample"]) if status == 0 else int(r["last_sample"]) + 1,
    }
