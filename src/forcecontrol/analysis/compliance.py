"""Equilibria of active compliance in contact with an elastic environment (Sect. 9.2.2).

With an active stiffness K_P and an environment stiffness K (both (m, m), K PSD), the contact
force and the pose error at equilibrium are (9.22)–(9.23)::

    h_e      = (I + K K_P⁻¹)⁻¹ K dx_{r,d}
    dx_{e,d} = K_P⁻¹ (I + K K_P⁻¹)⁻¹ K dx_{r,d}

with dx_{r,d} = x_d − x_r and dx_{e,d} = x_d − x_e (Example 9.1).

:func:`compliance_loop` is the same law (8.110) held over each sample, for the sampled loop's
stability (:mod:`forcecontrol.analysis.sampled_contact`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import as_gain_matrix, as_matrix, as_vector
from .impedance import HeldLoop, contact_plant, environment_matrices

__all__ = ["ComplianceEquilibrium", "compliance_equilibrium", "joint_space_compliance", "compliance_loop"]


@dataclass(frozen=True)
class ComplianceEquilibrium:
    """The equilibrium of (9.22)–(9.23).

    Attributes:
        contact_force: h_e at equilibrium, (m,) [N] (force on the environment).
        pose_error: dx_{e,d} = x_d − x_e, (m,) [m].
        position: x_e = x_d − dx_{e,d}, (m,) [m] (when the desired position was given).
    """

    contact_force: np.ndarray
    pose_error: np.ndarray
    position: np.ndarray


def compliance_equilibrium(stiffness: Any, environment_stiffness: Any, desired: Any, rest: Any) -> ComplianceEquilibrium:
    """Contact force (9.22) and pose error (9.23) at the equilibrium of compliance control.

    Args:
        stiffness: active stiffness K_P, symmetric positive definite (m, m) [N/m].
        environment_stiffness: K, symmetric positive semi-definite (m, m) [N/m].
        desired: x_d, (m,) [m].
        rest: x_r, the environment's rest position, (m,) [m].
    """
    x_d = as_vector("desired", desired)
    m = x_d.shape[0]
    x_r = as_vector("rest", rest, m)
    K_P = as_gain_matrix("stiffness", stiffness, m)
    K = as_gain_matrix("environment_stiffness", environment_stiffness, m, definite=False)
    dx_rd = x_d - x_r
    M = np.eye(m) + K @ np.linalg.inv(K_P)
    h = np.linalg.solve(M, K @ dx_rd)
    dx_ed = np.linalg.solve(K_P, h)
    return ComplianceEquilibrium(contact_force=h, pose_error=dx_ed, position=x_d - dx_ed)


def joint_space_compliance(jacobian: Any, joint_stiffness: Any) -> np.ndarray:
    """The operational compliance ``J K_P⁻¹ Jᵀ`` of joint-space PD control (9.26), (m, m) [m/N]."""
    J = np.asarray(jacobian, dtype=np.float64)
    K_P = as_gain_matrix("joint_stiffness", joint_stiffness, J.shape[1])
    return J @ np.linalg.solve(K_P, J.T)


def compliance_loop(stiffness: Any, damping: Any, environment_stiffness: Any, mobility: Any, *,
                    environment_damping: Any = None) -> HeldLoop:
    """Active compliance (8.110), ``u = g(q) + Jᵀ (K_P (x_d − x_e) − K_D ẋ_e)``, held over each sample on
    ``h_e = K (x − x_r) + D_e ẋ``.

    The law compensates gravity only: in the operational space ``ẍ = M (K_P x̃ − K_D ẋ)_k − M h(t)``
    with ``M = J B⁻¹ Jᵀ`` the arm's mobility (the velocity-product terms, zero at rest, left out).
    In the form of :class:`~forcecontrol.analysis.impedance.HeldLoop`, with the plant
    ``ẍ = v − M (K x + D_e ẋ)``: ``F = [−M K_P, −M K_D]``, ``G_d = M K_P``, ``G_r = M K``. Its rest is
    the equilibrium (9.22)–(9.23).

    Args:
        stiffness: K_P, symmetric positive definite (m, m) [N/m]; damping: K_D (m, m) [N s/m].
        environment_stiffness: K, symmetric positive semi-definite (m, m) [N/m] (base frame).
        mobility: ``M = J B⁻¹ Jᵀ`` at the pose considered, (m, m) [1/kg].
        environment_damping: D_e (m, m) [N s/m] (default 0).
    """
    Mob = np.atleast_2d(np.asarray(mobility, dtype=np.float64))
    m = Mob.shape[0]
    Mob = as_matrix("mobility", Mob, (m, m))
    KP = as_gain_matrix("stiffness", stiffness, m)
    KD = as_gain_matrix("damping", damping, m, definite=False)
    K, De = environment_matrices(environment_stiffness, environment_damping, m)
    A, B = contact_plant(Mob, K, De)
    return HeldLoop(A, B, np.hstack([-Mob @ KP, -Mob @ KD]), Mob @ KP, Mob @ K)
