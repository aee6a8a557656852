"""The sampled-data simulator: controller at Ts with zero-order hold, plant integrated between samples.

The loop, written out (this is exactly what :func:`simulate` does with ``engine="python"``)::

    for k in 0..N:
        t = k Ts
        h_e = environment.wrench(x(q), J q̇)          # true contact wrench
        h_m = sensor(h_e, k)                           # bias + noise, first-order low-pass
        u   = controller.step(t, Measurement(q, q̇, h_m), reference.at(t))
        log(t, q, q̇, x, ẋ, h_e, h_m, u, reference)
        integrate B q̈ + C q̇ + F q̇ + g = u − Jᵀ h_e over [t, t + Ts] with u held  (RK4, nsub steps)

With ``actuator=Actuator(...)`` (Python engine) the command passes through its quantiser and
delay line before it is held, and its joint friction ``τ_f(q̇)`` joins the plant inside every RK4
stage: ``B q̈ + C q̇ + F q̇ + τ_f(q̇) + g = u − Jᵀ h_e``.

``engine="compiled"`` runs the same loop compiled with Numba for the chapter's arm and the
built-in environments and controllers (the control laws are the very same compiled functions);
``engine="auto"`` picks it when it applies. The two engines agree to round-off (tested).
For a 6-D serial arm (Panda, UR) with a SpatialImpedanceController or AdmittanceController on a
Table or ConstantWrench, ``engine="compiled"`` runs :mod:`forcecontrol.sim.loop_tree` (about 10x
the Python engine's speed once compiled; its first run compiles for tens of seconds, so
``"auto"`` keeps the Python engine for 6-D arms).
"""

from __future__ import annotations

import math
import platform
import warnings
from typing import Any, Literal, cast

import numpy as np

from .. import __version__
from ..controllers.base import REFERENCE_FIELDS, Controller, Measurement, Reference
from ..core.validate import as_vector, positive_scalar
from ..environments.base import Environment
from ..errors import ContactModelWarning, DimensionError, ParameterError, SimulationDivergedError, SingularityError
from ..robots.base import RobotModel
from ..robots.planar_2r import PlanarTwoLink
from ..sensors import ForceSensor, RealisticForceSensor
from ..trajectories import ReferenceSignal
from .actuators import Actuator
from .contact import _contact_guarded, _unresolved_in_log, _unresolved_note, choose_substeps, contact_rate
from .contact import _largest_real_eigenvalue as _largest_real_eigenvalue
from .contact import contact_mobility as contact_mobility
from .limits import MAX_LOG_BYTES, RK4_STABILITY, check_run_size, check_substeps
from .result import SimulationResult

__all__ = ["simulate", "SimulationResult", "choose_substeps", "contact_rate", "pre_start_wrench"]

_CAUSES = {
    1: "non-finite state",
    2: "runaway",
    3: "singular jacobian",
    4: "non-finite torque",
    5: "unresolved contact",
}


def _versions() -> dict[str, str]:
    import numba

    return {
        "forcecontrol": __version__,
        "numpy": np.__version__,
        "numba": numba.__version__,
        "python": platform.python_version(),
    }


def pre_start_wrench(robot: RobotModel, environment: Environment, q0: np.ndarray, qd0: np.ndarray) -> np.ndarray:
    """The true contact wrench at t = 0 (what a controller's ``reset`` is shown, before the sensor).

    Before t = 0 the arm is held at rest by gravity compensation: a rigid environment's first
    reaction is computed under that torque (elastic environments ignore it).
    """
    return environment.sampled_wrench(robot, q0, qd0, np.asarray(robot.gravity(q0), dtype=np.float64))


