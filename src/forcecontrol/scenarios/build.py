"""Building one case of a scenario into the library's objects (robot, environment, controller, reference, sensor, actuator)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ..errors import ForceControlError, ScenarioError
from ..robots import PlanarTwoLink, PlanarTwoLinkParameters
from ..sensors import ForceSensor
from ..sim.actuators import Actuator
from .build_share import PartShare, _shared_part
from .checks import METRICS, _check_expected_specs
from .model import _RICH_SENSOR_KEYS, ACTUATOR_FIELDS, ROBOT_FIELDS, SENSOR_FIELDS, TOP_FIELDS, CaseSpec
from .schema import CONTROLLERS, ENVIRONMENTS, REFERENCES, check_table, check_table_memo, check_value

__all__ = ["PartShare", "build_case", "build_sensor"]


def _allow_contact_loss(where: str, v: Any) -> bool:
    if not isinstance(v, bool):
        raise ScenarioError(f"{where}: key 'allow_contact_loss' must be true or false; got {v!r}")
    return v


def _part(where: str, table_name: str, table: Any, registry, ctx: dict[str, Any], memo: dict[Any, Any] | None = None):
    tw = f"{where}: [{table_name}]"
    if not isinstance(table, dict):
        raise ScenarioError(f"{tw}: must be a table; got {table!r}")
    kind = table.get("type")
    if not isinstance(kind, str) or kind not in registry:  # a list or table is not hashable: no TypeError
        raise ScenarioError(f"{tw}: key 'type' must be one of {', '.join(sorted(registry))}; got {kind!r}")
    spec = registry[kind]
    params = check_table_memo(memo, f"{tw} (type '{kind}')", table, spec.fields, extra_ok=("type",))
    try:
        return spec.build(params, ctx)
    except ScenarioError:
        raise
    except ForceControlError as exc:
        raise ScenarioError(f"{tw} (type '{kind}'): {exc}") from exc


#: built-in references that are pure functions of their table (no file, no context) and are not
#: changed once built: a sweep's memo shares one object between the cases with an equal table.
_SHARED_REFERENCES = ("setpoint", "linear-path", "path-on-plane")


def _shared_reference(where: str, table: Any, ctx: dict[str, Any], memo: dict[Any, Any] | None) -> Any:
    key = None
    if memo is not None and isinstance(table, dict) and table.get("type") in _SHARED_REFERENCES:
        try:
            key = ("reference", json.dumps(table, sort_keys=True))
        except (TypeError, ValueError):  # not plain data: built anew
            key = None
        if key is not None and key in memo:
            return memo[key]
    ref = _part(where, "reference", table, REFERENCES, ctx, memo)
    if key is not None:
        memo[key] = ref  # type: ignore[index]
    return ref


def build_case(case: CaseSpec, where: str = "<scenario>", memo: dict[Any, Any] | None = None, *,
               sensor: ForceSensor | None = None, share: PartShare | None = None) -> dict[str, Any]:
    """Build a case's parts: robot, environment, controller, reference, sensor, q0, settings.

    ``memo`` (a dict the caller keeps, e.g. for the cases of one sweep): tables equal to ones
    already checked are not checked again, and the chapter's planar arm (immutable) with its q0
    and the built-in set-point and path references are built once per distinct table. Every
    other part (environment, controller, sensor, any URDF robot) is built anew for each case.

    ``sensor``: a sensor the caller already built with :func:`build_sensor` from this case's
    ``[sensor]`` table at its sample time, used instead of building it again (a sweep shares
    one between the cases whose sensor values are equal).

    ``share`` (:class:`PartShare`): parts already built for cases whose keys are equal are
    returned again (the same objects), their tables not checked again; a sweep's compiled cases.
    """
    cfg = case.config
    if share is not None:
        top_key = ("top", share.keys["top"])
        if top_key in share._store:  # these top-level values passed the checks below
            hit = share._store.get(("robot", share.keys["top"], share.keys["robot"]))
            if hit is not None:
                rt, robot, q0 = hit
                return _build_rest(case, where, memo, rt, robot, q0.copy(), sensor, share)
        else:
            _check_top(where, case)
            share._store[top_key] = True
    else:
        _check_top(where, case)
    rt = check_table_memo(memo, f"{where}: [robot]", cfg["robot"], ROBOT_FIELDS)
    robot_key = None
    if memo is not None and rt["model"] in ("planar-2r", "chapter-arm"):
        robot_key = ("robot", json.dumps(rt, sort_keys=True, default=repr))
        if robot_key in memo:
            robot, q0 = memo[robot_key]
            if share is not None:
                share._store[("robot", share.keys["top"], share.keys["robot"])] = (rt, robot, q0.copy())
            return _build_rest(case, where, memo, rt, robot, q0.copy(), sensor, share)
    if rt.get("payload_weight_in_reading") and not rt.get("payload_mass"):
        raise ScenarioError(f"{where}: [robot]: key 'payload_weight_in_reading' needs a payload_mass > 0")
    if rt.get("payload_mass") is not None and rt["model"] not in ("ur5", "ur10"):
        raise ScenarioError(f"{where}: [robot]: key 'payload_mass' needs model = 'ur5' or 'ur10'; got model = {rt['model']!r}")
    if rt["model"] in ("panda", "ur5", "ur10", "urdf"):
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
            _check_joint_limits(where, robot, q0)
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
    if rt.get("servo") is not None:  # a position/velocity-interface arm: the robot seen through its servo
        from .servo_robot import servo_robot

        robot = servo_robot(where, rt["servo"], robot)
    if robot_key is not None:
        memo[robot_key] = (robot, q0.copy())  # type: ignore[index]
        if share is not None:
            share._store[("robot", share.keys["top"], share.keys["robot"])] = (rt, robot, q0.copy())
    return _build_rest(case, where, memo, rt, robot, q0, sensor, share)


def _check_top(where: str, case: CaseSpec) -> None:
    """The case's top-level keys: none unknown, the four tables present, substeps and windows in range, [expected]."""
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
            at = _key_where(where, case, key)
            v = check_value(at, key, TOP_FIELDS[key], cfg[key])
            if v < low or (key == "settle_window" and v == 0.0):
                raise ScenarioError(f"{at}: key '{key}' must be {what}; got {v!r}")
    _check_expected_specs(where, case.expected)


