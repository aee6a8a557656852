"""6-D compliance (9.15) and impedance (9.35) control with the error on the desired frame.

Error (9.9): ``x̃ = −[R_dᵀ (o_e − o_d); φ_{d,e}]``, φ_{d,e} the XYZ Euler angles of ``R_dᵀ R_e``
(or, with ``orientation="rotvec"``, its rotation vector: no representation singularity short of
a 2π rotation, the chapter's alternative to Euler angles). ``x̃̇ = −J_Ad q̇ + b`` (9.33) with the
analytical Jacobian on the desired frame (9.14) ``J_Ad = T_A⁻¹ blockdiag(R_dᵀ, R_dᵀ) J``.

Impedance (9.30), (9.35): ``u = B y + n + Jᵀ h_e`` with y solving
``J_Ad y = M_d⁻¹ (K_D x̃̇ + K_P x̃ − h_e^d) − J̇_Ad q̇ + ḃ``, which gives the
configuration-independent impedance (9.36) ``M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_e^d``, all vectors on the
desired frame. ``−J̇_Ad q̇ + ḃ`` is computed as one term, the part of x̃̈ that does not depend on
q̈ (written out in :func:`forcecontrol.laws.spatial.desired_frame_terms`), for a desired frame moving with
``[ȯ_d; ω_d]`` and ``[ö_d; ω̇_d]``.

Redundant arms (n > 6) and singularities: y is solved with
:func:`forcecontrol.controllers.redundant.redundant_acceleration` (null-space posture, variable
damped least squares); away from singularities the solution is exact and (9.36) holds.

References use the library's :class:`~forcecontrol.controllers.base.Reference` with m = 6:
``position = [o_d; φ_d]`` (φ_d XYZ Euler angles of R_d in the base frame; R_d is rebuilt from
them, which is well defined at every φ_d), ``velocity = [ȯ_d; ω_d]``, ``acceleration = [ö_d; ω̇_d]``
(base frame). The measured wrench is ``[f_e; μ_e]`` in the base frame about the end-effector origin
(a plain (6,) array), or a :class:`~forcecontrol.spatial.Wrench` that must say so.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np

from .. import laws
from ..core.numba_cache import kernel_array
from ..core.validate import as_gain_matrix, readonly
from ..errors import ParameterError, SingularityError
from ..laws.impedance import impedance_core
from ..laws.layout import OS_PD, REFERENCE
from ..laws.spatial import desired_frame_terms, spatial_impedance_torque
from ..robots.base import RobotModel
from ..spatial import Wrench, euler_xyz_T, euler_xyz_T_dot, euler_xyz_T_inv, rotvec_T
from ..spatial.closed_form import euler_xyz_to_rotation, rotation_to_euler_xyz, rotation_vector  # per sample
from .base import Controller, Measurement, Reference
from .redundant import NullSpacePosture, SingularityHandling

__all__ = [
    "SpatialImpedanceController",
    "SpatialComplianceController",
    "DesiredFrameError",
    "desired_frame_error",
    "spatial_impedance_acceleration",
]

Orientation = Literal["euler", "rotvec"]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


class DesiredFrameError:
    """x̃, x̃̇ and what (9.35) needs, at one sample (plain attributes, no checks: the hot path).

    Attributes:
        x: x̃ (9.9), (6,); xd: x̃̇ (9.33), (6,); JAd: J_Ad (9.14), (6, n);
        c: ``−J̇_Ad q̇ + ḃ``, (6,), so that ``x̃̈ = −J_Ad q̈ + c`` (9.34);
        R_d: desired rotation, (3, 3).
    """

    __slots__ = ("x", "xd", "JAd", "c", "R_d")

    def __init__(self, x, xd, JAd, c, R_d) -> None:
        self.x, self.xd, self.JAd, self.c, self.R_d = x, xd, JAd, c, R_d


def _euler_regular(R: np.ndarray, t: float, what: str, advice: str) -> None:
    """SingularityError when R's XYZ Euler angles are at their representation singularity (|cos φ₂| < 1e-3)."""
    c2 = math.hypot(R[0, 0], R[0, 1])
    if c2 < 1e-3:
        raise SingularityError(
            f"at t = {t:.6g} s {what} is at a representation singularity of XYZ Euler angles "
            f"(cos(phi_2) = {c2:.3g}); {advice}"
        )


