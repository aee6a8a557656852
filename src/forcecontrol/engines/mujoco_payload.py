"""A payload in the MuJoCo engine: a body welded to the controlled frame, read by a force/torque sensor at that frame.

The robot's :class:`~forcecontrol.robots.pinocchio.Payload` (mass m, centre of mass c and inertia
I_c about it, in the controlled frame's axes; the numbers the built-in model adds to its last
link) becomes a child body ``payload`` of the controlled frame's body, at the frame's origin, with
``ipos = c`` and ``fullinertia = I_c``. The end-effector's contact sphere is carried by that body,
so a contact pushes on the payload, as on the built-in model where the sensor sits between the
flange and everything after it.

The sensor is MuJoCo's own: a ``force`` and a ``torque`` sensor at a site on the payload body at
the frame's origin. MuJoCo reads them from ``cfrc_int`` (its recursive Newton-Euler pass after the
constraint forces): the wrench the flange applies to the payload, ``m (a_c − g) + h_e`` and its
moment about the site, in the site's axes. That is the library's convention for the reading
(:class:`~forcecontrol.sensors.payload.PayloadForceSensor`: h_e, the wrench the end-effector
exerts on the environment, plus the payload's inertial wrench), obtained here from MuJoCo's
quantities and none of the built-in formulas, so the two engines check each other.

Sampling: the reading at t_k is MuJoCo's at the state reached at t_k with the torque held over the
last period (``mj_forward`` before the controller computes the next one: the acceleration just
before t_k, what a real sensor sampled at t_k feels); at t = 0 the arm was at rest (q̈ = 0,
``mj_inverse``). The built-in sensor forms q̈ by backward differences of q instead: the two agree
up to that difference (see ``tests/test_payload_mujoco.py`` for the stated tolerances).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError

__all__ = ["add_payload_body", "PayloadReader"]

BODY, SITE = "payload", "payload_ft_sensor"


def add_payload_body(mujoco: Any, spec: Any, frame_body: Any, payload: Any, task: str) -> Any:
    """Add the payload body (same mass, centre of mass and inertia as the built-in model) and its F/T sensor site to
    ``spec`` under ``frame_body``; returns the new body (the one that carries the contact sphere)."""
    if task not in ("pose", "position"):
        raise ParameterError(
            f"the MuJoCo engine reads a payload's wrench for a robot with task 'pose' or 'position' (as the built-in "
            f"payload sensor does); got task {task!r}"
        )
    body = frame_body.add_body()
    body.name = BODY
    body.pos = [0.0, 0.0, 0.0]
    body.mass = float(payload.mass)
    body.ipos = [float(c) for c in payload.com]
    I = np.asarray(payload.inertia, dtype=float)
    lam = np.linalg.eigvalsh(I)  # ascending
    if lam[0] + lam[1] < lam[2] * (1.0 - 1e-9):  # MuJoCo would "balance" it (compiler balanceinertia): another payload
        raise ParameterError(
            "the MuJoCo engine needs a payload inertia a rigid body can have (principal moments A + B >= C); got "
            f"principal moments {lam.tolist()} kg m²"
        )
    # MuJoCo refuses a zero inertia: a point mass gets 1e-9 kg m² on the diagonal (1e-9 of FZI #177's payload inertia
    # about the sensor; its wrench I α + ω × I ω stays below 1e-7 N m at the rates any arm reaches)
    I = I + 1e-9 * np.eye(3) if lam[0] < 1e-9 else I
    body.fullinertia = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
    body.explicitinertial = True
    site = body.add_site()
    site.name = SITE
    site.pos = [0.0, 0.0, 0.0]
    for kind, name in ((mujoco.mjtSensor.mjSENS_FORCE, "payload_force"), (mujoco.mjtSensor.mjSENS_TORQUE, "payload_torque")):
        s = spec.add_sensor()
        s.name = name
        s.type = kind
        s.objtype = mujoco.mjtObj.mjOBJ_SITE
        s.objname = SITE
    return body


class PayloadReader:
    """The F/T sensor's reading from a compiled model with the payload: base-frame axes, about the controlled frame.

    Args:
        mujoco: the mujoco module; model: the compiled ``MjModel``; dim: the task's wrench size (3 or 6).
        gravity_compensated: leave out the payload's static weight and its moment at the current orientation
            (the arm's payload setting, as :class:`~forcecontrol.sensors.payload.PayloadForceSensor` by default).
    """

    def __init__(self, mujoco: Any, model: Any, dim: int, gravity_compensated: bool = True) -> None:
        self._mujoco = mujoco
        self.model = model
        self.dim = int(dim)
        self.gravity_compensated = bool(gravity_compensated)
        self.body = model.body(BODY).id
        self.site = model.site(SITE).id
        self._force = int(model.sensor_adr[model.sensor("payload_force").id])
        self._torque = int(model.sensor_adr[model.sensor("payload_torque").id])
        self.mass = float(model.body_mass[self.body])

    def read(self, data: Any, qacc: Any = None) -> np.ndarray:
        """The reading (dim,) at ``data``'s q, q̇: with the applied torque (``mj_forward``), or at the joint
        accelerations ``qacc`` (``mj_inverse``; zeros: the arm held still before the run starts)."""
        mujoco, m = self._mujoco, self.model
        if qacc is not None:
            saved = data.qacc.copy()
            data.qacc[:] = np.asarray(qacc, dtype=float)
            mujoco.mj_inverse(m, data)
            data.qacc[:] = saved
        else:
            mujoco.mj_forward(m, data)
        R = data.site_xmat[self.site].reshape(3, 3)
        s = data.sensordata
        f = R @ s[self._force : self._force + 3]
        tau = R @ s[self._torque : self._torque + 3]
        if self.gravity_compensated:
            w = self.mass * m.opt.gravity  # the weight m g; the static reading is −m g and r × (−m g)
            r = data.xipos[self.body] - data.site_xpos[self.site]
            f = f + w
            tau = tau + np.cross(r, w)
        return np.concatenate([f, tau])[: self.dim]

    def describe(self) -> dict[str, Any]:
        m = self.model
        return {
            "mass": self.mass, "com": m.body_ipos[self.body].tolist(), "sensor": "MuJoCo force/torque at the controlled frame",
            "gravity_compensated": self.gravity_compensated,
        }
