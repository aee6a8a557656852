"""Hybrid force/motion control (Sect. 9.7): compliant (9.74)–(9.84) and rigid (9.87)–(9.95) environments.

Both schemes are inverse-dynamics schemes and use the shared inner loop
``u = B J⁻¹ (a − J̇ q̇) + n + Jᵀ h`` (:func:`forcecontrol.laws.inverse_dynamics`):

* compliant environment, ``γ_e = B_e α + n_e + h_e`` with (9.77)
  ``α = S_v α_ν + C′ S_f f_λ``: ``a = α`` and ``h = h_e`` (the measured wrench); the closed loop
  is ``ν̇ = α_ν`` (9.78), ``λ̈ = f_λ`` (9.79);
* rigid environment, (9.91) ``γ_e = B_e S_v α_ν + S_f f_λ + n_e + B_e Ṡ_v ν``:
  ``a = S_v α_ν + Ṡ_v ν`` and ``h = S_f f_λ``; the closed loop is ``ν̇ = α_ν``, ``λ = f_λ``.

(with ``u = Jᵀ γ_e``, ``B_e = J⁻ᵀ B J⁻¹`` and ``n_e = J⁻ᵀ n − B_e J̇ q̇``, ``Jᵀ γ_e`` is exactly the
inner loop above.) All vectors are in the base frame; the selection matrices are constant
(``Ṡ_v = Ṡ_f = O``, as the chapter assumes in Sect. 9.7.1).

References: the controllers read the usual base-frame :class:`Reference` and map it on the task,
``ν_d = S_v† ẋ_d``, ``ν̇_d = S_v† ẍ_d``, ``λ_d = S_f† f_d``, ``λ̇_d = S_f† ḟ_d``, ``λ̈_d = S_f† f̈_d``
(and ``r_d = S_v† x_d`` for force/position control): a reference with components the natural
constraints forbid is projected, only the artificial constraints are used.

Integrators: the state holds ``∫(ν_d − ν)`` (and ``∫(λ_d − λ)`` for (9.94)), updated by forward
Euler after each sample's law (the law at sample k uses the integral of the errors up to k − 1);
``reset()`` zeroes them.
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np

from .. import laws
from ..core.validate import as_gain_matrix
from ..errors import DimensionError, ParameterError
from ..laws.layout import HYBRID_COMPLIANT, HYBRID_RIGID, HYBRID_STATE
from ..robots.base import RobotModel
from ..task import SelectionMatrices, Task
from .base import Controller, Measurement, Reference, _f64, runs_law

__all__ = [
    "HybridCompliantController",
    "HybridRigidController",
]


# ------------------------------------------------------------------------------------ classes


def _selection(selection: Any, m: int) -> SelectionMatrices:
    if isinstance(selection, Task):
        if selection.frame.moving:
            raise ParameterError(
                "selection must have a fixed constraint frame for hybrid control (Ṡ_v = Ṡ_f = O); "
                f"got the moving frame of task {selection.name!r}"
            )
        selection = selection.selection("base")
    if not isinstance(selection, SelectionMatrices):
        raise ParameterError(f"selection must be a SelectionMatrices or a Task; got {type(selection).__name__}")
    if selection.dim != m:
        raise DimensionError(
            f"selection must act on the robot's {m}-dimensional operational space; got {selection.dim}-dimensional"
        )
    return selection


#: The blocks of HYBRID_COMPLIANT an estimated (moving) frame changes every sample, in this order.
_FRAME_BLOCKS = ("S_v", "S_v_pinv", "S_f_pinv", "CpS_f", "L_hat")

def _frame_pose(controller: Controller, measurement: Measurement) -> tuple[Any, np.ndarray, np.ndarray]:
    """(T, x, ẋ) for a moving-frame step: on the chapter's arm T is None (the law computes the terms in its
    one compiled call, :func:`_on_arm_step`) and x, ẋ come from the kinematics alone; else the robot's terms."""
    pose_twist = getattr(controller.robot, "pose_twist", None) if controller._fused_K is not None else None
    if pose_twist is not None:
        x, xd = pose_twist(measurement.q, measurement.qd)
        return None, x, xd
    T = controller.robot.terms(measurement.q, measurement.qd)
    return T, T.x, T.xd


