"""Admittance control (Sect. 9.3, Fig. 9.5): a compliant frame from the measured wrench, tracked by inverse dynamics.

The compliant frame O_t (o_t, R_t) is the ideal behaviour under impedance control. Its error
from the desired frame, ``z̃ = −[R_dᵀ (o_t − o_d); φ_{d,t}]`` ((9.9) with t in place of e), obeys
(9.37)::

    M_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e^d

integrated here exactly over each sample with the measured wrench held (zero-order hold, the
matrix exponential of the linear system). The compliant frame's pose, twist and acceleration
are then the reference of an inverse-dynamics motion loop ((9.28), (9.30), on the compliant
frame's error (9.9) so the motion loop is configuration-independent too)::

    J_At y = c + K_D ẽ̇ + K_P ẽ,      u = B y + n + Jᵀ h_e        (ẽ = error of O_e from O_t)

so that ``ẽ̈ + K_D ẽ̇ + K_P ẽ = 0``: the end-effector tracks the compliant frame with the motion
loop's (stiff) gains while the interaction is shaped by (9.37). The scheme is stable when the
motion loop is faster than the impedance loop; the constructor checks the natural frequencies
``ω_motion = sqrt(λ_min(K_P))`` and ``ω_impedance = sqrt(λ_max(M_t⁻¹ K_Pt))`` (with an expected
environment stiffness added to K_Pt when given) and warns with :class:`BandwidthWarning` when
``ω_motion < bandwidth_ratio · ω_impedance``.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from ..core.validate import as_gain_matrix, positive_scalar, readonly
from ..errors import BandwidthWarning, ParameterError
from ..robots.base import RobotModel
from ..spatial import euler_xyz_T, euler_xyz_T_dot
from ..spatial.closed_form import euler_xyz_to_rotation, rotation_to_euler_xyz  # per sample
from .base import Measurement, Reference
from .spatial import _cross, _SpatialBase, desired_frame_error, spatial_impedance_acceleration

__all__ = ["AdmittanceController", "compliant_frame"]



def compliant_frame(reference: Reference, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray) -> Reference:
    """The compliant frame as a 6-D reference, from z̃, z̃̇, z̃̈ (9.37) and the desired frame.

    With ``o^d = −z̃_P`` (o_{d,t}^d) and ``φ = −z̃_O`` (φ_{d,t}), in the base frame::

        o_t = o_d + R_d o^d,                 R_t = R_d R(φ)
        ȯ_t = ȯ_d + ω_d × R_d o^d + R_d ȯ^d
        ω_t = ω_d + R_d T(φ) φ̇
        ö_t = ö_d + ω̇_d × R_d o^d + ω_d × (ω_d × R_d o^d) + 2 ω_d × R_d ȯ^d + R_d ö^d
        ω̇_t = ω̇_d + ω_d × R_d T φ̇ + R_d (Ṫ φ̇ + T φ̈)

    Returns:
        A :class:`Reference` (position ``[o_t; φ_t]`` XYZ angles, velocity ``[ȯ_t; ω_t]``,
        acceleration ``[ö_t; ω̇_t]``; force blocks zero).
    """
    pos, vel, acc = reference.position, reference.velocity, reference.acceleration
    R_d = euler_xyz_to_rotation(pos[3:])
    w_d, wd_dot = vel[3:], acc[3:]
    p, pd, pdd = -z[:3], -zd[:3], -zdd[:3]
    phi, phid, phidd = -z[3:], -zd[3:], -zdd[3:]
    Rp = R_d @ p
    Rpd = R_d @ pd
    T = euler_xyz_T(phi)
    wrel = R_d @ (T @ phid)
    o_t = pos[:3] + Rp
    R_t = R_d @ euler_xyz_to_rotation(phi)
    od_t = vel[:3] + _cross(w_d, Rp) + Rpd
    w_t = w_d + wrel
    odd_t = acc[:3] + _cross(wd_dot, Rp) + _cross(w_d, _cross(w_d, Rp)) + 2.0 * _cross(w_d, Rpd) + R_d @ pdd
    wd_t = wd_dot + _cross(w_d, wrel) + R_d @ (euler_xyz_T_dot(phi, phid) @ phid + T @ phidd)
    z6 = np.zeros(6)
    return Reference(
        np.concatenate([o_t, rotation_to_euler_xyz(R_t)]), np.concatenate([od_t, w_t]), np.concatenate([odd_t, wd_t]),
        z6, z6, z6,
    )


class AdmittanceController(_SpatialBase):
    """Admittance control: (9.37) for the compliant frame, inverse dynamics (9.28), (9.30) to track it.

    Law: ``z̃`` integrated from ``M_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e^d`` (exact ZOH over each sample);
    ``u = B y + n + Jᵀ h_e`` with ``J_At y = c + K_D ẽ̇ + K_P ẽ`` (ẽ the end-effector's error
    from the compliant frame, (9.9)); null-space posture and damped least squares as in
    :class:`~forcecontrol.controllers.spatial.SpatialImpedanceController`.

    State: ``state = [z̃ (6); z̃̇ (6)]`` (desired-frame coordinates), zero after :meth:`reset`
    (the compliant frame starts on the desired frame). ``step`` advances it by one sample.

    Inputs: ``measurement.q, .qd`` (n,), ``measurement.wrench`` h_e (6,) base frame about the
    end-effector origin; ``reference`` with m = 6. Output: torques (n,) [N m].

    Args:
        robot: a 6-D robot with ``spatial_terms``.
        inertia, damping, stiffness: M_t, K_Dt, K_Pt of (9.37), SPD (6, 6) (K_Pt may be PSD).
        motion_stiffness, motion_damping: K_P, K_D of the motion loop, SPD (6, 6) [1/s², 1/s].
        environment_stiffness: expected contact stiffness (6, 6) PSD for the bandwidth check
            (default none).
        bandwidth_ratio: required ``ω_motion / ω_impedance`` (default 3).
        orientation, posture, singularity, sample_time: as for the impedance controller
            (``orientation`` applies to the motion loop; (9.37) uses XYZ angles).
    """

    GAINS = ("inertia", "damping", "stiffness", "motion_stiffness", "motion_damping", "bandwidths")

    def __init__(
        self, robot: RobotModel, inertia: Any, damping: Any, stiffness: Any, *, motion_stiffness: Any = 2500.0,
        motion_damping: Any = 100.0, environment_stiffness: Any = None, bandwidth_ratio: float = 3.0,
        orientation: str = "euler", posture: Any = None, singularity: Any = None, sample_time: float = 1e-3,
        base_frame: str = "world", ee_frame: str | None = None,
    ) -> None:
        super().__init__(robot, orientation, posture, singularity, sample_time, base_frame, ee_frame)
        self.inertia = as_gain_matrix("inertia", inertia, 6)
        self.damping = as_gain_matrix("damping", damping, 6)
        self.stiffness = as_gain_matrix("stiffness", stiffness, 6, definite=False)
        self.motion_stiffness = as_gain_matrix("motion_stiffness", motion_stiffness, 6)
        self.motion_damping = as_gain_matrix("motion_damping", motion_damping, 6)
        self.bandwidth_ratio = positive_scalar("bandwidth_ratio", bandwidth_ratio)
        self.environment_stiffness = (
            None
            if environment_stiffness is None
            else as_gain_matrix("environment_stiffness", environment_stiffness, 6, definite=False)
        )
        self._Mt_inv = np.linalg.inv(self.inertia)
        self._discretise()
        self.state = np.zeros(12)
        self._eye6 = readonly(np.eye(6))  # M_d⁻¹ of the motion law: read-only like its gains (one compiled law)
        self.bandwidths = self.check_bandwidth()

    def _discretise(self) -> None:
        """(9.37) as x = [z; ż]: ẋ = A x + G h, discretised exactly with the wrench held (ZOH)."""
        from scipy.linalg import expm  # type: ignore[import-untyped]  # here: SciPy costs ~0.4 s to import

        Mt_inv = self._Mt_inv
        A = np.zeros((12, 12))
        A[:6, 6:] = np.eye(6)
        A[6:, :6] = -Mt_inv @ self.stiffness
        A[6:, 6:] = -Mt_inv @ self.damping
        G = np.zeros((12, 6))
        G[6:] = Mt_inv
        big = np.zeros((18, 18))
        big[:12, :12] = A * self.sample_time
        big[:12, 12:] = G * self.sample_time
        with np.errstate(all="ignore"):
            E = expm(big) if np.all(np.isfinite(big)) else np.full_like(big, np.nan)
        if not np.all(np.isfinite(E)):
            raise ParameterError(
                "inertia, damping and stiffness give a compliant frame (9.37) that cannot be discretised at "
                f"sample_time = {self.sample_time:g} s (its matrix exponential overflows): M_t⁻¹ K_Pt has eigenvalues up to "
                f"{float(np.max(np.abs(np.linalg.eigvals(np.nan_to_num(Mt_inv @ self.stiffness))))):.3g} 1/s²; "
                "use physically sized gains"
            )
        self._Ad, self._Gd = E[:12, :12], E[:12, 12:]
        self._A, self._G = A, G

    def check_bandwidth(self) -> dict[str, float]:
        """The two loops' natural frequencies [rad/s]; warns when the motion loop is not faster.

        Returns:
            ``{"motion": ω_motion, "impedance": ω_impedance, "ratio": ω_motion / ω_impedance}``.
        """
        K = self.stiffness if self.environment_stiffness is None else self.stiffness + self.environment_stiffness
        w_imp = math.sqrt(max(float(np.max(np.real(np.linalg.eigvals(self._Mt_inv @ K)))), 0.0))
        w_mot = math.sqrt(float(np.linalg.eigvalsh(self.motion_stiffness)[0]))
        ratio = w_mot / w_imp if w_imp > 0 else math.inf
        if ratio < self.bandwidth_ratio:
            warnings.warn(
                f"admittance control: the motion loop (ω = {w_mot:.3g} rad/s) must be faster than the impedance "
                f"loop (ω = {w_imp:.3g} rad/s) by bandwidth_ratio = {self.bandwidth_ratio:g}; got a ratio of "
                f"{ratio:.3g}. Raise motion_stiffness or lower the impedance stiffness",
                BandwidthWarning,
                stacklevel=3,
            )
        return {"motion": w_mot, "impedance": w_imp, "ratio": ratio}

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """The compliant frame back on the desired frame at rest."""
        self.state[:] = 0.0

    def compliant_reference(self, reference: Reference, h_d: np.ndarray) -> Reference:
        """The compliant frame for the current state and held wrench (desired frame, h_e^d)."""
        z, zd = self.state[:6], self.state[6:]
        zdd = self._Mt_inv @ (h_d - self.damping @ zd - self.stiffness @ z)
        return compliant_frame(reference, z, zd, zdd)

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques tracking the compliant frame; advances (9.37) by one sample."""
        q, qd = measurement.q, measurement.qd
        h = self._wrench(measurement.wrench)
        R_d = euler_xyz_to_rotation(reference.position[3:])
        h_d = np.concatenate([R_d.T @ h[:3], R_d.T @ h[3:]])
        self.held_wrench = h_d  # h_e^d held over this sample (the input of (9.37)'s discretisation)
        ref_t = self.compliant_reference(reference, h_d)
        if self.compiled:
            u = self._compiled_torque(t, q, qd, h, ref_t, self._eye6, self.motion_damping, self.motion_stiffness, False)
            self.state[:] = self._Ad @ self.state + self._Gd @ h_d
            return self._check_output(t, u, measurement)
        R_e, o_e, J, Jdq, B, nv, _g = self._spatial.spatial_terms(q, qd)
        err = desired_frame_error(R_e, o_e, J, Jdq, qd, ref_t, self.orientation, t)
        r = spatial_impedance_acceleration(err, h_d, self._eye6, self.motion_damping, self.motion_stiffness, False)
        u = self._redundant_torque(err.JAd, r, q, qd, B, nv, J, h)
        self.state[:] = self._Ad @ self.state + self._Gd @ h_d
        return self._check_output(t, u, measurement)

