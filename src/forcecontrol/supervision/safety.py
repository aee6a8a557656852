"""A safety layer composable around any controller: limits, reactions and a log of what happened.

:class:`Safety` wraps a :class:`~forcecontrol.controllers.base.Controller` and is itself one, so
it runs in :func:`~forcecontrol.sim.simulation.simulate` and in a user's own loop alike. Each sample::

    if stopped:            u = g(q) + K_hold (q_hold − q) − D_hold q̇          (safe stop: hold position)
    elif |h_e| > f_max or |ẋ_e| > v_max or |S (x_d − x_e)| > e_max:
                           stop: q_hold ← q, log, u = hold law
    else:                  u = controller.step(t, measurement, reference)
    |u_i| > τ_max,i        → clamp to ±τ_max,i (or stop), log at onset
    |u_i − u_i,prev| > τ̇_max,i Ts → clamp to u_prev ± τ̇_max,i Ts (or stop), log at onset

Actuator limits (torque, torque rate) are applied to every command, the hold law's included,
since no motor can exceed them. Cartesian limits (contact force, tip speed, deviation from the
reference path) cannot be clamped by the torque: their reaction is the safe stop, a stop that
holds the position where the violation was detected (a category-2 stop). The wrapped
controller is not stepped while stopped (its integrators freeze); :meth:`Safety.reset` clears
the stop. The first command after a reset is not rate-limited (the torque applied before it is
not known to the layer).

Every reaction is logged in :attr:`Safety.events` (and so in ``SimulationResult.events``) with
the time, the cause, the value, the limit and the reaction (``"clamp"``, ``"stop"``, or
``"holding"`` for a Cartesian violation while a stop is already in force), once per episode
(when a violation starts); the number of violating samples per cause is in :attr:`Safety.counts`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any, ClassVar, Literal, cast

import numpy as np

from ..controllers.base import Controller, Measurement, Reference
from ..core.validate import as_gain_matrix, positive_scalar
from ..errors import DimensionError, ParameterError

__all__ = ["Safety", "SAFETY_CAUSES"]

#: the causes a :class:`Safety` layer can log.
SAFETY_CAUSES = ("torque limit", "torque rate limit", "force limit", "speed limit", "path deviation limit")


def _limit(name: str, value: Any, size: int, unit: str) -> np.ndarray | None:
    """None, or a positive finite limit broadcast to (size,)."""
    if value is None:
        return None
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a positive number or ({size},) vector [{unit}]; got {value!r}") from exc
    if a.ndim == 0:
        a = np.full(size, float(a))
    if a.shape != (size,):
        raise DimensionError(f"{name} must be a scalar or have shape ({size},) [{unit}]; got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a <= 0.0):
        raise ParameterError(f"{name} must be positive and finite [{unit}]; got {a.tolist()}")
    a.flags.writeable = False
    return a


def _scalar_limit(name: str, value: Any, unit: str) -> float | None:
    """None, or a positive finite scalar limit."""
    a = _limit(name, value, 1, unit)
    return None if a is None else float(a[0])


class Safety(Controller):
    """Limits and reactions around a controller; logs every reaction with time and cause.

    Inputs and output as the wrapped controller: ``measurement`` (q, q̇ (n,), h_e (m,) [N]),
    ``reference`` (x_d (m,) [m] for the deviation limit); torques (n,) [N m].

    Args:
        controller: the controller to protect (any :class:`Controller`, another wrapper too).
        max_torque: τ_max per joint [N m], scalar or (n,); None = no limit.
        max_torque_rate: τ̇_max per joint [N m/s], scalar or (n,); None = no limit.
        max_force: largest contact force norm ‖h_e‖ [N]; None = no limit.
        max_speed: largest tip speed ‖ẋ_e‖ [m/s]; None = no limit.
        max_path_deviation: largest ‖S (x_d − x_e)‖ [m]; None = no limit. In a 6-D task space
            these three act on the linear parts only (‖f_e‖, ‖ȯ_e‖, the position error).
        deviation_axes: (m,) booleans, the motion-controlled axes S the deviation is measured on
            (all axes by default; leave force-controlled axes out).
        torque_reaction: ``"clamp"`` (saturate, default) or ``"stop"`` for the actuator limits.
        hold_stiffness: K_hold of the safe stop, (n, n) or scalar [N m/rad]. By default it is
            scaled to the arm: ``K_hold = diag(b_ii) ω²`` with b_ii the joint inertias B(q) at the
            stop posture and ``ω = hold_frequency``, so the hold is equally stiff, and stable at
            1 kHz, on the chapter's arm (b_ii ≈ 120–180 kg m²: about 5e4 N m/rad) and on a Panda
            wrist (0.007 kg m²), where fixed gains of that size diverge within a few samples.
            A stop during an impact must brake the arm: with 5000 N m/rad and 1000 N m s/rad on
            the chapter's arm a 60 N force-limit stop lets the impact reach 116 N, more than
            without the layer (81 N, scenario ``impact-safety``); with the defaults it stays lower.
        hold_damping: D_hold of the safe stop, (n, n) or scalar [N m s/rad]; by default
            ``diag(b_ii) 2 ζ ω`` with ``ζ = hold_damping_ratio``.
        hold_frequency: ω of the default hold law [rad/s].
        hold_damping_ratio: ζ of the default hold law.

    Raises:
        ParameterError: a limit is zero, negative or not finite; an unknown reaction.
        DimensionError: a limit's shape does not match the joints or axes.
    """

    kind: ClassVar[int] = 0

    def __init__(
        self,
        controller: Controller,
        *,
        max_torque: Any = None,
        max_torque_rate: Any = None,
        max_force: float | None = None,
        max_speed: float | None = None,
        max_path_deviation: float | None = None,
        deviation_axes: Any = None,
        torque_reaction: Literal["clamp", "stop"] = "clamp",
        hold_stiffness: Any = None,
        hold_damping: Any = None,
        hold_frequency: float = 18.0,
        hold_damping_ratio: float = 1.5,
    ) -> None:
        if not isinstance(controller, Controller):
            raise ParameterError(f"controller must be a forcecontrol Controller; got {type(controller).__name__}")
        super().__init__(controller.robot, controller.sample_time)
        self.controller = controller
        n, m = int(self.robot.nq), self.m
        self.max_torque = _limit("max_torque", max_torque, n, "N m")
        self.max_torque_rate = _limit("max_torque_rate", max_torque_rate, n, "N m/s")
        self.max_force = _scalar_limit("max_force", max_force, "N")
        self.max_speed = _scalar_limit("max_speed", max_speed, "m/s")
        self.max_path_deviation = _scalar_limit("max_path_deviation", max_path_deviation, "m")
        axes = np.ones(m, dtype=bool) if deviation_axes is None else np.asarray(deviation_axes, dtype=bool).reshape(-1)
        if axes.shape != (m,):
            raise DimensionError(f"deviation_axes must have shape ({m},); got shape {axes.shape}")
        self.deviation_axes = axes
        if torque_reaction not in ("clamp", "stop"):
            raise ParameterError(f"torque_reaction must be 'clamp' or 'stop'; got {torque_reaction!r}")
        self.torque_reaction = torque_reaction
        if (hold_stiffness is None) != (hold_damping is None):
            raise ParameterError("hold_stiffness and hold_damping must be given together (or neither, for the scaled default)")
        self.hold_frequency = positive_scalar("hold_frequency", hold_frequency)
        self.hold_damping_ratio = positive_scalar("hold_damping_ratio", hold_damping_ratio)
        self.hold_stiffness: np.ndarray | None = (
            None if hold_stiffness is None else as_gain_matrix("hold_stiffness", hold_stiffness, n)
        )
        self.hold_damping: np.ndarray | None = (
            None if hold_damping is None else as_gain_matrix("hold_damping", hold_damping, n)
        )
        self._hold_gains: tuple[np.ndarray, np.ndarray] | None = None
        self.uses_force = controller.uses_force  # type: ignore[misc]
        self._events: list[dict[str, Any]] = []
        self.counts: dict[str, int] = {c: 0 for c in SAFETY_CAUSES}
        self._active: set[str] = set()
        self.q_hold: np.ndarray | None = None
        self.stop_time: float | None = None
        self._u_prev: np.ndarray | None = None

    # ------------------------------------------------------------------ state
    @property
    def stopped(self) -> bool:
        """True after a safe stop, until :meth:`reset`."""
        return self.q_hold is not None

    @property
    def events(self) -> list[dict[str, Any]]:
        """This layer's reactions and the wrapped controller's events, in time order."""
        inner = list(getattr(self.controller, "events", []))
        return sorted(self._events + inner, key=lambda e: e["t"])

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Reset the wrapped controller, clear the stop, the log and the rate-limit memory.

        Warns:
            UserWarning: τ_max is below the gravity torque at the measured pose: a safe stop
                could not hold the arm there.
        """
        if measurement is not None and self.max_torque is not None:
            g = np.abs(self.robot.gravity(np.asarray(measurement.q, dtype=np.float64)))
            if np.any(g > self.max_torque):
                warnings.warn(
                    f"max_torque {self.max_torque.tolist()} N m is below the gravity torque {np.round(g, 3).tolist()} N m "
                    "at the start pose: a safe stop cannot hold the arm there",
                    UserWarning,
                    stacklevel=2,
                )
        self.controller.reset(measurement, reference)
        self._events.clear()
        self.counts = {c: 0 for c in SAFETY_CAUSES}
        self._active.clear()
        self.q_hold = None
        self.stop_time = None
        self._u_prev = None

    def gains(self) -> dict[str, Any]:
        return {
            "wrapped": {"type": type(self.controller).__name__, **self.controller.gains()},
            "max_torque": None if self.max_torque is None else self.max_torque.tolist(),
            "max_torque_rate": None if self.max_torque_rate is None else self.max_torque_rate.tolist(),
            "max_force": self.max_force,
            "max_speed": self.max_speed,
            "max_path_deviation": self.max_path_deviation,
            "torque_reaction": self.torque_reaction,
        }

    # ------------------------------------------------------------------ logging
    def _log(self, t: float, cause: str, value: float, limit: float, reaction: str, detail: str) -> None:
        self._events.append({
            "t": float(t), "event": "safety", "cause": cause, "value": float(value), "limit": float(limit),
            "reaction": reaction, "detail": detail,
        })

    def _episode(self, t: float, cause: str, violated: bool, value: float, limit: float, reaction: str,
                 detail: Callable[[], str]) -> None:
        """Log at the start of a violation episode (the message is built only then); count every violating sample."""
        if violated:
            self.counts[cause] += 1
            if cause not in self._active:
                self._active.add(cause)
                self._log(t, cause, value, limit, reaction, detail())
        elif self._active:
            self._active.discard(cause)

    def _stop(self, t: float, q: np.ndarray) -> None:
        if self.q_hold is None:
            self.q_hold = np.array(q, dtype=np.float64)
            self.stop_time = float(t)
            if self.hold_stiffness is not None and self.hold_damping is not None:
                self._hold_gains = (self.hold_stiffness, self.hold_damping)
            else:  # scaled to the joint inertias at the stop posture
                b = np.diag(np.asarray(self.robot.mass_matrix(self.q_hold), dtype=np.float64))
                w, z = self.hold_frequency, self.hold_damping_ratio
                self._hold_gains = (np.diag(b * w * w), np.diag(b * 2.0 * z * w))

    # ------------------------------------------------------------------ the law
    def _hold_torque(self, measurement: Measurement) -> np.ndarray:
        q = np.asarray(measurement.q, dtype=np.float64)
        qd = np.asarray(measurement.qd, dtype=np.float64)
        q_hold = cast(np.ndarray, self.q_hold)  # set by _stop before any call
        K, D = cast(tuple[np.ndarray, np.ndarray], self._hold_gains)
        return self.robot.gravity(q) + K @ (q_hold - q) - D @ qd

    def _cartesian(self, t: float, measurement: Measurement, reference: Reference) -> None:
        q = np.asarray(measurement.q, dtype=np.float64)
        # a 6-D task space: the limits act on the linear parts (force, linear velocity, position);
        # moments and angles have other units, and Euler angles wrap at ±π
        lin = slice(0, 3) if self.m == 6 else slice(0, self.m)
        checks: list[tuple[str, float, float, str, str]] = []
        if self.max_force is not None:
            w = np.asarray(getattr(measurement.wrench, "vector", measurement.wrench), dtype=np.float64)[lin]
            checks.append(("force limit", math.sqrt(float(w @ w)), self.max_force, "contact force |h_e|", "N"))
        if self.max_speed is not None:
            v = (self.robot.jacobian(q) @ np.asarray(measurement.qd, dtype=np.float64))[lin]
            checks.append(("speed limit", math.sqrt(float(v @ v)), self.max_speed, "tip speed |xdot_e|", "m/s"))
        if self.max_path_deviation is not None:
            d = (np.asarray(reference.position) - self.robot.forward_kinematics(q))[lin]
            e = np.where(self.deviation_axes[lin], d, 0.0)
            checks.append(("path deviation limit", math.sqrt(float(e @ e)), self.max_path_deviation,
                           "deviation |S (x_d - x_e)|", "m"))
        for cause, value, limit, what, unit in checks:
            violated = value > limit
            if not violated and cause not in self._active:
                continue  # the usual sample: within the limit and no episode to close
            stopping = violated and not self.stopped
            if stopping:
                self._stop(t, q)

            def detail(what=what, value=value, limit=limit, unit=unit, stopping=stopping) -> str:
                msg = f"{what} = {value:.6g} {unit} > {limit:.6g} {unit}"
                return f"{msg}; safe stop, holding q = {np.round(q, 6).tolist()}" if stopping else msg

            # already holding: the violation is logged, the stop that is in force is the reaction
            self._episode(t, cause, violated, value, limit, "stop" if stopping or not self.stopped else "holding", detail)

    def _actuator(self, t: float, u: np.ndarray, measurement: Measurement) -> np.ndarray:
        u = np.array(u, dtype=np.float64)
        reaction = self.torque_reaction
        if self.max_torque is not None:
            tau_max = self.max_torque
            over = bool((np.abs(u) > tau_max).any())
            if over or "torque limit" in self._active:
                j = int(np.argmax(np.abs(u) / tau_max))
                value, stopping = float(abs(u[j])), over and reaction == "stop" and not self.stopped
                if stopping:
                    self._stop(t, measurement.q)
                    u = self._hold_torque(measurement)
                self._episode(
                    t, "torque limit", over, value, float(tau_max[j]), "stop" if stopping else "clamp",
                    lambda: f"joint {j + 1}: |u| = {value:.6g} N m > {tau_max[j]:.6g} N m" + ("; safe stop" if stopping else ""),
                )
                u = np.clip(u, -tau_max, tau_max)
        if self.max_torque_rate is not None and self._u_prev is not None:
            rate_max, u_prev = self.max_torque_rate, self._u_prev
            step = rate_max * self.sample_time
            du = u - u_prev
            over = bool((np.abs(du) > step * (1.0 + 1e-12)).any())
            if over or "torque rate limit" in self._active:
                j = int(np.argmax(np.abs(du) / step))
                rate, stopping = float(abs(du[j])) / self.sample_time, over and reaction == "stop" and not self.stopped
                if stopping:
                    self._stop(t, measurement.q)
                self._episode(
                    t, "torque rate limit", over, rate, float(rate_max[j]), "stop" if stopping else "clamp",
                    lambda: f"joint {j + 1}: |du/dt| = {rate:.6g} N m/s > {rate_max[j]:.6g} N m/s"
                    + ("; safe stop" if stopping else ""),
                )
                u = np.clip(u, u_prev - step, u_prev + step)
        return u

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """The wrapped controller's torques within the limits, or the hold law after a stop."""
        self._cartesian(t, measurement, reference)
        if self.stopped:
            u = self._hold_torque(measurement)
        else:
            u = np.asarray(self.controller.step(t, measurement, reference), dtype=np.float64)
        u = self._actuator(t, u, measurement)
        self._u_prev = u.copy()
        return u