def _orientation_terms(R_de: np.ndarray, orientation: str, t: float):
    """(φ, T(φ), T⁻¹(φ)) for the chosen representation of R_e^d."""
    if orientation == "euler":
        _euler_regular(R_de, t, "the orientation error", "use orientation='rotvec'")
        phi = rotation_to_euler_xyz(R_de)
        return phi, euler_xyz_T(phi), euler_xyz_T_inv(phi)
    phi = rotation_vector(R_de)
    T = rotvec_T(phi)
    return phi, T, np.linalg.inv(T)


def _T_dot(orientation: str, phi: np.ndarray, phid: np.ndarray) -> np.ndarray:
    if orientation == "euler":
        return euler_xyz_T_dot(phi, phid)
    # rotation vector: directional derivative of T(θ) along θ̇ (central difference, O(ε²))
    eps = 1e-6
    return (rotvec_T(phi + eps * phid) - rotvec_T(phi - eps * phid)) / (2 * eps)


def desired_frame_error(
    R_e: np.ndarray,
    o_e: np.ndarray,
    J: np.ndarray,
    Jdq: np.ndarray,
    qd: np.ndarray,
    reference: Reference,
    orientation: str = "euler",
    t: float = 0.0,
) -> DesiredFrameError:
    """x̃ (9.9), x̃̇ (9.33), J_Ad (9.14) and ``c = −J̇_Ad q̇ + ḃ`` for a moving desired frame.

    Args:
        R_e, o_e: end-effector pose in the base frame; J (6, n), Jdq (6,): geometric Jacobian
            and J̇q̇; qd: q̇ (n,); reference: 6-D reference (see module docstring).
        orientation: ``"euler"`` (XYZ, the chapter's) or ``"rotvec"``.

    Raises:
        SingularityError: Euler angles at a representation singularity (|cos φ₂| < 1e-3).
    """
    pos = reference.position
    o_d = pos[:3]
    R_d = euler_xyz_to_rotation(pos[3:])
    od_dot, w_d = reference.velocity[:3], reference.velocity[3:]
    od_ddot, wd_dot = reference.acceleration[:3], reference.acceleration[3:]
    RdT = R_d.T
    v = J @ qd
    e = o_e - o_d
    e_dot = v[:3] - od_dot
    w_rel = v[3:] - w_d
    R_de = RdT @ R_e
    phi, T, Tinv = _orientation_terms(R_de, orientation, t)
    phid = Tinv @ (RdT @ w_rel)
    x, xd, JAd, c = desired_frame_terms(np.ascontiguousarray(RdT), Tinv, _T_dot(orientation, phi, phid), phi, phid,
                                        e, e_dot, w_d, wd_dot, od_ddot, w_rel, J, Jdq)
    return DesiredFrameError(x, xd, JAd, c, R_d)


def spatial_impedance_acceleration(err: DesiredFrameError, h_e_d: np.ndarray, Md_inv, K_D, K_P,
                                   use_force: bool = True) -> np.ndarray:
    """The ``J_Ad q̈`` that (9.35) asks for: ``c + M_d⁻¹ (K_D x̃̇ + K_P x̃ − h_e^d)`` (:func:`forcecontrol.laws.impedance_core`).

    Without ``use_force`` the h_e^d term is left out (the motion loop of admittance control).
    """
    r = np.empty(6)
    G = np.concatenate([np.ravel(Md_inv), np.ravel(K_D), np.ravel(K_P)])  # IMPEDANCE's M_d_inv, K_D, K_P (per sample: no checks)
    f = kernel_array
    impedance_core(G, f(err.x), f(err.xd), f(err.c), f(h_e_d), use_force, np.empty(6), r)
    return r


def _spatial_robot(robot: RobotModel) -> None:
    if int(robot.task_dim) != 6 or not hasattr(robot, "spatial_terms"):
        raise ParameterError(
            "the 6-D controllers need a robot with task='pose' (task_dim 6) and spatial_terms(), e.g. "
            f"forcecontrol.robots.pinocchio.panda(); got {type(robot).__name__} with task_dim {robot.task_dim}"
        )