def _build_rest(case: CaseSpec, where: str, memo: dict[Any, Any] | None, rt: dict[str, Any], robot: Any,
                q0: np.ndarray, sensor: ForceSensor | None, share: PartShare | None = None) -> dict[str, Any]:
    """The parts after the robot: environment, controller, reference, sensor, actuator and the settings."""
    cfg = case.config
    times = None if share is None else share._store.get(("times", share.keys["top"]))
    if times is None:
        times = _times(where, case)
        if share is not None:
            share._store[("times", share.keys["top"])] = times
    Ts, duration = times
    ctx: dict[str, Any] = {"robot": robot, "sample_time": Ts, "q0": q0, "where": where}
    env = _shared_part(share, "environment", lambda c: _part(where, "environment", cfg["environment"], ENVIRONMENTS, c, memo),
                       ctx)
    ctx["environment"] = env
    ctl = _shared_part(share, "controller", lambda c: _part(where, "controller", cfg["controller"], CONTROLLERS, c, memo), ctx)
    ref = _shared_part(share, "reference", lambda c: _shared_reference(where, cfg["reference"], c, memo), ctx)
    sensor = build_sensor(where, cfg.get("sensor"), Ts) if sensor is None else sensor
    arm = getattr(robot, "torque_robot", robot)
    if getattr(arm, "payload", None) is not None:  # the sensor carries the payload: reads its inertial wrench
        if cfg.get("sensor"):
            raise ScenarioError(f"{where}: [sensor] cannot be combined with [robot] payload_mass (the payload's sensor is ideal)")
        from ..sensors import PayloadForceSensor

        sensor = PayloadForceSensor(arm, gravity_compensated=not rt.get("payload_weight_in_reading"))
    actuator = _actuator(where, cfg.get("actuator"), robot.nq)
    _check_delays(where, duration, Ts, sensor, actuator)
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


