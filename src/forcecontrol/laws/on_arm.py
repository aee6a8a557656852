"""Each law on the chapter's arm in one compiled call: what ``Controller.step`` runs there.

``<law>_on_arm(K, t, dt, q, q̇, h, x_d, ẋ_d, ẍ_d, f_d, ḟ_d, f̈_d, p, s, ws, u) -> ok`` checks the
inputs and computes the arm's terms (:func:`.arm.arm_inputs`), runs the law, and restores the
state when it failed (:func:`.arm.arm_finish`). One wrapper per law, because Numba caches a
function that calls a global law but not one that passes it on as a value, and Python calling a
function with a law argument pays 5 µs of type resolution per call.
"""

from __future__ import annotations

from numba import njit

from .arm import arm_finish, arm_inputs
from .compliance import joint_pd, os_pd
from .force import inner_position, inner_velocity, parallel
from .hybrid import hybrid_compliant, hybrid_rigid
from .impedance import impedance

__all__ = [
    "os_pd_on_arm",
    "joint_pd_on_arm",
    "impedance_on_arm",
    "inner_position_on_arm",
    "inner_velocity_on_arm",
    "parallel_on_arm",
    "hybrid_compliant_on_arm",
    "hybrid_rigid_on_arm",
]


@njit(cache=True)
def os_pd_on_arm(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
    ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
    return ok and arm_finish(os_pd(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u), s, ws, u)


@njit(cache=True)
def joint_pd_on_arm(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
    ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
    return ok and arm_finish(joint_pd(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u), s, ws, u)


@njit(cache=True)
def impedance_on_arm(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
    ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
    return ok and arm_finish(impedance(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u), s, ws, u)


@njit(cache=True)
def inner_position_on_arm(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
    ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
    return ok and arm_finish(inner_position(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u), s, ws, u)


@njit(cache=True)
def inner_velocity_on_arm(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
    ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
    return ok and arm_finish(inner_velocity(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u), s, ws, u)


@njit(cache=True)
def parallel_on_arm(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
    ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
    return ok and arm_finish(parallel(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u), s, ws, u)


@njit(cache=True)
def hybrid_compliant_on_arm(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
    ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
    return ok and arm_finish(hybrid_compliant(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u), s, ws, u)


@njit(cache=True)
def hybrid_rigid_on_arm(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
    ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
    return ok and arm_finish(hybrid_rigid(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u), s, ws, u)
