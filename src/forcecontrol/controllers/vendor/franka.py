"""franka_ros ``cartesian_impedance_example_controller``: a torque controller for the library's torque robots (Panda)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...core.validate import gain_scalar, nonnegative_scalar, positive_scalar
from ...errors import ParameterError
from ...laws.vendor import franka_impedance_torque
from ...laws.vendor.layout import FRANKA, FRANKA_STATE
from ..base import Controller, Measurement, Reference
from .common import pose, require_pose_robot, target_pose

__all__ = ["FrankaCartesianImpedanceController", "UPSTREAM_START_NULLSPACE_STIFFNESS", "quat_from_matrix", "slerp"]


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method), w ≥ 0."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    if tr > 0:
        S = 2.0 * np.sqrt(tr + 1.0)
        q = np.array([0.25 * S, (R[2, 1] - R[1, 2]) / S, (R[0, 2] - R[2, 0]) / S, (R[1, 0] - R[0, 1]) / S])
    else:
        i = int(np.argmax([R[0, 0], R[1, 1], R[2, 2]]))
        j, k = (i + 1) % 3, (i + 2) % 3
        S = 2.0 * np.sqrt(1.0 + R[i, i] - R[j, j] - R[k, k])
        q = np.empty(4)
        q[0] = (R[k, j] - R[j, k]) / S
        q[1 + i] = 0.25 * S
        q[1 + j] = (R[j, i] + R[i, j]) / S
        q[1 + k] = (R[k, i] + R[i, k]) / S
    return q if q[0] >= 0 else -q


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def slerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """Spherical interpolation from a to b by t along the shorter arc (Eigen's ``slerp``)."""
    d = float(a @ b)
    if d < 0:
        b, d = -b, -d
    if d > 1.0 - 1e-12:
        out = (1.0 - t) * a + t * b
    else:
        th = np.arccos(d)
        out = (np.sin((1.0 - t) * th) * a + np.sin(t * th) * b) / np.sin(th)
    return out / np.linalg.norm(out)


#: k_ns at the start [N m/rad]: franka_ros's cartesian_impedance_example_controller.h initialises
#: ``nullspace_stiffness_`` to 20 (and K, D to 0 in ``init``); its gain filter then moves it to the target.
UPSTREAM_START_NULLSPACE_STIFFNESS = 20.0


class FrankaCartesianImpedanceController(Controller):
    """franka_ros's ``cartesian_impedance_example_controller`` (commit c11f000c) on a torque robot.

    Law (:func:`forcecontrol.laws.vendor.franka_impedance_torque`; survey of issue 30, §3), every
    sample (1 kHz on the robot)::

        τ = τ_J_d + clamp(Jᵀ(−K e − D J q̇) + τ_ns + C q̇ − τ_J_d, ±Δτ_max) + g(q)
        D = 2 sqrt(K),  τ_ns = (I − Jᵀ J^{T+}) (k_ns (q_ns − q) − 2 sqrt(k_ns) q̇)

    (the chapter's impedance control without inertia shaping, (9.35) with M_d = Λ). ``g(q)`` is
    added here because the robot adds gravity itself. The equilibrium pose is
    ``reference.position`` (``[o; φ]``, the ``equilibrium_pose`` topic); K, D, k_ns and the
    equilibrium are filtered towards their targets by ``filter_coefficient`` per sample (0.005).
    With ``soft_start`` (the project's behaviour) K and D start at 0, k_ns at
    :data:`UPSTREAM_START_NULLSPACE_STIFFNESS` (20, the value the example's header initialises it to,
    which the first samples filter down to the target) and the equilibrium at the pose at reset;
    q_ns is the posture at reset.

    Args:
        robot: a 6-D torque robot (the Panda from example-robot-data).
        translational_stiffness: [N/m] (cfg default 200, range [0, 400]);
        rotational_stiffness: [N m/rad] (10, [0, 30]); nullspace_stiffness (0.5, [0, 100]).
        delta_tau_max: [N m per sample] (1.0); filter_coefficient: (0.005); pinv_damping: λ (0.2).
        sample_time: [s] (the FCI's 1 ms).
    """

    GAINS: Any = ("translational_stiffness", "rotational_stiffness", "nullspace_stiffness", "delta_tau_max",
                  "filter_coefficient", "soft_start")
    law = None
    uses_force = False

    def __init__(self, robot: Any, *, translational_stiffness: float = 200.0, rotational_stiffness: float = 10.0,
                 nullspace_stiffness: float = 0.5, delta_tau_max: float = 1.0, filter_coefficient: float = 0.005,
                 pinv_damping: float = 0.2, soft_start: bool = True, sample_time: float = 1e-3) -> None:
        require_pose_robot("FrankaCartesianImpedanceController", robot)
        super().__init__(robot, sample_time)
        self.translational_stiffness = gain_scalar("translational_stiffness", translational_stiffness, "N/m")
        self.rotational_stiffness = gain_scalar("rotational_stiffness", rotational_stiffness, "N m/rad")
        self.nullspace_stiffness = gain_scalar("nullspace_stiffness", nullspace_stiffness)
        self.delta_tau_max = positive_scalar("delta_tau_max", delta_tau_max, "N m")
        a = float(filter_coefficient)
        if not 0.0 < a <= 1.0:
            raise ParameterError(f"filter_coefficient must be in (0, 1] (per sample); got {filter_coefficient!r}")
        self.filter_coefficient = a
        self.pinv_damping = nonnegative_scalar("pinv_damping", pinv_damping)
        if not isinstance(soft_start, bool):
            raise ParameterError(f"soft_start must be true or false; got {soft_start!r}")
        self.soft_start = soft_start
        n = int(robot.nq)
        K = np.array([self.translational_stiffness] * 3 + [self.rotational_stiffness] * 3)
        self._p = FRANKA.pack(6, n, K=K, D=2.0 * np.sqrt(K), k_ns=self.nullspace_stiffness, delta_tau_max=self.delta_tau_max,
                              filter=a, pinv_damping=self.pinv_damping, q_ns=np.zeros(n))
        # state: the law's (K, D, k_ns, τ_J_d), then the filtered equilibrium p_d (3), quat_d (4)
        self._ns = FRANKA_STATE.size(6, n)
        self.state = np.zeros(self._ns + 7)

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        n = int(self.robot.nq)
        self.state[:] = 0.0
        if self.soft_start:
            self.state[FRANKA_STATE.slice("k_ns", 6, n)] = UPSTREAM_START_NULLSPACE_STIFFNESS
        else:
            for block in ("K", "D", "k_ns"):
                self.state[FRANKA_STATE.slice(block, 6, n)] = self._p[FRANKA.slice(block, 6, n)]
        q = np.zeros(n) if measurement is None else np.asarray(measurement.q, dtype=np.float64)
        self._p[FRANKA.slice("q_ns", 6, n)] = q
        R, p = self.robot.frame_pose(q)
        self.state[self._ns : self._ns + 3] = p
        self.state[self._ns + 3 :] = quat_from_matrix(np.asarray(R))

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        n = int(self.robot.nq)
        s = self.state
        q = np.asarray(measurement.q, dtype=np.float64)
        qd = np.asarray(measurement.qd, dtype=np.float64)
        R, p, J = pose(self.robot, q)
        p_d, quat_d = s[self._ns : self._ns + 3], s[self._ns + 3 :]
        quat = quat_from_matrix(R)
        if quat_d @ quat < 0:
            quat = -quat
        err_q = _qmul(quat * np.array([1.0, -1.0, -1.0, -1.0]), quat_d)  # quat⁻¹ ⊗ quat_d
        e = np.concatenate([p - p_d, -R @ err_q[1:]])
        g = np.asarray(self.robot.gravity(q), dtype=np.float64)
        F = getattr(getattr(self.robot, "robot", self.robot), "friction", None)
        coriolis = np.asarray(self.robot.nonlinear_effects(q, qd), dtype=np.float64) - g
        if F is not None:
            coriolis = coriolis - np.asarray(F) @ qd
        u = np.empty(n)
        franka_impedance_torque(J, e, qd, q, coriolis, self._p, s[: self._ns], u)
        a = self.filter_coefficient
        R_t, p_t = target_pose(np.asarray(reference.position, dtype=np.float64))
        p_d[:] = a * p_t + (1.0 - a) * p_d
        quat_d[:] = slerp(quat_d.copy(), quat_from_matrix(R_t), a)
        return self._check_output(t, u + g, measurement)