def _on_arm_step(controller: Controller, t: float, measurement: Measurement, ref: Reference, params: np.ndarray) -> np.ndarray:
    """The controller's law on the chapter's arm with this sample's ``params``, in one compiled call
    (:func:`forcecontrol.laws.on_arm`; ``ref``'s fields float64 arrays): what ``_law_step`` computes from
    the robot's terms, equal to round-off."""
    u = np.empty(controller.robot.nq)
    m = measurement
    if not laws.on_arm(controller.law)(
        controller._fused_K, float(t), controller.sample_time, _f64(m.q), _f64(m.qd), _f64(m.wrench),
        _f64(ref.position), _f64(ref.velocity), _f64(ref.acceleration), _f64(ref.force), _f64(ref.force_rate),
        _f64(ref.force_accel), params, controller.state, controller._workspace(), u,
    ):
        u[:] = np.nan  # named by _check_output (a non-finite input, a singular Jacobian)
    return controller._check_output(t, u, m)


def _frame_provider(frame: Any) -> Any:
    """``frame`` itself when it has what a moving-frame hybrid needs, else a ParameterError naming what is missing."""
    if frame is None:
        return None
    missing = [m for m in ("update", "selection", "reset", "signals", "describe") if not callable(getattr(frame, m, None))]
    if missing:
        raise ParameterError(
            "frame must provide update(force, velocity, x), selection(), reset(), signals() and describe(); "
            f"got a {type(frame).__name__} without {', '.join(missing)}"
        )
    return frame


