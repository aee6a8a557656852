"""A compiled 6-D closed loop: impedance (9.35) or admittance (9.37) with a serial arm on an elastic table.

The loop of :func:`forcecontrol.sim.simulation.simulate` (``engine="python"``) for a
:class:`~forcecontrol.controllers.spatial.SpatialImpedanceController` (XYZ Euler error on the
desired frame) or an :class:`~forcecontrol.controllers.admittance.AdmittanceController` (the
compliant frame (9.37) advanced by the controller's exact discretisation, tracked by the motion
loop), a :class:`~forcecontrol.environments.spatial.Table` or
:class:`~forcecontrol.environments.spatial.ConstantWrench`, an ideal sensor, and a robot whose
dynamics :mod:`forcecontrol.robots.compiled_tree` compiles (a serial revolute/prismatic chain:
the Panda, the UR arms), written as one compiled function:

per sample k: the arm's terms (:func:`~forcecontrol.robots.compiled_tree.tree_terms`), the true
wrench, the controller's own compiled law
(:func:`~forcecontrol.laws.spatial.spatial_impedance_torque`; for admittance after the compliant
frame, :func:`compliant_frame_arrays`), the logs, then RK4 with ``nsub``
sub-steps and the torque held, each stage ``B q̈ = u − n − Jᵀ h_e`` solved by Cholesky (the Python
engine uses Pinocchio's ABA: equal to round-off).

Nothing crosses between Python and compiled code inside the run. This is the compiled loop the
benchmark ``benchmarks/bench_6d_vs_cpp.py`` measures against the same loop in C++; it is not yet
what ``simulate`` or the scenarios run (they keep the Python engine for 6-D arms).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from ..controllers.base import REFERENCE_FIELDS
from ..core.numba_cache import kernel_array
from ..errors import ParameterError
from ..laws.spatial import _c3, _R_xyz, spatial_impedance_torque
from ..robots.compiled_tree import chol_solve, compile_tree, tree_terms
from ..spatial.closed_form import EULER_SINGULARITY_TOL

__all__ = ["impedance_loop", "run_tree_loop", "run_impedance_loop", "tree_loop_support", "env_params", "compliant_frame_arrays"]

#: environment kinds of the loop: 0 a constant wrench, 1 an elastic table.
CONSTANT, TABLE = 0, 1


@njit(cache=True, inline="always")
def _wrench(env_kind, env_p, o, v, h):  # pragma: no cover - compiled
    """h_e of the environment (same arithmetic as ``Table.wrench`` / ``ConstantWrench.wrench``)."""
    if env_kind == 0:
        for i in range(6):
            h[i] = env_p[i]
        return
    for i in range(6):
        h[i] = 0.0
    n0, n1, n2 = env_p[3], env_p[4], env_p[5]
    delta = n0 * (env_p[0] - o[0]) + n1 * (env_p[1] - o[1]) + n2 * (env_p[2] - o[2])
    if delta <= 0.0:
        return
    mag = env_p[6] * delta - env_p[7] * (n0 * v[0] + n1 * v[1] + n2 * v[2])
    if mag > 0.0:
        h[0], h[1], h[2] = -mag * n0, -mag * n1, -mag * n2


@njit(cache=True)
def _euler_xyz(R, out):  # pragma: no cover - compiled
    """XYZ Euler angles of R into out (``spatial.closed_form.rotation_to_euler_xyz``, its singular branch included)."""
    s2 = min(1.0, max(-1.0, R[0, 2]))
    c2 = math.hypot(R[0, 0], R[0, 1])
    if c2 < EULER_SINGULARITY_TOL:
        out[0], out[1], out[2] = math.atan2(R[2, 1], R[1, 1]), math.asin(s2), 0.0
    else:
        out[0], out[1], out[2] = math.atan2(-R[1, 2], R[2, 2]), math.atan2(s2, c2), math.atan2(-R[0, 1], R[0, 0])


@njit(cache=True)
def compliant_frame_arrays(pos, vel, acc, z, zd, zdd, pos_t, vel_t, acc_t):  # pragma: no cover - compiled
    """The compliant frame (pose, twist, acceleration) from z̃, z̃̇, z̃̈ (9.37) and the desired frame.

    The formulas of :func:`forcecontrol.controllers.admittance.compliant_frame`, on arrays.
    """
    R_d = _R_xyz(pos[3:])
    w_d = vel[3:].copy()
    wd_dot = acc[3:].copy()
    p, pd, pdd = -z[:3], -zd[:3], -zdd[:3]
    phi, phid, phidd = -z[3:], -zd[3:], -zdd[3:]
    Rp = R_d @ p
    Rpd = R_d @ pd
    c1, s1 = math.cos(phi[0]), math.sin(phi[0])
    c2, s2 = math.cos(phi[1]), math.sin(phi[1])
    T = np.array([[1.0, 0.0, s2], [0.0, c1, -s1 * c2], [0.0, s1, c1 * c2]])
    d1, d2 = phid[0], phid[1]
    Tdot = np.array([[0.0, 0.0, c2 * d2], [0.0, -s1 * d1, -c1 * c2 * d1 + s1 * s2 * d2],
                     [0.0, c1 * d1, -s1 * c2 * d1 - c1 * s2 * d2]])
    wrel = R_d @ (T @ phid)
    R_t = R_d @ _R_xyz(phi)
    pos_t[:3] = pos[:3] + Rp
    _euler_xyz(R_t, pos_t[3:])
    vel_t[:3] = vel[:3] + _c3(w_d, Rp) + Rpd
    vel_t[3:] = w_d + wrel
    acc_t[:3] = acc[:3] + _c3(wd_dot, Rp) + _c3(w_d, _c3(w_d, Rp)) + 2.0 * _c3(w_d, Rpd) + R_d @ pdd
    acc_t[3:] = wd_dot + _c3(w_d, wrel) + R_d @ (Tdot @ phid + T @ phidd)


@njit(cache=True)
def impedance_loop(kind, axis, Rp, pp, mass, com, Ic, armature, friction, coupling, gravity, fj, Rf, pf,
                   env_kind, env_p, refs, Md_inv, K_D, K_P, posture, k_n, d_n, has_posture, thr, lmax,
                   q0, qd0, Ts, nsub, max_qd, Q, QD, H, U, adm, Mt_inv, K_Dt, K_Pt, Ad, Gd,
                   xa, bias, noise, alpha, X, XD, HM):  # pragma: no cover - compiled
    """The sampled loop; fills Q, Q̇, H (true wrench), U, X (``[o_e; φ_e]``), Ẋ (twist), H_m row by row.

    The law reads the measured wrench ``h_m`` (bias + noise, first-order low-pass α, as the
    simple :class:`~forcecontrol.sensors.ForceSensor` of ``simulate``); the plant the true one.
    Returns (status, last_row, λ² of the last law call); ``xa`` (12,) is the compliant frame's
    state (admittance), advanced in place.

    ``adm`` false: impedance (9.35) with M_d⁻¹, K_D, K_P. ``adm`` true: admittance (9.37), the
    compliant frame's state ``[z̃; z̃̇]`` from 0, advanced each sample by ``Ad x + Gd h_e^d`` (the
    controller's exact discretisation), tracked by the motion loop (M_d⁻¹ = I, K_D, K_P the motion
    gains, no h_e^d term); ``Mt_inv, K_Dt, K_Pt`` give z̃̈.

    Status: 0 ok, 1 non-finite state (or B not positive definite), 2 runaway joint speed,
    3 non-finite torque (the Python engine's SingularityError: an Euler representation singularity
    or a singular Jacobian).
    """
    n = kind.shape[0]
    N = Q.shape[0] - 1
    ws = np.empty((n + 1, 64))
    R_e = np.empty((3, 3))
    o_e = np.empty(3)
    J = np.empty((6, n))
    Jdq = np.empty(6)
    B = np.empty((n, n))
    nv = np.empty(n)
    L = np.empty((n, n))
    r = np.empty(n)
    h = np.empty(6)
    v = np.empty(3)
    q = q0.copy()
    qd = qd0.copy()
    qs = np.empty(n)
    vs = np.empty(n)
    a = np.empty((4, n))
    vk = np.empty((4, n))
    dt = Ts / nsub
    h_d = np.empty(6)
    hm = np.zeros(6)
    lam2 = 0.0
    pos_t, vel_t, acc_t = np.empty(6), np.empty(6), np.empty(6)
    # the flags of tree_terms and the law as plain booleans: a constant argument would compile each callee once more,
    # for its literal value (Numba types True as Literal[bool](True)), besides the version Python calls
    yes, no = bool(True), bool(False)  # noqa: UP018 - not literals, on purpose
    for k in range(N + 1):
        tree_terms(kind, axis, Rp, pp, mass, com, Ic, armature, friction, coupling, gravity, fj, Rf, pf,
                   q, qd, yes, yes, R_e, o_e, J, Jdq, B, nv, ws)
        for i in range(3):
            s = 0.0
            for j in range(n):
                s += J[i, j] * qd[j]
            v[i] = s
        _wrench(env_kind, env_p, o_e, v, h)
        for i in range(6):
            raw = h[i] + bias[i] + noise[k, i]
            hm[i] = raw if k == 0 else hm[i] + alpha * (raw - hm[i])
        row = refs[k]
        if adm:
            RdT = _R_xyz(row[3:6]).T.copy()
            h_d[:3] = RdT @ hm[:3]
            h_d[3:] = RdT @ hm[3:]
            zdd = Mt_inv @ (h_d - K_Dt @ xa[6:] - K_Pt @ xa[:6])
            compliant_frame_arrays(row[0:6], row[6:12], row[12:18], xa[:6], xa[6:], zdd, pos_t, vel_t, acc_t)
            u, lam2, _c2 = spatial_impedance_torque(R_e, o_e, J, Jdq, B, nv, q, qd, hm, pos_t, vel_t, acc_t,
                                                    Md_inv, K_D, K_P, no, posture, k_n, d_n, has_posture, thr, lmax)
            xa[:] = Ad @ xa + Gd @ h_d
        else:
            u, lam2, _c2 = spatial_impedance_torque(R_e, o_e, J, Jdq, B, nv, q, qd, hm, row[0:6], row[6:12], row[12:18],
                                                    Md_inv, K_D, K_P, yes, posture, k_n, d_n, has_posture, thr, lmax)
        for i in range(n):
            Q[k, i] = q[i]
            QD[k, i] = qd[i]
            U[k, i] = u[i]
        for i in range(3):
            X[k, i] = o_e[i]
        _euler_xyz(R_e, X[k, 3:])
        for i in range(6):
            s = 0.0
            for j in range(n):
                s += J[i, j] * qd[j]
            XD[k, i] = s
            H[k, i] = h[i]
            HM[k, i] = hm[i]
        for i in range(n):
            if not math.isfinite(u[i]):
                return 3, k, lam2
        if k == N:
            break
        for _ in range(nsub):
            for st in range(4):
                # the stage's state: (q, q̇) + c dt (q̇_prev-stage velocity, q̈_prev)
                if st == 0:
                    for i in range(n):
                        qs[i] = q[i]
                        vs[i] = qd[i]
                else:
                    c = 0.5 * dt if st < 3 else dt
                    for i in range(n):
                        qs[i] = q[i] + c * vk[st - 1, i]
                        vs[i] = qd[i] + c * a[st - 1, i]
                for i in range(n):
                    vk[st, i] = vs[i]
                tree_terms(kind, axis, Rp, pp, mass, com, Ic, armature, friction, coupling, gravity, fj, Rf, pf,
                           qs, vs, yes, no, R_e, o_e, J, Jdq, B, nv, ws)
                for i in range(3):
                    s = 0.0
                    for j in range(n):
                        s += J[i, j] * vs[j]
                    v[i] = s
                _wrench(env_kind, env_p, o_e, v, h)
                for i in range(n):
                    s = u[i] - nv[i]
                    for j in range(6):
                        s -= J[j, i] * h[j]
                    r[i] = s
                if not chol_solve(B, r, L, a[st]):
                    return 1, k, lam2
            for i in range(n):
                q[i] += dt / 6.0 * (vk[0, i] + 2.0 * vk[1, i] + 2.0 * vk[2, i] + vk[3, i])
                qd[i] += dt / 6.0 * (a[0, i] + 2.0 * a[1, i] + 2.0 * a[2, i] + a[3, i])
        for i in range(n):
            if not (math.isfinite(q[i]) and math.isfinite(qd[i])):
                return 1, k, lam2
            if abs(qd[i]) > max_qd:
                return 2, k, lam2
    return 0, N, lam2


def env_params(environment: Any) -> tuple[int, np.ndarray]:
    """(kind, parameters) of a Table ([point, normal, k, c]) or a ConstantWrench ([h_e]).

    Raises:
        ParameterError: another environment (the loop supports these two).
    """
    name = type(environment).__name__
    if name == "Table":
        p = np.concatenate([environment.point, environment.normal, [environment.stiffness, environment.damping]])
        return TABLE, kernel_array(p)
    if name == "ConstantWrench":
        return CONSTANT, kernel_array(environment.value)
    raise ParameterError(f"the compiled 6-D loop supports a Table or a ConstantWrench environment; got {name}")


_LAWS = ("SpatialImpedanceController", "AdmittanceController")
_ENVS = ("Table", "ConstantWrench")


def tree_loop_support(robot: Any, environment: Any, controller: Any, sensor: Any = None) -> str | None:
    """None when :func:`run_tree_loop` runs this combination, else why not (one sentence).

    Runs: a serial revolute/prismatic arm (:func:`~forcecontrol.robots.compiled_tree.tree_support`)
    with ``task="pose"``, a Table or ConstantWrench, a SpatialImpedanceController (frame
    ``"desired"``) or an AdmittanceController with XYZ Euler angles (exactly these classes, not
    subclasses such as the variable-gain ones), and the simple ForceSensor.
    """
    name = type(controller).__name__
    if name not in _LAWS or not getattr(controller, "compiled", False):
        return f"the controller is a {name} (compiled 6-D loop: {' or '.join(_LAWS)} with orientation='euler')"
    if type(environment).__name__ not in _ENVS:
        return f"the environment is a {type(environment).__name__} (compiled 6-D loop: {' or '.join(_ENVS)})"
    if getattr(robot, "task", None) != "pose":
        return "the robot's task is not 'pose'"
    if sensor is not None and not getattr(sensor, "compiled_ok", False):
        return f"the sensor is a {type(sensor).__name__} (compiled 6-D loop: the simple ForceSensor)"
    from ..robots.compiled_tree import tree_support

    return tree_support(robot)


def run_tree_loop(robot: Any, environment: Any, controller: Any, refs: np.ndarray, bias: np.ndarray, noise: np.ndarray,
                  alpha: float, q0: np.ndarray, qd0: np.ndarray, Ts: float, nsub: int, max_qd: float,
                  logs: dict[str, np.ndarray], state: np.ndarray | None = None) -> tuple[int, int]:
    """Run :func:`impedance_loop` into ``simulate``'s logs (q, qd, x, xd, wrench, wrench_measured, torque).

    The controller's compliant-frame state (admittance) starts from ``state`` (default: the
    controller's own, as after ``reset``) and is left where the run ended, like the Python engine's;
    ``controller.last_damping`` is the last sample's λ². Returns (status, last_row).

    Raises:
        ParameterError: :func:`tree_loop_support` names a part the loop does not run.
    """
    why = tree_loop_support(robot, environment, controller)
    if why is not None:
        raise ParameterError(f"the compiled 6-D loop cannot run this case: {why}")
    adm = type(controller).__name__ == "AdmittanceController"
    tree = compile_tree(robot)
    env_kind, env_p = env_params(environment)
    post, k_n, d_n, has = controller._post
    s = controller.singularity
    if adm:
        gains = (np.eye(6), controller.motion_damping, controller.motion_stiffness)
        extra = (controller._Mt_inv, controller.damping, controller.stiffness, controller._Ad, controller._Gd)
        xa = np.array(controller.state if state is None else state, dtype=np.float64)
    else:
        gains = (controller._Md_inv, controller.damping, controller.stiffness)
        z6 = np.zeros((6, 6))
        extra = (z6, z6, z6, np.zeros((12, 12)), np.zeros((12, 6)))
        xa = np.zeros(12)
    # one argument type each (a read-only wrench, or a writable gain, would compile the loop again): the law's gains
    # read-only, as the controllers keep them and pass them to the law from Python; the other arrays writable
    gains = tuple(kernel_array(g, frozen=True) for g in gains)
    f = kernel_array
    status, last, lam2 = impedance_loop(
        *tree.arrays(), env_kind, f(env_p), f(refs), *gains, f(post), float(k_n), float(d_n), bool(has),
        float(s.threshold), float(s.max_damping), f(q0), f(qd0), float(Ts), int(nsub), float(max_qd),
        logs["q"], logs["qd"], logs["wrench"], logs["torque"], adm, *(f(e) for e in extra),
        xa, f(bias), f(noise), float(alpha), logs["x"], logs["xd"], logs["wrench_measured"],
    )
    if adm:
        controller.state[:] = xa
    controller.last_damping = float(lam2)
    return int(status), int(last)


def run_impedance_loop(robot: Any, environment: Any, controller: Any, reference: Any, q0: Any, duration: float,
                       substeps: int, max_qd: float = 100.0) -> dict[str, Any]:
    """:func:`run_tree_loop` from rest at q0 with an ideal sensor and the compliant frame at rest (the benchmark's entry).

    Returns a dict with ``status``, ``last_row``, ``t`` and the logs ``q``, ``qd``, ``x``, ``xd``,
    ``wrench``, ``wrench_measured``, ``torque`` (the rows of ``simulate``'s result).

    Raises:
        ParameterError: a part the compiled loop does not run (:func:`tree_loop_support`), or a reference that is not 6-D.
    """
    Ts = float(controller.sample_time)
    N = int(round(duration / Ts))
    t = np.arange(N + 1) * Ts
    refs = np.ascontiguousarray(reference.sample(t), dtype=np.float64)
    if refs.shape[1] != 6 * len(REFERENCE_FIELDS):
        m = refs.shape[1] // len(REFERENCE_FIELDS)
        raise ParameterError(f"the compiled 6-D loop needs a 6-D reference; got a {m}-D one")
    n = int(robot.nq)
    logs = {k: np.full((N + 1, n if k in ("q", "qd", "torque") else 6), np.nan)
            for k in ("q", "qd", "x", "xd", "wrench", "wrench_measured", "torque")}
    status, last = run_tree_loop(robot, environment, controller, refs, np.zeros(6), np.zeros((N + 1, 6)), 1.0,
                                 np.array(q0, dtype=np.float64), np.zeros(n), Ts, int(substeps), float(max_qd), logs,
                                 state=np.zeros(12))
    return {"status": status, "last_row": last, "t": t, **logs}
