"""Equilibria of active compliance in contact with an elastic environment (Sect. 9.2.2).

With an active stiffness K_P and an environment stiffness K (both (m, m), K PSD), the contact
force and the pose error at equilibrium are (9.22)–(9.23)::

    h_e      = (I + K K_P⁻¹)⁻¹ K dx_{r,d}
    dx_{e,d} = K_P⁻¹ (I + K K_P⁻¹)⁻¹ K dx_{r,d}

with dx_{r,d} = x_d − x_r and dx_{e,d} = x_d − x_e (Example 9.1).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import as_gain_matrix, as_vector

__all__ = ["ComplianceEquilibrium", "compliance_equilibrium", "joint_space_compliance"]


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