class HybridCompliantController(Controller):
    """Hybrid force/velocity control on a compliant environment, (9.77) with (9.80)–(9.82).

    Law: ``u = B J⁻¹ (α − J̇ q̇) + n + Jᵀ h_e`` with ``α = S_v α_ν + Ĉ′ S_f f_λ`` (9.77),
    ``α_ν = ν̇_d + K_Pν (ν_d − ν) + K_Iν ∫(ν_d − ν)`` (9.80),
    ``f_λ = λ̈_d + K_Dλ (λ̇_d − λ̇) + K_Pλ (λ_d − λ)`` (9.81),
    ``ν = S_v† J q̇`` (9.60), ``λ = S_f† h_e`` (9.54), ``λ̇ = S_f† K̂′ J q̇ = (S_fᵀ Ĉ S_f)⁻¹ S_fᵀ J q̇``
    (9.82), ``Ĉ′ = (I − P_v) Ĉ`` (9.72). With ``Ĉ = C`` the closed loop is ``ν̇ = α_ν`` (9.78),
    ``λ̈ = f_λ`` (9.79); with ``Ĉ ≠ C`` it is ``λ̈ = L_f f_λ``, ``λ̂̇ = L_f⁻¹ λ̇`` (9.83) and, for
    a constant λ_d, (9.84): still decoupled, still settling to λ_d.

    Inputs: ``measurement.q, .qd`` (n,); ``measurement.wrench`` h_e (d,) [N], base frame;
    ``reference.velocity/.acceleration`` (ẋ_d, ẍ_d) and ``reference.force/.force_rate/
    .force_accel`` (f_d, ḟ_d, f̈_d), base frame, mapped to ν_d, λ_d by S_v†, S_f†.
    Output: torques (n,) [N m]. State: ``∫(ν_d − ν)``, (d − m,).

    Args:
        robot: the manipulator (square Jacobian).
        selection: the task (a :class:`~forcecontrol.task.Task` with a fixed frame, or base-frame
            :class:`~forcecontrol.task.SelectionMatrices`).
        compliance: the environment's compliance C as the controller knows it (Ĉ), symmetric
            positive definite (d, d) [m/N], base frame; a scalar c means c I.
        velocity_gain: K_Pν, SPD (d − m, d − m) [1/s].
        velocity_integral_gain: K_Iν, SPD (d − m, d − m) [1/s²].
        force_gain: K_Pλ, SPD (m, m) [1/s²].
        force_rate_gain: K_Dλ, SPD (m, m) [1/s].
        sample_time: Ts [s].
        frame: optional frame provider for a constraint frame that moves (e.g. estimated online:
            :class:`~forcecontrol.task.estimation.ConstraintFrameEstimator`): an object with
            ``update(force, velocity, x)``, ``selection() -> (S_f, S_v)`` (orthonormal columns),
            ``reset()``, ``signals()`` and ``describe()``. Each sample it is updated with the measured
            h_e and ẋ_e, and (9.77)–(9.82) run with that sample's S_f, S_v (Ĉ′ and L̂ recomputed from
            ``compliance``); the reference is then in the frame's coordinates (its base-frame
            directions are not known in advance): ``velocity[:d−m]``, ``acceleration[:d−m]`` are ν_d,
            ν̇_d and ``force[:m]``, ``force_rate[:m]``, ``force_accel[:m]`` are λ_d, λ̇_d, λ̈_d. Python loop only.
    """

    law = staticmethod(laws.hybrid_compliant)
    acceleration = staticmethod(laws.hybrid_compliant_acceleration)
    position_task_only: ClassVar[bool] = True

    def __init__(
        self, robot: RobotModel, selection: SelectionMatrices | Task, compliance: Any, velocity_gain: Any,
        velocity_integral_gain: Any, force_gain: Any, force_rate_gain: Any, sample_time: float = 1e-3, *,
        frame: Any = None,
    ) -> None:
        super().__init__(robot, sample_time)
        sel = _selection(selection, self.m)
        self.frame = _frame_provider(frame)
        if frame is not None:
            self._compiled = False  # the selection changes every sample: the Python loop
            self.SIGNALS = tuple(getattr(frame, "SIGNALS", ()))  # plottable signals of the run
        self.selection = sel
        d, k = sel.dim, sel.m
        l = d - k
        self.compliance = as_gain_matrix("compliance", compliance, d)
        self.velocity_gain = as_gain_matrix("velocity_gain", velocity_gain, l)
        self.velocity_integral_gain = as_gain_matrix("velocity_integral_gain", velocity_integral_gain, l)
        self.force_gain = as_gain_matrix("force_gain", force_gain, k)
        self.force_rate_gain = as_gain_matrix("force_rate_gain", force_rate_gain, k)
        S_f = sel.force_selection
        self._CpS_f = np.ascontiguousarray(sel.compliance(self.compliance) @ S_f)
        self._L_hat = np.ascontiguousarray(np.linalg.solve(S_f.T @ self.compliance @ S_f, S_f.T))
        self._S_v = np.ascontiguousarray(sel.velocity_selection)
        self._S_v_pinv = np.ascontiguousarray(sel.velocity_pinv)
        self._S_f_pinv = np.ascontiguousarray(sel.force_pinv)
        self.state = np.zeros(HYBRID_STATE.size(l, 0))  # the block nu_integral only
        self._params = HYBRID_COMPLIANT.pack(
            d, l, k, task_dim=d, force_dim=k, position_mode=0.0, S_v=self._S_v, S_v_pinv=self._S_v_pinv,
            S_f_pinv=self._S_f_pinv, CpS_f=self._CpS_f, L_hat=self._L_hat, K_1=self.velocity_gain,
            K_2=self.velocity_integral_gain, K_Dlam=self.force_rate_gain, K_Plam=self.force_gain,
        )

    def force_coordinates(self, wrench: Any) -> np.ndarray:
        """λ = S_f† h_e (9.54)."""
        return self.selection.force_coordinates(wrench)

    @runs_law
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.77), (9.80), (9.81) for this sample; advances the velocity integral."""
        if self.frame is None:
            return self._law_step(t, measurement, reference)
        T, x, xd = _frame_pose(self, measurement)
        self.frame.update(measurement.wrench, xd, x)
        S_f, S_v = (np.asarray(a, dtype=np.float64) for a in self.frame.selection())
        d, k = self.selection.dim, self.selection.m
        l = d - k
        slices = self.__dict__.get("_frame_slices")
        if slices is None:  # where each moving block sits (the layout's offsets, asked once)
            where = [HYBRID_COMPLIANT.slice(b, d, l, k) for b in _FRAME_BLOCKS]
            flat = np.concatenate([np.arange(w.start, w.stop) for w in where])
            slices = self.__dict__["_frame_slices"] = (where, np.eye(d), flat)
        where, eye, flat = slices
        params = self._params.copy()
        r = reference
        if d == 2 and S_f.shape == (2, 1) and S_v.shape == (2, 1):  # planar: the same products on scalars
            values, base = self._planar_frame(S_f, S_v, r)
            params[flat] = values
        else:
            C = self.compliance
            for at, value in zip(where, (S_v, S_v.T, S_f.T, (eye - S_v @ S_v.T) @ C @ S_f,
                                         np.linalg.solve(S_f.T @ C @ S_f, S_f.T))):
                params[at] = value.ravel()
            base = Reference(_f64(r.position), S_v @ np.asarray(r.velocity)[:l],
                             S_v @ np.asarray(r.acceleration)[:l], S_f @ np.asarray(r.force)[:k],
                             S_f @ np.asarray(r.force_rate)[:k], S_f @ np.asarray(r.force_accel)[:k])
        self._params = params
        if T is None:
            return _on_arm_step(self, t, measurement, base, params)
        return self._law_step(t, measurement, base, T)

    def _planar_frame(self, S_f: np.ndarray, S_v: np.ndarray, r: Reference) -> tuple[list[float], Reference]:
        """The blocks S_v, S_v†, S_f†, Ĉ′ S_f = (I − S_v S_vᵀ) Ĉ S_f, L̂ = (S_fᵀ Ĉ S_f)⁻¹ S_fᵀ of a planar frame
        (S_f = n̂, S_v = t̂, (2, 1)) in that order, and the reference mapped on it: the products of the
        general path written out on scalars (equal to round-off), without its ten small arrays."""
        n0, n1 = S_f.ravel().tolist()
        t0, t1 = S_v.ravel().tolist()
        c00, c01, c10, c11 = self.compliance.ravel().tolist()
        p00, p01, p10, p11 = 1.0 - t0 * t0, 0.0 - t0 * t1, 0.0 - t1 * t0, 1.0 - t1 * t1
        q00, q01 = p00 * c00 + p01 * c10, p00 * c01 + p01 * c11
        q10, q11 = p10 * c00 + p11 * c10, p10 * c01 + p11 * c11
        lam = (n0 * c00 + n1 * c10) * n0 + (n0 * c01 + n1 * c11) * n1
        values = [t0, t1, t0, t1, n0, n1, q00 * n0 + q01 * n1, q10 * n0 + q11 * n1, n0 / lam, n1 / lam]
        v, a, f, fd, fdd = (float(np.asarray(w)[0]) for w in (r.velocity, r.acceleration, r.force, r.force_rate,
                                                              r.force_accel))
        base = Reference(_f64(r.position), np.array((t0 * v, t1 * v)), np.array((t0 * a, t1 * a)),
                         np.array((n0 * f, n1 * f)), np.array((n0 * fd, n1 * fd)), np.array((n0 * fdd, n1 * fdd)))
        return values, base

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Integrators zeroed; a frame provider back to its first guess."""
        self.state[:] = 0.0
        if self.frame is not None:
            self.frame.reset()

    def signals(self) -> dict[str, np.ndarray]:
        """The frame provider's logged signals (e.g. estimated vs true normal angle), else none."""
        return {} if self.frame is None else dict(self.frame.signals())

    def gains(self) -> dict[str, Any]:
        if self.frame is not None:
            return {"frame": self.frame.describe(), "compliance": self.compliance.tolist(),
                    "velocity_gain": self.velocity_gain.tolist(), "velocity_integral_gain": self.velocity_integral_gain.tolist(),
                    "force_gain": self.force_gain.tolist(), "force_rate_gain": self.force_rate_gain.tolist()}
        return {
            "S_f": self.selection.force_selection.tolist(),
            "S_v": self.selection.velocity_selection.tolist(),
            "compliance": self.compliance.tolist(),
            "velocity_gain": self.velocity_gain.tolist(),
            "velocity_integral_gain": self.velocity_integral_gain.tolist(),
            "force_gain": self.force_gain.tolist(),
            "force_rate_gain": self.force_rate_gain.tolist(),
        }


