"""The compiled closed loop for the chapter's arm (same semantics as the Python loop).

Per control sample k: the true wrench h_e(x(t_k)), the sensor model, the controller (through
the compiled dispatcher, i.e. the same law functions as the Python ``step``), logging, then the
plant integrated over Ts with the torque held (zero-order hold) by ``nsub`` RK4 steps.

Status codes returned: 0 ok, 1 non-finite state, 2 runaway joint speed, 3 singular Jacobian in
the control law, 4 non-finite torque.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._linalg import solve_into
from .controllers.dispatch import controller_step
from .environments.elastic import environment_wrench
from .robots.planar_2r import _terms_into

OK, NONFINITE_STATE, RUNAWAY, SINGULAR, NONFINITE_TORQUE = 0, 1, 2, 3, 4


@njit(cache=True)
def _accel(q, qd, u, K, env_kind, env_p, x, xd, J, Jdq, B, nv, g, out):  # pragma: no cover
    """q̈ = B⁻¹ (u − n − Jᵀ h_e) for the arm in contact with the environment, (9.1)."""
    _terms_into(q, qd, K, x, xd, J, Jdq, B, nv, g)
    h = environment_wrench(env_kind, env_p, x, xd)
    n = q.shape[0]
    rhs = np.empty(n)
    for i in range(n):
        s = u[i] - nv[i]
        for j in range(x.shape[0]):
            s -= J[j, i] * h[j]
        rhs[i] = s
    return solve_into(B, rhs, out)


@njit(cache=True)
def run_planar_loop(
    K, env_kind, env_p, ctrl_kind, ctrl_p, ctrl_s, refs, bias, noise, alpha,
    q0, qd0, Ts, nsub, max_qd, Q, QD, X, XD, H, HM, U,
):  # pragma: no cover - compiled
    """Run the sampled loop; fill the logs row by row. Returns (status, last_row)."""
    n = q0.shape[0]
    m = 2
    N = Q.shape[0] - 1
    q = q0.copy()
    qd = qd0.copy()
    x = np.empty(m)
    xd = np.empty(m)
    J = np.empty((m, n))
    Jdq = np.empty(m)
    B = np.empty((n, n))
    nv = np.empty(n)
    g = np.empty(n)
    hm = np.zeros(m)
    a1 = np.empty(n)
    a2 = np.empty(n)
    a3 = np.empty(n)
    a4 = np.empty(n)
    dt = Ts / nsub
    for k in range(N + 1):
        t = k * Ts
        _terms_into(q, qd, K, x, xd, J, Jdq, B, nv, g)
        h = environment_wrench(env_kind, env_p, x, xd)
        for i in range(m):
            raw = h[i] + bias[i] + noise[k, i]
            if k == 0:
                hm[i] = raw
            else:
                hm[i] = hm[i] + alpha * (raw - hm[i])
        u = controller_step(ctrl_kind, t, Ts, q, qd, x, xd, J, Jdq, B, nv, g, hm, refs[k], ctrl_p, ctrl_s)
        for i in range(n):
            Q[k, i] = q[i]
            QD[k, i] = qd[i]
            U[k, i] = u[i]
        for i in range(m):
            X[k, i] = x[i]
            XD[k, i] = xd[i]
            H[k, i] = h[i]
            HM[k, i] = hm[i]
        fin = True
        for i in range(n):
            if not math.isfinite(u[i]):
                fin = False
        if not fin:
            det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
            if abs(det) < 1e-9:
                return SINGULAR, k
            return NONFINITE_TORQUE, k
        if k == N:
            break
        for _ in range(nsub):
            ok = _accel(q, qd, u, K, env_kind, env_p, x, xd, J, Jdq, B, nv, g, a1)
            q2 = q + 0.5 * dt * qd
            v2 = qd + 0.5 * dt * a1
            ok = ok and _accel(q2, v2, u, K, env_kind, env_p, x, xd, J, Jdq, B, nv, g, a2)
            q3 = q + 0.5 * dt * v2
            v3 = qd + 0.5 * dt * a2
            ok = ok and _accel(q3, v3, u, K, env_kind, env_p, x, xd, J, Jdq, B, nv, g, a3)
            q4 = q + dt * v3
            v4 = qd + dt * a3
            ok = ok and _accel(q4, v4, u, K, env_kind, env_p, x, xd, J, Jdq, B, nv, g, a4)
            if not ok:
                return NONFINITE_STATE, k
            for i in range(n):
                q[i] += dt / 6.0 * (qd[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i])
                qd[i] += dt / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i])
        for i in range(n):
            if not (math.isfinite(q[i]) and math.isfinite(qd[i])):
                return NONFINITE_STATE, k
            if abs(qd[i]) > max_qd:
                return RUNAWAY, k
    return OK, N


@njit(cache=True)
def planar_controller_step(kind, K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s):  # pragma: no cover
    """One controller step for the chapter's arm in a single compiled call.

    Computes the arm's terms and calls the same dispatcher (hence the same law functions) as the
    compiled loop; used by ``Controller.step`` when the robot is the built-in arm.
    """
    n = q.shape[0]
    m = 2
    x = np.empty(m)
    xd = np.empty(m)
    J = np.empty((m, n))
    Jdq = np.empty(m)
    B = np.empty((n, n))
    nv = np.empty(n)
    g = np.empty(n)
    _terms_into(q, qd, K, x, xd, J, Jdq, B, nv, g)
    ref = np.empty(6 * m)
    ref[0:m] = x_d
    ref[m : 2 * m] = v_d
    ref[2 * m : 3 * m] = a_d
    ref[3 * m : 4 * m] = f_d
    ref[4 * m : 5 * m] = fd_d
    ref[5 * m : 6 * m] = fdd_d
    return controller_step(kind, t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
