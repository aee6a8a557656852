"""Hybrid force/motion control on the desired frame, 6-D: compliant (Sect. 9.7.1) and rigid (Sect. 9.7.2) environments.

Both run the planar laws of :mod:`forcecontrol.laws.hybrid` in the coordinates of the desired
frame (pose "x_e" = −x̃, the pose servo (9.95) on ``r = S_vᵀ (−x̃)``), then the inverse-dynamics
inner loop (9.30) on ``J_Ad`` (``J_Ad q̈ = c + a``, redundant arms with a null-space posture). The
twist "ẋ_e" and the bias c are the desired-frame error's (−x̃̇, with the desired frame's motion) along
S_v, and along S_f the tip's motion relative to the environment (at rest in the base frame) on the
desired frame (``J_Ad q̇``, ``−J̇_Ad q̇``): the force rate (9.82) is the environment's, and a pose
reference moving along S_f (not servoed) is neither a force rate nor an acceleration asked of the arm.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import laws
from ..core.validate import as_gain_matrix
from ..errors import ParameterError
from ..laws.layout import HYBRID_COMPLIANT, HYBRID_RIGID, HYBRID_STATE, REFERENCE
from ..robots.base import RobotModel
from ..spatial import euler_xyz_T_inv, rotvec_T
from .base import Measurement, Reference
from .hybrid import ForceLaw, _force_law_gains, _frame_provider
from .redundant import SingularityHandling
from .spatial import Orientation, _SpatialBase, _T_dot, desired_frame_error

__all__ = ["SpatialHybridController", "SpatialHybridRigidController"]


def _directions(force_directions: Any) -> tuple[np.ndarray, np.ndarray]:
    """S_f (6, k), orthonormalised, and S_v (6, 6 − k), an orthonormal basis of its complement, from
    desired-frame directions, a :class:`~forcecontrol.task.Task` or :class:`~forcecontrol.task.SelectionMatrices`."""
    if hasattr(force_directions, "selection"):  # a forcecontrol.task.Task (Tables 9.1-9.3)
        force_directions = force_directions.selection()
    if hasattr(force_directions, "force_selection"):  # forcecontrol.task.SelectionMatrices
        force_directions = force_directions.force_selection
    S = np.array(force_directions, dtype=np.float64)
    if S.ndim == 1:
        S = S.reshape(-1, 1)
    if S.ndim != 2 or S.shape[0] != 6 or not 1 <= S.shape[1] <= 6 or not np.all(np.isfinite(S)):
        raise ParameterError(f"force_directions must be a (6, k) matrix with 1 <= k <= 6; got shape {S.shape}")
    Q, Rq = np.linalg.qr(S)
    if np.min(np.abs(np.diag(Rq))) < 1e-9:
        raise ParameterError("force_directions must have linearly independent columns")
    k = Q.shape[1]
    return Q, np.ascontiguousarray(np.linalg.svd(Q, full_matrices=True)[0][:, k:])


#: Where f_d, ḟ_d, f̈_d start in the 6-D reference row (REFERENCE, m = 6).
_FORCE_BLOCKS = tuple(REFERENCE.offset(b, 6) for b in ("f_d", "fdot_d", "fddot_d"))


def _desired_frame(err: Any, reference: Reference, h: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """The measured wrench on the desired frame, h_e^d (6,); fills the force blocks of the packed
    reference row ``ref`` (6 × 6) with h_d, ḣ_d, ḧ_d on the desired frame (pose blocks stay zero:
    the desired frame in its own coordinates)."""
    RdT = err.R_d.T
    for o, w in zip(_FORCE_BLOCKS, (reference.force, reference.force_rate, reference.force_accel)):
        ref[o : o + 3] = RdT @ w[:3]
        ref[o + 3 : o + 6] = RdT @ w[3:]
    return np.concatenate([RdT @ h[:3], RdT @ h[3:]])


def _at_rest(err: Any, Jdq: np.ndarray, qd: np.ndarray, orientation: str) -> tuple[np.ndarray, np.ndarray]:
    """x̃̇ and c (9.33)-(9.34) of a desired frame at rest at this sample's pose: ``−J_Ad q̇`` and ``−J̇_Ad q̇``
    (:func:`~forcecontrol.laws.spatial.desired_frame_terms` with ȯ_d, ω_d, ö_d, ω̇_d zero), the tip's motion
    relative to the environment on the desired frame."""
    RdT = err.R_d.T
    phi = -err.x[3:]
    Tinv = euler_xyz_T_inv(phi) if orientation == "euler" else np.linalg.inv(rotvec_T(phi))
    xd = -(err.JAd @ qd)
    phid = -xd[3:]  # T⁻¹ R_dᵀ ω_e
    c = np.empty(6)
    c[:3] = -(RdT @ Jdq[:3])
    c[3:] = -(Tinv @ (RdT @ Jdq[3:] - _T_dot(orientation, phi, phid) @ phid))
    return xd, c


class _DesiredFrameHybrid(_SpatialBase):
    """What both 6-D hybrids do each sample: the desired-frame coordinates, then the planar law."""

    _params: np.ndarray
    _ws: np.ndarray
    _ref: np.ndarray
    _hc: np.ndarray

    def _run(self, law: Any, t: float, measurement: Measurement, reference: Reference, state: np.ndarray):
        """``law`` on the desired frame: returns (a (6,), the error terms, (q, q̇, B, n, J) for the
        inner loop, h_e); the law's force command is left in ``self._hc``.

        Along S_v the law sees the desired-frame error (twist ``−x̃̇``, bias ``c``, both with the desired
        frame's own motion). Along S_f it sees the tip's motion relative to the environment (at rest in
        the base frame), on the desired frame: the twist ``J_Ad q̇`` (so λ̇ = C⁻¹ S_fᵀ J_Ad q̇, (9.82)
        with K′ = C⁻¹ along S_f) and the bias of a desired frame at rest at this pose (``−J̇_Ad q̇``). A
        reference moving along S_f (whose pose components the law ignores) is thus neither read as a
        force rate nor asked of the arm as an acceleration; S_f is the one of this sample, after the
        frame provider's update. ``err.c`` is replaced by the bias the inner loop must use."""
        q, qd = measurement.q, measurement.qd
        h = self._wrench(measurement.wrench)
        R_e, o_e, J, Jdq, B, nv, _g = self._spatial.spatial_terms(q, qd)
        err = desired_frame_error(R_e, o_e, J, Jdq, qd, reference, self.orientation, t)
        reference = self._frame_step(err, o_e, J[:3] @ qd, h, reference)
        h_d = _desired_frame(err, reference, h, self._ref)
        xd = -err.xd
        if np.asarray(reference.velocity).any() or np.asarray(reference.acceleration).any():  # else x̃̇ = −J_Ad q̇, c = −J̇_Ad q̇
            rest_xd, rest_c = _at_rest(err, Jdq, qd, self.orientation)
            Q = self.force_selection  # this sample's S_f (desired frame, orthonormal columns)
            xd = xd + Q @ (Q.T @ (err.xd - rest_xd))  # S_f components: J_Ad q̇ = −x̃̇ of the frame at rest
            err.c = err.c + Q @ (Q.T @ (rest_c - err.c))
        a = np.empty(6)
        law(t, self.sample_time, -err.x, xd, h_d, self._ref, self._params, state, self._ws, a, self._hc)
        return a, err, (q, qd, B, nv, J), h

    def _frame_step(self, err: Any, o_e: np.ndarray, v_e: np.ndarray, h: np.ndarray, reference: Reference) -> Reference:
        """A frame provider's hook (none here): the reference unchanged."""
        return reference


#: the law's blocks that a frame provider's normal changes each sample (SpatialHybridController._frame_step)
_FRAME_BLOCKS = ("S_v", "S_v_pinv", "S_f_pinv", "CpS_f", "L_hat", "K_1", "K_2")


class SpatialHybridController(_DesiredFrameHybrid):
    """Hybrid force/motion control on the desired frame, for a compliant environment (Sect. 9.7.1 in 6-D).

    The 6-D form of (9.77)–(9.84) with a 6×k force selection ``S_f`` (orthonormal columns,
    desired-frame coordinates) and ``S_v`` its orthogonal complement. Along ``S_v`` the pose error
    on the desired frame (9.9) is servoed; along ``S_f`` the contact force is::

        x̃̈* = P_v (−K_D x̃̇ − K_P x̃) − S_f C f_λ,    P_v = I − S_f S_fᵀ
        f_λ = λ̈_d + K_Dλ (λ̇_d − λ̇) + K_Pλ (λ_d − λ)                       (9.82)
        J_Ad y = P_v c + S_f S_fᵀ c₀ − x̃̈*,   u = B y + n + Jᵀ h_e            (9.30)

    with ``λ = S_fᵀ h_e^d`` the measured force components, ``λ̇ = C⁻¹ S_fᵀ J_Ad q̇`` (9.82) with
    K′ = C⁻¹ along S_f: the tip's twist relative to the environment (at rest in the base frame) on the
    desired frame, so a reference velocity along S_f is not read as a force rate; ``c₀ = −J̇_Ad q̇``
    the bias of the desired frame at rest at this pose (the reference's acceleration along S_f is not
    asked of the arm); and the references ``λ_d = S_fᵀ h_d^d`` from ``reference.force`` (base frame,
    rotated to the desired frame). With the exact model and C:
    ``λ̈ + K_Dλ (λ̇ − λ̇_d) + K_Pλ (λ − λ_d) = λ̈_d`` ((9.79), (9.81)) and the motion error obeys
    ``x̃̈ + K_D x̃̇ + K_P x̃ = 0`` along S_v; at rest ``λ = λ_d`` even with an inexact C ((9.83),
    (9.84)). The pose reference's components along S_f (position, velocity, acceleration) do not
    enter. (S_f is fixed in the desired frame: the book's Ṡ_f = O; the rotation of a moving desired
    frame is not added to λ̇.)

    Inputs: ``measurement.q, .qd`` (n,), ``measurement.wrench`` (6,) base frame about the
    end-effector origin; ``reference`` with m = 6 (the pose components along S_f are ignored,
    ``force`` gives h_d). Output: torques (n,) [N m].

    Args:
        robot: a 6-D robot with ``spatial_terms``.
        force_directions: S_f, (6, k) desired-frame directions (orthonormalised), a (6,) vector, or a
            :class:`~forcecontrol.task.Task` / :class:`~forcecontrol.task.SelectionMatrices` whose
            constraint frame is the desired frame (e.g. ``task.peg_in_hole()``, Table 9.2).
        compliance: C, the environment's compliance along S_f (k, k) SPD [m/N] (scalar allowed).
        stiffness, damping: K_P, K_D of the motion loop (6, 6) SPD [1/s², 1/s].
        force_stiffness, force_damping: K_Pλ, K_Dλ (k, k) SPD [1/s², 1/s].
        orientation, posture, singularity, sample_time: as for :class:`SpatialImpedanceController`.
        frame: optional provider of a moving contact normal (e.g. estimated online:
            :class:`~forcecontrol.task.estimation.ConstraintFrameEstimator` in 3-D), with
            ``update(force, velocity, x)`` (base-frame tip force [N], tip velocity [m/s], tip position
            [m]) and ``selection()`` → (n̂ (3, 1), [t̂ b̂] (3, 2)), base frame. Each sample S_f = [n̂; 0]
            (k = 1) and S_v = [[t̂ b̂ O]; [O I]] (the tangent plane and every rotation) are rotated to
            the desired frame and the law's blocks rebuilt (the same law, no fork); the force
            reference is then λ_d = ``reference.force[0]`` (with its rates) along n̂, the pose
            reference's component along n̂ is not servoed and λ̇ = C⁻¹ n̂ᵀ ȯ_e (the tip's velocity
            along this sample's n̂; on a curved surface the estimate's lag δ makes it read
            ``v sin δ``, the lag term of :func:`forcecontrol.analysis.surface_following.surface_following_error`).
            ``force_directions`` must then be one direction (its value is replaced by the estimate at
            the first sample).
    """

    def __init__(
        self, robot: RobotModel, force_directions: Any, compliance: Any, stiffness: Any, damping: Any,
        force_stiffness: Any, force_damping: Any, *, orientation: Orientation = "euler", posture: Any = None,
        singularity: SingularityHandling | None = None, sample_time: float = 1e-3, frame: Any = None,
    ) -> None:
        super().__init__(robot, orientation, posture, singularity, sample_time, "world", None)
        self.frame = _frame_provider(frame)
        if frame is not None:
            self.SIGNALS = tuple(getattr(frame, "SIGNALS", ()))  # plottable signals of the run
        Q, S_v = _directions(force_directions)
        if frame is not None and Q.shape[1] != 1:
            raise ParameterError(f"force_directions must be one direction with a frame provider (the normal); got {Q.shape[1]}")
        self.force_selection = Q
        k = Q.shape[1]
        self.compliance = as_gain_matrix("compliance", compliance, k)
        self.stiffness = as_gain_matrix("stiffness", stiffness, 6)
        self.damping = as_gain_matrix("damping", damping, 6)
        self.force_stiffness = as_gain_matrix("force_stiffness", force_stiffness, k)
        self.force_damping = as_gain_matrix("force_damping", force_damping, k)
        # the planar hybrid law (9.77)-(9.82), laws.hybrid_compliant_acceleration, on the desired frame:
        # pose "x_e" = −x̃, twist "ẋ_e" = −x̃̇, the pose servo (9.95) with r = S_vᵀ(−x̃) and gains
        # S_vᵀ K S_v, C′ S_f = S_f C and λ̇ = C⁻¹ S_fᵀ ẋ_e (S_f orthonormal, S_v its complement; along S_f,
        # ẋ_e = J_Ad q̇, the tip relative to the environment: _run)
        l = 6 - k
        self._params = HYBRID_COMPLIANT.pack(
            6, l, k, task_dim=6, force_dim=k, position_mode=1.0, S_v=S_v, S_v_pinv=S_v.T, S_f_pinv=Q.T,
            CpS_f=Q @ self.compliance, L_hat=np.linalg.solve(self.compliance, Q.T), K_1=S_v.T @ self.damping @ S_v,
            K_2=S_v.T @ self.stiffness @ S_v, K_Dlam=self.force_damping, K_Plam=self.force_stiffness,
        )
        self._integral = np.zeros(HYBRID_STATE.size(l, 0))  # ∫(ν_d − ν) of (9.80): unused by the pose servo
        self._ws = np.zeros(9 * 6)
        self._ref = np.zeros(REFERENCE.size(6))
        self._hc = np.zeros(6)
        if self.frame is not None:  # where _frame_step writes each sample's blocks, and S_v's constant part
            self._frame_blocks = tuple(HYBRID_COMPLIANT.slice(b, 6, 5, 1) for b in _FRAME_BLOCKS)
            self._frame_S_v = np.zeros((6, 5))
            self._frame_S_v[3:, 2:] = np.eye(3)

    def _frame_step(self, err: Any, o_e: np.ndarray, v_e: np.ndarray, h: np.ndarray, reference: Reference) -> Reference:
        """With a frame provider: update it, rebuild the law's selection blocks on the desired frame, and
        return the reference with λ_d (and its rates) along n̂ in the base frame."""
        if self.frame is None:
            return reference
        self.frame.update(h[:3], v_e, o_e)
        n, tb = (np.asarray(a, dtype=np.float64) for a in self.frame.selection())
        n = n.reshape(3)
        RdT = err.R_d.T
        Q = np.zeros((6, 1))
        Q[:3, 0] = RdT @ n
        S_v = self._frame_S_v  # [[R_dᵀ [t̂ b̂], O]; [O, I]]: only its first block changes
        S_v[:3, :2] = RdT @ tb.reshape(3, 2)
        self.force_selection = Q
        # the blocks, in _FRAME_BLOCKS' order; L̂ = C⁻¹ S_fᵀ with C 1 x 1 (one direction), as LAPACK's solve computes it
        C = self.compliance
        blocks = (S_v, S_v.T, Q.T, Q @ C, Q.T * (1.0 / float(C[0, 0])), S_v.T @ self.damping @ S_v,
                  S_v.T @ self.stiffness @ S_v)
        params = self._params
        for place, value in zip(self._frame_blocks, blocks):
            params[place] = value.ravel()
        r = reference
        wr = np.zeros((3, 6))  # λ_d, λ̇_d, λ̈_d along n̂ (base frame), no moment
        for row, w in zip(wr, (r.force, r.force_rate, r.force_accel)):
            row[:3] = n * float(np.asarray(w, dtype=np.float64)[0])
        return Reference(r.position, r.velocity, r.acceleration, *wr)

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of the 6-D hybrid law for this sample: (9.77)-(9.82) on the desired frame, then (9.30)."""
        a, err, terms, h = self._run(laws.hybrid_compliant_acceleration, t, measurement, reference, self._integral)
        u = self._redundant_torque(err.JAd, err.c + a, *terms, h)  # x̃̈ = −J_Ad q̈ + c = −a
        return self._check_output(t, u, measurement)

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """As every controller; a frame provider back to its first guess."""
        super().reset(measurement, reference)
        if self.frame is not None:
            self.frame.reset()

    def signals(self) -> dict[str, np.ndarray]:
        """The frame provider's logged signals (e.g. estimated vs true normal angle), else none."""
        return {} if self.frame is None else dict(self.frame.signals())

    def gains(self) -> dict[str, Any]:
        if self.frame is not None:
            return {"frame": self.frame.describe(), "compliance": self.compliance.tolist(), "stiffness": self.stiffness.tolist(),
                    "damping": self.damping.tolist(), "force_stiffness": self.force_stiffness.tolist(),
                    "force_damping": self.force_damping.tolist()}
        return {
            "force_directions": self.force_selection.tolist(),
            "compliance": self.compliance.tolist(),
            "stiffness": self.stiffness.tolist(),
            "damping": self.damping.tolist(),
            "force_stiffness": self.force_stiffness.tolist(),
            "force_damping": self.force_damping.tolist(),
        }


class SpatialHybridRigidController(_DesiredFrameHybrid):
    """Hybrid force/motion control on the desired frame, for a rigid environment (Sect. 9.7.2 in 6-D).

    The 6-D form of (9.91)–(9.95): the planar law :func:`forcecontrol.laws.hybrid_rigid_acceleration`
    in the desired frame's coordinates with the pose servo (9.95) along ``S_v`` (the complement of
    ``S_f``) and the force law along ``S_f``::

        a = S_v α_ν,   α_ν = r̈_d + K_Dr (ṙ_d − ν) + K_Pr (r_d − r) = K_Dr S_vᵀ x̃̇ + K_Pr S_vᵀ x̃   (9.95)
        f_λ = λ_d [+ K_Pλ (λ_d − λ)] [+ K_Iλ ∫(λ_d − λ)]          (9.92)-(9.94), λ = S_fᵀ h_e^d
        J_Ad y = c + a,   u = B y + n + Jᵀ h_c,   h_c = blockdiag(R_d, R_d) S_f f_λ     (9.91), (9.30)

    On a rigid environment whose constraint directions are S_f, the reaction equals the commanded
    h_c (λ = f_λ, (9.93)), and the motion along S_v obeys ``r̈ + K_Dr ṙ + K_Pr r = 0``; the pose
    components along S_f are not servoed (the environment holds them): along S_f, c is that of the
    desired frame at rest (``−J̇_Ad q̇``), so the reference's acceleration there is not asked of the arm
    (it would load the environment). ``K_Dr = S_vᵀ K_D S_v``, ``K_Pr = S_vᵀ K_P S_v``.

    Args:
        robot: a 6-D robot with ``spatial_terms``.
        force_directions: S_f (6, k) desired-frame directions (orthonormalised), or a
            :class:`~forcecontrol.task.Task` / :class:`~forcecontrol.task.SelectionMatrices`.
        stiffness, damping: K_P, K_D of the pose servo (6, 6) SPD [1/s², 1/s].
        force_law: ``"feedforward"`` (9.92), ``"proportional"`` (9.93) or ``"integral"`` (9.94).
        force_gain: K_Pλ (k, k) (proportional law only); force_integral_gain: K_Iλ (k, k) [1/s]
            (integral law only).
        orientation, posture, singularity, sample_time: as for :class:`SpatialImpedanceController`.
    """

    def __init__(
        self, robot: RobotModel, force_directions: Any, stiffness: Any, damping: Any, *,
        force_law: ForceLaw = "feedforward", force_gain: Any = None, force_integral_gain: Any = None,
        orientation: Orientation = "euler", posture: Any = None, singularity: SingularityHandling | None = None,
        sample_time: float = 1e-3,
    ) -> None:
        super().__init__(robot, orientation, posture, singularity, sample_time, "world", None)
        Q, S_v = _directions(force_directions)
        self.force_selection = Q
        k = Q.shape[1]
        l = 6 - k
        self.stiffness = as_gain_matrix("stiffness", stiffness, 6)
        self.damping = as_gain_matrix("damping", damping, 6)
        self.force_law = force_law
        self.force_gain, self.force_integral_gain = _force_law_gains(force_law, force_gain, force_integral_gain, k)
        self._params = HYBRID_RIGID.pack(
            6, l, k, task_dim=6, force_dim=k, position_mode=1.0, S_v=S_v, S_v_pinv=S_v.T, S_f=Q, S_f_pinv=Q.T,
            K_1=S_v.T @ self.damping @ S_v, K_2=S_v.T @ self.stiffness @ S_v, K_Plam=self.force_gain,
            K_Ilam=self.force_integral_gain, S_v_dot=np.zeros((6, l)),
        )
        self.state = np.zeros(HYBRID_STATE.size(l, k))  # [∫(ν_d − ν) (unused by the pose servo), ∫(λ_d − λ)]
        self._ws = np.zeros(9 * 6)
        self._ref = np.zeros(REFERENCE.size(6))
        self._hc = np.zeros(6)

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """The force integral back to zero."""
        self.state[:] = 0.0

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.91) on the desired frame for this sample; advances ∫(λ_d − λ)."""
        a, err, terms, _h = self._run(laws.hybrid_rigid_acceleration, t, measurement, reference, self.state)
        h_c, R_d = self._hc, err.R_d  # S_f f_λ on the desired frame, to the base frame
        u = self._redundant_torque(err.JAd, err.c + a, *terms, np.concatenate([R_d @ h_c[:3], R_d @ h_c[3:]]))
        return self._check_output(t, u, measurement)

    def gains(self) -> dict[str, Any]:
        out: dict[str, Any] = {"force_directions": self.force_selection.tolist(), "stiffness": self.stiffness.tolist(),
                               "damping": self.damping.tolist(), "force_law": self.force_law}
        if self.force_law == "proportional":
            out["force_gain"] = self.force_gain.tolist()
        if self.force_law == "integral":
            out["force_integral_gain"] = self.force_integral_gain.tolist()
        return out
