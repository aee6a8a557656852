"""Controllers of position- and velocity-interface arms: a law that commands joints at the interface rate.

A :class:`PositionInterfaceController` runs its :meth:`~PositionInterfaceController.command`
once per interface cycle (every ``N = T_i / Ts`` steps, with the measurement of that instant)
and passes the joint command through the arm's own servo
(:class:`~forcecontrol.robots.servo.JointServo`: delay, low-pass, second-order servo, limits),
which produces the joint torques at every step ``Ts`` on the arm's full dynamics::

    every step t_j = j Ts:
        if j mod N == 0:   (q_c, q̇_c) = command(t_j, measurement, reference)   → delay line
        u = servo torque (q, q̇, terms, h)                                      → held for Ts

So a vendor's or the chapter's outer law is written once as ``command``; the simulator, the
user's loop and the analysis see the same sampled structure. State: ``state = [servo state;
law state]`` (the law's part is :attr:`PositionInterfaceController.law_state`, of
:meth:`PositionInterfaceController.law_state_size` floats).

Inputs: ``measurement.q, .qd`` (n,), ``measurement.wrench`` h_e (m,) (the ideal servo
compensates it); output: torques (n,) [N m].
"""

from __future__ import annotations

import warnings
from abc import abstractmethod
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..robots.ik import JointCommand
from ..robots.servo import PositionInterfaceRobot, ServoRuntime
from .base import Controller, Measurement, Reference

__all__ = ["PositionInterfaceController", "JointCommandPlayback", "JointCommand"]