ForceLaw = Literal["feedforward", "proportional", "integral"]


def _force_law_gains(force_law: str, force_gain: Any, force_integral_gain: Any, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(K_Pλ, K_Iλ) of the rigid hybrid's force law: (9.92) feedforward, (9.93) proportional or
    (9.94) integral; the gain the law does not use is zero, and giving it is refused."""
    if force_law not in ("feedforward", "proportional", "integral"):
        raise ParameterError(f"force_law must be 'feedforward', 'proportional' or 'integral'; got {force_law!r}")
    out = []
    for name, value, law, eq in (("force_gain", force_gain, "proportional", "K_Pλ of (9.93)"),
                                 ("force_integral_gain", force_integral_gain, "integral", "K_Iλ of (9.94)")):
        if force_law == law:
            if value is None:
                raise ParameterError(f"{name} must be given for force_law={law!r} ({eq}); got None")
            out.append(as_gain_matrix(name, value, k))
        elif value is not None:
            raise ParameterError(f"{name} applies to force_law={law!r} only; got a value with force_law={force_law!r}")
        else:
            out.append(np.zeros((k, k)))
    return out[0], out[1]


def _motion_gain(motion: str, name: str, value: Any, what: str, other: str, other_value: Any, size: int) -> np.ndarray:
    """The gain the motion law ``motion`` needs (``name``, required), refusing the other law's (``other``)."""
    if value is None:
        raise ParameterError(f"{name} must be given for motion={motion!r} ({what}); got None")
    if other_value is not None:
        law = "position" if motion == "velocity" else "velocity"
        raise ParameterError(f"{other} applies to motion={law!r} only; got a value with motion={motion!r}")
    return as_gain_matrix(name, value, size)


#: The blocks of HYBRID_RIGID a moving constraint changes every sample.
_MOVING_BLOCKS = ("S_v", "S_v_pinv", "S_f", "S_f_pinv", "S_v_dot")


class HybridRigidController(Controller):
    """Hybrid force/velocity (or force/position) control on a rigid environment, (9.91)–(9.95).

    Law: ``u = Jᵀ γ_e`` with (9.91) ``γ_e = B_e (S_v α_ν + Ṡ_v ν) + S_f f_λ + n_e``, i.e.
    ``u = B J⁻¹ (S_v α_ν + Ṡ_v ν − J̇ q̇) + n + Jᵀ S_f f_λ`` (Ṡ_v = O for a fixed task frame);
    the closed loop is ``ν̇ = α_ν``, ``λ = f_λ``. With a contact geometry that moves with the
    end-effector (``selection`` an :class:`~forcecontrol.environments.rigid.OperationalConstraint`,
    e.g. the handle of a crank) S_f, S_v and Ṡ_v are evaluated at each sample from the measured
    state and the term ``Ṡ_v ν`` is what keeps λ = f_λ (without it the reaction would carry the
    centripetal force). Force laws: ``"feedforward"`` (9.92)
    ``f_λ = λ_d``; ``"proportional"`` (9.93) ``f_λ = λ_d + K_Pλ (λ_d − λ)``; ``"integral"`` (9.94)
    ``f_λ = λ_d + K_Iλ ∫(λ_d − λ)``, with ``λ = S_f† h_e`` (9.54). Motion: ``"velocity"`` (9.80)
    ``α_ν = ν̇_d + K_Pν (ν_d − ν) + K_Iν ∫(ν_d − ν)``; ``"position"`` (9.95)
    ``α_ν = r̈_d + K_Dr (ṙ_d − ν) + K_Pr (r_d − r)`` with ``r = ψ(q) = S_v† x_e`` (a valid choice of
    (9.61) for a constant S_v, e.g. a plane: then ``ṙ = ν``) and ``r_d = S_v† x_d``.

    Inputs: ``measurement.q, .qd`` (n,), ``measurement.wrench`` h_e (d,) [N] (the reaction),
    ``reference.position/.velocity/.acceleration`` and ``reference.force`` (f_d), base frame,
    mapped with the selection of the sample (``ν_d = S_v† ẋ_d``, ``λ_d = S_f† f_d``).
    Output: torques (n,) [N m]. State: ``[∫(ν_d − ν) (d − m), ∫(λ_d − λ) (m)]``.

    Args:
        robot: the manipulator (square Jacobian).
        selection: task or base-frame selection matrices (fixed frame), or a planar single
            operational constraint whose ``selection(x, ẋ)`` gives S_f, S_v, Ṡ_v (moving
            geometry; velocity motion only; Python loop only).
        motion: ``"velocity"`` (9.80) or ``"position"`` (9.95).
        velocity_gain: K_Pν (velocity) or K_Dr (position), SPD (d − m, d − m) [1/s].
        velocity_integral_gain: K_Iν, SPD [1/s²] (velocity mode only).
        position_gain: K_Pr, SPD [1/s²] (position mode only).
        force_law: ``"feedforward"``, ``"proportional"`` or ``"integral"``.
        force_gain: K_Pλ, SPD (m, m) [-] (proportional law only).
        force_integral_gain: K_Iλ, SPD (m, m) [1/s] (integral law only).
        sample_time: Ts [s].
    """

    law = staticmethod(laws.hybrid_rigid)
    acceleration = staticmethod(laws.hybrid_rigid_acceleration)
    position_task_only: ClassVar[bool] = True

    def __init__(
        self, robot: RobotModel, selection: SelectionMatrices | Task, *,
        motion: Literal["velocity", "position"] = "velocity", velocity_gain: Any,
        velocity_integral_gain: Any = None, position_gain: Any = None, force_law: ForceLaw = "integral",
        force_gain: Any = None, force_integral_gain: Any = None, sample_time: float = 1e-3,
    ) -> None:
        super().__init__(robot, sample_time)
        from ..environments.rigid import OperationalConstraint

        self._constraint: OperationalConstraint | None = None
        if isinstance(selection, OperationalConstraint):
            if selection.dim != self.m or selection.dim != 2 or selection.size != 1:
                raise DimensionError(
                    "selection from a constraint needs one constraint on a 2-dimensional operational space; "
                    f"got dim {selection.dim}, size {selection.size} for a {self.m}-dimensional robot"
                )
            if motion != "velocity":
                raise ParameterError(
                    "motion must be 'velocity' with a moving contact geometry (r = ψ(q) of (9.95) is not known); "
                    f"got {motion!r}"
                )
            self._constraint = selection
            self._compiled = False  # state-dependent S_f, S_v: repacked each sample, the Python loop only
            selection = SelectionMatrices([[0.0], [1.0]], [[1.0], [0.0]])  # sizes and gains only
        sel = _selection(selection, self.m)
        self.selection = sel
        d, k = sel.dim, sel.m
        l = d - k
        if motion not in ("velocity", "position"):
            raise ParameterError(f"motion must be 'velocity' or 'position'; got {motion!r}")
        self.motion = motion
        self.force_law = force_law
        self.velocity_gain = as_gain_matrix("velocity_gain", velocity_gain, l)
        if motion == "velocity":
            self.second_gain = _motion_gain(motion, "velocity_integral_gain", velocity_integral_gain, "K_Iν of (9.80)",
                                            "position_gain", position_gain, l)
        else:
            self.second_gain = _motion_gain(motion, "position_gain", position_gain, "K_Pr of (9.95)",
                                            "velocity_integral_gain", velocity_integral_gain, l)
        self.force_gain, self.force_integral_gain = _force_law_gains(force_law, force_gain, force_integral_gain, k)
        self._S_v = np.ascontiguousarray(sel.velocity_selection)
        self._S_v_pinv = np.ascontiguousarray(sel.velocity_pinv)
        self._S_f = np.ascontiguousarray(sel.force_selection)
        self._S_f_pinv = np.ascontiguousarray(sel.force_pinv)
        self._S_v_dot = np.zeros((d, l))
        self.state = np.zeros(HYBRID_STATE.size(l, k))
        self._params = self._pack(self._S_v, self._S_v_pinv, self._S_f, self._S_f_pinv, self._S_v_dot)
        self._slices = {b: HYBRID_RIGID.slice(b, d, l, k) for b in _MOVING_BLOCKS}

    def _pack(self, S_v, S_v_pinv, S_f, S_f_pinv, S_v_dot) -> np.ndarray:
        """The parameters of :func:`forcecontrol.laws.hybrid_rigid` for this selection."""
        d, k = self.selection.dim, self.selection.m
        return HYBRID_RIGID.pack(
            d, d - k, k, task_dim=d, force_dim=k, position_mode=float(self.motion == "position"), S_v=S_v,
            S_v_pinv=S_v_pinv, S_f=S_f, S_f_pinv=S_f_pinv, K_1=self.velocity_gain, K_2=self.second_gain,
            K_Plam=self.force_gain, K_Ilam=self.force_integral_gain, S_v_dot=S_v_dot,
        )

    def force_coordinates(self, wrench: Any) -> np.ndarray:
        """λ = S_f† h_e (9.54)."""
        return self.selection.force_coordinates(wrench)

    @runs_law
    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.91) with the chosen force and motion laws; advances the integrals."""
        if self._constraint is None:
            return self._law_step(t, measurement, reference)
        T = self.robot.terms(measurement.q, measurement.qd)
        S_f, S_v, S_v_dot = self._constraint.selection(T.x, T.xd)
        params = self._params.copy()  # the blocks of this sample's selection (unit columns, W = I), in place by name
        for block, value in zip(_MOVING_BLOCKS, (S_v, S_v.T, S_f, S_f.T, S_v_dot)):
            params[self._slices[block]] = np.ravel(value)
        self._params = params
        return self._law_step(t, measurement, reference, T)

    def gains(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "S_f": self.selection.force_selection.tolist(),
            "S_v": self.selection.velocity_selection.tolist(),
        } if self._constraint is None else {"selection_from": self._constraint.describe()}
        out.update({
            "motion": self.motion,
            "force_law": self.force_law,
            "velocity_gain": self.velocity_gain.tolist(),
        })
        out["velocity_integral_gain" if self.motion == "velocity" else "position_gain"] = self.second_gain.tolist()
        if self.force_law == "proportional":
            out["force_gain"] = self.force_gain.tolist()
        if self.force_law == "integral":
            out["force_integral_gain"] = self.force_integral_gain.tolist()
        return out
