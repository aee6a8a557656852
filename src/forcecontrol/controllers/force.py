"""Direct force control by inverse dynamics (Sect. 9.4): three schemes on one inner loop.

Each scheme keeps the shared inner loop (9.30) ``u = B J⁻¹ (a − J̇q̇) + n + Jᵀ h_e`` and only
chooses the operational acceleration ``a`` (for the position-only operational space J_A = J):

* force control with inner position loop, Fig. 9.6, (9.39) with (9.41)/(9.43)::

      a = M_d⁻¹ (−K_D ẋ_e + K_P (x_F − x_e)),      x_F = C_F (f_d − f_e)

  closed loop (9.40) ``M_d ẍ_e + K_D ẋ_e + K_P x_e = K_P x_F``;
* force control with inner velocity loop, Fig. 9.7, (9.45) (with the corrected ``J̇ q̇``, not
  the printed ``J̈ q̇``) and (9.46)::

      a = M_d⁻¹ (−K_D ẋ_e + K_P x_F),              x_F = K_F (f_d − f_e)

  closed loop (9.47) ``M_d ẍ_e + K_D ẋ_e + K_P K_F K x_e = K_P K_F (K x_r + f_d)``;
* parallel force/position control, Fig. 9.8, (9.48)::

      a = M_d⁻¹ (−K_D ẋ_e + K_P (x̃ + x_F)),       x̃ = x_d − x_e,  x_F = C_F (f_d − f_e)

  equilibrium (9.49) ``x_e = x_d + C_F (K (x_r − x_e) + f_d)``.

C_F is diagonal (9.41). With the PI action (9.43) ``C_F = K_F + K_I ∫ (·) dζ`` the integral is
an explicit state ξ [m] (one entry per axis), so that ``x_F = K_F (f_d − f_e) + ξ`` and, per
sample, ``ξ ← ξ + Ts K_I (f_d − f_e)`` after x_F is computed (forward Euler, the same update in
the Python ``step`` and in the compiled loop). How ξ starts, and whether a change of f_d kicks
x_F through K_F, is ``integrator_start`` (:data:`INTEGRATOR_STARTS`; one meaning at any time of
the force step). Along an axis with zero C_F entries the force loop is open: in the base frame
``x_F = 0`` there and the inner position loop takes x_e to 0 (the chapter's remark after
(9.47)); in a task frame (``task_frame`` given) the inner position loop holds the tip's start
position along such an axis (the task frame's origin is the start tip: on a tilted surface the
tip does not slide along it), except with ``integrator_start = "zero"``. The inner velocity
loop takes ẋ_e to 0 there, the parallel scheme takes x_e to x_d (9.49).

A force reference with components outside R(K) is read by these schemes as a velocity reference
and makes the end-effector drift (Sect. 9.4.3); :func:`check_force_reference` reports it with a
:class:`~forcecontrol.errors.DriftWarning`.
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np

from .. import laws
from ..core.validate import as_gain_matrix, readonly
from ..errors import ParameterError
from ..laws.layout import FORCE, FORCE_STATE
from ..robots.base import RobotModel
from .base import Controller, Measurement, Reference, runs_law
from .force_checks import _check_force_reference, _diagonal_gain, _limit, check_force_reference

__all__ = [
    "InnerPositionForceController",
    "InnerVelocityForceController",
    "ParallelForcePositionController",
    "check_force_reference",
]


# --------------------------------------------------------------------------- classes


#: how the PI integrator of (9.43) starts and meets a change of f_d, at any time of the force step
#: (``p`` = the tip position, inner position loop, or ``p − x_d``, parallel scheme; f_e(0) the
#: contact force at the start; in task-frame coordinates along the axes with integral action):
#:
#: * ``"hold"`` (default of the inner position loop): ``ξ₀ = p − K_F (0 − f_e(0))``: x_F equals the
#:   tip as if f_d had been 0 before the start (with no contact force the loop holds the tip still
#:   until f_d becomes non-zero); every change of f_d, at t = 0 or later, acts on the whole PI,
#:   its proportional kick ``K_F Δf_d`` included: the step response of (9.42)–(9.43), with the
#:   zero at −k_I/k_F (Example 9.3, Fig. 9.9);
#: * ``"tip"`` (bumpless): ``ξ₀ = p − K_F (f_d(0) − f_e(0))``: x_F equals the tip at t = 0 with the
#:   reference f_d(0) applied, and every later change of f_d moves ξ by ``−K_F Δf_d``: x_F never
#:   jumps (the proportional action acts on −f_e only, setpoint weight 0; the integral still
#:   acts on f_d − f_e, so f_e → f_d); the step response has no zero;
#: * ``"zero"`` (default of the parallel scheme): ξ₀ = 0, the chapter's C_F literally (parallel:
#:   x_d and f_d step from the tip and from 0 at t = 0, Fig. 9.11); the whole PI acts on changes.
INTEGRATOR_STARTS = ("hold", "tip", "zero")


def _task_frame(value: Any, m: int) -> np.ndarray | None:
    """The task frame's rotation R (m, m) (columns: its axes in the base frame), or None for the base frame."""
    if value is None:
        return None
    from ..core.validate import as_matrix

    R = np.array(as_matrix("task_frame", value, (m, m)))
    if not np.allclose(R.T @ R, np.eye(m), atol=1e-9) or np.linalg.det(R) <= 0.0:
        raise ParameterError(f"task_frame must be a rotation matrix ({m}, {m}) (orthonormal, det = +1); got {R.tolist()}")
    return None if np.allclose(R, np.eye(m), atol=0.0) else readonly(R)


