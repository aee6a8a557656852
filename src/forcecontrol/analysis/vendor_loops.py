"""The sampled loops of ros2_controllers' admittance controller and UR's force mode along one contact normal (issue 30).

As :mod:`.vendor_fzi` for FZI's controllers: one interface cycle of the 1-DOF loop, written from
the controller's documented equations (survey of issue 30, §1.1–1.2 and §4) and the servo model
of :mod:`forcecontrol.robots.servo` (second order, exact zero-order hold over a cycle, n_d cycles
of delay), the contact a spring k_e on the measured position. The map is linear; its matrix is
built column by column, the loop is stable iff its spectral radius is below 1, and the k_e
stability limit is bisected.

ros2 admittance (J = 1, control frame = base)::

    x = q_r,  w_f ← α (−k_e x) + (1 − α) w_f
    q̈_a = (w_f − D ẋ − K x) / (M (1 + α_k)) − c_j q̇_a,  q̇_a ← q̇_a + T q̈_a,  q_a ← q_a + T q̇_a,  ẋ ← q̇_a
    command y = q_a

UR force mode (inferred law, compliant axis)::

    v ← (1 − d) v − T G s_g k_e q_r,   offset ← offset + T v,   command y = offset
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .vendor_fzi import _servo

__all__ = ["Ros2AdmittanceLoop", "UrForceModeLoop", "loop_matrix", "spectral_radius", "stability_limit"]


@dataclass(frozen=True)
class Ros2AdmittanceLoop:
    """One axis of the admittance rule (mass, damping_ratio, stiffness, joint_damping, filter α, kinematics α_k)
    with the servo (rate [Hz], bandwidth ω [rad/s], damping ζ, delay n_d [cycles])."""

    mass: float
    damping_ratio: float
    stiffness: float
    rate: float
    bandwidth: float
    damping: float
    delay: int = 1
    joint_damping: float = 5.0
    filter_coefficient: float = 0.05
    kinematics_alpha: float = 0.0

    def law_size(self) -> int:
        return 4

    def law(self, k_e: float, x: float, s: list[float]) -> tuple[float, list[float]]:
        qa, qda, xd, wf = s
        T = 1.0 / self.rate
        D = self.damping_ratio * 2.0 * math.sqrt(self.mass * self.stiffness)
        a = self.filter_coefficient
        wf = a * (-k_e * x) + (1.0 - a) * wf
        qdd = (wf - D * xd - self.stiffness * x) / (self.mass * (1.0 + self.kinematics_alpha)) - self.joint_damping * qda
        qda = qda + T * qdd
        qa = qa + T * qda
        return qa, [qa, qda, qda, wf]


@dataclass(frozen=True)
class UrForceModeLoop:
    """One compliant axis of the inferred force-mode law (gain G [1/kg], gain_scaling s_g, damping d) with the servo."""

    gain: float
    gain_scaling: float
    damping_force_mode: float
    rate: float
    bandwidth: float
    damping: float
    delay: int = 1

    def law_size(self) -> int:
        return 2

    def law(self, k_e: float, x: float, s: list[float]) -> tuple[float, list[float]]:
        v, off = s
        T = 1.0 / self.rate
        v = (1.0 - self.damping_force_mode) * v - T * self.gain * self.gain_scaling * k_e * x
        off = off + T * v
        return off, [v, off]


Loop = Ros2AdmittanceLoop | UrForceModeLoop


def loop_matrix(loop: Loop, environment_stiffness: float) -> np.ndarray:
    """The closed loop's matrix over one interface cycle: state ``[q_r, q̇_r, delay ring (n_d), law state]``."""
    if loop.delay < 0 or loop.rate <= 0 or loop.bandwidth <= 0:
        raise ParameterError(f"delay >= 0, rate > 0 and bandwidth > 0 are needed; got {loop!r}")
    Ad, Bd = _servo(1.0 / loop.rate, loop.bandwidth, loop.damping)
    nd, nl = loop.delay, loop.law_size()
    n = 2 + nd + nl

    def cycle(z: np.ndarray) -> np.ndarray:
        qr, qdr = z[0], z[1]
        ring = list(z[2 : 2 + nd])
        y_new, law = loop.law(environment_stiffness, qr, list(z[2 + nd :]))
        y = ring[0] if nd else y_new
        ring = [*ring[1:], y_new] if nd else []
        nxt = Ad @ np.array([qr, qdr]) + Bd * y
        return np.array([nxt[0], nxt[1], *ring, *law])

    return np.column_stack([cycle(np.eye(n)[i]) for i in range(n)])


def spectral_radius(loop: Loop, environment_stiffness: float) -> float:
    """max |z| of the loop's poles (< 1: stable)."""
    return float(np.max(np.abs(np.linalg.eigvals(loop_matrix(loop, environment_stiffness)))))


def stability_limit(loop: Loop, k_max: float = 1e9, rtol: float = 1e-4,
                    radius: Callable[[Loop, float], float] = spectral_radius) -> float:
    """The largest environment stiffness [N/m] with a stable loop (bisection); ``inf`` if stable up to ``k_max``."""
    if radius(loop, 0.0) > 1.0 + 1e-9:  # force mode's free space is marginal (the offset integrates): not unstable
        return 0.0
    hi = 1.0
    while radius(loop, hi) < 1.0:
        hi *= 2.0
        if hi > k_max:
            return math.inf
    lo = hi / 2.0
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if radius(loop, mid) < 1.0 else (lo, mid)
    return lo
