"""Registration of the 6-D analysis: spatial impedance (9.36)/(9.31) and admittance (9.37) on linear environments.

Kept apart from ``parts_spatial`` (which :mod:`.core` imports for the 6-D robots) so that importing
:func:`.core.register_analysis` here closes no import circle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .core import register_analysis, register_response

# ----------------------------------------------------------------------------- 6-D analysis

_AXES = ("x", "y", "z", "rx", "ry", "rz")
_WRENCH = ("fx", "fy", "fz", "mx", "my", "mz")


def _spatial_impedance_applies(parts: dict[str, Any]) -> bool:
    from ..controllers.admittance import AdmittanceController
    from ..controllers.spatial import SpatialImpedanceController
    from ..trajectories import Setpoint

    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    if not isinstance(ctl, (SpatialImpedanceController, AdmittanceController)) or not isinstance(ref, Setpoint):
        return False
    if ref.dim != 6 or not hasattr(env, "stiffness_matrix"):
        return False
    if isinstance(ctl, SpatialImpedanceController) and not getattr(ctl, "force_measurement", True):
        return False
    return np.shape(env.stiffness_matrix()) == (6, 6)


@dataclass
class _Linear6:
    """The 6-D linear model ``M p̈ + K_D ṗ + (K_P + K') p = K' p_r`` of a spatial impedance case.

    ``p`` is the end-effector's pose relative to the desired one in the controller's coordinates:
    ``[R_dᵀ (o_e − o_d); δ]`` with ``R_e = R_d exp([δ]×)`` on the desired frame (9.36)/(9.37), or
    ``x_e − x_d`` (XYZ Euler angles) in the base frame (9.31). ``X`` maps a wrench of the model to
    the base frame.
    """

    K: np.ndarray
    D: np.ndarray
    rest: np.ndarray
    normal: np.ndarray | None
    X: np.ndarray
    o_d: np.ndarray
    R_d: np.ndarray
    phi_d: np.ndarray
    base: bool

    def pose(self, p: np.ndarray) -> np.ndarray:
        """The base-frame pose [o_e; φ_e] (XYZ Euler angles) of a model coordinate p."""
        from ..spatial.closed_form import euler_xyz_to_rotation, rotation_to_euler_xyz, rotvec_to_rotation

        # the angles as the simulator reports them (each in (−π, π])
        if self.base:
            return np.concatenate([self.o_d + p[:3], rotation_to_euler_xyz(euler_xyz_to_rotation(self.phi_d + p[3:]))])
        R_e = self.R_d @ rotvec_to_rotation(p[3:])
        return np.concatenate([self.o_d + self.R_d @ p[:3], rotation_to_euler_xyz(R_e)])

    def coordinate(self, x: np.ndarray) -> np.ndarray:
        """The model coordinate p of a base-frame pose [o_e; φ_e]."""
        from ..spatial.closed_form import euler_xyz_to_rotation, rotation_vector

        if self.base:
            return np.concatenate([x[:3] - self.o_d, x[3:] - self.phi_d])
        return np.concatenate([self.R_d.T @ (x[:3] - self.o_d), rotation_vector(self.R_d.T @ euler_xyz_to_rotation(x[3:]))])


def _linear_model(parts: dict[str, Any]) -> _Linear6:
    """The environment ``h_e = K [o_e − o_r; θ]`` (θ the rotation vector of ``R_e R_rᵀ``) linearised
    about the desired pose, in the controller's coordinates.

    Desired frame: with ``R_e = R_d exp([δ]×)`` and ``R_r = R_d exp([δ_r]×)``, ``θ ≈ R_d (δ − δ_r)``,
    so ``h^d = Xᵀ K X (p − p_r)`` with ``X = blockdiag(R_d, R_d)``, ``p_r = [R_dᵀ (o_r − o_d); δ_r]``.
    Base frame (9.31): ``θ ≈ T(φ_d)(φ_e − φ_d) + rotvec(R_d R_rᵀ)`` and the wrench acts as
    ``h_A = T_Aᵀ h_e`` (9.29), so ``K' = T_Aᵀ K T_A`` with ``T_A = blockdiag(I, T(φ_d))``.
    """
    from ..spatial import euler_xyz_T
    from ..spatial.closed_form import euler_xyz_to_rotation, rotation_vector

    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    pose = np.asarray(ref.position, dtype=float)
    o_d, phi_d = pose[:3], pose[3:]
    R_d = euler_xyz_to_rotation(phi_d)
    K = np.asarray(env.stiffness_matrix(), dtype=float)
    De = np.asarray(env.damping_matrix(), dtype=float) if hasattr(env, "damping_matrix") else np.zeros((6, 6))
    o_r = np.asarray(env.point if hasattr(env, "point") else env.rest_position, dtype=float)[:3]
    R_r = np.asarray(getattr(env, "rest_rotation", R_d), dtype=float)
    normal = getattr(env, "normal", None)
    n6 = None if normal is None else np.concatenate([np.asarray(normal, dtype=float)[:3], np.zeros(3)])
    base = getattr(ctl, "frame", "desired") == "base"
    if base:
        T = euler_xyz_T(phi_d)
        X = np.zeros((6, 6))
        X[:3, :3] = np.eye(3)
        X[3:, 3:] = T  # [Δo; θ] = X p (+ the rest offset)
        rest = np.concatenate([o_r - o_d, -np.linalg.solve(T, rotation_vector(R_d @ R_r.T))])
        # h_A = Xᵀ h_e; the base-frame wrench of a model wrench w = Xᵀ h_e is h_e = X⁻ᵀ w
        to_base = np.linalg.inv(X).T
        normal6 = n6
    else:
        X = np.zeros((6, 6))
        X[:3, :3] = R_d
        X[3:, 3:] = R_d
        rest = np.concatenate([R_d.T @ (o_r - o_d), rotation_vector(R_d.T @ R_r)])
        to_base = X
        normal6 = None if n6 is None else X.T @ n6
    Kp, Dp = X.T @ K @ X, X.T @ De @ X  # the damping force acts on v_e = X ṗ like the spring on X p
    return _Linear6(0.5 * (Kp + Kp.T), 0.5 * (Dp + Dp.T), rest, normal6, to_base, o_d, R_d, phi_d, base)


def _spatial_impedance_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Equilibrium, ω_n and ζ of (9.36) (impedance on the desired frame), (9.31) (impedance in the
    base frame) or (9.37) (admittance) on a linear environment, translation and rotation together.

    The closed loop with force measurement is ``M z̃̈ + K_D z̃̇ + K_P z̃ = h^d`` in the controller's
    coordinates; with the environment linearised about the desired pose (:func:`_linear_model`)
    it is the coupled 6-D model of :func:`~forcecontrol.analysis.impedance_modes` (coupling gains
    and moment stiffness included; valid while the orientation error stays small, the Euler
    angles' T(φ) ≈ T(φ_d)). The admittance's motion loop is taken as ideal (the tip on the
    compliant frame). The equilibrium is reported in the base frame (``steady_x … steady_rz``,
    XYZ Euler angles; ``steady_fx … steady_mz``, the wrench exerted on the environment), the modes
    along the model's axes when they decouple (``omega_n_x``, ``omega_n_rz``, ...), else numbered.
    """
    from ..analysis import impedance_modes

    ctl = parts["controller"]
    lin = _linear_model(parts)
    md = impedance_modes(ctl.inertia, ctl.damping, ctl.stiffness, lin.K, np.zeros(6), lin.rest,
                         one_sided_normal=lin.normal, environment_damping=lin.D)
    x_e = lin.pose(md.position)
    wrench = lin.X @ md.contact_force
    out: dict[str, Any] = {}
    for i in range(6):
        out[f"steady_{_AXES[i]}"] = float(x_e[i])
        out[f"steady_{_WRENCH[i]}"] = float(wrench[i])
    out.update(md.named(_AXES, with_directions=False))
    out["in_contact"] = md.in_contact
    return out


def _coordinate_mobility(lin: _Linear6, robot: Any, q0: np.ndarray) -> np.ndarray:
    """``J_c B⁻¹ Jᵀ X``: the acceleration of the model coordinate per unit model wrench at q0.

    ``J_c = ∂p/∂q`` by central differences of :meth:`_Linear6.coordinate` of the arm's pose (exact
    for any coordinates: rotation vector on the desired frame, Euler angles in the base frame),
    J the geometric Jacobian and X the model wrench's map to the base frame.
    """
    from ..spatial import wrap_angle

    q0 = np.asarray(q0, dtype=float)
    eps = 1e-6
    Jc = np.empty((6, q0.shape[0]))
    for j in range(q0.shape[0]):
        dq = np.zeros_like(q0)
        dq[j] = eps
        d = lin.coordinate(robot.forward_kinematics(q0 + dq)) - lin.coordinate(robot.forward_kinematics(q0 - dq))
        d[3:] = wrap_angle(d[3:])  # Euler angles may wrap between the two poses
        Jc[:, j] = d / (2.0 * eps)
    J = np.asarray(robot.jacobian(q0), dtype=float)
    return Jc @ np.linalg.solve(np.asarray(robot.mass_matrix(q0), dtype=float), J.T) @ lin.X


def _spatial_impedance_response(parts: dict[str, Any], times: Any) -> Any:
    """h_e(t) (base frame, (N, 6)) of the 6-D linear model from rest at the start pose; None when
    the one-sided contact would be left (or is not yet made) at one of the times.

    The loop as the simulator runs it, sampled at the controller's Ts, with the mobility of the
    model coordinate (:func:`_coordinate_mobility`): impedance by
    :func:`~forcecontrol.analysis.impedance_response` with ``sample_time`` and ``mobility``,
    admittance by :func:`_admittance_response`.
    """
    from ..analysis import impedance_response
    from ..controllers.admittance import AdmittanceController

    ctl, robot = parts["controller"], parts["robot"]
    lin = _linear_model(parts)
    q0 = np.asarray(parts["q0"], dtype=float)
    p0 = lin.coordinate(np.asarray(robot.forward_kinematics(q0), dtype=float))
    Mc = _coordinate_mobility(lin, robot, q0)
    if isinstance(ctl, AdmittanceController):
        p, w = _admittance_response(ctl, lin, Mc, p0, times)
    else:  # the desired pose is the model's origin
        p, w = impedance_response(ctl.inertia, ctl.damping, ctl.stiffness, lin.K, np.zeros(6), lin.rest, p0, times,
                                  environment_damping=lin.D, sample_time=ctl.sample_time, mobility=Mc)
    if lin.normal is not None and np.any((p - lin.rest) @ lin.normal > 1e-9):
        return None
    return w @ lin.X.T


def _admittance_response(ctl: Any, lin: _Linear6, Mc: np.ndarray, p0: np.ndarray, times: Any) -> tuple[np.ndarray, np.ndarray]:
    """(p, w) of admittance control (9.37), sampled as the controller runs it, from rest at p0.

    The compliant frame's state ``s = [z̃; z̃̇]`` advances by the controller's own exact ZOH step
    ``s_{k+1} = A_d s_k + G_d w_k`` with the measured wrench w_k (desired frame); the motion loop
    tracks the compliant frame, ``p_t = −z̃`` to first order, with
    ``a_k = p̈_t + K_D (ṗ_t − ṗ_k) + K_P (p_t − p_k)``, ``p̈_t = −M_t⁻¹ (w_k − K_Dt z̃̇ − K_Pt z̃)``,
    and the torque is held while the environment pushes: ``p̈ = a_k + M_c (w_k − w(t))``
    (:func:`~forcecontrol.analysis.contact_plant`).
    """
    from ..analysis import contact_plant, held_input_response

    Mt_inv = np.linalg.inv(ctl.inertia)
    K, D = lin.K, lin.D
    Kw = np.hstack([K, D])  # w = Kw [p; ṗ] − K p_r
    KPD = np.hstack([ctl.motion_stiffness, ctl.motion_damping])
    A, B = contact_plant(Mc, K, D)
    F = (Mc - Mt_inv) @ Kw - KPD
    H = Mt_inv @ np.hstack([ctl.stiffness, ctl.damping]) - KPD
    controller = (H, ctl._Ad, ctl._Gd @ Kw, -ctl._Gd @ (K @ lin.rest))
    z = held_input_response(A, B, F, Mt_inv @ (K @ lin.rest), ctl.sample_time, np.concatenate([p0, np.zeros(6)]), times,
                            controller=controller)
    p = z[:, :6]
    return p, (p - lin.rest) @ K.T + z[:, 6:] @ D.T


register_analysis(_spatial_impedance_applies, _spatial_impedance_analysis)
register_response(_spatial_impedance_applies, _spatial_impedance_response)


# ----------------------------------------------------------------------------- 6-D hybrid (compliant)


def _spatial_hybrid_applies(parts: dict[str, Any]) -> bool:
    from ..controllers.spatial_hybrid import SpatialHybridController

    env = parts["environment"]
    return (isinstance(parts["controller"], SpatialHybridController) and hasattr(env, "stiffness_matrix")
            and np.shape(env.stiffness_matrix()) == (6, 6) and getattr(parts["reference"], "dim", 0) == 6)


def _spatial_hybrid_model(parts: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(L_f, λ_d, the base-frame wrench per unit λ (6, k), the environment's stiffness along S_f K_f).

    On the desired frame the environment's stiffness seen along the force directions is
    ``K_f = S_fᵀ Xᵀ K X S_f`` (X = blockdiag(R_d, R_d)); the commanded ``p̈_f = Ĉ f_λ`` then gives
    ``λ̈ = K_f Ĉ f_λ``, so ``L_f = K_f Ĉ`` (= I when Ĉ = K_f⁻¹), and with λ̇ estimated through Ĉ
    (9.82) the force loop is ``λ̈ + K_Dλ λ̇ + L_f K_Pλ (λ − λ_d) = 0`` (9.84).
    """
    from ..spatial.closed_form import euler_xyz_to_rotation

    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    final = ref.at(float(parts.get("duration", 0.0)))
    R_d = euler_xyz_to_rotation(np.asarray(final.position, dtype=float)[3:])
    X = np.zeros((6, 6))
    X[:3, :3] = R_d
    X[3:, 3:] = R_d
    S_f = np.asarray(ctl.force_selection, dtype=float)
    K_f = S_f.T @ X.T @ np.asarray(env.stiffness_matrix(), dtype=float) @ X @ S_f
    L_f = K_f @ ctl.compliance
    lam_d = S_f.T @ X.T @ np.asarray(final.force, dtype=float)
    return L_f, lam_d, X @ S_f, K_f


def _spatial_hybrid_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """The decoupled closed loops of 6-D hybrid control on a compliant environment: the force loop
    (9.84) along S_f (``force_omega_n``, ``force_zeta``, ``L_f``; settles at λ_d even with Ĉ ≠ C)
    and the pose servo ``x̃̈ + K_D x̃̇ + K_P x̃ = 0`` along S_v (``motion_omega_n_i``,
    ``motion_zeta_i``); the steady wrench on the environment (``steady_fx … steady_mz``) is the
    reference's along S_f (one force direction: k = 1 reports scalars)."""
    from ..analysis import impedance_modes

    ctl = parts["controller"]
    L_f, lam_d, W, K_f = _spatial_hybrid_model(parts)
    out: dict[str, Any] = {}
    if L_f.shape == (1, 1):
        w = float(np.sqrt(L_f[0, 0] * ctl.force_stiffness[0, 0]))
        out.update(L_f=float(L_f[0, 0]), force_omega_n=w, force_zeta=float(ctl.force_damping[0, 0]) / (2.0 * w))
    wrench = W @ lam_d
    for i in range(6):
        out[f"steady_{_WRENCH[i]}"] = float(wrench[i])
    S_v = np.linalg.svd(np.eye(6) - ctl.force_selection @ ctl.force_selection.T)[0][:, : 6 - ctl.force_selection.shape[1]]
    l = S_v.shape[1]
    md = impedance_modes(np.eye(l), S_v.T @ ctl.damping @ S_v, S_v.T @ ctl.stiffness @ S_v, np.zeros((l, l)),
                         np.zeros(l), np.zeros(l))
    for i in range(l):
        out[f"motion_omega_n_{i + 1}"] = float(md.natural_frequencies[i])
        out[f"motion_zeta_{i + 1}"] = float(md.damping_ratios[i])
    out["in_contact"] = bool(np.all(np.linalg.eigvalsh(0.5 * (K_f + K_f.T)) > 0.0))
    return out


def _spatial_hybrid_response_applies(parts: dict[str, Any]) -> bool:
    if not _spatial_hybrid_applies(parts) or parts["controller"].force_selection.shape[1] != 1:
        return False
    return _constant_force_reference(parts)  # the force loop's step response needs a constant λ_d


def _spatial_hybrid_response(parts: dict[str, Any], times: Any) -> Any:
    """h_e(t) of the 6-D force loop (9.84) along the force direction (:func:`_hybrid_force_response`)."""
    ctl = parts["controller"]
    L_f, lam_d, W, K_f = _spatial_hybrid_model(parts)
    return _hybrid_force_response(parts, times, W, float(K_f[0, 0]), float(L_f[0, 0]), float(lam_d[0]),
                                  float(ctl.force_stiffness[0, 0]), float(ctl.force_damping[0, 0]))


def _hybrid_force_response(parts: dict[str, Any], times: Any, W: np.ndarray, kf: float, lf: float, lam_d: float,
                           kp: float, kd: float) -> Any:
    """h_e(t) of the hybrid force loop (9.84) from the start (at rest, contact force of the start pose),
    along the force direction W (the base-frame wrench per unit λ); the motion along S_v exerts
    nothing on the environment.

    The loop is modelled as the simulator runs it, sampled: the law reads λ_k and λ̇_k at
    t_k = k Ts and the torque is held until t_{k+1}. The inner loop (9.30) cancels the measured
    ``Jᵀ h_k`` while the environment pushes with h(t), so between samples
    ``λ̈ = L_f f_λ,k + K_f m (λ_k − λ(t))`` with ``m = wᵀ J B⁻¹ Jᵀ w`` the arm's mobility along
    the force direction w at q0 (:func:`~forcecontrol.analysis.held_input_response`). As
    Ts → 0 this is (9.84), ``λ̈ + K_Dλ λ̇ + L_f K_Pλ (λ − λ_d) = 0``.
    """
    from ..analysis import held_input_response
    from ..sim.simulation import contact_mobility, pre_start_wrench

    ctl, robot = parts["controller"], parts["robot"]
    q0 = np.asarray(parts["q0"], dtype=float)
    h0 = pre_start_wrench(robot, parts["environment"], q0, np.zeros(robot.nq))
    lam0 = float(np.linalg.lstsq(W, h0, rcond=None)[0][0])
    w = W[:, 0]
    mob = float(w @ contact_mobility(robot, q0) @ w)  # [1/kg] along the force direction
    A = np.array([[0.0, 1.0], [-kf * mob, 0.0]])
    B = np.array([[0.0], [1.0]])
    F = np.array([[kf * mob - lf * kp, -kd]])  # v_k = L_f (K_Pλ (λ_d − λ_k) − K_Dλ L_f⁻¹ λ̇_k) + K_f m λ_k
    z = held_input_response(A, B, F, [lf * kp * lam_d], ctl.sample_time, [lam0, 0.0], times)
    return z[:, :1] @ W.T


def _constant_force_reference(parts: dict[str, Any]) -> bool:
    """The reference's force is the same at the start and the end and does not ramp (a step of λ_d)."""
    ref, T = parts["reference"], float(parts.get("duration", 0.0))
    f0, f1 = ref.at(0.0), ref.at(T)
    return bool(np.array_equal(f0.force, f1.force) and not np.any(f0.force_rate) and not np.any(f1.force_rate))


# ----------------------------------------------------------------------------- planar hybrid (compliant)


def _planar_hybrid_response_applies(parts: dict[str, Any]) -> bool:
    """Hybrid force/velocity control (9.77) on an elastic plane, one force direction S_f along the
    plane's normal (unit length), a constant λ_d."""
    from ..controllers.hybrid import HybridCompliantController
    from ..environments.elastic import ElasticPlane

    ctl, env = parts["controller"], parts["environment"]
    if not isinstance(ctl, HybridCompliantController) or not isinstance(env, ElasticPlane) or ctl.selection.m != 1:
        return False
    s_f = np.asarray(ctl.selection.force_selection, dtype=float)[:, 0]
    return bool(abs(abs(float(s_f @ np.asarray(env.normal, dtype=float))) - 1.0) < 1e-9) and _constant_force_reference(parts)


def _planar_hybrid_response(parts: dict[str, Any], times: Any) -> Any:
    """h_e(t) of the planar force loop (9.84) (:func:`_hybrid_force_response`): ``K_f = k``,
    ``L_f = k S_fᵀ Ĉ S_f`` (as the analysis reports it); None when the modelled λ would pull on
    the one-sided plane at one of the times."""
    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    W = np.asarray(ctl.selection.force_selection, dtype=float)
    s_f = W[:, 0]
    kf = float(env.stiffness) * float(s_f @ env.normal) ** 2
    lf = float(s_f @ ctl.compliance @ s_f) * kf
    lam_d = float(ctl.selection.force_pinv[0] @ ref.at(float(parts.get("duration", 0.0))).force)
    h = _hybrid_force_response(parts, times, W, kf, lf, lam_d, float(ctl.force_gain[0, 0]), float(ctl.force_rate_gain[0, 0]))
    if np.any(h @ np.asarray(env.normal, dtype=float) > 1e-9):  # a plane only pushes
        return None
    return h


register_analysis(_spatial_hybrid_applies, _spatial_hybrid_analysis)
register_response(_spatial_hybrid_response_applies, _spatial_hybrid_response)
register_response(_planar_hybrid_response_applies, _planar_hybrid_response)
