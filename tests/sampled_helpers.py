"""Models written from scratch for the tests of the sampled contact loop (test_sampled_contact.py,
test_parts_sampled.py): the one-axis loop along a plane's normal and the free axis, on Example 9.2's arm.

The arm's mobility is ``J B⁻¹ Jᵀ`` from its own Jacobian and inertia matrix; the loop along the
normal is ``s̈ = v_k − μ k s`` between samples (s the penetration), discretised with
``scipy.linalg.expm`` of ``[A B; 0 0] Ts``; the free axis' zero-order hold is written out by hand.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm

import forcecontrol as fc

ARM = fc.PlanarTwoLink()
MD, KD, KP = 100.0, 500.0, 2500.0
TS = 1e-3
Q0 = ARM.inverse_kinematics([1.0, 0.0], elbow="up")


def mobility(q):
    """J B⁻¹ Jᵀ of the chapter's arm at q [1/kg]."""
    J = ARM.jacobian(q)
    return J @ np.linalg.inv(ARM.mass_matrix(q)) @ J.T


def plane_normal(angle_deg):
    """The inclined plane's outward normal (ElasticPlane.inclined, the scenario's ``angle``): [−sin a, cos a]."""
    a = math.radians(angle_deg)
    return np.array([-math.sin(a), math.cos(a)])


def one_axis_radius(k, mu, law="9.31", md=MD, kd=KD, kp=KP, ts=TS):
    """ρ of the loop along the normal: s (penetration) obeys s̈ = v_k − μ k s between samples.

    (9.31): v = (−k_P s − k_D ṡ − k s)/m_d + μ k s (the inner loop adds Jᵀ h_k); (9.28): v = (−k_P s − k_D ṡ)/m_d.
    """
    big = np.zeros((3, 3))
    big[0, 1] = 1.0
    big[1, 0] = -mu * k
    big[1, 2] = 1.0
    E = expm(big * ts)
    Phi, Gam = E[:2, :2], E[:2, 2:]
    if law == "9.31":
        F = np.array([[-(kp + k) / md + mu * k, -kd / md]])
    else:
        F = np.array([[-kp / md, -kd / md]])
    return float(np.max(np.abs(np.linalg.eigvals(Phi + Gam @ F))))


def free_axis_radius(md=MD, kd=KD, kp=KP, ts=TS):
    """ρ of a free axis: the double integrator's ZOH by hand, x⁺ = x + T ẋ + T²/2 a, ẋ⁺ = ẋ + T a, a = −(k_P x + k_D ẋ)/m_d."""
    Phi = np.array([[1.0, ts], [0.0, 1.0]])
    Gam = np.array([[0.5 * ts * ts], [ts]])
    F = np.array([[-kp / md, -kd / md]])
    return float(np.max(np.abs(np.linalg.eigvals(Phi + Gam @ F))))