def simulate(
    robot: RobotModel,
    environment: Environment,
    controller: Controller,
    reference: ReferenceSignal,
    *,
    q0: Any,
    duration: float,
    qd0: Any = None,
    sensor: ForceSensor | None = None,
    substeps: int | None = None,
    engine: Literal["auto", "python", "compiled"] = "auto",
    max_joint_speed: float = 50.0,
    label: str = "",
    metadata: dict[str, Any] | None = None,
    max_log_bytes: float = MAX_LOG_BYTES,
    actuator: Actuator | None = None,
) -> SimulationResult:
    """Simulate the closed loop for ``duration`` seconds at the controller's sample time.

    Args:
        robot: the plant (the full nonlinear model).
        environment: what the end-effector touches.
        controller: its ``sample_time`` is the control period Ts; it is ``reset`` first.
        reference: references as a function of time.
        q0: initial joint positions (n,) [rad]; qd0: initial velocities (zeros by default).
        duration: simulated time [s], > 0.
        sensor: force sensor model; exact by default. A sensor whose ``compiled_ok`` is False
            (a stateful one, e.g. RealisticForceSensor) runs in the Python loop through its
            ``start``/``measure`` hooks.
        substeps: RK4 steps per sample; by default from :func:`choose_substeps`.
        engine: ``"python"``, ``"compiled"`` (chapter arm, built-in parts) or ``"auto"``.
        max_joint_speed: a joint faster than this [rad/s] stops the run as a runaway.
        label: the case's label; metadata: extra metadata merged into the result's.
        max_log_bytes: memory the logs may take [bytes] (default 2 GiB): a longer run is refused
            before anything is allocated (see :mod:`forcecontrol.sim.limits`).
        actuator: joint friction, actuation delay and torque quantisation
            (:class:`~forcecontrol.sim.actuators.Actuator`); runs on the Python engine (``"auto"``
            picks it; ``"compiled"`` is refused). The log's ``torque`` is then the applied torque
            and ``torque_commanded`` the controller's.

    Raises:
        ParameterError: ``engine="compiled"`` with an actuator, or a bad argument.
        SimulationDivergedError: the state became non-finite, ran away or met a singularity;
            the message says when and where, ``err.partial`` holds the log up to then.
    """
    if not isinstance(controller, Controller):
        raise ParameterError(f"controller must be a forcecontrol Controller; got {type(controller).__name__}")
    if controller.robot is not robot and type(controller.robot) is not type(robot):
        raise ParameterError("controller.robot must be the simulated robot's model")
    n, m = int(robot.nq), int(robot.task_dim)
    if environment.dim != m:
        raise DimensionError(f"environment must be {m}-dimensional like the robot's task space; got {environment.dim}")
    if reference.dim != m:
        raise DimensionError(f"reference must be {m}-dimensional like the robot's task space; got {reference.dim}")
    q0 = np.array(as_vector("q0", q0, n))
    qd0 = np.zeros(n) if qd0 is None else np.array(as_vector("qd0", qd0, n))
    duration = positive_scalar("duration", duration)
    Ts = controller.sample_time
    max_qd = positive_scalar("max_joint_speed", max_joint_speed)
    sensor = ForceSensor() if sensor is None else sensor
    if not isinstance(sensor, ForceSensor):
        raise ParameterError(f"sensor must be a ForceSensor (e.g. RealisticForceSensor) or None; got {type(sensor).__name__}")
    if engine not in ("auto", "python", "compiled"):
        raise ParameterError(f"engine must be 'auto', 'python' or 'compiled'; got {engine!r}")
    N = check_run_size(duration, Ts, n, m, max_log_bytes)  # before anything is allocated
    if N < 1:
        raise ParameterError(f"duration must be at least one sample time ({Ts:.6g} s); got {duration:.6g} s")
    if actuator is not None:
        if not isinstance(actuator, Actuator):
            raise ParameterError(f"actuator must be a forcecontrol Actuator; got {type(actuator).__name__}")
        actuator.check(n)
    if substeps is None:
        nsub = choose_substeps(robot, environment, q0, Ts)
        if actuator is not None and actuator.has_friction:
            # friction's fastest rate: (F_v + τ_c / v_s) / λ_min(B), resolved like a contact mode (ω h <= 0.05)
            lam = float(np.linalg.eigvalsh(np.asarray(robot.mass_matrix(q0), dtype=np.float64)).min())
            slope = float(np.max(np.broadcast_to(actuator.viscous + actuator.coulomb / actuator.coulomb_band, (n,))))
            nsub = max(nsub, int(math.ceil(slope / max(lam, 1e-9) * Ts / 0.05)))
    else:
        if (isinstance(substeps, bool) or not isinstance(substeps, (int, float, np.integer, np.floating))
                or (isinstance(substeps, (float, np.floating)) and not math.isfinite(substeps))
                or int(substeps) != substeps or substeps < 1 or substeps > 2**31):
            raise ParameterError(f"substeps must be a positive integer; got {substeps!r}")
        nsub = int(substeps)
    # the contact's fastest mode at q0: an explicit substeps must let RK4 follow it (checked below)
    rate = contact_rate(robot, environment, q0) if substeps is not None and _contact_guarded(environment) else None
    times = np.arange(N + 1) * Ts
    refs = np.ascontiguousarray(reference.sample(times), dtype=np.float64)
    bias, noise = sensor.sequences(N + 1, m)
    alpha = sensor.alpha(Ts)

    compiled_ok = (
        isinstance(robot, PlanarTwoLink)
        and environment.kind in (1, 2, 3)
        and controller.compiled_law is not None
        and sensor.compiled_ok
    )
    tree_ok, why_6d = False, ""  # 6-D arms: sim/loop_tree.py, on request only (its first run compiles for tens of seconds)
    if engine == "compiled" and not compiled_ok and actuator is None and m == 6:
        from .loop_tree import tree_loop_support

        why_6d = tree_loop_support(robot, environment, controller, sensor) or ""
        tree_ok = compiled_ok = not why_6d
    if engine == "compiled" and not compiled_ok:
        missing = [what for what, ok in (
            (f"the robot is a {type(robot).__name__}, not the built-in planar arm", isinstance(robot, PlanarTwoLink)),
            (f"the environment {type(environment).__name__} has no compiled model", environment.kind in (1, 2, 3)),
            (f"the controller {type(controller).__name__} has no compiled law (e.g. gains that change every sample)",
             controller.compiled_law is not None),
            (f"the sensor {type(sensor).__name__} is not the simple ForceSensor", sensor.compiled_ok),
        ) if not ok]
        raise ParameterError(
            "engine='compiled' needs the built-in planar arm, a built-in environment and a "
            f"built-in controller (and the simple ForceSensor); got {type(robot).__name__}, "
            f"{type(environment).__name__}, {type(controller).__name__}, {type(sensor).__name__}"
            + (f": {'; '.join(missing)}" if missing and not why_6d else "")
            + (f"; for a 6-D arm: {why_6d}" if why_6d else "")
        )
    if actuator is not None:
        if engine == "compiled":
            raise ParameterError(
                "engine='compiled' does not model an actuator (friction, delay, quantisation); "
                "use engine='python' or 'auto' (which picks the Python loop when an actuator is given)"
            )
        compiled_ok = False
    use_compiled = compiled_ok and engine != "python"
    check_substeps(nsub, N, Ts, float(environment.max_stiffness()), "compiled" if use_compiled else "python",
                   rate=rate, explicit=substeps is not None)

    # a curved surface's projection that found no unique closest point (said after the run)
    take_projection_note = getattr(environment, "take_projection_note", None)
    if take_projection_note is not None:
        take_projection_note()  # forget what was evaluated before this run
    if getattr(environment, "stateful", False):  # e.g. friction's stick/slip (Python loop only: such environments have kind 0)
        environment.start(robot, q0, qd0, N + 1)  # type: ignore[attr-defined]
    # initial measurement for controllers whose reset depends on it
    h0 = pre_start_wrench(robot, environment, q0, qd0)
    rich = None if sensor.compiled_ok else cast("RealisticForceSensor", sensor)  # the stateful kind
    hm0 = h0 + bias + noise[0] if rich is None else rich.start(N + 1, m, Ts, h0, q0)
    controller.reset(Measurement(q0, qd0, hm0), reference.at(0.0))

    logs = {
        "q": np.full((N + 1, n), np.nan), "qd": np.full((N + 1, n), np.nan),
        "x": np.full((N + 1, m), np.nan), "xd": np.full((N + 1, m), np.nan),
        "wrench": np.full((N + 1, m), np.nan), "wrench_measured": np.full((N + 1, m), np.nan),
        "torque": np.full((N + 1, n), np.nan),
    }
    if actuator is not None:
        logs["torque_commanded"] = np.full((N + 1, n), np.nan)
    meta = {
        "label": label,
        "robot": type(robot).__name__,
        "environment": environment.describe(),
        "controller": {"type": type(controller).__name__, **controller.gains()},
        "reference": reference.describe(),
        "sensor": sensor.describe(),
        "sample_time": Ts,
        "duration": duration,
        "substeps": nsub,
        "engine": "compiled" if use_compiled else "python",
        **({"actuator": actuator.describe()} if actuator is not None else {}),
        "versions": _versions(),
        **(metadata or {}),
    }
    if use_compiled and tree_ok:
        from .loop_tree import run_tree_loop

        status, k = run_tree_loop(robot, environment, controller, refs, bias, noise, alpha, q0, qd0, Ts, nsub, max_qd, logs)
    elif use_compiled:
        from .loop import planar_loop

        status, k = planar_loop(controller.compiled_law)(
            cast(PlanarTwoLink, robot)._K, environment.kind, environment.packed(), controller._params,
            controller.state, refs, bias, noise, alpha, q0, qd0, Ts, nsub, max_qd,
            logs["q"], logs["qd"], logs["x"], logs["xd"], logs["wrench"], logs["wrench_measured"], logs["torque"],
        )
    else:
        status, k = _python_loop(
            robot, environment, controller, refs, bias, noise, alpha, q0, qd0, Ts, nsub, max_qd, logs, sensor=rich,
            actuator=actuator,
        )
    events = [dict(e) for e in getattr(controller, "events", [])]
    projection = take_projection_note() if take_projection_note is not None else None
    if projection:
        warnings.warn(f"{label or 'simulate'}: {projection}", ContactModelWarning, stacklevel=2)
        events.append({"event": "contact-projection", "detail": projection})
    if events:
        meta["events"] = events  # saved with the log's metadata
    signals = _controller_signals(controller, times.shape[0])
    if getattr(environment, "stateful", False):
        signals.update(environment.signals())  # type: ignore[attr-defined]
    result = SimulationResult(t=times, reference=refs, label=label, metadata=meta, events=events, signals=signals, **logs)
    note = ""
    if use_compiled and status in (0, 1, 2):  # no guard inside the compiled loop: the samples in contact, after
        unresolved, first, why = _unresolved_in_log(robot, environment, logs, Ts / nsub, int(k))
        if unresolved:  # the cause of a blow-up or runaway that follows, or of a run that went on regardless
            status, k, note = unresolved, first, why
    elif status == 5:
        note = _unresolved_note(robot, environment, logs["q"][k], Ts / nsub)
    if status != 0:
        _raise_diverged(result, int(status), int(k), Ts, max_qd, note)
    return result


