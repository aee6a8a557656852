"""The joint servo's state and its per-step update (see :mod:`forcecontrol.robots.servo` for the model).

Kept apart from the parameters (:class:`~forcecontrol.robots.servo.JointServo`): a controller of a
position-interface arm owns one :class:`ServoRuntime`, whose state lives in the controller's
``state`` array (so a failed step restores it like any integrator).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..core.validate import positive_scalar
from ..errors import ParameterError
from .base import RobotTerms

if TYPE_CHECKING:
    from .servo import JointServo

__all__ = ["ServoRuntime"]


class ServoRuntime:
    """The servo's state and its per-step update, on a flat float64 array (the controller's state).

    Layout of ``state`` (length :meth:`size`): ``[y (n), q_r (n), q̇_r (n), q̈_r (n), v_c (n),
    held_q (n), delay ring (n_d × 2n), counter (1)]``. ``y`` is the (filtered, for a velocity
    interface integrated) position command the servo acts on.
    """

    def __init__(self, servo: JointServo, sample_time: float) -> None:
        self.servo = servo
        self.Ts = positive_scalar("sample_time", sample_time, "s")
        self.N = servo.substeps(self.Ts)
        if servo.tracking == "ideal" and servo.tracking_bandwidth * self.Ts > 0.35:
            raise ParameterError(
                f"tracking_bandwidth = {servo.tracking_bandwidth:g} rad/s is too fast for sample_time = {self.Ts:g} s "
                f"(ω_t Ts = {servo.tracking_bandwidth * self.Ts:.3g} > 0.35): lower it or the sample time"
            )
        n = servo.nq
        self.n = n
        w, z = servo.bandwidth, servo.damping
        # exact ZOH discretisation of each joint's second order over one inner step (command held)
        self._Ad = np.empty((n, 2, 2))
        self._Bd = np.empty((n, 2, 2))
        from scipy.linalg import expm  # type: ignore[import-untyped]

        for i in range(n):
            A = np.array([[0.0, 1.0], [-w[i] ** 2, -2.0 * z[i] * w[i]]])
            B = np.array([[0.0, 0.0], [w[i] ** 2, 2.0 * z[i] * w[i]]])  # inputs (y, v_c)
            big = np.zeros((4, 4))
            big[:2, :2], big[:2, 2:] = A * self.Ts, B * self.Ts
            E = expm(big)
            self._Ad[i], self._Bd[i] = E[:2, :2], E[:2, 2:]
        self._a = servo.lowpass_gain()
        #: the joints whose reference a limit (speed, acceleration, jerk) changed in the last step
        self.limited = np.zeros(n, dtype=bool)

    def size(self) -> int:
        """Length of the state array this runtime needs."""
        return 6 * self.n + 2 * self.n * self.servo.delay + 1

    def views(self, s: np.ndarray) -> dict[str, np.ndarray]:
        n, d = self.n, self.servo.delay
        names = ("y", "q_r", "qd_r", "qdd_r", "v_c", "held")
        out = {k: s[i * n : (i + 1) * n] for i, k in enumerate(names)}
        out["ring"] = s[6 * n : 6 * n + 2 * n * d].reshape(max(d, 0), 2 * n) if d else s[6 * n : 6 * n]
        out["counter"] = s[6 * n + 2 * n * d :]
        return out

    def start(self, s: np.ndarray, q0: np.ndarray) -> None:
        """At rest on q0: every command in flight is q0 with zero velocity."""
        v = self.views(s)
        s[:] = 0.0
        v["y"][:] = q0
        v["q_r"][:] = q0
        v["held"][:] = q0
        if self.servo.delay:
            v["ring"][:, : self.n] = q0

    def is_tick(self, s: np.ndarray) -> bool:
        """Whether the next step is an interface cycle's first (a new command is taken)."""
        return int(round(float(s[-1]))) % self.N == 0

    def command(self, s: np.ndarray, q_c: np.ndarray, v_c: np.ndarray | None) -> None:
        """Take this cycle's command (q_c for a position interface; for a velocity interface q_c is
        ignored and ``v_c`` is the command) through the delay line and the low-pass."""
        v = self.views(s)
        n = self.n
        new = np.empty(2 * n)
        new[:n] = q_c
        new[n:] = 0.0 if v_c is None else v_c
        d = self.servo.delay
        if d:
            ring = v["ring"]
            k = int(round(float(s[-1]))) // self.N
            slot = k % d
            out = ring[slot].copy()
            ring[slot] = new
        else:
            out = new
        if self.servo.interface == "position":
            v["held"][:] = out[:n]
            a = self._a
            v["y"][:] = a * out[:n] + (1.0 - a) * v["y"]
        v["v_c"][:] = out[n:]

    def torque(self, s: np.ndarray, q: np.ndarray, qd: np.ndarray, T: RobotTerms, h: np.ndarray) -> np.ndarray:
        """The joint torques for this step (then advances the servo by one sample time)."""
        sv = self.servo
        v = self.views(s)
        y, q_r, qd_r, qdd_r, v_c = v["y"], v["q_r"], v["qd_r"], v["qdd_r"], v["v_c"]
        w, z = sv.bandwidth, sv.damping
        if sv.tracking == "dynamic":
            acc = w * w * (y - q) + 2.0 * z * w * (v_c - qd)
            if sv.acceleration_limit is not None:
                acc = np.clip(acc, -sv.acceleration_limit, sv.acceleration_limit)
            lim = np.zeros(self.n, dtype=bool)
            if sv.acceleration_limit is not None:
                lim |= np.abs(w * w * (y - q) + 2.0 * z * w * (v_c - qd)) > sv.acceleration_limit
            if sv.velocity_limit is not None:  # no push beyond the speed limit
                over = np.abs(qd) >= sv.velocity_limit
                push = over & (np.sign(acc) == np.sign(qd))
                lim |= push
                acc = np.where(push, 0.0, acc)
            self.limited = lim
            u = T.B @ acc + T.n
            q_r[:], qd_r[:], qdd_r[:] = y, v_c, acc
        else:
            a0 = w * w * (y - q_r) + 2.0 * z * w * (v_c - qd_r)
            wt = sv.tracking_bandwidth
            u = T.B @ (a0 + 2.0 * wt * (qd_r - qd) + wt * wt * (q_r - q)) + T.n + T.J.T @ h
            self._advance(v, a0)
        if sv.interface == "velocity":
            y += v_c * self.Ts
        s[-1] += 1.0
        return u

    def _advance(self, v: dict[str, np.ndarray], a0: np.ndarray) -> None:
        """q_r, q̇_r over one inner step: exact with the command held, or limited Euler where a limit bites."""
        sv = self.servo
        y, q_r, qd_r, qdd_r, v_c = v["y"], v["q_r"], v["qd_r"], v["qdd_r"], v["v_c"]
        Ts = self.Ts
        Ad, Bd = self._Ad, self._Bd
        qn = Ad[:, 0, 0] * q_r + Ad[:, 0, 1] * qd_r + Bd[:, 0, 0] * y + Bd[:, 0, 1] * v_c
        vn = Ad[:, 1, 0] * q_r + Ad[:, 1, 1] * qd_r + Bd[:, 1, 0] * y + Bd[:, 1, 1] * v_c
        bad = np.zeros(self.n, dtype=bool)
        a = a0.copy()
        if sv.acceleration_limit is not None:
            bad |= np.abs(a0) > sv.acceleration_limit
            a = np.clip(a, -sv.acceleration_limit, sv.acceleration_limit)
        if sv.jerk_limit is not None:
            jmax = sv.jerk_limit * Ts
            bad |= np.abs(a0 - qdd_r) > jmax
            a = np.clip(a, qdd_r - jmax, qdd_r + jmax)
        if sv.velocity_limit is not None:
            bad |= np.abs(vn) > sv.velocity_limit
        if bad.any():
            ve = qd_r + a * Ts
            if sv.velocity_limit is not None:
                ve = np.clip(ve, -sv.velocity_limit, sv.velocity_limit)
            qe = q_r + 0.5 * (qd_r + ve) * Ts
            qn = np.where(bad, qe, qn)
            vn = np.where(bad, ve, vn)
            a = np.where(bad, (ve - qd_r) / Ts, a0)
        else:
            a = a0
        self.limited = bad
        q_r[:], qd_r[:], qdd_r[:] = qn, vn, a
