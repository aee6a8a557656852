"""Recorded data through a controller ("replay"); simulated traces against recorded ones in :mod:`.traces`.

:func:`replay` runs any library controller over a recorded log: at each sample of the log,
resampled onto the controller's period Ts, it calls ``controller.step(t, Measurement(q, q̇, h_e),
reference)`` exactly as the simulator does, and returns the torques it would have commanded
and its force errors ``f_d − h_e`` side by side with the torques that were recorded. A log of
the simulator replayed through the same controller gives back the simulated torques (tested):
what differs on a real log is the arm, not the law.

:func:`compare_traces` puts a simulated trace beside a recorded one: the time shift that best
aligns them (searched over ±``max_shift``), then RMS and maximum force and joint-position
errors, and a figure.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..controllers.base import REFERENCE_FIELDS, Controller, Measurement, Reference
from ..core.axes import joint_columns
from ..errors import DimensionError, MeasurementError, ParameterError
from ..robots.base import RobotModel
from ..spatial import Transform
from ..trajectories import ReferenceSignal
from ..viz.plotting import finish_figure
from .conventions import BY_END_EFFECTOR
from .io import RecordedRun
from .io.recorded import wrench_axis_names
from .traces import TraceComparison, compare_traces, recorded_from_simulation
from .wrenches import (
    _check_wrench_convention,
    end_effector_rotation,
    model_joint_names,
    recorded_wrench_in_base,
    wrench_to_base,
)

__all__ = [
    "replay", "wrench_to_base", "end_effector_rotation", "ReplayResult", "recorded_from_simulation", "compare_traces",
    "TraceComparison", "recorded_wrench_in_base", "model_joint_names",
]


@dataclass(frozen=True)
class ReplayResult:
    """What a controller would have commanded over a recorded log, beside what was recorded.

    Attributes:
        t: controller sample times (N,) [s], from 0 at the first replayed sample.
        torque: the torques the controller commands (N, n) [N m].
        torque_recorded: the log's torques on the same grid (N, n) [N m], or None.
        wrench: the wrench fed to the controller, h_e in the base frame (N, m) [N].
        force_reference: f_d (N, m) [N]; force_error: ``f_d − h_e`` (N, m) [N].
        q, qd: the joint signals fed to the controller (N, n).
        metadata: controller, source file, period.
    """

    t: np.ndarray
    torque: np.ndarray
    torque_recorded: np.ndarray | None
    wrench: np.ndarray
    force_reference: np.ndarray
    force_error: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)

    def torque_difference(self) -> np.ndarray | None:
        """``torque − torque_recorded`` (N, n) [N m], or None without recorded torques."""
        return None if self.torque_recorded is None else self.torque - self.torque_recorded

    def metrics(self) -> dict[str, float]:
        """RMS and maximum of the torque difference (per all joints) and of the force error norm."""
        out: dict[str, float] = {}
        d = self.torque_difference()
        if d is not None:
            out["torque_difference_rms"] = float(np.sqrt(np.mean(d**2)))
            out["torque_difference_max"] = float(np.max(np.abs(d)))
        fe = np.linalg.norm(self.force_error, axis=1)
        out["force_error_rms"] = float(np.sqrt(np.mean(fe**2)))
        out["force_error_max"] = float(np.max(fe))
        return out

    def columns(self) -> dict[str, np.ndarray]:
        """Flat named columns: ``t``, ``q1 qd1 u1 u1_recorded ...``, ``fx ...``, ``fd_x ...``, ``ef_x ...``."""
        cols = joint_columns(self.t, self.q, self.qd, self.torque, self.torque_recorded, "u{}_recorded")
        for j, name in enumerate(wrench_axis_names(self.wrench.shape[1])):
            cols[name] = self.wrench[:, j]
            cols[f"{name}_reference"] = self.force_reference[:, j]
            cols[f"{name}_error"] = self.force_error[:, j]
        return cols

    def to_pandas(self) -> Any:
        """The columns as a pandas DataFrame (pandas imported here only)."""
        import pandas as pd

        return pd.DataFrame(self.columns())

    def plot(self, path: str | Path | None = None) -> Any:
        """Replayed against recorded torques, and the force error, over time (matplotlib).

        Args:
            path: save a PNG there (the figure is then closed and the path returned).
        """
        import matplotlib

        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(2, 1, figsize=(7.5, 6.0), sharex=True)
        for i in range(self.torque.shape[1]):
            line = axes[0].plot(self.t, self.torque[:, i], lw=1.2, label=f"u{i + 1} replayed")[0]
            if self.torque_recorded is not None:
                axes[0].plot(self.t, self.torque_recorded[:, i], "--", lw=1.0, color=line.get_color(), label=f"u{i + 1} recorded")
        axes[0].set_ylabel("joint torque [N m]")
        for j, name in enumerate(wrench_axis_names(self.force_error.shape[1])):
            axes[1].plot(self.t, self.force_error[:, j], lw=1.0, label=f"{name}_d − {name}")
        axes[1].set_ylabel("force error [N]")
        axes[1].set_xlabel("t [s]")
        for ax in axes:
            ax.grid(True, lw=0.3)
            ax.legend(fontsize=7, ncol=2)
        kind = self.metadata.get("controller", {}).get("type", "controller")
        fig.suptitle(f"{kind} replayed over {self.metadata.get('source', '')}", fontsize=9)
        fig.tight_layout()
        return finish_figure(fig, path)


def _check_dimensions(controller: Controller, recorded: RecordedRun, robot: RobotModel | None) -> tuple[int, int]:
    if not isinstance(controller, Controller):
        raise ParameterError(f"controller must be a forcecontrol Controller; got {type(controller).__name__}")
    if robot is not None and controller.robot is not robot and type(controller.robot) is not type(robot):
        raise ParameterError(
            f"controller.robot ({type(controller.robot).__name__}) is not the robot given ({type(robot).__name__})"
        )
    model = robot if robot is not None else controller.robot
    n, m = int(model.nq), int(model.task_dim)
    if recorded.n != n:
        passed = recorded.metadata.get("joint_states_passed_over", {})
        raise DimensionError(
            f"the controller's robot has {n} joints; the log {recorded.source} has {recorded.n} "
            f"({', '.join(recorded.joint_names)})" + "".join(
                f"; {k} JointState message(s) of ({who}) passed over: choose the joints with joint_names (--joint-names)"
                for who, k in passed.items())
        )
    if recorded.wrench is not None and recorded.m != m:
        raise DimensionError(
            f"the controller works in a {m}-dimensional task space and needs a {m}-component wrench "
            f"({' '.join(wrench_axis_names(m))}); the log {recorded.source} has {recorded.m} components "
            "(read it with wrench_components=m)"
        )
    if recorded.wrench is None and controller.uses_force:
        raise MeasurementError(
            f"{type(controller).__name__} reads the contact force, but the log {recorded.source} has no wrench"
        )
    return n, m


def replay(
    controller: Controller,
    recorded: RecordedRun,
    reference: ReferenceSignal,
    robot: RobotModel | None = None,
    *,
    base_frame: str = "base",
    end_effector_frame: str = "end-effector",
    sensor_pose: Transform | None = None,
    max_gap: float | None = None,
    start: float | None = None,
    end: float | None = None,
) -> ReplayResult:
    """Run a controller over a recorded log: the torques and force errors it would have produced.

    The log is resampled onto the controller's period (linear interpolation, see
    :meth:`RecordedRun.resample`); the controller is ``reset`` with the first sample and then
    stepped at every sample with ``Measurement(q, q̇, h_e)`` and the reference at ``t − t₀``.
    The wrench is converted to the chapter's sense (by the end-effector on the environment).

    Args:
        controller: any library controller (its ``sample_time`` is the period).
        recorded: the log (:mod:`forcecontrol.realarm.io`).
        reference: references as functions of time, from t = 0 at the first replayed sample.
        robot: the robot model (default: the controller's); its joints and task dimension must
            match the log's.
        base_frame: the name of the frame the controller's wrench is expressed in. A 6-D wrench
            in it about the base origin (``wrench_point == base_frame``: a ROS ``WrenchStamped`` in
            the base frame) has its moment moved to the end-effector with the forward kinematics at
            the recorded q, ``μ_e = μ_o − p_e × f``; about the end-effector (the library's logs), as is.
        end_effector_frame: the name a log uses for the end-effector frame (the robot's own
            frame name, e.g. ``panda_hand_tcp``, is accepted too). A wrench recorded in it is
            rotated per sample into the base frame with the forward kinematics at the recorded
            q (:func:`wrench_to_base`).
        sensor_pose: for a wrench recorded in a sensor frame: that frame's pose in the
            end-effector frame (``Transform(R, p, parent=end_effector_frame, child=<the log's
            wrench frame>)``); the wrench is rotated into the base frame and its moment moved
            from the sensor's origin to the end-effector's (μ_e = μ_s − r × f, r from the sensor
            origin to the end-effector origin).
        max_gap, start, end: passed to :meth:`RecordedRun.resample`.

    Returns:
        A :class:`ReplayResult`.

    Raises:
        DimensionError: joints or wrench components differ from the controller's; FrameError:
            the wrench is in neither the base, the end-effector nor the given sensor frame, or a
            6-D end-effector-frame wrench is about another point; MeasurementError: the log cannot be resampled, or the
            controller needs a wrench the log does not have.
    """
    n, m = _check_dimensions(controller, recorded, robot)
    recorded = recorded.in_joint_order(model_joint_names(robot if robot is not None else controller.robot))
    if not isinstance(reference, ReferenceSignal):
        raise ParameterError(f"reference must be a ReferenceSignal (e.g. Setpoint); got {type(reference).__name__}")
    if reference.dim != m:
        raise DimensionError(f"reference must be {m}-dimensional like the controller's task space; got {reference.dim}")
    model = robot if robot is not None else controller.robot
    _check_wrench_convention(recorded, model, base_frame, end_effector_frame, sensor_pose)
    Ts = controller.sample_time
    rec = recorded.resample(Ts, max_gap=max_gap, start=start, end=end)
    N = rec.t.size
    t = rec.t - rec.t[0]
    t = np.where(np.abs(t - Ts * np.arange(N)) < 1e-9 * Ts, Ts * np.arange(N), t)  # exact grid when it is one
    sign = 1.0 if rec.wrench_sense == BY_END_EFFECTOR else -1.0
    if rec.wrench is None:
        h = np.zeros((N, m))
    else:
        h = sign * recorded_wrench_in_base(rec, model, base_frame, end_effector_frame, sensor_pose)
    refs = np.ascontiguousarray(reference.sample(t), dtype=np.float64)
    k_f = REFERENCE_FIELDS.index("force")
    controller.reset(Measurement(rec.q[0].copy(), rec.qd[0].copy(), h[0].copy()), reference.at(0.0))
    u = np.empty((N, n))
    for k in range(N):
        row = refs[k]
        ref = Reference(*(row[i * m : (i + 1) * m] for i in range(len(REFERENCE_FIELDS))))
        u[k] = controller.step(float(t[k]), Measurement(rec.q[k].copy(), rec.qd[k].copy(), h[k].copy()), ref)
    f_d = refs[:, k_f * m : (k_f + 1) * m]
    return ReplayResult(
        t=t, torque=u, torque_recorded=rec.tau, wrench=h, force_reference=f_d.copy(), force_error=f_d - h,
        q=rec.q, qd=rec.qd,
        metadata={"controller": {"type": type(controller).__name__, **controller.gains()}, "source": recorded.source,
                  "period": Ts, "time_origin": float(recorded.time_origin + rec.t[0]),
                  "max_gap": float(rec.metadata["resampled"]["max_gap"])},
    )