class _DirectForceController(Controller):
    """Shared parts: motion gains (M_d, K_D, K_P), diagonal C_F, integral state and checks."""

    _has_integral: ClassVar[bool] = True
    GAINS = ("inertia", "damping", "stiffness", "force_gain")
    _default_start: ClassVar[str] = "hold"
    #: along axes without force action (K_F = K_I = 0) in a task frame, x_F holds the start tip
    _holds_free_axes: ClassVar[bool] = True
    position_task_only: ClassVar[bool] = True

    def __init__(
        self, robot: RobotModel, inertia: Any, damping: Any, stiffness: Any, force_gain: Any,
        integral_gain: Any = 0.0, *, integral_limit: Any = None,
        integrator_start: Literal["hold", "tip", "zero"] | None = None, environment_stiffness: Any = None,
        posture: Any = None, singularity: Any = None, sample_time: float = 1e-3, task_frame: Any = None,
    ) -> None:
        super().__init__(robot, sample_time)
        m = self.m
        self._set_redundancy(posture, singularity)
        self.task_frame = _task_frame(task_frame, m)
        self._framed = task_frame is not None  # a task frame (even I): its origin is the start tip
        self.inertia = as_gain_matrix("inertia", inertia, m)
        self.damping = as_gain_matrix("damping", damping, m)
        self.stiffness = as_gain_matrix("stiffness", stiffness, m)
        self.force_gain = _diagonal_gain("force_gain", force_gain, m, "m/N")
        if self._has_integral:
            self.integral_gain = _diagonal_gain("integral_gain", integral_gain, m, "m/(N s)")
        else:
            self.integral_gain = readonly(np.zeros(m))
        if not np.any(self.force_gain) and not np.any(self.integral_gain):
            raise ParameterError(
                "force_gain and integral_gain are zero on every axis: C_F must act on at least one "
                f"axis; got force_gain {self.force_gain.tolist()}, integral_gain {self.integral_gain.tolist()}"
            )
        self.integral_limit = readonly(_limit(integral_limit, m))
        start = self._default_start if integrator_start is None else integrator_start
        if start not in INTEGRATOR_STARTS:
            raise ParameterError(f"integrator_start must be 'tip', 'hold' or 'zero'; got {integrator_start!r}")
        self.integrator_start = start
        self.environment_stiffness = (
            None if environment_stiffness is None
            else as_gain_matrix("environment_stiffness", environment_stiffness, m, definite=False)
        )
        self._consistent_reference: bytes | None = None
        self._task_rotation = readonly(np.eye(m) if self.task_frame is None else np.array(self.task_frame))
        self._Md_inv = readonly(np.linalg.inv(self.inertia))
        self._params = FORCE.pack(
            m, M_d_inv=self._Md_inv, K_D=self.damping, K_P=self.stiffness,
            K_F=self.force_gain, K_I=self.integral_gain, limit=self.integral_limit,
            R=np.eye(m) if self.task_frame is None else self.task_frame,
            bumpless=1.0 if self._has_integral and start == "tip" else 0.0,
        )
        self.state = np.zeros(FORCE_STATE.size(m) if self._has_integral else 0)

    @property
    def force_axes(self) -> np.ndarray:
        """(m,) booleans: axes where C_F acts (non-zero K_F or K_I)."""
        return (self.force_gain != 0.0) | (self.integral_gain != 0.0)

    @property
    def integral_action(self) -> np.ndarray:
        """The integral action ξ = K_I ∫ (f_d − f_e) [m] (plus its initial value), (m,)."""
        return self.state[FORCE_STATE.slice("xi", self.m)].copy() if self._has_integral else np.zeros(self.m)

    def _position_offset(self, measurement: Measurement, reference: Reference) -> np.ndarray:
        """What x_F must equal at t = 0 for the chosen start (overridden by the parallel scheme)."""
        return self.robot.forward_kinematics(measurement.q)

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Reset the integral action ξ and check the force reference.

        ξ₀ on every axis with integral action (see :data:`INTEGRATOR_STARTS`), with
        ``p`` the tip position (inner position loop) or ``p − x_d`` (parallel scheme), in
        task-frame coordinates:

        * ``"hold"``: ``ξ₀ = p − K_F (0 − f_e(0))``: x_F equals the tip as if f_d had been 0
          before the start; a step of f_d (at t = 0 or later) acts on the whole PI, its
          proportional kick included: the step response of (9.42)–(9.43) with its zero at
          −k_I/k_F (Figs. 9.9 and the analysis' responses);
        * ``"tip"``: ``ξ₀ = p − K_F (f_d(0) − f_e(0))``: x_F (or x̃ + x_F) equals the tip at
          t = 0 with f_d(0) applied, and the law cancels the proportional kick of every later
          change of f_d (bumpless, :mod:`forcecontrol.laws.force`);
        * ``"zero"`` (or no measurement): ξ₀ = 0.

        Axes with K_F > 0 and no integral action keep ξ = 0 (there x_F = K_F (f_d − f_e), as the
        chapter has it). Axes without any force action (K_F = K_I = 0) of the inner position loop
        in a task frame get ξ₀ = p there (with "hold" and "tip"): x_F holds the start tip along
        them, so the tip does not slide along a tilted surface; in the base frame they keep
        ξ = 0 (x_F = 0: the tip goes to 0 along them, the chapter's remark in Sect. 9.4.3).

        Warns:
            DriftWarning: the reference force has components the environment cannot balance
                (needs ``environment_stiffness``) or along axes where C_F is zero.
        """
        m = self.m
        R = self._task_rotation  # C_F is diagonal in the task frame
        turned = self.task_frame is not None  # else R = I: no products (a sweep resets once per case)
        self.state[:] = 0.0
        if reference is not None:
            f_d = np.asarray(reference.force, dtype=np.float64)
            f_d = R.T @ f_d if turned else f_d
            # the check is a pure function of f_d and the (read-only) gains: a reference already
            # found consistent is not checked again (a sweep resets one controller per case)
            if f_d.tobytes() != self._consistent_reference:
                ok = True
                if self.environment_stiffness is not None:
                    K = R.T @ self.environment_stiffness @ R if turned else self.environment_stiffness
                    ok = _check_force_reference(f_d, K, self.force_axes, True, 1e-9, 2)
                elif np.any(np.where(self.force_axes, 0.0, f_d)):
                    ok = _check_force_reference(f_d, np.eye(m), self.force_axes, True, 1e-9, 2)
                self._consistent_reference = f_d.tobytes() if ok else None
        if not self._has_integral or reference is None:
            return
        f_ref = np.asarray(reference.force, dtype=np.float64)
        if self.integrator_start == "tip":  # the reference the bumpless shift starts from (unused otherwise)
            self.state[FORCE_STATE.slice("f_s", m)] = R.T @ f_ref if turned else f_ref
        if measurement is None or self.integrator_start == "zero":
            return
        f_pre = f_ref if self.integrator_start == "tip" else np.zeros(m)
        target = self._position_offset(measurement, reference)
        error = f_pre - np.asarray(measurement.wrench, dtype=np.float64)
        if turned:
            target, error = R.T @ target, R.T @ error
        xi0 = np.where(self.integral_gain > 0.0, target - self.force_gain * error, 0.0)
        if self._holds_free_axes and self._framed:
            xi0 = np.where(self.force_axes, xi0, target)
        self.state[FORCE_STATE.slice("xi", m)] = xi0
        self.state[FORCE_STATE.slice("xi0", m)] = xi0

    def gains(self) -> dict[str, Any]:
        out = super().gains()
        if self._has_integral:
            out["integral_gain"] = self.integral_gain.tolist()
            out["integral_limit"] = self.integral_limit.tolist()
            out["integrator_start"] = self.integrator_start
        if self.task_frame is not None:
            out["task_frame"] = self.task_frame.tolist()
        return out


class InnerPositionForceController(_DirectForceController):
    """Force control with inner position loop (Fig. 9.6): (9.39) with x_F = C_F (f_d − f_e) (9.41), (9.43).

    Law: ``u = B J⁻¹ (a − J̇ q̇) + n + Jᵀ h_e`` (9.30) with
    ``a = M_d⁻¹ (−K_D ẋ_e + K_P (x_F − x_e))`` (9.39),
    ``x_F = K_F (f_d − f_e) + K_I ∫ (f_d − f_e) dζ`` (PI, (9.43)).
    Closed loop per axis with the environment (9.38) (corrected (9.42), third order):
    ``m s³ + k_D s² + k_P (1 + k_F k_x) s + k_P k_x k_I``; equilibrium f_e = f_d, (9.44).

    Inputs: ``measurement.q, .qd`` (n,); ``measurement.wrench`` f_e (m,) [N];
    ``reference.force`` f_d (m,) [N]. Output: torques (n,) [N m].
    State: ``state = [ξ (m), ξ₀ (m), f_s (m)]``, ξ the integral action [m], ξ₀ the centre of its
    anti-windup band [m], f_s the force reference of the last sample in the task frame [N].

    Args:
        robot: the manipulator model (square Jacobian).
        inertia: M_d, symmetric positive definite (m, m) [kg] (scalar or diagonal allowed).
        damping: K_D, symmetric positive definite (m, m) [N s/m].
        stiffness: K_P, symmetric positive definite (m, m) [N/m].
        force_gain: K_F, diagonal of C_F's proportional part, scalar, (m,) or diagonal (m, m) [m/N], >= 0.
        integral_gain: K_I, diagonal of C_F's integral part, same forms [m/(N s)], >= 0.
        integral_limit: anti-windup bound on ξ − ξ₀ [m], scalar or (m,); None = no clamping.
        integrator_start: ``"hold"`` (default): x_F equals the tip before the force step and
            every step of f_d (at t = 0 or later) acts on the whole PI, proportional kick
            included: the book's step response of (9.42)–(9.43) (Example 9.3, Fig. 9.9);
            ``"tip"``: bumpless, x_F equals the tip at t = 0 with f_d(0) applied and no change of
            f_d ever kicks x_F (no zero in the step response; about a third lower peak in
            Example 9.3); ``"zero"``: ξ₀ = 0 (pulls the arm toward x_F ≈ 0 along integral axes).
            See :data:`INTEGRATOR_STARTS` and :meth:`reset`.
        environment_stiffness: K of (9.38), (m, m) [N/m], optional: checks f_d ∈ R(K) at reset.
        posture: for a redundant arm (J of shape (m, n), m < n), a ``NullSpacePosture`` acting in
            the null space of J; singularity: a ``SingularityHandling`` (damped least squares).
        task_frame: rotation R (m, m) whose columns are the task frame's axes in the base frame: C_F
            (K_F, K_I) is diagonal in that frame, ``x_F = R C_F Rᵀ (f_d − f_e)`` (Sect. 9.4 on a
            surface that is not aligned with the base axes; ``task.planar_rotation(angle)`` in the
            plane); None: the base frame (the chapter's case). Both run compiled (R is packed with the gains).
            A task frame's origin is the tip at the start: along its axes without force action
            (K_F = K_I = 0, e.g. the tangent of a tilted plane) x_F holds the start tip (with
            ``"hold"`` and ``"tip"``), so the tip does not slide; in the base frame x_F = 0 there.
        sample_time: Ts [s].

    Raises:
        DimensionError: a gain has the wrong shape.
        ParameterError: negative, non-diagonal or all-zero C_F, indefinite motion gains.
    """

    law = staticmethod(laws.inner_position)
    acceleration = staticmethod(laws.inner_position_acceleration)
    #: the law never reads ``reference.position`` (x_F replaces x_d): figures draw no "desired" position for it
    reads_position_reference = False

    @runs_law
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.30), (9.39), (9.43) for this sample; advances ξ by one sample."""
        return self._law_step(t, measurement, reference)


class InnerVelocityForceController(_DirectForceController):
    """Force control with inner velocity loop (Fig. 9.7): (9.45) (J̇ q̇ corrected) with x_F = K_F (f_d − f_e) (9.46).

    Law: ``u = B J⁻¹ (a − J̇ q̇) + n + Jᵀ h_e`` (9.30) with
    ``a = M_d⁻¹ (−K_D ẋ_e + K_P K_F (f_d − f_e))``.
    Closed loop (9.47): ``M_d ẍ_e + K_D ẋ_e + K_P K_F K x_e = K_P K_F (K x_r + f_d)``, second order;
    equilibrium f_e = f_d (9.44) with a purely proportional C_F (K_P and K_F enter as K_P K_F).

    Inputs: ``measurement.q, .qd`` (n,); ``measurement.wrench`` f_e (m,) [N];
    ``reference.force`` f_d (m,) [N]. Output: torques (n,) [N m]. No state.

    Args:
        force_gain: K_F = C_F, scalar, (m,) or diagonal (m, m) [m/N], >= 0, not all zero.

    The other arguments (robot, inertia, damping, stiffness, environment_stiffness, posture,
    singularity, task_frame, sample_time) are those of :class:`InnerPositionForceController`.
    """

    law = staticmethod(laws.inner_velocity)
    #: the law never reads ``reference.position`` (x_F replaces x_d): figures draw no "desired" position for it
    reads_position_reference = False
    acceleration = staticmethod(laws.inner_velocity_acceleration)
    _has_integral: ClassVar[bool] = False

    def __init__(
        self, robot: RobotModel, inertia: Any, damping: Any, stiffness: Any, force_gain: Any, *,
        environment_stiffness: Any = None, posture: Any = None, singularity: Any = None,
        sample_time: float = 1e-3, task_frame: Any = None,
    ) -> None:
        super().__init__(
            robot, inertia, damping, stiffness, force_gain, 0.0,
            environment_stiffness=environment_stiffness, posture=posture, singularity=singularity,
            sample_time=sample_time, task_frame=task_frame,
        )

    @runs_law
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.30), (9.45), (9.46) for this sample."""
        return self._law_step(t, measurement, reference)


class ParallelForcePositionController(_DirectForceController):
    """Parallel force/position control (Fig. 9.8): (9.48) with x_F = C_F (f_d − f_e) (9.41), (9.43).

    Law: ``u = B J⁻¹ (a − J̇ q̇) + n + Jᵀ h_e`` (9.30) with
    ``a = M_d⁻¹ (−K_D ẋ_e + K_P (x̃ + x_F))``, ``x̃ = x_d − x_e`` (9.48),
    ``x_F = K_F (f_d − f_e) + K_I ∫ (f_d − f_e) dζ``.
    Equilibrium (9.49): ``x_e = x_d + C_F (K (x_r − x_e) + f_d)``: x_d is reached along axes
    outside R(K); with integral action f_e = f_d along the force axes. Same characteristic
    polynomial as the inner position loop.

    Inputs: ``measurement.q, .qd`` (n,); ``measurement.wrench`` f_e (m,) [N];
    ``reference.position`` x_d (m,) [m]; ``reference.force`` f_d (m,) [N]. Output: torques (n,) [N m].
    State: ``state = [ξ (m), ξ₀ (m), f_s (m)]`` as for the inner position loop.

    Arguments are those of :class:`InnerPositionForceController`, except that ``integrator_start``
    defaults to ``"zero"`` (x_F is a correction about x_d; x_d steps from the tip and f_d from 0
    at t = 0 with the whole PI acting, the book's step response of Fig. 9.11); ``"hold"`` chooses
    ξ₀ so that x_d + x_F equals the tip before the force step, ``"tip"`` so that it equals the tip
    at t = 0 with f_d(0) applied, bumpless afterwards. The free axes (C_F zero) go to x_d in any
    frame.
    """

    law = staticmethod(laws.parallel)
    acceleration = staticmethod(laws.parallel_acceleration)
    _default_start: ClassVar[str] = "zero"
    _holds_free_axes: ClassVar[bool] = False  # x_d is the free axes' position reference (9.49)

    def __init__(self, robot: RobotModel, *args: Any, frame: Any = None, **kwargs: Any) -> None:
        """As :class:`InnerPositionForceController`, plus ``frame``: an optional frame provider (a moving,
        e.g. estimated, constraint frame: ``update(force, velocity, x)``, ``selection() -> (S_f, S_v)``,
        ``reset()``, ``signals()``, ``describe()``; :class:`~forcecontrol.task.estimation.ConstraintFrameEstimator`).
        With it the task frame is ``R = [S_f S_v]`` of each sample (C_F, ξ in its coordinates: give
        force_gain/integral_gain as ``[normal, 0]``); the reference is in the frame's coordinates
        (``force[:k]`` = λ_d, ``velocity[:d−k]`` = ν_d) and x_d = x_e + S_v (r_d − r), with
        ``r_d − r = ∫ (ν_d − S_vᵀ ẋ_e) dt`` (the tangential position error, kept by the controller).
        Python loop only."""
        self.frame = None
        if frame is not None:
            from .hybrid import _frame_provider

            frame = _frame_provider(frame)
            S_f, S_v = (np.asarray(a, dtype=np.float64) for a in frame.selection())
            kwargs["task_frame"] = np.hstack([S_f, S_v])
        super().__init__(robot, *args, **kwargs)
        if frame is not None:
            self.frame = frame
            self._compiled = False  # R changes every sample: the Python loop
            self.SIGNALS = tuple(getattr(frame, "SIGNALS", ()))
            self._k = int(np.asarray(S_f).shape[1])
            self._tangential_error = np.zeros(self.m - self._k)

    def _position_offset(self, measurement: Measurement, reference: Reference) -> np.ndarray:
        return self.robot.forward_kinematics(measurement.q) - np.asarray(reference.position, dtype=np.float64)

    def _base_reference(self, x: np.ndarray, reference: Reference, S_f: np.ndarray, S_v: np.ndarray) -> Reference:
        """The frame-coordinate reference in the base frame: x_d = x_e + S_v (r_d − r), ẋ_d = S_v ν_d, f_d = S_f λ_d."""
        k, r = self._k, reference
        return Reference(x + S_v @ self._tangential_error, S_v @ np.asarray(r.velocity)[: self.m - k],
                         S_v @ np.asarray(r.acceleration)[: self.m - k], S_f @ np.asarray(r.force)[:k],
                         S_f @ np.asarray(r.force_rate)[:k], S_f @ np.asarray(r.force_accel)[:k])

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """ξ as for the fixed frame; a frame provider back to its first guess, r_d − r = 0."""
        if self.frame is None:
            return super().reset(measurement, reference)
        self.frame.reset()
        self._tangential_error[:] = 0.0
        S_f, S_v = (np.asarray(a, dtype=np.float64) for a in self.frame.selection())
        base = None
        if reference is not None:
            x = self.robot.forward_kinematics(measurement.q) if measurement is not None else np.asarray(reference.position)
            base = self._base_reference(np.asarray(x, dtype=np.float64), reference, S_f, S_v)
        getattr(_DirectForceController.reset, "__wrapped__", _DirectForceController.reset)(self, measurement, base)

    def signals(self) -> dict[str, np.ndarray]:
        """The frame provider's logged signals, else none."""
        return {} if self.frame is None else dict(self.frame.signals())

    @runs_law
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.30), (9.48), (9.43) for this sample; advances ξ by one sample."""
        if self.frame is None:
            return self._law_step(t, measurement, reference)
        from .hybrid import _frame_pose, _on_arm_step

        T, x, xd = _frame_pose(self, measurement)
        self.frame.update(measurement.wrench, xd, x)
        S_f, S_v = (np.asarray(a, dtype=np.float64) for a in self.frame.selection())
        params = self._params.copy()
        where = self.__dict__.get("_R_slice")
        if where is None:  # the block's place in the layout, asked once
            where = self.__dict__["_R_slice"] = FORCE.slice("R", self.m)
        params[where] = np.ravel(np.hstack([S_f, S_v]))
        self._params = params
        x = np.asarray(x, dtype=np.float64)
        base = self._base_reference(x, reference, S_f, S_v)
        u = _on_arm_step(self, t, measurement, base, params) if T is None else self._law_step(t, measurement, base, T)
        nu_d = np.asarray(reference.velocity, dtype=np.float64)[: self.m - self._k]
        self._tangential_error += self.sample_time * (nu_d - S_v.T @ np.asarray(xd, dtype=np.float64))
        return u
