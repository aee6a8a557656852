"""FZI ``cartesian_compliance_controller`` / ``cartesian_force_controller``: forward dynamics compliance control (FDCC).

Read from fzi-forschungszentrum-informatik/cartesian_controllers, branch ``ros2`` at f53f7980
(2024-10-20, BSD-3-Clause): ``cartesian_controller_base/src/ForwardDynamicsSolver.cpp``
(``getJointControlCmds``, ``buildGenericModel``), ``PDController.cpp``, ``SpatialPDController.cpp``,
``cartesian_compliance_controller/src/cartesian_compliance_controller.cpp`` (``computeComplianceError``)
and ``cartesian_force_controller/src/cartesian_force_controller.cpp`` (``computeForceError``); the 2021
solver from branch ``ros1`` before PR #30 (commits 81ba909 … 97a4ee3, Nov–Dec 2021). Written anew
in the library's notation (survey of issue 30, §2); no code copied. Paper: Scherzinger, Roennau,
Dillmann, "Forward Dynamics Compliance Control (FDCC)", IROS 2017.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .layout import FDCC_P, FDCC_STATE_QD, fdcc_D_g, fdcc_decay, fdcc_error_scale, fdcc_h, fdcc_instantaneous, fdcc_state_e_prev


@njit(cache=True)
def fdcc_error(e_motion, w_err, K, R, e):  # pragma: no cover - compiled
    """The compliance controller's error ``e = R K Rᵀ e_motion + w_err``, written into ``e`` (m,).

    ``K`` (m,) the ``stiffness`` (diagonal in ``compliance_ref_link``; zeros for the force
    controller, whose error is ``w_err`` alone), ``R`` (m, m) that frame's rotation in the base
    (block-diagonal for m = 6). ``e_motion = [p_target − p; angle·axis(R_target Rᵀ)]`` in the base
    frame with its position norm and its angle each clamped to 1 (m, rad) by the caller;
    ``w_err = w_target + w_sensor`` (the sensor wrench *on* the robot, the target pulling the
    robot along itself), so ``−h_e + f_d`` in the chapter's sense.
    """
    m = e.shape[0]
    tmp = np.empty(m)
    for i in range(m):
        acc = 0.0
        for j in range(m):
            acc += R[j, i] * e_motion[j]
        tmp[i] = K[i] * acc
    for i in range(m):
        acc = 0.0
        for j in range(m):
            acc += R[i, j] * tmp[j]
        e[i] = acc + w_err[i]


@njit(cache=True)
def fdcc_step(e, p, s, H, J, q, q_lo, q_hi):  # pragma: no cover - compiled
    """One internal step of the forward-dynamics solver: ``q`` (in place) and ``q̇`` (in ``s``) advanced by h.

    ``f = error_scale · (P e + D_g (e − e_prev)/h)`` (per-axis PD, the derivative on the
    internal period h, base-frame axes), ``q̈ = H_v⁻¹ Jᵀ f`` (the virtual model: zero gravity),
    then explicit Euler with the *old* velocity and the fixed 10 % velocity decay::

        q ← clamp(q + h q̇, q_lo, q_hi)          q̇ ← decay · (q̇ + h q̈)     (decay = 0.9)

    With ``instantaneous`` (the solver before PR #30, Nov 2021; what issue #21 ran on) each
    step starts from rest: ``q̇ = ½ h q̈``, ``q ← q + ½ h q̇`` (= ``q + ¼ h² q̈``).

    Args:
        e: (m,) the error (:func:`fdcc_error`).
        p: ``layout.FDCC``: ``[P (m), D_g (m), error_scale, h, decay, instantaneous (0/1)]``.
        s: state (``layout.FDCC_STATE``), advanced in place: ``[q̇ (n), e_prev (m)]``.
        H: (n, n) joint-space inertia of the virtual model; J: (m, n) base-frame Jacobian of the
            end-effector link, both at ``q``.
        q: (n,) the solver's joint positions, advanced in place.
        q_lo, q_hi: (n,) position limits (±inf for a continuous joint).

    Returns:
        False when H cannot be solved (nothing is changed then).
    """
    m = e.shape[0]
    n = q.shape[0]
    o_dg, o_ep = fdcc_D_g(m), fdcc_state_e_prev(m, n)
    P = p[FDCC_P : FDCC_P + m]
    Dg = p[o_dg : o_dg + m]
    scale = p[fdcc_error_scale(m)]
    h = p[fdcc_h(m)]
    decay = p[fdcc_decay(m)]
    inst = p[fdcc_instantaneous(m)] != 0.0
    qd = s[FDCC_STATE_QD : FDCC_STATE_QD + n]
    e_prev = s[o_ep : o_ep + m]
    f = np.empty(m)
    for i in range(m):
        f[i] = scale * (P[i] * e[i] + Dg[i] * (e[i] - e_prev[i]) / h)
    if not np.all(np.isfinite(H)) or abs(np.linalg.det(H)) < 1e-300:
        return False
    qdd = np.linalg.solve(H, J.T @ f)
    for i in range(n):
        if inst:
            qd[i] = 0.5 * h * qdd[i]
            q[i] = q[i] + 0.5 * h * qd[i]
        else:
            q[i] = q[i] + h * qd[i]
            qd[i] = decay * (qd[i] + h * qdd[i])
        if q[i] < q_lo[i]:
            q[i] = q_lo[i]
        elif q[i] > q_hi[i]:
            q[i] = q_hi[i]
    for i in range(m):
        e_prev[i] = e[i]
    return True
