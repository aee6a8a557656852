"""The compiled closed loop for the chapter's arm (same semantics as the Python loop).

Per control sample k: the true wrench h_e(x(t_k)), the sensor model, the controller, logging,
then the plant integrated over Ts with the torque held (zero-order hold) by ``nsub`` RK4 steps.
Everything runs on scalars with the allocation-free helpers of :mod:`forcecontrol._batch`
(about 0.3 µs per step instead of 3): the built-in controllers (kinds 1-6) through their scalar
transcriptions, which repeat the law functions' order of operations, the others (hybrid, kinds
7+) through the compiled dispatcher, i.e. the law functions of the Python ``step``. The Python
loop of :mod:`forcecontrol.simulation` is the reference (tests: agreement to round-off).

Status codes returned: 0 ok, 1 non-finite state, 2 runaway joint speed, 3 singular Jacobian in
the control law, 4 non-finite torque.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._batch import _accel2, _accel_terms2, _control2, _terms2, _wrench2
from .controllers.dispatch import controller_step
from .robots.planar_2r import _terms_into

OK, NONFINITE_STATE, RUNAWAY, SINGULAR, NONFINITE_TORQUE = 0, 1, 2, 3, 4


@njit(cache=True)
def run_planar_loop(
    K, env_kind, env_p, ctrl_kind, ctrl_p, ctrl_s, refs, bias, noise, alpha,
    q0, qd0, Ts, nsub, max_qd, Q, QD, X, XD, H, HM, U,
):  # pragma: no cover - compiled
    """Run the sampled loop; fill the logs row by row. Returns (status, last_row).

    The arm's terms, the environment, the sensor and the RK4 plant (q̈ from (9.1), 2x2 solve
    with the pivoting of ``solve_into``) run on scalars and allocate nothing. Controller kinds
    1-6 run their scalar transcriptions in :func:`forcecontrol._batch._control2` (same order of
    operations as the law functions; checked against the Python loop); other kinds go through
    the dispatcher, i.e. the law functions themselves.
    """
    n = q0.shape[0]
    m = 2
    N = Q.shape[0] - 1
    x = np.empty(m)
    xd = np.empty(m)
    J = np.empty((m, n))
    Jdq = np.empty(m)
    B = np.empty((n, n))
    nv = np.empty(n)
    g = np.empty(n)
    q = np.empty(n)
    qd = np.empty(n)
    hm = np.zeros(m)
    T = np.empty(17)
    q_0, q_1, w_0, w_1 = q0[0], q0[1], qd0[0], qd0[1]
    hm0 = 0.0
    hm1 = 0.0
    dt = Ts / nsub
    hdt = 0.5 * dt
    sdt = dt / 6.0
    scalar_law = ctrl_kind >= 1 and ctrl_kind <= 6
    for k in range(N + 1):
        t = k * Ts
        _terms2(K, q_0, q_1, w_0, w_1, T)
        h0, h1 = _wrench2(env_kind, env_p, T[0], T[1], T[2], T[3])
        raw0 = h0 + bias[0] + noise[k, 0]
        raw1 = h1 + bias[1] + noise[k, 1]
        if k == 0:
            hm0 = raw0
            hm1 = raw1
        else:
            hm0 = hm0 + alpha * (raw0 - hm0)
            hm1 = hm1 + alpha * (raw1 - hm1)
        if scalar_law:
            u0, u1 = _control2(ctrl_kind, Ts, q_0, q_1, w_0, w_1, T, hm0, hm1, refs[k], ctrl_p, ctrl_s)
        else:
            q[0], q[1], qd[0], qd[1] = q_0, q_1, w_0, w_1
            x[0], x[1], xd[0], xd[1] = T[0], T[1], T[2], T[3]
            J[0, 0], J[0, 1], J[1, 0], J[1, 1] = T[4], T[5], T[6], T[7]
            Jdq[0], Jdq[1] = T[8], T[9]
            B[0, 0], B[0, 1], B[1, 0], B[1, 1] = T[10], T[11], T[11], T[12]
            nv[0], nv[1], g[0], g[1] = T[13], T[14], T[15], T[16]
            hm[0], hm[1] = hm0, hm1
            u = controller_step(ctrl_kind, t, Ts, q, qd, x, xd, J, Jdq, B, nv, g, hm, refs[k], ctrl_p, ctrl_s)
            u0 = u[0]
            u1 = u[1]
        Q[k, 0], Q[k, 1], QD[k, 0], QD[k, 1] = q_0, q_1, w_0, w_1
        U[k, 0], U[k, 1] = u0, u1
        X[k, 0], X[k, 1], XD[k, 0], XD[k, 1] = T[0], T[1], T[2], T[3]
        H[k, 0], H[k, 1], HM[k, 0], HM[k, 1] = h0, h1, hm0, hm1
        if not (math.isfinite(u0) and math.isfinite(u1)):
            det = T[4] * T[7] - T[5] * T[6]
            if abs(det) < 1e-9:
                return SINGULAR, k
            return NONFINITE_TORQUE, k
        if k == N:
            break
        for j in range(nsub):
            if j == 0:  # the state of the sample: its terms and wrench are already in T, h
                ok1, a10, a11 = _accel_terms2(T, h0, h1, u0, u1)
            else:
                ok1, a10, a11 = _accel2(K, env_kind, env_p, q_0, q_1, w_0, w_1, u0, u1, T)  # T reused as scratch
            v20 = w_0 + hdt * a10
            v21 = w_1 + hdt * a11
            ok2, a20, a21 = _accel2(K, env_kind, env_p, q_0 + hdt * w_0, q_1 + hdt * w_1, v20, v21, u0, u1, T)
            v30 = w_0 + hdt * a20
            v31 = w_1 + hdt * a21
            ok3, a30, a31 = _accel2(K, env_kind, env_p, q_0 + hdt * v20, q_1 + hdt * v21, v30, v31, u0, u1, T)
            v40 = w_0 + dt * a30
            v41 = w_1 + dt * a31
            ok4, a40, a41 = _accel2(K, env_kind, env_p, q_0 + dt * v30, q_1 + dt * v31, v40, v41, u0, u1, T)
            if not (ok1 and ok2 and ok3 and ok4):
                return NONFINITE_STATE, k
            q_0 += sdt * (w_0 + 2.0 * v20 + 2.0 * v30 + v40)
            q_1 += sdt * (w_1 + 2.0 * v21 + 2.0 * v31 + v41)
            w_0 += sdt * (a10 + 2.0 * a20 + 2.0 * a30 + a40)
            w_1 += sdt * (a11 + 2.0 * a21 + 2.0 * a31 + a41)
        if not (math.isfinite(q_0) and math.isfinite(q_1) and math.isfinite(w_0) and math.isfinite(w_1)):
            return NONFINITE_STATE, k
        if abs(w_0) > max_qd or abs(w_1) > max_qd:
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
    for i in range(6 * m):  # a non-finite reference, used by the law or not, is refused before any state moves
        if not math.isfinite(ref[i]):
            u = np.empty(n)
            u[:] = np.nan
            return u
    return controller_step(kind, t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