class _SpatialBase(Controller):
    kind: ClassVar[int] = 0

    def __init__(self, robot, orientation, posture, singularity, sample_time, base_frame, ee_frame) -> None:
        super().__init__(robot, sample_time)
        _spatial_robot(robot)
        #: the robot as a 6-D model (``spatial_terms``), for the type checker.
        self._spatial: Any = robot
        if orientation not in ("euler", "rotvec"):
            raise ParameterError(f"orientation must be 'euler' or 'rotvec'; got {orientation!r}")
        self.orientation = orientation
        n = int(robot.nq)
        if posture is None:  # a redundant arm still gets null-space damping, or self-motion never dies out
            posture = NullSpacePosture(np.zeros(n), 0.0, NullSpacePosture.damping) if n > 6 else None
        elif not isinstance(posture, NullSpacePosture):
            posture = NullSpacePosture(posture)
        if posture is not None and posture.posture.shape != (n,):
            raise ParameterError(f"posture must have {n} joint values; got {posture.posture.shape[0]}")
        self.posture = posture
        self.singularity = singularity if singularity is not None else SingularityHandling()
        self.base_frame = base_frame
        self.ee_frame = ee_frame or getattr(robot, "frame", "end_effector")
        #: λ² of the last step (0 away from singularities).
        self.last_damping = 0.0
        #: run the XYZ-Euler law as one compiled call (same formulas as the readable functions).
        self.compiled = orientation == "euler"
        p = self.posture
        self._post = (np.array(p.posture), p.stiffness, p.damping, True) if p is not None else (np.zeros(n), 0.0, 0.0, False)

    def _compiled_torque(self, t, q, qd, h, reference, Md_inv, K_D, K_P, use_force) -> np.ndarray:
        R_e, o_e, J, Jdq, B, nv, _g = self._spatial.spatial_terms(q, qd)
        post, k_n, d_n, has = self._post
        s = self.singularity
        f = kernel_array  # the law's argument types: one compiled version (gains frozen, as the controllers keep them)
        u, self.last_damping, c2 = spatial_impedance_torque(
            R_e, o_e, J, Jdq, B, nv, f(q), f(qd), f(h), f(reference.position), f(reference.velocity),
            f(reference.acceleration), f(Md_inv, frozen=True), f(K_D, frozen=True), f(K_P, frozen=True), use_force,
            post, k_n, d_n, has,
            s.threshold, s.max_damping,
        )
        if c2 < 1e-3:
            raise SingularityError(
                f"at t = {t:.6g} s the orientation error is at a representation singularity of XYZ Euler "
                f"angles (cos(phi_2) = {c2:.3g}); use orientation='rotvec'"
            )
        return u

    def _wrench(self, w: Any) -> np.ndarray:
        if isinstance(w, Wrench):
            return w.require(self.base_frame, self.ee_frame)
        return w


