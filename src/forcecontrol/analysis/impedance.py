"""Impedance control on an elastic environment: per-axis dynamics and steady state (Example 9.2).

With force measurement the closed loop is the impedance (9.32); on a plane of stiffness k along
an axis, that axis obeys ``m_d ẍ + k_D ẋ + (k_P + k) x = k x_r + k_P x_d`` with::

    ω_n = sqrt((k_P + k) / m_d),   ζ = k_D / (2 sqrt(m_d (k_P + k)))

and a free axis has ω_n = sqrt(k_P / m_d), ζ = k_D / (2 sqrt(m_d k_P)). At rest the position
is ``x_e = (k_P x_d + k x_r) / (k_P + k)`` and the contact force ``f = k (x_e − x_r)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .._validate import nonnegative_scalar, positive_scalar

__all__ = ["AxisDynamics", "impedance_axis"]


@dataclass(frozen=True)
class AxisDynamics:
    """Second-order dynamics and steady state of one operational axis.

    Attributes:
        natural_frequency: ω_n [rad/s]; damping_ratio: ζ.
        position: steady position x_e [m]; contact_force: steady f = k (x_e − x_r) [N].
        displacement: x_e − x_r [m] (environment deformation; 0 when free).
    """

    natural_frequency: float
    damping_ratio: float
    position: float
    contact_force: float
    displacement: float


def impedance_axis(
    inertia: float,
    damping: float,
    stiffness: float,
    environment_stiffness: float = 0.0,
    desired: float = 0.0,
    rest: float = 0.0,
) -> AxisDynamics:
    """ω_n, ζ and the steady state along one axis under impedance control with force measurement.

    Args:
        inertia: m_d [kg]; damping: k_D [N s/m]; stiffness: k_P [N/m].
        environment_stiffness: k along the axis [N/m] (0: free motion).
        desired: x_d [m]; rest: x_r, the environment's rest position [m].
    """
    m = positive_scalar("inertia", inertia)
    kd = nonnegative_scalar("damping", damping)
    kp = positive_scalar("stiffness", stiffness)
    k = nonnegative_scalar("environment_stiffness", environment_stiffness)
    wn = math.sqrt((kp + k) / m)
    zeta = kd / (2.0 * math.sqrt(m * (kp + k)))
    x = (kp * desired + k * rest) / (kp + k)
    return AxisDynamics(wn, zeta, x, k * (x - rest), x - rest if k > 0 else 0.0)
