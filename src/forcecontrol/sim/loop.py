"""The compiled closed loop for the chapter's arm, and one controller step on it.

Per control sample k: the true wrench h_e(x(t_k)), the sensor model (bias, noise, first-order
low-pass), the control law, logging, then the plant integrated over Ts with the torque held
(zero-order hold) by :func:`forcecontrol.sim.plant.rk4_sample`. The control law is the controller's
own compiled law (:mod:`forcecontrol.laws`), passed as a function argument: the loop is
specialised (and cached) per law, and runs exactly the function ``Controller.step`` runs.
The Python loop of :mod:`forcecontrol.sim.simulation` is the reference (tests: agreement to
round-off).

Status codes returned: 0 ok, 1 non-finite state, 2 runaway joint speed, 3 singular Jacobian in
the control law, 4 non-finite torque.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from ..core.numba_cache import build_once, kernel_identity, stable_identities
from ..laws.inner import law_parts, on_planar_arm
from .plant import NONFINITE_STATE, NONFINITE_TORQUE, OK, RUNAWAY, SINGULAR, fill_terms, rk4_sample, terms2, wrench2

__all__ = ["planar_loop", "OK", "NONFINITE_STATE", "RUNAWAY", "SINGULAR", "NONFINITE_TORQUE"]


def planar_loop(law: Any, full_log: bool = True) -> Any:
    """The compiled sampled loop for control ``law``, built once per law and cached on disk by Numba.

    ``planar_loop(law)(K, env_kind, env_p, ctrl_p, ctrl_s, refs, bias, noise, alpha, q0, q̇0, Ts,
    nsub, max_q̇, Q, Q̇, X, Ẋ, H, H_m, U) -> (status, last_row)``. The law is a constant of the
    loop (a closure), so Numba compiles the loop with the law inlined, specialised for it (an
    inverse-dynamics law as its two parts, :func:`~forcecontrol.laws.inner.law_parts`). With
    ``full_log=False`` (the sweeps' batch, which keeps the contact force only) every log but ``H``
    may have one row: row 0 is overwritten at each sample, the same arithmetic otherwise.
    The law is compiled for the arm's sizes (:func:`forcecontrol.laws.inner.on_planar_arm`: its
    general-size path, never taken here, is not compiled).
    """
    def build() -> Any:
        stable_identities()
        arm_law = on_planar_arm(law)
        loop = njit(cache=True)(_make_loop(arm_law, full_log, law_parts(arm_law)))
        tag = "" if full_log else ":h-only"
        # its own identity: found again on disk (see stable_identities), and its own cache files (per law and variant)
        kernel_identity(loop, f"forcecontrol:loop:{law._uuid}{tag}")
        return loop

    return build_once(_LOOPS, (law, full_log), build)  # once, even when a sweep's threads ask together


_LOOPS: dict[Any, Any] = {}


def _make_loop(law: Any, full_log: bool, parts: tuple[bool, Any, Any]) -> Any:  # pragma: no cover - compiled
    split, acceleration, inner = parts  # an inverse-dynamics law: its two parts called here (laws.inner.law_parts)

    def run(
        K, env_kind, env_p, ctrl_p, ctrl_s, refs, bias, noise, alpha,
        q0, qd0, Ts, nsub, max_qd, Q, QD, X, XD, H, HM, U,
    ):  # pragma: no cover - compiled
        """The sampled loop with the factory's ``law``; fills the logs row by row. Returns (status, last_row).

        The arm's terms, the environment, the sensor and the RK4 plant run on scalars and allocate
        nothing; the law reads them from arrays filled once per sample.
        """
        n = 2  # the chapter's arm (a constant: the compiler drops the laws' general-size paths)
        m = 2
        N = H.shape[0] - 1
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
        u = np.empty(n)
        ws = np.empty(2 * m * m + 12 * m + 2 * n + 8)
        T = np.empty(17)
        q_0, q_1, w_0, w_1 = q0[0], q0[1], qd0[0], qd0[1]
        hm0 = 0.0
        hm1 = 0.0
        for k in range(N + 1):
            t = k * Ts
            terms2(K, q_0, q_1, w_0, w_1, T)
            h0, h1 = wrench2(env_kind, env_p, T[0], T[1], T[2], T[3])
            raw0 = h0 + bias[0] + noise[k, 0]
            raw1 = h1 + bias[1] + noise[k, 1]
            if k == 0:
                hm0 = raw0
                hm1 = raw1
            else:
                hm0 = hm0 + alpha * (raw0 - hm0)
                hm1 = hm1 + alpha * (raw1 - hm1)
            fill_terms(T, q_0, q_1, w_0, w_1, q, qd, x, xd, J, Jdq, B, nv, g)
            hm[0], hm[1] = hm0, hm1
            if split:  # a constant: Numba compiles one branch
                comp = acceleration(t, Ts, x, xd, hm, refs[k], ctrl_p, ctrl_s, ws[2 * m :], ws[0:m], ws[m : 2 * m])
                inner(B, nv, J, Jdq, ws[0:m], ws[m : 2 * m], comp, ws[2 * m :], u)
            else:
                law(t, Ts, q, qd, x, xd, J, Jdq, B, nv, g, hm, refs[k], ctrl_p, ctrl_s, ws, u)
            u0 = u[0]
            u1 = u[1]
            r = k if full_log else 0
            Q[r, 0], Q[r, 1], QD[r, 0], QD[r, 1] = q_0, q_1, w_0, w_1
            U[r, 0], U[r, 1] = u0, u1
            X[r, 0], X[r, 1], XD[r, 0], XD[r, 1] = T[0], T[1], T[2], T[3]
            H[k, 0], H[k, 1], HM[r, 0], HM[r, 1] = h0, h1, hm0, hm1
            if not (math.isfinite(u0) and math.isfinite(u1)):
                det = T[4] * T[7] - T[5] * T[6]
                if abs(det) < 1e-9:
                    return SINGULAR, k
                return NONFINITE_TORQUE, k
            if k == N:
                break
            ok, q_0, q_1, w_0, w_1 = rk4_sample(K, env_kind, env_p, q_0, q_1, w_0, w_1, u0, u1, T, h0, h1, Ts, nsub)
            if not ok:
                return NONFINITE_STATE, k
            if not (math.isfinite(q_0) and math.isfinite(q_1) and math.isfinite(w_0) and math.isfinite(w_1)):
                return NONFINITE_STATE, k
            if abs(w_0) > max_qd or abs(w_1) > max_qd:
                return RUNAWAY, k
        return OK, N

    return run
