"""What every controller shares: signals, the base class and how a step runs its law.

A controller object holds checked gains, packed once into ``_params`` in the layout of its law,
and its state. Its ``step`` runs the law of :mod:`forcecontrol.laws` (each of the chapter's laws
written once, compiled): on the chapter's arm in one fused compiled call, on any other robot on
the robot's terms; a redundant arm or a configured singularity handling runs the law's
acceleration part through the damped inner loop of :mod:`.redundant`.
"""

from __future__ import annotations

import functools
import math
import threading
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from .. import laws
from ..core.validate import positive_scalar
from ..errors import DimensionError, ForceControlError, MeasurementError, ParameterError, SingularityError
from ..robots.base import RobotModel
from .inputs import (
    _check_inputs,
    _check_reference_finite,
    _check_step_arguments,
    _forget_time,
    _io_shapes,
    _time_rule,
    _unusual_time,
)
from .signals import REFERENCE_FIELDS, Measurement, Reference, pack_reference


def _f64(a: Any) -> np.ndarray:
    """The array itself when already float64 and contiguous (no copy), else a converted copy."""
    if type(a) is np.ndarray and a.dtype == np.float64 and a.flags.c_contiguous:
        return a
    return np.ascontiguousarray(a, dtype=np.float64)


__all__ = [
    "Controller",
    "Measurement",
    "Reference",
    "pack_reference",
    "REFERENCE_FIELDS",
]

_F64 = np.dtype(np.float64)


def _vectors(*arrays: Any) -> bool:
    """Every argument is a float64 NumPy vector (what the compiled step reads; lengths it checks itself)."""
    for a in arrays:
        if type(a) is not np.ndarray or a.dtype is not _F64 or a.ndim != 1:
            return False
    return True


def _fast_step(self: Controller, t: float, measurement: Measurement, reference: Reference) -> np.ndarray | None:
    """The law in one compiled call with its checks inside (:func:`forcecontrol.laws.on_arm`).

    Taken on the built-in arm when the signals are float64 vectors; the kernel checks their
    lengths and finiteness and restores the state when the law fails. Returns None otherwise, or
    when the kernel reports a problem: the checked path then runs and raises the library's error
    naming it.

    The compiled call has one signature, so Numba's dispatcher itself refuses any other input
    (lists, integer or 2-D arrays, views) with a TypeError, before anything runs. That refusal
    costs about 0.2 ms, against 1 µs for checking the nine signals in Python first (a third of
    the step): so the signals are not checked until a call has been refused, and from then on
    this controller checks them before each call (a caller that passed lists once likely does
    it every time).
    """
    on_arm = self.__dict__.get("_on_arm", False)
    if on_arm is False:
        on_arm = laws.on_arm(self.compiled_law) if self._fused_K is not None and self.compiled_law is not None else None
        self.__dict__["_on_arm"] = on_arm
    if on_arm is None:
        return None
    m, r = measurement, reference
    if "_check_signals" in self.__dict__ and not _vectors(
        m.q, m.qd, m.wrench, r.position, r.velocity, r.acceleration, r.force, r.force_rate, r.force_accel
    ):
        return None
    try:  # one compiled signature (read-only inputs, C layout): another layout takes the checked path
        u = np.empty(len(m.q))
        ok = on_arm(
            self._fused_K, float(t), self.sample_time, m.q, m.qd, m.wrench, r.position, r.velocity, r.acceleration,
            r.force, r.force_rate, r.force_accel, self._params, self.state, self._workspace(), u,
        )
    except TypeError:
        self.__dict__["_check_signals"] = True
        return None
    return u if ok else None


#: per thread, while a checked ``step`` runs: the inputs it checked ``(measurement, reference, t,
#: shapes)``, so that the controllers it wraps (a safety layer around a supervisor around a law)
#: do not check the same objects again within the call; restored when the step returns.
_SCOPE = threading.local()