def _controller_signals(controller: Controller, rows: int) -> dict[str, np.ndarray]:
    """The controller's per-sample signals (its ``signals()``), padded with NaN to the log's length.

    ``rows`` is the length of the log, N+1 (a run that diverged logged fewer: the rest is NaN).
    """
    fn = getattr(controller, "signals", None)
    if not callable(fn):
        return {}
    out: dict[str, np.ndarray] = {}
    for name, v in fn().items():
        v = np.asarray(v, dtype=np.float64)
        if v.shape[0] > rows:
            raise ParameterError(
                f"controller signal {name!r} has {v.shape[0]} rows for a run of {rows} samples; "
                "a controller must log one row per step (and reset its log in reset())"
            )
        full = np.full((rows,) + v.shape[1:], np.nan)
        full[: v.shape[0]] = v
        out[str(name)] = full
    return out


def _raise_diverged(result: SimulationResult, status: int, k: int, Ts: float, max_qd: float, note: str = "") -> None:
    cause = _CAUSES.get(status, "unknown")
    t = k * Ts
    q = result.q[k]
    detail = {
        1: "the state became NaN or infinite during integration",
        2: f"a joint speed exceeded max_joint_speed = {max_qd:.6g} rad/s",
        3: "the Jacobian is singular and the control law cannot invert it",
        4: "the controller returned a NaN or infinite torque",
        5: note,
    }.get(status, "")
    sl = slice(0, k + 1)
    partial = SimulationResult(
        t=result.t[sl], q=result.q[sl], qd=result.qd[sl], x=result.x[sl], xd=result.xd[sl],
        wrench=result.wrench[sl], wrench_measured=result.wrench_measured[sl], torque=result.torque[sl],
        reference=result.reference[sl], label=result.label, metadata=result.metadata, events=result.events,
        signals={name: v[sl] for name, v in result.signals.items()},
        torque_commanded=None if result.torque_commanded is None else result.torque_commanded[sl],
    )
    err = SimulationDivergedError(
        f"simulation '{result.label or 'case'}' diverged at t = {t:.4f} s (sample {k}): {cause}: {detail}; "
        f"q = {np.round(q, 6).tolist()}, tip = {np.round(result.x[k], 6).tolist()}, "
        f"contact force = {np.round(result.wrench[k], 3).tolist()} N",
        time=t, step=k, cause=cause, q=q,
    )
    err.partial = partial  # type: ignore[attr-defined]
    raise err