def _times(where: str, case: CaseSpec) -> tuple[Any, Any]:
    """The case's sample time and duration, checked positive."""
    cfg = case.config
    at = _key_where(where, case, "sample_time")
    Ts = check_value(at, "sample_time", TOP_FIELDS["sample_time"], cfg.get("sample_time", 1e-3))
    if Ts <= 0:
        raise ScenarioError(f"{at}: key 'sample_time' must be a positive number [s]; got {Ts!r}")
    at = _key_where(where, case, "duration")
    duration = check_value(at, "duration", TOP_FIELDS["duration"], cfg["duration"])
    if duration <= 0:
        raise ScenarioError(f"{at}: key 'duration' must be a positive number [s]; got {duration!r}")
    return Ts, duration


def _key_where(where: str, case: CaseSpec, key: str) -> str:
    """Where a top-level setting's value was written: the case's ``[[case]]`` table when it sets ``key`` (``where``
    as given), else the file's top level, whose value every case that does not set it takes (an error there named
    ``[[case]] #1``, a table that does not hold the key)."""
    head, sep, _ = where.rpartition(": [[case]] #")
    return where if not sep or key in case.overrides else f"{head}: top level"


def _check_joint_limits(where: str, robot: Any, q0: np.ndarray) -> None:
    """Refuse a q0 outside the robot's joint limits, when its model has them (a URDF's ``<limit>``)."""
    model = getattr(robot, "model", None)
    lo, hi = getattr(model, "lowerPositionLimit", None), getattr(model, "upperPositionLimit", None)
    if lo is None or hi is None:
        return
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if lo.shape != q0.shape or hi.shape != q0.shape:
        return
    bad = [i for i in range(q0.size) if np.isfinite(lo[i]) and np.isfinite(hi[i]) and lo[i] < hi[i]
           and not lo[i] - 1e-9 <= q0[i] <= hi[i] + 1e-9]
    if bad:
        i = bad[0]
        raise ScenarioError(
            f"{where}: [robot]: key 'q0' entry {i} must be within the joint's limits [{lo[i]:.6g}, {hi[i]:.6g}] [rad]; "
            f"got {q0[i]:.6g}"
        )


def _check_delays(where: str, duration: float, Ts: float, sensor: Any, actuator: Actuator | None) -> None:
    """A sensor's or actuator's delay of more samples than the run has would never deliver anything: refused."""
    samples = int(round(duration / Ts)) if Ts > 0 and duration / Ts < 1e15 else None
    if samples is None:
        return  # the run's size check refuses it with its own message
    for table, value in (("sensor", getattr(sensor, "delay_samples", 0)), ("actuator", getattr(actuator, "delay", 0))):
        if value > samples:
            raise ScenarioError(
                f"{where}: [{table}]: key 'delay_samples' must be in [0, {samples:,}] (at most the run's samples: "
                f"duration {duration:.6g} s / sample_time {Ts:.6g} s); got {value:,}: the delayed signal would never arrive"
            )


def build_sensor(where: str, table: Any, sample_time: float) -> ForceSensor:
    """The ``[sensor]`` table as a sensor (ideal when absent), checked at the case's sample time.

    Raises:
        ScenarioError: an unknown key, a value of the wrong type, or a sensor the sample time
            cannot realise (e.g. a cutoff above Nyquist); the message names the key.
    """
    Ts = sample_time
    st = check_table(f"{where}: [sensor]", table or {}, SENSOR_FIELDS)
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
    return sensor


def _actuator(where: str, table: Any, n: int) -> Actuator | None:
    """The ``[actuator]`` table as an :class:`~forcecontrol.sim.actuators.Actuator` (None without the table).

    Raises:
        ScenarioError: an unknown key, a value of the wrong type, a negative friction, delay or
            quantum, or a per-joint list without one entry per joint (the message names the key).
    """
    if table is None:
        return None
    d = table.get("delay_samples") if isinstance(table, dict) else None
    if isinstance(d, int) and not isinstance(d, bool) and d < 0:  # this message before the range's
        raise ScenarioError(f"{where}: [actuator]: key 'delay_samples' must be a whole number of samples >= 0; got {d!r}")
    at = check_table(f"{where}: [actuator]", table, ACTUATOR_FIELDS)
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
