"""A wrist F/T sensor carrying a payload: it reads the contact wrench plus the payload's weight and inertial wrench (FZI #177).

The payload (mass m, centre of mass at r = R c from the sensor's origin o, inertia I_c about its
centre of mass) is held by the sensor alone. Newton-Euler on the payload, with the library's
sign (the sensor reads h_e, the wrench the end-effector exerts on the environment; see
:class:`~forcecontrol.sensors.gravity.ToolGravity`), gives the reading in the base frame, about o::

    f = h_f + m (a_c − g),   a_c = a_o + α × r + ω × (ω × r)
    τ = h_τ + r × m (a_c − g) + I α + ω × (I ω),   I = R I_c Rᵀ

``gravity_compensated=True`` (the default) subtracts the static part ``−m g`` and ``r × (−m g)``
at the current orientation, as an arm controller does with its configured payload (UR's
``set_payload``): what is left is the inertial wrench. On the simulated arm the sensor takes q at
each sample and forms q̇, q̈ by second-order backward differences over the last four samples
(exact for a quadratic motion; the arm's acceleration is not an input of a sensor model).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import DimensionError, ParameterError
from .realistic import RealisticForceSensor

__all__ = ["payload_wrench", "PayloadForceSensor"]


def payload_wrench(mass: float, r: Any, inertia: Any, a_o: Any, omega: Any, alpha: Any, gravity: Any,
                   gravity_compensated: bool = False) -> np.ndarray:
    """The wrench [f; τ] (6,) the sensor applies to a payload (what it reads with no contact), base frame, about o.

    Args:
        mass: m [kg]; r: o → centre of mass, (3,) [m]; inertia: I about the centre of mass in base-frame
            axes, (3, 3) [kg m²]; a_o: the classical acceleration of o, (3,) [m/s²]; omega, alpha: the
            angular velocity [rad/s] and acceleration [rad/s²] (3,); gravity: g (3,) [m/s²].
        gravity_compensated: leave out the static weight ``−m g`` and its moment.
    """
    r, w, al = (np.asarray(v, dtype=np.float64) for v in (r, omega, alpha))
    I = np.asarray(inertia, dtype=np.float64)
    a_c = np.asarray(a_o, dtype=np.float64) + np.cross(al, r) + np.cross(w, np.cross(w, r))
    f = mass * (a_c if gravity_compensated else a_c - np.asarray(gravity, dtype=np.float64))
    tau = np.cross(r, f) + I @ al + np.cross(w, I @ w)
    return np.concatenate([f, tau])


class PayloadForceSensor(RealisticForceSensor):
    """A :class:`RealisticForceSensor` at the controlled frame of a Pinocchio robot with a :class:`Payload`.

    Args:
        robot: a PinocchioRobot whose ``payload`` is set (the sensor sits at its controlled frame, the
            payload after it), task ``"pose"`` (6-D wrench) or ``"position"`` (the force rows).
        gravity_compensated: the reading leaves out the payload's static weight (the arm's payload setting).
        **kwargs: the :class:`RealisticForceSensor` options (noise, filter, delay, ...).

    Raises:
        ParameterError: the robot has no payload or is not a PinocchioRobot.
    """

    def __init__(self, robot: Any, *, gravity_compensated: bool = True, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        if getattr(robot, "payload", None) is None or not hasattr(robot, "spatial_jacobian"):
            label = getattr(robot, "name", type(robot).__name__)
            raise ParameterError(f"robot must be a PinocchioRobot with a payload; got {label!r} without one")
        if robot.task not in ("pose", "position"):
            raise ParameterError(f"the payload sensor needs task 'pose' or 'position'; got {robot.task!r}")
        self.robot = robot
        self.gravity_compensated = bool(gravity_compensated)
        self._hist: list[np.ndarray] = []
        self._Ts = 0.0

    @property
    def exact(self) -> bool:
        """False: the payload's wrench is added to the contact wrench."""
        return False

    def inertial_wrench(self, q: Any, qd: Any, qdd: Any) -> np.ndarray:
        """The payload's wrench (6,) at joint positions, velocities and accelerations (q, q̇, q̈)."""
        rb = self.robot
        pin, model, data, fid = rb._pin, rb.model, rb.data, rb.frame_id
        pin.forwardKinematics(model, data, np.asarray(q, float), np.asarray(qd, float), np.asarray(qdd, float))
        pin.updateFramePlacement(model, data, fid)
        R = data.oMf[fid].rotation
        lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        acc = pin.getFrameClassicalAcceleration(model, data, fid, lwa)
        vel = pin.getFrameVelocity(model, data, fid, lwa)
        P = rb.payload
        return payload_wrench(P.mass, R @ np.asarray(P.com), R @ P.inertia @ R.T, acc.linear, vel.angular, acc.angular,
                              model.gravity.linear, self.gravity_compensated)

    def start(self, n_samples: int, dim: int, sample_time: float, h0: Any, q0: Any = None) -> np.ndarray:
        if dim != self.robot.task_dim:
            raise DimensionError(f"the payload sensor reads a {self.robot.task_dim}-D wrench; the run has {dim}")
        if q0 is None:
            raise ParameterError("the payload sensor needs q0 (the payload's pose) at start; got None")
        self._Ts = float(sample_time)
        self._hist = []
        return super().start(n_samples, dim, sample_time, h0, q0)

    def measure(self, k: int, t: float, h: Any, q: Any = None) -> np.ndarray:
        if k == self._k or q is None:
            return super().measure(k, t, h, q)
        qa = np.asarray(q, dtype=np.float64)
        self._hist = [qa, *self._hist[:3]] if k else [qa] * 4
        q0, q1, q2, q3 = self._hist if len(self._hist) == 4 else [qa] * 4
        T = self._Ts
        qd = (3.0 * q0 - 4.0 * q1 + q2) / (2.0 * T)
        qdd = (2.0 * q0 - 5.0 * q1 + 4.0 * q2 - q3) / (T * T)
        w = self.inertial_wrench(qa, qd, qdd)[: self.robot.task_dim]
        return super().measure(k, t, np.asarray(h, dtype=np.float64) + w, q)

    def describe(self) -> dict[str, Any]:
        return {**super().describe(), "kind": "payload", "payload": self.robot.payload.describe(),
                "gravity_compensated": self.gravity_compensated}