def _pose(T: Any) -> tuple[np.ndarray, np.ndarray]:
    return T.x, T.xd


def _python_loop(
    robot, environment, controller, refs, bias, noise, alpha, q0, qd0, Ts, nsub, max_qd, logs, sensor=None, actuator=None
):
    """The reference loop in plain Python/NumPy (any robot, environment, controller, sensor, actuator)."""
    N = refs.shape[0] - 1
    m = int(robot.task_dim)
    q, qd = q0.copy(), qd0.copy()
    hm = np.zeros(m)
    dt = Ts / nsub
    hdt, sdt = 0.5 * dt, dt / 6.0
    planar = q0.shape[0] == 2
    robot_nq = q0.shape[0]
    # (x, ẋ) of a sample: from the kinematics alone where the robot offers it (terms' x and, to round-off, its J q̇);
    # an elastic environment's sampled wrench is its wrench there (Environment.sampled_wrench, without a second call)
    pose_twist = getattr(robot, "pose_twist", None)
    elastic_sample = pose_twist is not None and type(environment).sampled_wrench is Environment.sampled_wrench

    u = np.asarray(robot.gravity(q0), dtype=np.float64)  # held before t = 0 (see pre_start_wrench)
    friction = actuator.friction if actuator is not None and actuator.has_friction else None
    line = actuator.start(robot.nq, u) if actuator is not None else None

    # the contact at any RK4 stage of the sample (it may come and go between two samples)
    touched = [False]
    guard = _contact_guarded(environment)
    stateful = getattr(environment, "stateful", False)
    next_check = 0  # the contact mode is checked on a contact's first sample, then every 32 with a 2x margin

    def accel(q, qd, u):
        a, h = environment.acceleration(robot, q, qd, u if friction is None else u - friction(qd))
        if np.count_nonzero(h):  # h.any(), a fifth of its cost on a 6-vector (NaN counts as in contact)
            touched[0] = True
        return np.asarray(a, dtype=np.float64)

    for k in range(N + 1):
        t = k * Ts
        x, xd = pose_twist(q, qd) if pose_twist is not None else _pose(robot.terms(q, qd))
        if elastic_sample:
            h = np.asarray(environment.wrench(x, xd), dtype=np.float64)
        else:
            h = environment.sampled_wrench(robot, q, qd, u if friction is None else u - friction(qd))
        if sensor is not None:  # stateful sensor model (started in simulate)
            hm = sensor.measure(k, t, h, q)
        else:
            raw = h + bias + noise[k]
            hm = raw.copy() if k == 0 else hm + alpha * (raw - hm)
        row = refs[k]
        ref = Reference(*(row[i * m : (i + 1) * m] for i in range(len(REFERENCE_FIELDS))))
        try:
            u = np.asarray(controller.step(t, Measurement(q.copy(), qd.copy(), hm.copy()), ref), dtype=np.float64)
            status = 0 if all(map(math.isfinite, u.tolist())) else 4
            if line is not None:
                logs["torque_commanded"][k] = u
                if not status:
                    u = line.apply(u)
        except SingularityError:
            u = np.full(robot.nq, np.nan)
            status = 3
        logs["q"][k], logs["qd"][k], logs["x"][k], logs["xd"][k] = q, qd, x, xd
        logs["wrench"][k], logs["wrench_measured"][k], logs["torque"][k] = h, hm, u
        if stateful:
            environment.log_sample(k, x, xd)
        if status:
            return status, k
        if k == N:
            break
        try:
            for _ in range(nsub) if not planar else ():
                a1 = accel(q, qd, u)
                v2 = qd + 0.5 * dt * a1
                a2 = accel(q + 0.5 * dt * qd, v2, u)
                v3 = qd + 0.5 * dt * a2
                a3 = accel(q + 0.5 * dt * v2, v3, u)
                v4 = qd + dt * a3
                a4 = accel(q + dt * v3, v4, u)
                q = q + dt / 6.0 * (qd + 2 * v2 + 2 * v3 + v4)
                qd = qd + dt / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
                if stateful:
                    environment.advance(robot, q, qd)
            for _ in range(nsub) if planar else ():  # the same arithmetic on scalars (2 joints: no small arrays)
                q_0, q_1 = q.tolist()
                w_0, w_1 = qd.tolist()
                a10, a11 = accel(q, qd, u).tolist()
                v20, v21 = w_0 + hdt * a10, w_1 + hdt * a11
                a20, a21 = accel(np.array((q_0 + hdt * w_0, q_1 + hdt * w_1)), np.array((v20, v21)), u).tolist()
                v30, v31 = w_0 + hdt * a20, w_1 + hdt * a21
                a30, a31 = accel(np.array((q_0 + hdt * v20, q_1 + hdt * v21)), np.array((v30, v31)), u).tolist()
                v40, v41 = w_0 + dt * a30, w_1 + dt * a31
                a40, a41 = accel(np.array((q_0 + dt * v30, q_1 + dt * v31)), np.array((v40, v41)), u).tolist()
                q = np.array((q_0 + sdt * (w_0 + 2 * v20 + 2 * v30 + v40), q_1 + sdt * (w_1 + 2 * v21 + 2 * v31 + v41)))
                qd = np.array((w_0 + sdt * (a10 + 2 * a20 + 2 * a30 + a40), w_1 + sdt * (a11 + 2 * a21 + 2 * a31 + a41)))
                if stateful:
                    environment.advance(robot, q, qd)
        except np.linalg.LinAlgError:
            return 1, k
        if guard and touched[0] and k >= next_check:
            # the contact was met within this sample: can RK4 follow it here? (status 5 if not)
            try:
                ratio = contact_rate(robot, environment, q if np.all(np.isfinite(q)) else logs["q"][k]) * dt
            except np.linalg.LinAlgError:
                ratio = 0.0
            if ratio > RK4_STABILITY:
                return 5, k
            next_check = k + (1 if ratio > 0.5 * RK4_STABILITY else 32)
        elif guard and not touched[0]:
            next_check = 0  # out of contact: the next contact is checked at once
        touched[0] = False
        state = q.tolist() + qd.tolist()
        if not all(map(math.isfinite, state)):
            return 1, k
        if max(map(abs, state[robot_nq:])) > max_qd:
            return 2, k
    return 0, N