class PositionInterfaceController(Controller):
    """Base of the controllers of position/velocity-interface arms (see the module docstring).

    Subclasses implement :meth:`command` (once per interface cycle) and, when they keep state,
    :meth:`law_state_size` and :meth:`reset_law`.

    Args:
        robot: a :class:`~forcecontrol.robots.servo.PositionInterfaceRobot` (the torque robot and its servo).
        sample_time: the simulation/servo step Ts [s]; the interface period ``1/servo.rate`` must be a
            whole multiple of it.
    """

    GAINS: Any = ("servo_description",)

    def __init__(self, robot: PositionInterfaceRobot, sample_time: float = 2e-4) -> None:
        if not isinstance(robot, PositionInterfaceRobot):
            raise ParameterError(
                f"robot must be a PositionInterfaceRobot (a torque robot with its JointServo); got {type(robot).__name__}"
            )
        super().__init__(robot, sample_time)
        self.servo = robot.servo
        self._rt = ServoRuntime(self.servo, self.sample_time)
        self.steps_per_cycle = self._rt.N
        self.interface_period = self.servo.period
        ns = self._rt.size()
        self.state = np.zeros(ns + int(self.law_state_size()))
        self._servo_state = self.state[:ns]
        self.law_state = self.state[ns:]
        self._log_cmd: list[np.ndarray] = []
        self._log_ref: list[np.ndarray] = []
        self.servo_description = self.servo.describe()
        self.limited_cycles = 0
        self._events: list[dict[str, Any]] = []
        self._episodes: set[str] = set()

    # -- what a subclass writes
    def law_state_size(self) -> int:
        """Floats of state the law keeps (in :attr:`law_state`)."""
        return 0

    def reset_law(self, measurement: Measurement | None, reference: Reference | None) -> None:
        """Set the law's state at the start (``law_state`` is zero when this is called)."""

    @abstractmethod
    def command(self, t: float, measurement: Measurement, reference: Reference) -> JointCommand:
        """This interface cycle's joint command: positions q_c (n,) [rad] (ignored by a velocity
        interface) and velocities q̇_c (n,) [rad/s] (feed-forward, or the command of a velocity interface)."""

    # -- the sampled structure
    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Servo at rest on the measured q (zeros without a measurement); then the law's reset."""
        q0 = np.zeros(self.robot.nq) if measurement is None else np.asarray(measurement.q, dtype=np.float64)
        self.state[:] = 0.0
        self._rt.start(self._servo_state, q0)
        self._log_cmd, self._log_ref = [], []
        self.limited_cycles = 0
        self._events, self._episodes = [], set()
        self.reset_law(measurement, reference)

    @property
    def events(self) -> list[dict[str, Any]]:
        """When a limit started to change what was commanded (``servo-limit``, ``ik-limit``), in time order."""
        return list(self._events)

    def _episode(self, t: float, kind: str, active: bool, detail: Any) -> None:
        """Log (and warn, once per run and kind) at the start of an episode where a limit changes the command."""
        if not active:
            self._episodes.discard(kind)
            return
        if kind in self._episodes:
            return
        self._episodes.add(kind)
        first = not any(e["event"] == kind for e in self._events)
        text = detail()
        self._events.append({"t": float(t), "event": kind, "detail": text})
        if first:
            warnings.warn(f"{type(self).__name__} at t = {t:.6g} s: {text} (logged in the run's events)", UserWarning,
                          stacklevel=4)

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques for one step Ts; a new joint command every ``steps_per_cycle`` steps."""
        s = self._servo_state
        if self._rt.is_tick(s):
            cmd = self.command(t, measurement, reference)
            q_c = np.asarray(cmd.q, dtype=np.float64)
            qd_c = None if cmd.qd is None else np.asarray(cmd.qd, dtype=np.float64)
            if not np.all(np.isfinite(q_c)) or (qd_c is not None and not np.all(np.isfinite(qd_c))):
                raise ParameterError(f"{type(self).__name__}: the joint command at t = {t:.6g} s is not finite: {q_c.tolist()}")
            self._rt.command(s, q_c, qd_c)
        q = np.asarray(measurement.q, dtype=np.float64)
        qd = np.asarray(measurement.qd, dtype=np.float64)
        T = self.robot.terms(q, qd)
        v = self._rt.views(s)
        self._log_cmd.append(v["held"].copy() if self.servo.interface == "position" else v["y"].copy())
        self._log_ref.append(v["q_r"].copy())
        u = self._rt.torque(s, q, qd, T, np.asarray(measurement.wrench, dtype=np.float64))
        lim = self._rt.limited
        self._episode(t, "servo-limit", bool(lim.any()), lambda: (
            f"the servo's speed/acceleration/jerk limits changed the motion of joint(s) {np.flatnonzero(lim).tolist()}"))
        return self._check_output(t, u, measurement)

    def signals(self) -> dict[str, np.ndarray]:
        """Per step: ``joint_command`` (the command the servo acts on after the delay, (n,)) and
        ``servo_reference`` (its internal reference q_r, (n,))."""
        n = int(self.robot.nq)
        return {
            "joint_command": np.array(self._log_cmd).reshape(-1, n),
            "servo_reference": np.array(self._log_ref).reshape(-1, n),
        }


class JointCommandPlayback(PositionInterfaceController):
    """Plays joint commands given as a function of time (steps, ramps, recorded targets).

    ``commands(t) -> q_c (n,)`` is called once per interface cycle; with ``velocities`` (a function
    of t too) it also sends q̇_c. For step tests and the servo identification.
    """

    def __init__(self, robot: PositionInterfaceRobot, commands: Callable[[float], Any], *, sample_time: float = 2e-4,
                 velocities: Callable[[float], Any] | None = None) -> None:
        if not callable(commands):
            raise ParameterError(
                f"commands must be a function of time returning (n,) joint positions; got {type(commands).__name__}"
            )
        self.commands = commands
        self.velocities = velocities
        super().__init__(robot, sample_time)

    def command(self, t: float, measurement: Measurement, reference: Reference) -> JointCommand:
        q = np.asarray(self.commands(t), dtype=np.float64)
        qd = None if self.velocities is None else np.asarray(self.velocities(t), dtype=np.float64)
        return JointCommand(q, qd)  # type: ignore[arg-type]
