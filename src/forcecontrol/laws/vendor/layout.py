"""The layouts of the vendor laws' parameter and state vectors, each declared once (as in :mod:`forcecontrol.laws.layout`).

The controllers of :mod:`forcecontrol.controllers.vendor` pack with ``<DECLARATION>.pack(dims...,
block=value, ...)``; the laws read every block by the name of its offset: a compiled function
``<name>_<block>(*dims)`` or, for the first block, the constant ``<NAME>_<BLOCK>`` = 0.
``tests/test_vendor_layout.py`` checks every offset against its declaration for each dimension
from 1 to 6 and that no vendor law indexes ``p`` or ``s`` by a number.
"""

from __future__ import annotations

from numba import njit

from ..layout import Blocks

__all__ = [
    "ROS2_ADMITTANCE", "ROS2_ADMITTANCE_STATE", "FDCC", "FDCC_STATE", "FRANKA", "FRANKA_STATE", "UR_FORCE_MODE",
    "UR_FORCE_MODE_STATE", "DECLARATIONS",
]

# ---------------------------------------------------------------------------------------------- ros2 admittance
ROS2_ADMITTANCE = Blocks("ros2_admittance", "m", ("mass", "m"), ("damping", "m"), ("stiffness", "m"), ("selected", "m"),
                         ("joint_damping", "1"), ("filter_coefficient", "1"), ("dls_alpha", "1"))
ROS2_ADMITTANCE_MASS = 0


@njit(inline="always", cache=True)
def ros2_admittance_damping(m):  # pragma: no cover - compiled
    return m


@njit(inline="always", cache=True)
def ros2_admittance_stiffness(m):  # pragma: no cover - compiled
    return 2 * m


@njit(inline="always", cache=True)
def ros2_admittance_selected(m):  # pragma: no cover - compiled
    return 3 * m


@njit(inline="always", cache=True)
def ros2_admittance_joint_damping(m):  # pragma: no cover - compiled
    return 4 * m


@njit(inline="always", cache=True)
def ros2_admittance_filter_coefficient(m):  # pragma: no cover - compiled
    return 4 * m + 1


@njit(inline="always", cache=True)
def ros2_admittance_dls_alpha(m):  # pragma: no cover - compiled
    return 4 * m + 2


ROS2_ADMITTANCE_STATE = Blocks("ros2_admittance_state", ("m", "n"), ("q_a", "n"), ("qd_a", "n"), ("xd", "m"), ("w_f", "m"))
ROS2_ADMITTANCE_STATE_Q_A = 0


@njit(inline="always", cache=True)
def ros2_admittance_state_qd_a(m, n):  # pragma: no cover - compiled
    return n


@njit(inline="always", cache=True)
def ros2_admittance_state_xd(m, n):  # pragma: no cover - compiled
    return 2 * n


@njit(inline="always", cache=True)
def ros2_admittance_state_w_f(m, n):  # pragma: no cover - compiled
    return 2 * n + m


# ---------------------------------------------------------------------------------------------- FZI FDCC
FDCC = Blocks("fdcc", "m", ("P", "m"), ("D_g", "m"), ("error_scale", "1"), ("h", "1"), ("decay", "1"), ("instantaneous", "1"))
FDCC_P = 0


@njit(inline="always", cache=True)
def fdcc_D_g(m):  # pragma: no cover - compiled
    return m


@njit(inline="always", cache=True)
def fdcc_error_scale(m):  # pragma: no cover - compiled
    return 2 * m


@njit(inline="always", cache=True)
def fdcc_h(m):  # pragma: no cover - compiled
    return 2 * m + 1


@njit(inline="always", cache=True)
def fdcc_decay(m):  # pragma: no cover - compiled
    return 2 * m + 2


@njit(inline="always", cache=True)
def fdcc_instantaneous(m):  # pragma: no cover - compiled
    return 2 * m + 3


FDCC_STATE = Blocks("fdcc_state", ("m", "n"), ("qd", "n"), ("e_prev", "m"))
FDCC_STATE_QD = 0


@njit(inline="always", cache=True)
def fdcc_state_e_prev(m, n):  # pragma: no cover - compiled
    return n


# ---------------------------------------------------------------------------------------------- Franka
FRANKA = Blocks("franka", ("m", "n"), ("K", "m"), ("D", "m"), ("k_ns", "1"), ("delta_tau_max", "1"), ("filter", "1"),
                ("pinv_damping", "1"), ("q_ns", "n"))
FRANKA_K = 0


@njit(inline="always", cache=True)
def franka_D(m, n):  # pragma: no cover - compiled
    return m


@njit(inline="always", cache=True)
def franka_k_ns(m, n):  # pragma: no cover - compiled
    return 2 * m


@njit(inline="always", cache=True)
def franka_delta_tau_max(m, n):  # pragma: no cover - compiled
    return 2 * m + 1


@njit(inline="always", cache=True)
def franka_filter(m, n):  # pragma: no cover - compiled
    return 2 * m + 2


@njit(inline="always", cache=True)
def franka_pinv_damping(m, n):  # pragma: no cover - compiled
    return 2 * m + 3


@njit(inline="always", cache=True)
def franka_q_ns(m, n):  # pragma: no cover - compiled
    return 2 * m + 4


FRANKA_STATE = Blocks("franka_state", ("m", "n"), ("K", "m"), ("D", "m"), ("k_ns", "1"), ("tau_J_d", "n"))
FRANKA_STATE_K = 0


@njit(inline="always", cache=True)
def franka_state_D(m, n):  # pragma: no cover - compiled
    return m


@njit(inline="always", cache=True)
def franka_state_k_ns(m, n):  # pragma: no cover - compiled
    return 2 * m


@njit(inline="always", cache=True)
def franka_state_tau_J_d(m, n):  # pragma: no cover - compiled
    return 2 * m + 1


# ---------------------------------------------------------------------------------------------- UR force mode
UR_FORCE_MODE = Blocks("ur_force_mode", "m", ("selection", "m"), ("wrench", "m"), ("limits", "m"), ("gain", "1"),
                       ("gain_scaling", "1"), ("damping", "1"))
UR_FORCE_MODE_SELECTION = 0


@njit(inline="always", cache=True)
def ur_force_mode_wrench(m):  # pragma: no cover - compiled
    return m


@njit(inline="always", cache=True)
def ur_force_mode_limits(m):  # pragma: no cover - compiled
    return 2 * m


@njit(inline="always", cache=True)
def ur_force_mode_gain(m):  # pragma: no cover - compiled
    return 3 * m


@njit(inline="always", cache=True)
def ur_force_mode_gain_scaling(m):  # pragma: no cover - compiled
    return 3 * m + 1


@njit(inline="always", cache=True)
def ur_force_mode_damping(m):  # pragma: no cover - compiled
    return 3 * m + 2


UR_FORCE_MODE_STATE = Blocks("ur_force_mode_state", "m", ("v", "m"), ("offset", "m"))
UR_FORCE_MODE_STATE_V = 0


@njit(inline="always", cache=True)
def ur_force_mode_state_offset(m):  # pragma: no cover - compiled
    return m


#: every declaration of this module (the tests check each offset against it).
DECLARATIONS = (ROS2_ADMITTANCE, ROS2_ADMITTANCE_STATE, FDCC, FDCC_STATE, FRANKA, FRANKA_STATE, UR_FORCE_MODE,
                UR_FORCE_MODE_STATE)