class SpatialImpedanceController(_SpatialBase):
    """Impedance control on the desired frame, (9.30) with (9.35).

    Law: ``u = B(q) y + n(q, q̇) + Jᵀ(q) h_e`` with
    ``J_Ad y = M_d⁻¹ (K_D x̃̇ + K_P x̃ − h_e^d) − J̇_Ad q̇ + ḃ`` (null-space posture and variable
    damped least squares for n > 6 or near singularities). Closed loop (9.36):
    ``M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_e^d``, independent of the configuration.

    Inputs: ``measurement.q, .qd`` (n,); ``measurement.wrench`` h_e (6,) [N, N m], base frame,
    about the end-effector origin; ``reference`` with m = 6 (module docstring).
    Output: torques (n,) [N m].

    Args:
        robot: a 6-D robot with ``spatial_terms`` (:class:`~forcecontrol.robots.pinocchio.PinocchioRobot`).
        inertia: M_d, SPD (6, 6) [kg, kg m²]; damping: K_D, SPD (6, 6); stiffness: K_P, SPD (6, 6).
        orientation: ``"euler"`` (XYZ, the chapter's) or ``"rotvec"``.
        posture: null-space posture (n > 6): a :class:`NullSpacePosture` or joint values. Without
            one the joint acceleration is the minimum-norm solution and self-motion is only damped
            by the joints' friction.
        singularity: damped-least-squares settings.
        sample_time: Ts [s]; base_frame, ee_frame: names a :class:`~forcecontrol.spatial.Wrench`
            measurement must carry.
    """

    GAINS = ("inertia", "damping", "stiffness", "orientation", "frame")

    def __init__(
        self, robot: RobotModel, inertia: Any, damping: Any, stiffness: Any, *,
        orientation: Orientation = "euler", posture: Any = None, singularity: SingularityHandling | None = None,
        sample_time: float = 1e-3, base_frame: str = "world", ee_frame: str | None = None,
        frame: Literal["desired", "base"] = "desired",
    ) -> None:
        super().__init__(robot, orientation, posture, singularity, sample_time, base_frame, ee_frame)
        if frame not in ("desired", "base"):
            raise ParameterError(f"frame must be 'desired' (9.35) or 'base' (9.28)-(9.31); got {frame!r}")
        if frame == "base" and orientation != "euler":
            raise ParameterError(
                "frame='base' is the chapter's (9.28)-(9.31) with XYZ Euler angles of R_e and T_A; "
                f"got orientation={orientation!r} (use frame='desired' for a rotation-vector error)"
            )
        self.frame = frame
        self.compiled = self.compiled and frame == "desired"
        self.inertia = as_gain_matrix("inertia", inertia, 6)
        self.damping = as_gain_matrix("damping", damping, 6)
        self.stiffness = as_gain_matrix("stiffness", stiffness, 6)
        self._Md_inv = readonly(np.linalg.inv(self.inertia))

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.30), (9.35) (or (9.30)-(9.31) in the base frame) for this sample."""
        q, qd = measurement.q, measurement.qd
        h = self._wrench(measurement.wrench)
        if self.frame == "base":
            return self._check_output(t, self._base_frame_torque(t, q, qd, h, reference), measurement)
        if self.compiled:
            u = self._compiled_torque(t, q, qd, h, reference, self._Md_inv, self.damping, self.stiffness, True)
            return self._check_output(t, u, measurement)
        R_e, o_e, J, Jdq, B, nv, _g = self._spatial.spatial_terms(q, qd)
        err = desired_frame_error(R_e, o_e, J, Jdq, qd, reference, self.orientation, t)
        RdT = err.R_d.T
        h_d = np.concatenate([RdT @ h[:3], RdT @ h[3:]])
        r = spatial_impedance_acceleration(err, h_d, self._Md_inv, self.damping, self.stiffness)
        # x̃̈ = −J_Ad q̈ + c  ⇒  J_Ad q̈ = c − x̃̈*  (= r)
        u = self._redundant_torque(err.JAd, r, q, qd, B, nv, J, h)
        return self._check_output(t, u, measurement)

    def _base_frame_torque(self, t: float, q: Any, qd: Any, h: np.ndarray, reference: Reference) -> np.ndarray:
        """(9.30)-(9.31) with the operational space of (2.70): x_e = [o_e; φ_e], φ_e the XYZ Euler
        angles of R_e, J_A = T_A⁻¹(φ_e) J (3.66) and h_A = T_Aᵀ h_e (the wrench doing work on ẋ_e).

        ``J_A y = ẍ_d − J̇_A q̇ + M_d⁻¹ (K_D x̃̇ + K_P x̃ − h_A)`` (:func:`forcecontrol.laws.impedance_core`),
        ``u = B y + n + Jᵀ h_e``; closed loop (9.32) ``M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A`` in the
        coordinates x_e, whose orientation part depends on the configuration (the point of
        Sect. 9.3's impedance on the desired frame). The reference's angular velocity and
        acceleration ω_d, ω̇_d become φ̇_d = T⁻¹(φ_d) ω_d and φ̈_d = T⁻¹ (ω̇_d − Ṫ φ̇_d).
        """
        R_e, o_e, J, Jdq, B, nv, _g = self._spatial.spatial_terms(q, qd)
        _euler_regular(R_e, t, "the end-effector orientation", "frame='base' cannot be used there (use frame='desired')")
        phi_e = rotation_to_euler_xyz(R_e)
        Tinv_e = euler_xyz_T_inv(phi_e)
        v = J @ qd
        phid_e = Tinv_e @ v[3:]
        JA = np.vstack([J[:3], Tinv_e @ J[3:]])
        JAdq = np.concatenate([Jdq[:3], Tinv_e @ (Jdq[3:] - euler_xyz_T_dot(phi_e, phid_e) @ phid_e)])  # J̇_A q̇
        phi_d = reference.position[3:]
        Tinv_d = euler_xyz_T_inv(phi_d)
        phid_d = Tinv_d @ reference.velocity[3:]
        phidd_d = Tinv_d @ (reference.acceleration[3:] - euler_xyz_T_dot(phi_d, phid_d) @ phid_d)
        x = np.concatenate([reference.position[:3] - o_e, np.angle(np.exp(1j * (phi_d - phi_e)))])  # wrapped
        xd = np.concatenate([reference.velocity[:3] - v[:3], phid_d - phid_e])
        c = np.concatenate([reference.acceleration[:3], phidd_d]) - JAdq
        h_A = np.concatenate([h[:3], euler_xyz_T(phi_e).T @ h[3:]])
        r = np.empty(6)
        G = np.concatenate([self._Md_inv.ravel(), self.damping.ravel(), self.stiffness.ravel()])  # as above
        impedance_core(G, x, xd, c, h_A, True, np.empty(6), r)
        return self._redundant_torque(JA, r, q, qd, B, nv, J, h)


class SpatialComplianceController(_SpatialBase):
    """PD control with gravity compensation on the desired frame (active compliance), (9.15).

    Law: ``u = g(q) + J_Adᵀ (K_P x̃ − K_D J_Ad q̇)`` (+ a posture torque projected in the null
    space of J_Adᵀ for n > 6). At equilibrium with the environment (9.16)–(9.19):
    ``h_e = K_P dx_{e,d}``; with an environment (9.21) the force and pose at equilibrium are
    (9.22)–(9.23).

    Inputs: ``measurement.q, .qd`` (n,) (no force measurement); ``reference.position`` (6,).
    Output: torques (n,) [N m].

    Args:
        robot: a 6-D robot with ``spatial_terms``.
        stiffness: K_P, SPD (6, 6) [N/m, N m/rad]; damping: K_D, SPD (6, 6).
        orientation, posture, singularity, sample_time: as for :class:`SpatialImpedanceController`
            (the posture torque here is ``B y₀`` projected with ``I − J_Adᵀ J_Ad⁺ᵀ``).
    """

    uses_force: ClassVar[bool] = False
    GAINS = ("stiffness", "damping", "orientation")

    def __init__(
        self, robot: RobotModel, stiffness: Any, damping: Any, *, orientation: Orientation = "euler",
        posture: Any = None, singularity: SingularityHandling | None = None, sample_time: float = 1e-3,
    ) -> None:
        super().__init__(robot, orientation, posture, singularity, sample_time, "world", None)
        self.stiffness = as_gain_matrix("stiffness", stiffness, 6)
        self.damping = as_gain_matrix("damping", damping, 6)
        self._params = OS_PD.pack(6, K_P=self.stiffness, K_D=self.damping)
        self._zero_ref = np.zeros(REFERENCE.size(6))
        self._zero_h = np.zeros(6)
        self._ws = np.zeros(12)

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.15) for this sample."""
        q, qd = measurement.q, measurement.qd
        R_e, o_e, J, Jdq, B, nv, g = self._spatial.spatial_terms(q, qd)
        err = desired_frame_error(R_e, o_e, J, Jdq, qd, reference, self.orientation, t)
        JAd = err.JAd
        # (9.15) is (8.110), laws.os_pd, on the desired frame: x_d = 0, x_e = −x̃, ẋ_e = J_Ad q̇, J = J_Ad
        u = np.empty(q.shape[0])
        laws.os_pd(t, self.sample_time, q, qd, -err.x, JAd @ qd, JAd, Jdq, B, nv, g, self._zero_h, self._zero_ref,
                   self._params, self._zero_h, self._ws, u)
        if self.posture is not None:
            # Euclidean (not dynamically consistent) null-space projection of the posture torque:
            # it leaves the equilibrium (9.16) unchanged but can disturb task transients
            # (J B⁻¹ N τ₀ ≠ 0); the inverse-dynamics controllers project at acceleration level instead
            tau0 = B @ self.posture.acceleration(q, qd)
            u = u + tau0 - JAd.T @ np.linalg.lstsq(JAd.T, tau0, rcond=None)[0]
        return self._check_output(t, u, measurement)