def _validated_step(fn: Any) -> Any:
    runs_law = getattr(fn, "_runs_law", False)

    @functools.wraps(fn)
    def step(self: Controller, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        d = self.__dict__
        prev = d.get("_t_prev")  # the last accepted step's t, kept only by a controller with state
        if runs_law and type(t) is float and type(measurement) is Measurement and type(reference) is Reference:
            if prev is not None and not prev < t <= prev + d["_t_gap"]:
                _unusual_time(self, t, prev)  # raises for a t that does not advance; warns once for a jump
            u = _fast_step(self, t, measurement, reference)
            if u is not None:
                if prev is not None or (d["_time_rule"] if "_time_rule" in d else _time_rule(self)):
                    d["_t_prev"] = t
                return u
        outer = getattr(_SCOPE, "checked", None)
        shapes = _io_shapes(self)
        if not (outer is not None and outer[0] is measurement and outer[1] is reference and outer[2] == t
                and outer[3] == shapes):
            if type(measurement) is not Measurement or type(reference) is not Reference or type(t) is not float:
                _check_step_arguments(t, measurement, reference)
            elif t != t or t in (math.inf, -math.inf):
                raise ParameterError(f"t must be finite; got {t!r}")
            _check_inputs(self, t, measurement, reference)
        # else: an enclosing layer (a safety layer, a supervisor) checked these very objects, for
        # the same shapes, within this call; nothing can have changed them since
        if prev is not None and not prev < t <= prev + d["_t_gap"]:
            _unusual_time(self, t, prev)
        state = self.state
        saved = state.copy() if state.size else None
        _SCOPE.checked = (measurement, reference, t, shapes)
        done = False
        try:
            u = fn(self, t, measurement, reference)
            done = True
        except ForceControlError:
            if saved is not None:
                state[:] = saved  # a failed sample leaves the integrators as they were
            _check_reference_finite(t, reference)
            raise
        finally:
            _SCOPE.checked = outer
            if not done:  # nor the time (a nested step of the same controller may have recorded it)
                if prev is None:
                    d.pop("_t_prev", None)
                else:
                    d["_t_prev"] = prev
        if prev is not None or (d["_time_rule"] if "_time_rule" in d else _time_rule(self)):
            d["_t_prev"] = float(t)
        return u

    step._validates_inputs = True  # type: ignore[attr-defined]
    return step


def runs_law(fn: Any) -> Any:
    """Mark a ``step`` whose whole work is :meth:`Controller._law_step` (enables the one-call fast path)."""
    fn._runs_law = True
    return fn


def _validated_reset(fn: Any) -> Any:
    @functools.wraps(fn)
    def reset(self: Controller, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        _check_inputs(self, 0.0, measurement, reference)
        _forget_time(self)
        return fn(self, measurement, reference)

    reset._validates_inputs = True  # type: ignore[attr-defined]
    return reset


def reset_prechecked(controller: Controller, measurement: Measurement, reference: Reference) -> None:
    """``controller.reset(measurement, reference)`` without the input check, for inputs the library
    built itself from parts it has already checked (a sweep resets one controller per case)."""
    fn = type(controller).reset
    _forget_time(controller)
    getattr(fn, "__wrapped__", fn)(controller, measurement, reference)


#: robot classes already found to implement RobotModel (the check looks at the class's methods).
_ROBOT_TYPES: set[type] = set()


class Controller(ABC):
    """Base of every controller: gains checked once, explicit state, ``reset`` and ``step``.

    A controller is usable outside the simulator: call ``step`` from your own fixed-rate loop
    with a :class:`Measurement` and a :class:`Reference` and apply the returned torques for one
    sample time.

    Subclasses name their compiled ``law`` (and, for inverse-dynamics schemes, its
    ``acceleration`` part) from :mod:`forcecontrol.laws`, fill ``_params`` (a flat float64 array
    in the law's documented layout) and ``state`` (integrators, may be empty). Controllers with
    no compiled law (``law = None``) implement ``step`` in Python.
    """

    #: the attributes :meth:`gains` reports.
    GAINS: ClassVar[tuple[str, ...]] = ()
    #: the compiled control law (``staticmethod`` of a :mod:`forcecontrol.laws` function) or None.
    law: ClassVar[Any] = None
    #: its acceleration part (inverse-dynamics schemes), for the redundant/damped inner loop.
    acceleration: ClassVar[Any] = None
    #: whether the controller reads the force measurement at all.
    uses_force: ClassVar[bool] = True
    #: the law acts on a position task space (x_e = o_e, J = J_P): a robot whose task includes
    #: the orientation (task='pose') is refused, since the law would treat Euler angles with the
    #: geometric Jacobian (the chapter's 6-D forms are the controllers of ``controllers.spatial``).
    position_task_only: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Every concrete ``step`` and ``reset`` checks its inputs first (shapes, finiteness).

        The check runs before any state (integrators) is touched, so one bad sample cannot
        corrupt the controller; it costs about 1–2 µs per step.
        """
        super().__init_subclass__(**kwargs)
        for name, wrap in (("step", _validated_step), ("reset", _validated_reset)):
            fn = cls.__dict__.get(name)
            if fn is not None and not getattr(fn, "_validates_inputs", False) and not getattr(
                fn, "__isabstractmethod__", False
            ):
                setattr(cls, name, wrap(fn))

    def __init__(self, robot: RobotModel, sample_time: float = 1e-3) -> None:
        if type(robot) not in _ROBOT_TYPES:  # a runtime Protocol check costs ~15 µs: once per type
            if not isinstance(robot, RobotModel):
                raise ParameterError(f"robot must implement RobotModel; got {type(robot).__name__}")
            _ROBOT_TYPES.add(type(robot))
        if self.position_task_only and getattr(robot, "task", None) == "pose":
            raise ParameterError(
                f"{type(self).__name__} works in a position task space (x_e = o_e, J = J_P); the robot's task is "
                "'pose' (position and orientation). Use the 6-D controllers of forcecontrol.controllers "
                "(SpatialImpedanceController (9.35), AdmittanceController (9.37), SpatialHybridController, "
                "SpatialHybridRigidController) or build the robot with task='position'"
            )
        self.robot = robot
        self.sample_time = positive_scalar("sample_time", sample_time)
        self.state = np.zeros(0)
        self._params = np.zeros(0)
        #: False when this instance cannot run its law in the compiled loops (state-dependent
        #: parameters, a singularity handling or a posture): the simulator then runs its ``step``.
        self._compiled = type(self).law is not None
        # the built-in arm gets one fused compiled call per step (the same law function)
        self._fused_K = getattr(robot, "_K", None) if type(robot).__name__ == "PlanarTwoLink" else None

    @property
    def compiled_law(self) -> Any:
        """The compiled law the simulator's compiled loop and the sweeps run for this instance, or None."""
        if not self._compiled or getattr(self, "singularity", None) is not None or getattr(self, "posture", None) is not None:
            return None
        return self.law

    @property
    def m(self) -> int:
        """Operational-space dimension."""
        return int(self.robot.task_dim)

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Reset the internal state (integrators) to its documented initial value (and forget the last step's t)."""
        _forget_time(self)
        self.state[:] = 0.0

    @abstractmethod
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques u, (n,) [N m], to hold for one sample time.

        One call is one sample: the integrators (``state``) advance by ``sample_time`` per call,
        whatever ``t`` is. So the time must follow the samples:

        * a controller with integrator state (a non-empty ``state``, or wrapping one that has)
          refuses a ``t`` that does not increase past the previous step's (``ParameterError``
          naming both times): a repeated ``t`` would integrate twice for one sample;
        * a wrapper of stateless controllers (a safety layer, a supervisor, encoder feedback:
          per-sample memory of its own) refuses a ``t`` that goes back, and accepts a repeat;
        * a stateless controller accepts any finite ``t``.

        ``reset()`` starts the time again (``t = 0`` is accepted next). A step that fails records
        neither its time nor any change of state. A ``t`` more than 1.5 sample times after the
        previous step's warns once (until ``reset()``): the integrators still advance by one
        ``sample_time`` (call ``step`` once per sample).
        """

    def gains(self) -> dict[str, Any]:
        """The controller's parameters as plain values (for metadata and reports): those named in ``GAINS``."""
        out: dict[str, Any] = {}
        for name in self.GAINS:
            v = getattr(self, name)
            out[name] = v.tolist() if isinstance(v, np.ndarray) else v
        return out

    # -- shared helpers
    def _set_redundancy(self, posture: Any, singularity: Any) -> None:
        """Check and keep the ``posture`` (NullSpacePosture) and ``singularity`` (SingularityHandling) options."""
        from .redundant import NullSpacePosture, SingularityHandling

        if posture is not None and not isinstance(posture, NullSpacePosture):
            raise ParameterError(f"posture must be a NullSpacePosture or None; got {type(posture).__name__}")
        if singularity is not None and not isinstance(singularity, SingularityHandling):
            raise ParameterError(f"singularity must be a SingularityHandling or None; got {type(singularity).__name__}")
        n = int(self.robot.nq)
        if posture is not None and np.shape(posture.posture) != (n,):
            raise DimensionError(f"posture.posture must have shape ({n},); got shape {np.shape(posture.posture)}")
        self.posture = posture
        self.singularity = singularity

    def _workspace(self) -> np.ndarray:
        ws = self.__dict__.get("_ws")
        if ws is None:
            m, n = int(self.robot.task_dim), int(self.robot.nq)
            ws = np.empty(64 + 2 * n * n + laws.workspace_size(m, n))
            self.__dict__["_ws"] = ws
        return ws

    def _law_step(self, t: float, measurement: Measurement, reference: Reference, T: Any = None) -> np.ndarray:
        """Torques of this controller's compiled ``law`` for one sample (advances its state).

        On the chapter's arm the law runs in one fused compiled call with the arm's terms. On
        any other robot (or with precomputed terms ``T``) it runs on ``robot.terms``; a redundant
        arm (J of shape (m, n), m < n) or a configured ``singularity`` handling runs the law's
        acceleration part through :meth:`_redundant_torque` (damped least squares near a
        singularity, the ``posture`` in the null space). Away from singularities the task-space
        closed loop is the same.
        """
        if T is None:
            u = self._fused_step(t, measurement, reference)
            if u is not None:
                return u
            T = self.robot.terms(measurement.q, measurement.qd)
        q, qd = _f64(measurement.q), _f64(measurement.qd)
        h = _f64(measurement.wrench)
        ref = pack_reference(reference)
        ws = self._workspace()
        J = np.ascontiguousarray(T.J, dtype=np.float64)
        square = J.shape[0] == J.shape[1]
        if self.acceleration is not None and (not square or getattr(self, "singularity", None) is not None):
            m = J.shape[0]
            a = np.empty(m)
            hc = np.empty(m)
            comp = self.acceleration(t, self.sample_time, _f64(T.x), _f64(T.xd), h, ref, self._params, self.state, ws, a, hc)
            u = self._redundant_torque(J, a - T.Jdq, q, qd, T.B, T.n, J if comp else None, hc)
        else:
            u = np.empty(q.shape[0])
            self.law(
                float(t), self.sample_time, q, qd, _f64(T.x), _f64(T.xd), J, _f64(T.Jdq), _f64(T.B), _f64(T.n),
                _f64(T.g), h, ref, self._params, self.state, ws, u,
            )
        return self._check_output(t, u, measurement)

    def _redundant_torque(
        self, J_task: np.ndarray, r: np.ndarray, q: Any, qd: Any, B: np.ndarray, n: np.ndarray,
        J_wrench: np.ndarray | None = None, h: Any = None,
    ) -> np.ndarray:
        """``u = B y + n [+ J_wrenchᵀ h]`` with ``J_task y = r`` solved by :mod:`.redundant`.

        Uses the controller's ``posture`` (a ``NullSpacePosture`` acting in the null space of
        J_task; None: minimum-norm accelerations) and ``singularity`` (a ``SingularityHandling``;
        None: the exact pseudo-inverse). The damping used is kept in ``last_damping``.
        """
        from .redundant import redundant_acceleration

        posture = getattr(self, "posture", None)
        y0 = None if posture is None else posture.acceleration(np.asarray(q), np.asarray(qd))
        sing = getattr(self, "singularity", None)
        threshold, max_damping = (sing.threshold, sing.max_damping) if sing is not None else (1.0, 0.0)
        y, self.last_damping = redundant_acceleration(J_task, r, y0, threshold, max_damping)
        u = B @ y + n
        return u + J_wrench.T @ np.asarray(h, dtype=np.float64) if J_wrench is not None else u

    def _fused_step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray | None:
        """Torques of the law in one compiled call on the built-in arm (:func:`forcecontrol.laws.on_arm`).

        None on another robot or without a compiled law.
        """
        if self._fused_K is None or self.compiled_law is None:
            return None
        r = reference
        u = np.empty(self.robot.nq)
        if not laws.on_arm(self.compiled_law)(
            self._fused_K, float(t), self.sample_time, _f64(measurement.q), _f64(measurement.qd),
            _f64(measurement.wrench), _f64(r.position), _f64(r.velocity), _f64(r.acceleration), _f64(r.force),
            _f64(r.force_rate), _f64(r.force_accel), self._params, self.state, self._workspace(), u,
        ):
            u[:] = np.nan  # the cause (a non-finite reference, a singular Jacobian) is named by the caller
        return self._check_output(t, u, measurement)

    def _check_output(self, t: float, u: np.ndarray, measurement: Measurement) -> np.ndarray:
        if math.isfinite(sum(u.tolist())):
            return u
        for name in ("q", "qd", "wrench"):
            v = np.asarray(getattr(measurement, name))
            if not np.all(np.isfinite(v)):
                raise MeasurementError(
                    f"measurement.{name} is not finite at t = {t:.6g} s: {v.tolist()}"
                )
        raise SingularityError(
            f"{type(self).__name__}: the Jacobian is singular at t = {t:.6g} s, "
            f"q = {np.asarray(measurement.q).tolist()}; the inverse-dynamics law cannot be applied"
        )
