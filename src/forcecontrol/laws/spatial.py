"""6-D impedance on the desired frame, (9.30) with (9.35), XYZ Euler angles: one compiled law.

Error (9.9): ``x̃ = −[R_dᵀ (o_e − o_d); φ_{d,e}]`` with φ_{d,e} the XYZ Euler angles of
``R_dᵀ R_e``; ``x̃̇ = −J_Ad q̇ + b`` (9.33) with ``J_Ad = T_A⁻¹ blockdiag(R_dᵀ, R_dᵀ) J`` (9.14); the
requested ``J_Ad q̈ = c + M_d⁻¹ (K_D x̃̇ + K_P x̃ − h_e^d)``, c the part of x̃̈ independent of q̈.
The closed loop is (9.36) ``M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_e^d``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .impedance import impedance_core

__all__ = ["desired_frame_terms", "spatial_impedance_torque"]


@njit(cache=True)
def _c3(a, b):  # pragma: no cover - compiled
    out = np.empty(3)
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


@njit(cache=True)
def _R_xyz(phi):  # pragma: no cover - compiled
    c1, s1 = math.cos(phi[0]), math.sin(phi[0])
    c2, s2 = math.cos(phi[1]), math.sin(phi[1])
    c3, s3 = math.cos(phi[2]), math.sin(phi[2])
    R = np.empty((3, 3))
    R[0, 0], R[0, 1], R[0, 2] = c2 * c3, -c2 * s3, s2
    R[1, 0], R[1, 1], R[1, 2] = c1 * s3 + s1 * s2 * c3, c1 * c3 - s1 * s2 * s3, -s1 * c2
    R[2, 0], R[2, 1], R[2, 2] = s1 * s3 - c1 * s2 * c3, s1 * c3 + c1 * s2 * s3, c1 * c2
    return R


@njit(cache=True)
def desired_frame_terms(RdT, Tinv, Tdot, phi, phid, e, e_dot, w_d, wd_dot, od_ddot, w_rel, J, Jdq):  # pragma: no cover - compiled
    """x̃ (9.9), x̃̇ (9.33), J_Ad (9.14) and ``c = −J̇_Ad q̇ + ḃ`` on the desired frame, (6,), (6,), (6, n), (6,).

    From the representation's φ, T⁻¹(φ), Ṫ and φ̇ = T⁻¹ R_dᵀ (ω_e − ω_d), the position error
    ``e = o_e − o_d`` and its rate, ω_d, ω̇_d, ö_d, ``ω_e − ω_d``, J and J̇q̇. c is the part of
    x̃̈ (9.34) independent of q̈:

    * position (``x̃_P = −R_dᵀ e`` differentiated twice with ``Ṙ_d = S(ω_d) R_d``):
      ``c_P = −R_dᵀ [ (S(ω_d)² − S(ω̇_d)) e − 2 S(ω_d) ė + J̇_P q̇ − ö_d ]``;
    * orientation (``x̃_O = −φ``):
      ``c_O = −T⁻¹ ( −Ṫ φ̇ + R_dᵀ [ −S(ω_d)(ω_e − ω_d) + J̇_O q̇ − ω̇_d ] )``.

    Used by the compiled law below and, for every orientation representation, by
    :func:`forcecontrol.controllers.spatial.desired_frame_error`.
    """
    x = np.empty(6)
    x[:3] = -(RdT @ e)
    x[3:] = -phi
    xd = np.empty(6)
    wxe = _c3(w_d, e)
    xd[:3] = RdT @ (wxe - e_dot)
    xd[3:] = -phid
    JAd = np.empty((6, J.shape[1]))
    JAd[:3] = RdT @ J[:3]
    JAd[3:] = Tinv @ (RdT @ J[3:])
    c = np.empty(6)
    c[:3] = -(RdT @ (_c3(w_d, wxe) - _c3(wd_dot, e) - 2.0 * _c3(w_d, e_dot) + Jdq[:3] - od_ddot))
    c[3:] = -(Tinv @ (RdT @ (Jdq[3:] - _c3(w_d, w_rel) - wd_dot) - Tdot @ phid))
    return x, xd, JAd, c


@njit(cache=True)
def spatial_impedance_torque(
    R_e, o_e, J, Jdq, B, nv, q, qd, h, pos, vel, acc, Md_inv, K_D, K_P, use_force, posture, k_n, d_n, has_posture, thr, lmax
):  # pragma: no cover - compiled
    """(9.30) with (9.35): 6-D impedance on the desired frame, XYZ Euler error, in one compiled call.

    The error (9.9) on the desired frame and its rates (9.33)–(9.34) (:func:`desired_frame_terms`), the
    impedance equation :func:`forcecontrol.laws.impedance_core` (the planar law's), the redundant
    or damped solve of :func:`~forcecontrol.controllers.redundant.redundant_acceleration`, then
    ``u = B y + n + Jᵀ h``. With ``use_force`` false the h_e^d term is left out of the requested
    acceleration (the admittance motion loop, M_d⁻¹ = I) but ``Jᵀ h`` is still added.

    Returns:
        (u (n,), λ², cos φ₂); u is NaN when cos φ₂ < 1e-3 (representation singularity).
    """
    n = J.shape[1]
    R_d = _R_xyz(pos[3:])
    RdT = R_d.T.copy()
    od_dot = vel[:3].copy()
    w_d = vel[3:].copy()
    od_ddot = acc[:3].copy()
    wd_dot = acc[3:].copy()
    v = J @ qd
    e = o_e - pos[:3]
    e_dot = v[:3] - od_dot
    w_rel = v[3:] - w_d
    R_de = RdT @ R_e
    c2 = math.hypot(R_de[0, 0], R_de[0, 1])
    u = np.empty(n)
    if c2 < 1e-3:
        u[:] = np.nan
        return u, 0.0, c2
    s2 = min(1.0, max(-1.0, R_de[0, 2]))
    phi = np.empty(3)
    phi[0] = math.atan2(-R_de[1, 2], R_de[2, 2])
    phi[1] = math.atan2(s2, c2)
    phi[2] = math.atan2(-R_de[0, 1], R_de[0, 0])
    cc1, ss1 = math.cos(phi[0]), math.sin(phi[0])
    cc2, ss2 = math.cos(phi[1]), math.sin(phi[1])
    Tinv = np.array([[1.0, ss1 * ss2 / cc2, -cc1 * ss2 / cc2], [0.0, cc1, ss1], [0.0, -ss1 / cc2, cc1 / cc2]])
    w_rel_d = RdT @ w_rel
    phid = Tinv @ w_rel_d
    d1, d2 = phid[0], phid[1]
    Tdot = np.array(
        [
            [0.0, 0.0, cc2 * d2],
            [0.0, -ss1 * d1, -cc1 * cc2 * d1 + ss1 * ss2 * d2],
            [0.0, cc1 * d1, -ss1 * cc2 * d1 - cc1 * ss2 * d2],
        ]
    )
    x, xd, JAd, c = desired_frame_terms(RdT, Tinv, Tdot, phi, phid, e, e_dot, w_d, wd_dot, od_ddot, w_rel, J, Jdq)
    h_d = np.empty(6)
    h_d[:3] = RdT @ h[:3]
    h_d[3:] = RdT @ h[3:]
    r = np.empty(6)
    G = np.concatenate((Md_inv.ravel(), K_D.ravel(), K_P.ravel()))  # the blocks M_d_inv, K_D, K_P of layout.IMPEDANCE
    impedance_core(G, x, xd, c, h_d, use_force, np.empty(6), r)
    JJt = JAd @ JAd.T
    lam2 = 0.0
    if lmax > 0.0:
        s_min2 = np.linalg.eigvalsh(JJt)[0]
        if s_min2 < thr * thr:
            lam2 = lmax * lmax * (1.0 - max(s_min2, 0.0) / (thr * thr))
            for i in range(6):
                JJt[i, i] += lam2
    if has_posture:
        y0 = k_n * (posture - q) - d_n * qd
        y = y0 + JAd.T @ np.linalg.solve(JJt, r - JAd @ y0)
    else:
        y = JAd.T @ np.linalg.solve(JJt, r)
    u[:] = B @ y + nv + J.T @ h
    return u, lam2, c2
