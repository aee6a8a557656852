"""The cases of a sweep: what the cases of one plant share (:class:`_Plant`), and one case as a job.

A plant (robot, environment, controller, reference) is checked and packed once per distinct set
of non-sensor values (:func:`_plant`); each case then differs only in its sensor, which enters
the controller's reset through the first sample (:func:`_job`). Cases that the compiled batch
kernel runs carry its packed arrays; the others carry their parts for ``simulate()``.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .spec import SweepError

__all__ = ["CaseJob"]


@dataclass
class _RunShape:
    """What the cases of one plant share: sample time, samples, sub-steps, the settle window (samples),
    the unit direction d of the force metrics and the reference force along it, and the hash of the
    sampled reference."""

    Ts: float
    N: int
    nsub: int
    window: int
    d: np.ndarray
    f_ref: float
    ref_key: str


@dataclass
class CaseJob(_RunShape):
    """One case, ready to simulate (picklable: it travels to Dask workers).

    ``fast`` cases carry the kernel's packed arrays; the others carry their parts for
    :func:`forcecontrol.sim.simulation.simulate`.
    """

    case_id: int
    label: str
    values: dict[str, Any]
    fast: bool
    reference: Any
    sensor: Any
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
    #: the compiled batch chosen when the sweep was prepared (:func:`~forcecontrol.sweep.prepare.sweep_kernel`), so a
    #: worker with another FORCECONTROL_SWEEP_KERNEL runs the same one; "" outside the kernel.
    kernel: str = ""

    @property
    def steps(self) -> int:
        """Control samples times integration substeps (the cost of the case)."""
        return self.N * self.nsub


def _force_direction(env: Any, ref: Any, duration: float, ctl: Any = None, dim: int | None = None) -> tuple[np.ndarray, float]:
    """Unit direction d of the force metrics (as many components as the wrench: ``dim``) and the
    reference force along it.

    In order: the final reference force; when it is zero, the environment's push direction (minus
    its normal: a plane, a table; a moment-free direction in 6-D); else, for a 6-D hybrid task,
    its first force-controlled direction (the first column of S_f, desired frame, turned to the
    base frame by the final reference orientation); else the first axis.
    """
    f_d = np.asarray(ref.at(duration).force, dtype=np.float64)
    n = int(dim) if dim is not None else len(f_d)
    norm = float(np.linalg.norm(f_d))
    if norm > 0.0 and len(f_d) == n:
        return f_d / norm, norm
    d = np.zeros(n)
    if norm > 0.0:  # a force-only reference of a 6-D task (3 components): no moments
        d[: len(f_d)] = f_d[:n] / norm
        return d, norm
    if hasattr(env, "normal"):
        normal = np.asarray(env.normal, dtype=np.float64)
        d[: len(normal)] = -normal[:n]
        return d, 0.0
    S_f = getattr(ctl, "force_selection", None)
    if n == 6 and S_f is not None and np.shape(S_f)[0] == 6:
        from ..spatial.rotations import euler_xyz_to_rotation

        R_d = euler_xyz_to_rotation(np.asarray(ref.at(duration).position, dtype=np.float64)[3:6])
        s = np.asarray(S_f, dtype=np.float64)[:, 0]
        d = np.concatenate([R_d @ s[:3], R_d @ s[3:]])
        return d / float(np.linalg.norm(d)), 0.0
    d[0] = 1.0
    return d, 0.0


def _per_object(cache: dict[Any, Any] | None, tag: str, obj: Any, extra: tuple[Any, ...], compute: Any) -> Any:
    """``compute()``, remembered in ``cache`` for this very object (and ``extra``).

    The entry holds the object itself, so its ``id`` cannot be reused by another object while the
    entry lives; ``cache=None`` computes every time.
    """
    if cache is None:
        return compute()
    key = (tag, id(obj), *extra)
    held = cache.get(key)
    if held is None or held[0] is not obj:
        held = cache[key] = (obj, compute())
    return held[1]


def _reference_key(ref: Any, N: int, Ts: float, cache: dict[Any, Any] | None) -> str:
    """The hash of a reference's samples over the run (cases with equal samples share them in a block).

    A reference whose class declares ``describe_complete`` (its ``describe()`` says all that
    shapes the samples: set-points and trapezoidal paths) is sampled and hashed once per distinct
    description in a sweep (``cache``); any other is sampled for every case. The same object
    again (a sweep shares built-in references between cases) is not described again.
    """
    return _per_object(cache, "reference", ref, (N, Ts), lambda: _reference_digest(ref, N, Ts, cache))


def _reference_digest(ref: Any, N: int, Ts: float, cache: dict[Any, Any] | None) -> str:
    key = None
    if cache is not None and vars(type(ref)).get("describe_complete", False):
        key = (type(ref).__qualname__, json.dumps(ref.describe(), sort_keys=True, default=str), N, Ts)
        if key in cache:
            return cache[key]
    samples = np.ascontiguousarray(ref.sample(np.arange(N + 1) * Ts), dtype=np.float64)
    digest = hashlib.sha256(samples.tobytes()).hexdigest()
    if key is not None:
        cache[key] = digest
    return digest


@dataclass
class _Plant(_RunShape):
    """What the cases sharing a robot, environment, controller and reference share (all but the sensor).

    Built once per distinct set of non-sensor values in a sweep; the cases then differ only in
    their sensor (noise seed, bias), which enters the controller's reset through the first sample.
    """

    parts: dict[str, Any]
    #: every part can run in the batch kernel (the sensor is checked per case).
    compiled: bool
    h0: np.ndarray | None = None
    ref0: Any = None
    K: np.ndarray | None = None
    env_p: np.ndarray | None = None
    q0: np.ndarray | None = None
    qd0: np.ndarray | None = None


def _plant(label: str, parts: dict[str, Any], ref_keys: dict[Any, Any] | None, memo: dict[Any, Any] | None = None) -> _Plant:
    """Check a built case's run size and sub-steps and pack what its cases share.

    ``memo``: the sweep's memo (see :func:`~forcecontrol.scenarios.build_case`); the arm's
    mobility at q0 is computed once per arm object and q0, and the plant once per robot,
    environment and reference object (cases sharing them share everything but the controller).
    """
    robot, env, ctl, ref = (parts[k] for k in ("robot", "environment", "controller", "reference"))
    if memo is None:
        return _new_plant(label, parts, ref_keys, memo)
    # what the plant depends on: the very robot, environment and reference objects (a sweep shares
    # them between cases with equal tables), the controller's sample time and whether it has a
    # compiled law (the controller itself only for a 6-D task's force direction), and the settings
    qd0 = parts["qd0"]
    extra = (id(env), id(ref), id(ctl) if robot.task_dim != 2 else None, float(ctl.sample_time),
             getattr(ctl, "compiled_law", None) is not None, parts.get("actuator") is None,
             parts["duration"], parts["substeps"], parts["settle_window"],
             np.asarray(parts["q0"], dtype=np.float64).tobytes(),
             None if qd0 is None else np.asarray(qd0, dtype=np.float64).tobytes())
    held = (env, ref, ctl if robot.task_dim != 2 else None)

    def new() -> tuple[Any, _Plant]:
        return held, _new_plant(label, parts, ref_keys, memo)

    _, template = _per_object(memo, "plant", robot, extra, new)  # the entry holds env, ref (and ctl): their ids stay theirs
    plant = _Plant.__new__(_Plant)  # the template with this case's parts (dataclasses.replace: 20 µs a case)
    plant.__dict__.update(template.__dict__)
    plant.parts = parts
    return plant


def _new_plant(label: str, parts: dict[str, Any], ref_keys: dict[Any, Any] | None, memo: dict[Any, Any] | None) -> _Plant:
    from ..errors import ParameterError
    from ..robots import PlanarTwoLink
    from ..sim.contact import _contact_guarded, contact_rate
    from ..sim.limits import check_run_size, check_substeps
    from ..sim.simulation import choose_substeps, contact_mobility, pre_start_wrench

    robot, env, ctl, ref = (parts[k] for k in ("robot", "environment", "controller", "reference"))
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
    rate = None
    if parts["substeps"] is not None:
        nsub = int(parts["substeps"])
        if _contact_guarded(env):  # an explicit substeps must let RK4 follow the contact (as in simulate())
            rate = contact_rate(robot, env, q0)
    else:
        def mobility() -> np.ndarray | None:
            try:
                return contact_mobility(robot, q0)
            except np.linalg.LinAlgError:  # choose_substeps falls back on B alone
                return None

        nsub = choose_substeps(robot, env, q0, Ts, mobility=_per_object(memo, "mobility", robot, (q0.tobytes(),), mobility))
    d, f_ref = _force_direction(env, ref, N * Ts, ctl, int(robot.task_dim))
    # the samples of the last settle_window, both ends included: the ones SimulationResult.settled_values averages
    # (t >= t_end - settle_window; round(settle_window / Ts) was one fewer, e.g. 100 of run's 101 at 0.1 s, 1 ms)
    window = int(math.floor(float(parts["settle_window"]) / Ts + 1e-9)) + 1
    compiled = (
        isinstance(robot, PlanarTwoLink) and getattr(env, "kind", 0) in (1, 2) and getattr(ctl, "compiled_law", None) is not None
        and robot.task_dim == 2
        and parts.get("actuator") is None  # friction, delay, quantisation: simulate() on the Python engine
    )
    try:
        check_substeps(nsub, N, Ts, float(env.max_stiffness()), "compiled" if compiled else "python",
                       rate=rate, explicit=parts["substeps"] is not None)
    except ParameterError as exc:
        raise SweepError(f"case {label!r}: {exc}") from exc
    # cases share a sampled reference only when the samples themselves are equal (a describe()
    # of a user's reference type need not say everything that shapes it)
    plant = _Plant(Ts, N, nsub, window, d, f_ref, _reference_key(ref, N, Ts, ref_keys), parts=parts, compiled=compiled)
    if compiled:
        plant.h0 = pre_start_wrench(robot, env, q0, qd0)
        plant.ref0 = ref.at(0.0)
        plant.K = np.array(robot._K, dtype=np.float64)
        plant.env_p = np.array(env.packed(), dtype=np.float64)
        plant.q0, plant.qd0 = q0, qd0
    return plant


def _first_sample(sensor: Any, dim: int) -> np.ndarray:
    """bias + the first noise sample: what the sensor reads at t = 0 on top of the true wrench."""
    bias, noise0 = sensor.sequences(1, dim)
    return bias + noise0[0]


def _batch_sensor(sensor: Any) -> bool:
    """The sensor runs in the batch kernel (a realistic sensor is stateful: simulate() runs it)."""
    return bool(getattr(sensor, "compiled_ok", True))


def _controllers_base() -> Any:
    """:mod:`forcecontrol.controllers.base`, imported on first use (this module is imported before the controllers)."""
    global _BASE
    if _BASE is None:
        from ..controllers import base

        _BASE = base
    return _BASE


_BASE: Any = None


def _job(case_id: int, label: str, values: dict[str, Any], plant: _Plant, sensor: Any, first: np.ndarray) -> CaseJob:
    """One case: the kernel's packed arrays (compiled plants and sensors) or its parts for simulate()."""
    p = plant.parts
    job = CaseJob(plant.Ts, plant.N, plant.nsub, plant.window, plant.d, plant.f_ref, plant.ref_key,
                  case_id=case_id, label=label, values=values, fast=False, reference=p["reference"], sensor=sensor)
    if not (plant.compiled and _batch_sensor(sensor)):
        job.parts = {k: p[k] for k in ("robot", "environment", "controller", "reference", "q0", "qd0", "actuator")}
        job.parts["sensor"] = sensor
        return job
    base = _controllers_base()

    ctl = p["controller"]
    # the controller's reset exactly as simulate() does it (same first noise sample); the packed
    # parameters and state are copied, so the next case may reset the same controller
    base.reset_prechecked(ctl, base.Measurement(plant.q0, plant.qd0, plant.h0 + first), plant.ref0)  # checked parts
    job.fast = True
    job.K, job.env_kind, job.env_p = plant.K, int(p["environment"].kind), plant.env_p
    job.law = ctl.compiled_law
    job.ctrl_p = np.array(ctl._params, dtype=np.float64)
    job.ctrl_s = np.array(ctl.state, dtype=np.float64)
    job.q0, job.qd0 = plant.q0, plant.qd0
    job.alpha = float(sensor.alpha(plant.Ts))
    return job
