"""FZI ``cartesian_compliance_controller`` and ``cartesian_force_controller`` (FDCC) on a position-interface arm."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...core.validate import positive_scalar
from ...errors import ParameterError
from ...laws.vendor import fdcc_error, fdcc_step
from ...laws.vendor.layout import FDCC, FDCC_STATE
from ...robots.ik import JointCommand, model_limits
from ..base import Measurement, Reference
from ..position_interface import PositionInterfaceController
from .common import axis_vector, blockdiag, check_measurement, pose, pose_error, require_pose_robot, target_pose

__all__ = ["FziComplianceController", "FziForceController"]


class FziComplianceController(PositionInterfaceController):
    """FZI's ``cartesian_compliance_controller`` (ros2 branch f53f7980), once per interface cycle.

    Law (:func:`forcecontrol.laws.vendor.fdcc_step`; survey of issue 30, §2.1–2.4)::

        q ← q_meas   (q̇ kept)                                  (2021 solver: q ← last command)
        repeat `iterations` times, the sensor wrench held:
            e = R_c K R_cᵀ e_motion + (f_d − h_e)                (e_motion = [p_t − p; θ(R_t Rᵀ)], ≤ 1 m, 1 rad)
            f = error_scale (P e + D_g (e − e_prev)/h)           (h = 0.02 s, fixed)
            q̈ = H_v⁻¹ Jᵀ f,   q ← q + h q̇,   q̇ ← 0.9 (q̇ + h q̈)
        command q (and q̇)

    The first iteration's pose is that of the previous command (the project does not update the
    kinematics after the sync); J and H_v are taken at q. The loop settles where
    ``K (x_t − x) + f_d − h_e = 0``: the target pose ``reference.position``, the target wrench
    ``reference.force`` (the chapter's f_d, base frame), ``stiffness`` "the steady-state stiffness".

    The virtual model: the project gives every link 0.1 kg and the last one 1 kg with inertia
    1 kg m², so that ``Λ_v = (J H_v⁻¹ Jᵀ)⁻¹`` measured with Pinocchio on the UR5/UR10 at a usual
    posture is ≈ (1.25–1.40 kg, 1.0 kg m²) (survey §2.1). Here ``H_v = Jᵀ diag(m_v, m_v, m_v, I_v,
    I_v, I_v) J + 10⁻⁶ I`` with ``virtual_mass`` m_v (default 1.3 kg) and ``virtual_inertia`` I_v
    (1 kg m²): the end-effector's apparent inertia as measured, constant over the workspace (an
    approximation of the project's posture-dependent model, stated here).

    Args:
        robot: a :class:`~forcecontrol.robots.servo.PositionInterfaceRobot` on a 6-D arm.
        stiffness: per axis [N/m, N m/rad] (``stiffness.trans_x … rot_z``); zeros for the force controller.
        p, d: per axis (``pd_gains.<axis>.p/.d``).
        error_scale: ``solver.error_scale``; iterations: ``solver.iterations``.
        solver: ``"accumulating"`` (since Dec 2021) or ``"instantaneous"`` (the 2021 solver, issue #21).
        compliance_frame: ``"tool"`` or ``"base"`` (the frame K is diagonal in).
    """

    GAINS: Any = ("stiffness", "p", "d", "error_scale", "iterations", "solver", "internal_period", "virtual_mass",
                  "virtual_inertia", "compliance_frame", "servo_description")
    #: whether this controller has a stiffness (the compliance controller) or only force (FziForceController).
    compliant = True

    def __init__(self, robot: Any, *, stiffness: Any = (500.0, 500.0, 500.0, 50.0, 50.0, 50.0), p: Any = 0.0, d: Any = 0.0,
                 error_scale: float = 1.0, iterations: int = 1, solver: str = "accumulating", virtual_mass: float = 1.3,
                 virtual_inertia: float = 1.0, internal_period: float = 0.02, compliance_frame: str = "tool",
                 sample_time: float = 2e-4) -> None:
        who = type(self).__name__
        require_pose_robot(who, robot)
        self.stiffness = axis_vector("stiffness", stiffness, low=0.0, unit="N/m")
        self.p = axis_vector("p", p, low=0.0)
        self.d = axis_vector("d", d, low=0.0)
        es = float(error_scale)
        if not np.isfinite(es) or es < 0:
            raise ParameterError(f"error_scale must be a finite number >= 0; got {error_scale!r}")
        self.error_scale = es
        if isinstance(iterations, bool) or int(iterations) != iterations or iterations < 1:
            raise ParameterError(f"iterations must be a positive integer; got {iterations!r}")
        self.iterations = int(iterations)
        if solver not in ("accumulating", "instantaneous"):
            raise ParameterError(f"solver must be 'accumulating' (current) or 'instantaneous' (before Dec 2021); got {solver!r}")
        self.solver = solver
        if compliance_frame not in ("tool", "base"):
            raise ParameterError(
                f"compliance_frame must be 'tool' (the robot's controlled frame) or 'base'; got {compliance_frame!r}"
            )
        self.compliance_frame = compliance_frame
        self.virtual_mass = positive_scalar("virtual_mass", virtual_mass, "kg")
        self.virtual_inertia = positive_scalar("virtual_inertia", virtual_inertia, "kg m^2")
        self.internal_period = positive_scalar("internal_period", internal_period, "s")
        super().__init__(robot, sample_time)
        n = int(robot.nq)
        lo, hi, _ = model_limits(robot)
        self._lo = np.full(n, -np.inf) if lo is None else lo
        self._hi = np.full(n, np.inf) if hi is None else hi
        self._Lv = np.diag([self.virtual_mass] * 3 + [self.virtual_inertia] * 3)
        self._pp = FDCC.pack(6, P=self.p, D_g=self.d, error_scale=self.error_scale, h=self.internal_period, decay=0.9,
                             instantaneous=1.0 if solver == "instantaneous" else 0.0)

    def law_state_size(self) -> int:
        """``[q̇ (n), e_prev (6), q_cmd (n)]``: the solver's velocity, the PD's last error, the last command."""
        return FDCC_STATE.size(6, int(self.robot.nq)) + int(self.robot.nq)

    def reset_law(self, measurement: Measurement | None, reference: Reference | None) -> None:
        n = int(self.robot.nq)
        if measurement is not None:
            self.law_state[FDCC_STATE.size(6, n) :] = np.asarray(measurement.q, dtype=np.float64)

    def virtual_inertia_matrix(self, J: np.ndarray) -> np.ndarray:
        """``H_v = Jᵀ Λ_v J + 10⁻⁶ I`` (n, n) at the Jacobian J (6, n)."""
        return J.T @ self._Lv @ J + 1e-6 * np.eye(J.shape[1])

    def command(self, t: float, measurement: Measurement, reference: Reference) -> JointCommand:
        n = int(self.robot.nq)
        s = self.law_state
        k = FDCC_STATE.size(6, n)
        law, q_last = s[:k], s[k:]
        h = check_measurement(type(self).__name__, measurement.wrench)
        R_prev, p_prev = self.robot.frame_pose(q_last)  # the previous command's pose (no kinematics update after sync)
        q = q_last.copy() if self.solver == "instantaneous" else np.array(measurement.q, dtype=np.float64)
        R_t, p_t = target_pose(np.asarray(reference.position, dtype=np.float64))
        w_err = np.asarray(reference.force, dtype=np.float64) - h
        R_cur, p_cur = np.asarray(R_prev), np.asarray(p_prev)
        J = np.ascontiguousarray(self.robot.spatial_jacobian(q), dtype=np.float64)
        e = np.empty(6)
        for _ in range(self.iterations):
            e_m = pose_error(R_t, p_t, R_cur, p_cur)
            e_m[:3] /= max(1.0, float(np.linalg.norm(e_m[:3])))  # the project's 1 m / 1 rad clamp
            e_m[3:] /= max(1.0, float(np.linalg.norm(e_m[3:])))
            Rc = blockdiag(R_cur) if self.compliance_frame == "tool" else np.eye(6)
            fdcc_error(e_m, w_err, self.stiffness, Rc, e)
            if not fdcc_step(e, self._pp, law, self.virtual_inertia_matrix(J), J, q, self._lo, self._hi):
                raise ParameterError(
                    f"{type(self).__name__}: the virtual model's inertia is singular at t = {t:.6g} s, q = {q.tolist()}"
                )
            R_cur, p_cur, J = pose(self.robot, q)
        q_last[:] = q
        # the position command interface: positions only (the servo gets no velocity feed-forward)
        return JointCommand(q.copy(), None)  # type: ignore[arg-type]


class FziForceController(FziComplianceController):
    """FZI's ``cartesian_force_controller``: the compliance controller's solver with no stiffness, one step per cycle.

    Law: ``e = f_d − h_e`` (the target wrench ``reference.force`` against the measured one, base
    frame), then one :func:`forcecontrol.laws.vendor.fdcc_step` (``solver.iterations`` has no
    effect in the project). Integral action: the contact force settles at f_d exactly.
    """

    compliant = False
    GAINS: Any = ("p", "d", "error_scale", "solver", "internal_period", "virtual_mass", "virtual_inertia", "servo_description")

    def __init__(self, robot: Any, *, p: Any = 0.0, d: Any = 0.0, error_scale: float = 1.0, solver: str = "accumulating",
                 virtual_mass: float = 1.3, virtual_inertia: float = 1.0, internal_period: float = 0.02,
                 sample_time: float = 2e-4) -> None:
        super().__init__(robot, stiffness=0.0, p=p, d=d, error_scale=error_scale, iterations=1, solver=solver,
                         virtual_mass=virtual_mass, virtual_inertia=virtual_inertia, internal_period=internal_period,
                         compliance_frame="base", sample_time=sample_time)
