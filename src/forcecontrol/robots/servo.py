"""Position- and velocity-interface robots: the arm's own joint servo as a model (issue 30).

Most industrial arms take joint *position* (or velocity) commands at a fixed interface rate and
close their own joint servo. :class:`JointServo` holds that servo's parameters; it turns one
command per interface cycle into joint torques on the full dynamics of any torque robot of the
library (the chapter's arm, Pinocchio's Panda/UR5/UR10), so the arm's dynamics and the contact
stay in the loop. Per joint, with the interface period ``T_i = 1 / rate``::

    command q_c,k (and v_c,k)  at t_k = k T_i, held (zero-order hold) for T_i
    delay:      the servo applies the command of n_d whole cycles earlier (transport delay)
    low-pass:   y_k = a q_c + (1 − a) y_{k−1}, a = T_i / (T_i + 1/(2π f_c))  (optional, Franka)
    servo:      q̈_r = ω_s² (y − q_r) + 2 ζ_s ω_s (v_c − q̇_r)      (second order, per joint)
                with |q̇_r| ≤ v_max, |q̈_r| ≤ a_max, |dq̈_r/dt| ≤ j_max  (limits on the servo's
                internal reference, not on the torque)

Two realisations of the servo on the arm (``tracking``):

* ``"ideal"`` (default): q_r above is the servo's reference, integrated exactly over each inner
  step (ZOH of the command); the arm tracks it by computed torque on its full dynamics with a
  stiff tracking loop (``tracking_bandwidth`` ω_t, critically damped) and compensates the
  measured contact wrench: ``τ = B(q)(q̈_r + 2ω_t (q̇_r − q̇) + ω_t² (q_r − q)) + n(q, q̇) + Jᵀ h``.
  The arm's joints then follow the second-order servo whatever the contact pushes (as a stiff
  industrial joint servo does): exactly the linear model the analysis uses.
* ``"dynamic"``: the servo is the PD on the arm itself, ``τ = B(q)(ω_s² (y − q) + 2ζ_s ω_s
  (v_c − q̇)) + n(q, q̇)``, contact *not* compensated: the servo then has a finite stiffness
  ``Λ ω_s²`` at the end-effector, and payload and contact forces deflect it.

A *velocity* interface (``interface="velocity"``) takes joint velocities v_c; the servo
integrates them into its position command (``y += v_c dt`` at every inner step) and uses v_c as
velocity feed-forward.

The simulation runs at the controller's ``sample_time`` Ts (the servo's torque rate); the
interface period must be a whole multiple of it. Named presets (:meth:`JointServo.preset`) give
the documented interface rates and limits; the servo bandwidth and delay of the presets are
*nominal* where the vendor does not publish them (flagged in ``source``): identify them from a
recorded step (:func:`forcecontrol.analysis.servo_identify.identify_servo`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from ..core.validate import positive_scalar, readonly
from ..errors import DimensionError, ParameterError
from .base import RobotModel, RobotTerms
from .servo_runtime import ServoRuntime

__all__ = ["JointServo", "PRESETS", "PositionInterfaceRobot", "ServoRuntime", "servo_preset_names"]

Interface = Literal["position", "velocity"]
Tracking = Literal["ideal", "dynamic"]


def _per_joint(name: str, value: Any, nq: int, *, allow_none: bool = True) -> np.ndarray | None:
    if value is None:
        if allow_none:
            return None
        raise ParameterError(f"{name} must be given (a positive number or one per joint)")
    a = np.asarray(value, dtype=np.float64)
    if a.ndim == 0:
        a = np.full(nq, float(a))
    if a.shape != (nq,):
        raise DimensionError(f"{name} must be a number or have shape ({nq},) (one per joint); got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise ParameterError(f"{name} must be positive and finite per joint; got {a.tolist()}")
    return readonly(a.copy())


@dataclass(frozen=True)
class JointServo:
    """The joint servo of a position- or velocity-interface arm (parameters only; no state).

    Args:
        nq: number of joints n.
        rate: interface rate f_i [Hz] (commands per second; e.g. 500 UR e-Series, 250 KUKA RSI
            IPO_FAST, 1000 Franka).
        bandwidth: servo natural frequency ω_s [rad/s], a number or (n,).
        damping: servo damping ratio ζ_s [-], a number or (n,).
        delay: transport delay n_d in whole interface cycles (≥ 0): a command sent at t_k acts
            from t_{k+n_d}.
        interface: ``"position"`` (q_c, optional velocity feed-forward) or ``"velocity"`` (q̇_c).
        tracking: ``"ideal"`` or ``"dynamic"`` (see the module docstring).
        tracking_bandwidth: ω_t of the ideal realisation's computed-torque tracking [rad/s].
        velocity_limit, acceleration_limit, jerk_limit: limits of the servo's reference
            [rad/s, rad/s², rad/s³], number or (n,), None for none.
        lowpass_cutoff: first-order low-pass on the commands [Hz] (libfranka's 100 Hz), None for none.
        name, source: the preset's name and where its numbers come from.
    """

    nq: int
    rate: float
    bandwidth: Any
    damping: Any = 1.0
    delay: int = 1
    interface: Interface = "position"
    tracking: Tracking = "ideal"
    tracking_bandwidth: float = 400.0
    velocity_limit: Any = None
    acceleration_limit: Any = None
    jerk_limit: Any = None
    lowpass_cutoff: float | None = None
    name: str = "custom"
    source: str = "given by the user"

    def __post_init__(self) -> None:
        if isinstance(self.nq, bool) or int(self.nq) != self.nq or self.nq < 1:
            raise ParameterError(f"nq must be a positive integer (the number of joints); got {self.nq!r}")
        s = object.__setattr__
        s(self, "nq", int(self.nq))
        s(self, "rate", positive_scalar("rate", self.rate, "Hz"))
        s(self, "bandwidth", _per_joint("bandwidth", self.bandwidth, self.nq, allow_none=False))
        s(self, "damping", _per_joint("damping", self.damping, self.nq, allow_none=False))
        if isinstance(self.delay, bool) or int(self.delay) != self.delay or self.delay < 0:
            raise ParameterError(f"delay must be a whole number of interface cycles >= 0; got {self.delay!r}")
        s(self, "delay", int(self.delay))
        if self.interface not in ("position", "velocity"):
            raise ParameterError(f"interface must be 'position' or 'velocity'; got {self.interface!r}")
        if self.tracking not in ("ideal", "dynamic"):
            raise ParameterError(f"tracking must be 'ideal' or 'dynamic'; got {self.tracking!r}")
        s(self, "tracking_bandwidth", positive_scalar("tracking_bandwidth", self.tracking_bandwidth, "rad/s"))
        for name in ("velocity_limit", "acceleration_limit", "jerk_limit"):
            s(self, name, _per_joint(name, getattr(self, name), self.nq))
        if self.lowpass_cutoff is not None:
            s(self, "lowpass_cutoff", positive_scalar("lowpass_cutoff", self.lowpass_cutoff, "Hz"))
            if self.interface == "velocity":
                raise ParameterError("lowpass_cutoff filters position commands; a velocity interface has none (give None)")

    # -- derived numbers
    @property
    def period(self) -> float:
        """Interface period T_i = 1 / rate [s]."""
        return 1.0 / self.rate

    def substeps(self, sample_time: float) -> int:
        """Simulation steps per interface cycle, T_i / Ts (checked to be a whole number ≥ 1)."""
        Ts = positive_scalar("sample_time", sample_time, "s")
        r = self.period / Ts
        N = int(round(r))
        if N < 1 or abs(r - N) > 1e-6 * max(1.0, r):
            raise ParameterError(
                f"the interface period 1/rate = {self.period:.6g} s must be a whole multiple of the sample time; "
                f"got sample_time = {Ts:.6g} s (ratio {r:.6g})"
            )
        return N

    def lowpass_gain(self) -> float:
        """a of the command low-pass ``y_k = a u_k + (1 − a) y_{k−1}`` (1 without a low-pass)."""
        if self.lowpass_cutoff is None:
            return 1.0
        return self.period / (self.period + 1.0 / (2.0 * math.pi * self.lowpass_cutoff))

    def with_(self, **changes: Any) -> JointServo:
        """A copy with some parameters changed (e.g. ``servo.with_(rate=250.0, delay=2)``)."""
        from dataclasses import replace

        return replace(self, **changes)

    def describe(self) -> dict[str, Any]:
        """Plain description for metadata and reports."""
        def v(a: Any) -> Any:
            return None if a is None else np.asarray(a).tolist()

        return {
            "name": self.name, "rate": self.rate, "bandwidth": v(self.bandwidth), "damping": v(self.damping),
            "delay": self.delay, "interface": self.interface, "tracking": self.tracking,
            "tracking_bandwidth": self.tracking_bandwidth, "velocity_limit": v(self.velocity_limit),
            "acceleration_limit": v(self.acceleration_limit), "jerk_limit": v(self.jerk_limit),
            "lowpass_cutoff": self.lowpass_cutoff, "source": self.source,
        }

    # -- presets
    @classmethod
    def servoj(cls, nq: int = 6, gain: float = 300.0, lookahead_time: float = 0.1, rate: float = 500.0,
               **kw: Any) -> JointServo:
        """UR's ``servoj(q, a, v, t, lookahead_time, gain)`` as a second-order servo (INFERRED mapping).

        UR documents gain "like the P-term of a PID" (range 100–2000) and lookahead_time "projects
        the current position forward with the current velocity" (0.03–0.2 s). Read as
        ``q̈ = gain (q_c − q − T_la q̇)``: ω_s = sqrt(gain), ζ_s = T_la sqrt(gain) / 2. UR does not
        publish this model; identify it from a recorded step.
        """
        g = positive_scalar("gain", gain)
        la = positive_scalar("lookahead_time", lookahead_time, "s")
        w = math.sqrt(g)
        kw.setdefault("name", "ur-servoj")
        kw.setdefault("source", _UR_SOURCE)
        kw.setdefault("velocity_limit", _UR5_VMAX[:nq] if nq <= 6 else None)
        return cls(nq=nq, rate=rate, bandwidth=w, damping=la * w / 2.0, **kw)

    @classmethod
    def preset(cls, name: str, nq: int | None = None, **changes: Any) -> JointServo:
        """A named preset (see :data:`PRESETS`), optionally with some parameters changed.

        Raises:
            ParameterError: unknown name (the message lists the presets) or a joint count the
                preset's per-joint limits do not fit.
        """
        if name not in PRESETS:
            raise ParameterError(f"servo preset must be one of {sorted(PRESETS)}; got {name!r}")
        p = dict(PRESETS[name])
        n = int(p.pop("nq")) if nq is None else int(nq)
        for k in ("velocity_limit", "acceleration_limit", "jerk_limit"):
            v = p.get(k)
            if v is not None and np.ndim(v) == 1 and len(v) != n:
                raise ParameterError(
                    f"servo preset {name!r} has per-joint {k} for {len(v)} joints; the robot has nq = {n}: "
                    f"give {k}= explicitly"
                )
        p.pop("nq", None)
        p.update(changes)
        return cls(nq=n, **p)


_UR_SOURCE = (
    "URScript manual SW5.20, servoj: t = 0.002 s (500 Hz e-Series), lookahead_time 0.1 s default (0.03-0.2), "
    "gain 300 default (100-2000); mapping omega = sqrt(gain), zeta = lookahead*sqrt(gain)/2 INFERRED (not published); "
    "delay 1 cycle nominal (not published); velocity limits from the UR5 URDF of example-robot-data"
)
_UR5_VMAX = (3.15, 3.15, 3.15, 3.2, 3.2, 3.2)

#: The named presets: documented interface rates and limits with their sources. Bandwidth, damping
#: and delay are nominal where the vendor publishes none (said in ``source``): identify them.
PRESETS: dict[str, dict[str, Any]] = {
    "ur-e-series": {
        "nq": 6, "rate": 500.0, "bandwidth": math.sqrt(300.0), "damping": 0.1 * math.sqrt(300.0) / 2.0, "delay": 1,
        "velocity_limit": _UR5_VMAX, "name": "ur-e-series", "source": _UR_SOURCE,
    },
    "kuka-rsi": {
        "nq": 6, "rate": 250.0, "bandwidth": 30.0, "damping": 1.0, "delay": 2, "name": "kuka-rsi",
        "source": "KUKA RSI IPO_FAST: 4 ms cycle (250 Hz), joint corrections (AXISCORR) on the robot's position "
                  "controller (kuka_experimental #151, #77); bandwidth 30 rad/s, damping 1 and delay 2 cycles NOMINAL "
                  "(KUKA publishes none; the stored material says 1-3 cycles): identify from a step",
    },
    "franka-joint-position": {
        "nq": 7, "rate": 1000.0, "bandwidth": 40.0, "damping": 1.0, "delay": 1, "lowpass_cutoff": 100.0,
        "velocity_limit": (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61),
        "acceleration_limit": (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),
        "jerk_limit": (7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0),
        "name": "franka-joint-position",
        "source": "libfranka 0.9.2 (Panda): 1 kHz FCI, lowpass_filter.h kDefaultCutoffFrequency = 100 Hz, "
                  "rate_limiting.h velocity/acceleration/jerk limits (frankaemika.github.io/docs/control_parameters.html); "
                  "1 cycle delay (packets are due every 1 ms); joint-impedance bandwidth 40 rad/s, damping 1 NOMINAL "
                  "(sqrt(K_theta/B_jj) depends on the posture; damping not published): identify from a step",
    },
}


def servo_preset_names() -> list[str]:
    """The names :meth:`JointServo.preset` accepts."""
    return sorted(PRESETS)


class PositionInterfaceRobot:
    """A torque robot of the library seen through its joint servo (a :class:`RobotModel`).

    Every kinematic and dynamic question goes to the wrapped ``robot`` (the simulator integrates
    the full dynamics); ``servo`` says how the arm turns joint commands into torques. Controllers
    for position/velocity-interface arms
    (:class:`~forcecontrol.controllers.position_interface.PositionInterfaceController`) take one.

    Args:
        robot: any torque robot (PlanarTwoLink, PinocchioRobot, ...).
        servo: its :class:`JointServo` (``servo.nq`` must equal ``robot.nq``), or a preset name.
    """

    def __init__(self, robot: RobotModel, servo: JointServo | str) -> None:
        if isinstance(servo, str):
            servo = JointServo.preset(servo, nq=int(robot.nq))
        if not isinstance(servo, JointServo):
            raise ParameterError(f"servo must be a JointServo or a preset name; got {type(servo).__name__}")
        if servo.nq != int(robot.nq):
            raise DimensionError(f"servo.nq must equal the robot's nq = {robot.nq}; got {servo.nq}")
        self.robot = robot
        self.servo = servo
        self.nq = int(robot.nq)
        self.task_dim = int(robot.task_dim)

    @property
    def torque_robot(self) -> RobotModel:
        """The wrapped torque robot (what a plant, e.g. MuJoCo, integrates)."""
        return self.robot

    def __getattr__(self, name: str) -> Any:  # everything else (spatial_terms, model, task, ...) from the robot
        if name in ("robot", "servo"):
            raise AttributeError(name)
        return getattr(self.robot, name)

    def forward_kinematics(self, q: np.ndarray) -> np.ndarray:
        return self.robot.forward_kinematics(q)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        return self.robot.jacobian(q)

    def jdot_qdot(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return self.robot.jdot_qdot(q, qd)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        return self.robot.mass_matrix(q)

    def nonlinear_effects(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return self.robot.nonlinear_effects(q, qd)

    def gravity(self, q: np.ndarray) -> np.ndarray:
        return self.robot.gravity(q)

    def terms(self, q: np.ndarray, qd: np.ndarray) -> RobotTerms:
        return self.robot.terms(q, qd)

    def describe(self) -> dict[str, Any]:
        inner = self.robot.describe() if hasattr(self.robot, "describe") else {"type": type(self.robot).__name__}
        return {"type": "PositionInterfaceRobot", "robot": inner, "servo": self.servo.describe()}
