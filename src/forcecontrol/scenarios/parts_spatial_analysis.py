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
        from ..spatial import euler_xyz_to_rotation, rotation_to_euler_xyz, rotvec_to_rotation

        # the angles as the simulator reports them (each in (−π, π])
        if self.base:
            return np.concatenate([self.o_d + p[:3], rotation_to_euler_xyz(euler_xyz_to_rotation(self.phi_d + p[3:]))])
        R_e = self.R_d @ rotvec_to_rotation(p[3:])
        return np.concatenate([self.o_d + self.R_d @ p[:3], rotation_to_euler_xyz(R_e)])

    def coordinate(self, x: np.ndarray) -> np.ndarray:
        """The model coordinate p of a base-frame pose [o_e; φ_e]."""
        from ..spatial import euler_xyz_to_rotation, rotation_vector

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
    from ..spatial import euler_xyz_T, euler_xyz_to_rotation, rotation_vector

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
    D = np.abs(md.directions)
    aligned = bool(np.all(np.abs(D.max(axis=1) - 1.0) < 1e-9)) and len(set(D.argmax(axis=1).tolist())) == 6
    for i in range(6):
        name = _AXES[int(D[i].argmax())] if aligned else str(i + 1)
        out[f"omega_n_{name}"] = float(md.natural_frequencies[i])
        out[f"zeta_{name}"] = float(md.damping_ratios[i])
    out["in_contact"] = md.in_contact
    return out


def _spatial_impedance_response_applies(parts: dict[str, Any]) -> bool:
    from ..controllers.spatial import SpatialImpedanceController

    # admittance (9.37): its transient also holds the inner motion loop's dynamics, which the
    # model (the tip on the compliant frame) leaves out; its equilibrium is exact
    return isinstance(parts["controller"], SpatialImpedanceController) and _spatial_impedance_applies(parts)


def _spatial_impedance_response(parts: dict[str, Any], times: Any) -> Any:
    """h_e(t) (base frame, (N, 6)) of the 6-D linear model from rest at the start pose; None when
    the one-sided contact would be left (or is not yet made) at one of the times."""
    from ..analysis import impedance_response

    ctl, robot = parts["controller"], parts["robot"]
    lin = _linear_model(parts)
    x0 = np.asarray(robot.forward_kinematics(np.asarray(parts["q0"], dtype=float)), dtype=float)
    p, w = impedance_response(ctl.inertia, ctl.damping, ctl.stiffness, lin.K, np.zeros(6), lin.rest,
                              lin.coordinate(x0), times, environment_damping=lin.D)
    if lin.normal is not None and np.any((p - lin.rest) @ lin.normal > 1e-9):
        return None
    return w @ lin.X.T


register_analysis(_spatial_impedance_applies, _spatial_impedance_analysis)
register_response(_spatial_impedance_response_applies, _spatial_impedance_response)
