"""Hybrid force/motion control (Sect. 9.7): compliant (9.77)–(9.82) and rigid (9.91)–(9.95) environments.

Packed parameters (row-major blocks; d = task dimension, k = force-controlled, l = d − k):

* compliant: ``p = [d, k, position_mode, S_v (d l), S_v† (l d), S_f† (k d), C′ S_f (d k), L̂ (k d),
  K_1 (l²), K_2 (l²), K_Dλ (k²), K_Pλ (k²)]`` with ``L̂ = (S_fᵀ Ĉ S_f)⁻¹ S_fᵀ`` (λ̇ = L̂ v_e,
  (9.82)) and K_1, K_2 as for the rigid law; state ``s = ∫(ν_d − ν)`` (l).
* rigid: ``p = [d, k, position_mode, S_v (d l), S_v† (l d), S_f (d k), S_f† (k d), K_1 (l²),
  K_2 (l²), K_Pλ (k²), K_Iλ (k²), Ṡ_v (d l)]``; velocity motion: ``K_1 = K_Pν, K_2 = K_Iν``
  (9.80); position motion: ``K_1 = K_Dr, K_2 = K_Pr`` (9.95) with ``r = S_v† x``; state
  ``s = [∫(ν_d − ν) (l), ∫(λ_d − λ) (k)]``.
"""

from __future__ import annotations

from numba import njit

from ..core.linalg import mv_into
from .inner import inverse_dynamics_law


@njit(cache=True, inline="always")
def _block(p, o, rows, cols):  # pragma: no cover - compiled
    return p[o : o + rows * cols].reshape((rows, cols)), o + rows * cols


@njit(cache=True, inline="always")
def _blocks9(p, o, s0, s1, s2, s3, s4, s5, s6, s7, s8):  # pragma: no cover - compiled
    """Nine consecutive row-major blocks of p from offset o, of shapes s0..s8 (rows, cols)."""
    b0, o = _block(p, o, s0[0], s0[1])
    b1, o = _block(p, o, s1[0], s1[1])
    b2, o = _block(p, o, s2[0], s2[1])
    b3, o = _block(p, o, s3[0], s3[1])
    b4, o = _block(p, o, s4[0], s4[1])
    b5, o = _block(p, o, s5[0], s5[1])
    b6, o = _block(p, o, s6[0], s6[1])
    b7, o = _block(p, o, s7[0], s7[1])
    b8, o = _block(p, o, s8[0], s8[1])
    return b0, b1, b2, b3, b4, b5, b6, b7, b8


@njit(cache=True, inline="always")
def _velocity_servo(S_v_pinv, K, xd, ref, d, k, ws):  # pragma: no cover - compiled
    """(9.80)/(9.95), the part both hybrid laws share: ``ν = S_v† ẋ_e``, ``ν_d = S_v† ẋ_d``,
    ``α_ν = ν̇_d + K (ν_d − ν)``; returns views (ν, ν_d, α_ν, scratch) of ``ws`` and the force
    loop's three k-vectors (f_λ and two scratch vectors for λ's)."""
    l = S_v_pinv.shape[0]
    nu = ws[0:l]
    nu_d = ws[d : d + l]
    alpha = ws[2 * d : 2 * d + l]
    tmp = ws[3 * d : 4 * d]
    mv_into(S_v_pinv, xd, nu)
    mv_into(S_v_pinv, ref[d : 2 * d], nu_d)
    mv_into(S_v_pinv, ref[2 * d : 3 * d], alpha)  # ν̇_d (r̈_d)
    _mv_diff_add(K, nu_d, nu, alpha, tmp)
    return nu, nu_d, alpha, tmp, ws[4 * d : 4 * d + k], ws[5 * d : 5 * d + k], ws[6 * d : 6 * d + k]


@njit(cache=True, inline="always")
def _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, k, s, ws):  # pragma: no cover - compiled
    """α_ν of both hybrid laws: (9.80) ``ν̇_d + K_1 (ν_d − ν) + K_2 ∫(ν_d − ν)`` or, with
    ``position_mode``, (9.95) ``r̈_d + K_1 (ṙ_d − ν) + K_2 (r_d − r)``, ``r = S_v† x``; returns the
    views of :func:`_velocity_servo`."""
    l = d - k
    nu, nu_d, alpha, tmp, f_lam, lam_a, lam_b = _velocity_servo(S_v_pinv, K_1, xd, ref, d, k, ws)
    if position_mode:
        r_d = ws[7 * d : 7 * d + l]
        r = ws[8 * d : 8 * d + l]
        mv_into(S_v_pinv, ref[0:d], r_d)
        mv_into(S_v_pinv, x, r)
        _mv_diff_add(K_2, r_d, r, alpha, tmp)
    else:
        _mv_add(K_2, s[0:l], alpha)
    return nu, nu_d, alpha, tmp, f_lam, lam_a, lam_b


@njit(cache=True, inline="always")
def _mv_add(A, x, out):  # pragma: no cover - compiled
    """``out += A x``."""
    r, c = A.shape
    for i in range(r):
        acc = 0.0
        for j in range(c):
            acc += A[i, j] * x[j]
        out[i] += acc


@njit(cache=True, inline="always")
def _mv_diff_add(A, x, y, out, tmp):  # pragma: no cover - compiled
    """``out += A (x − y)`` (tmp: scratch of len(x))."""
    for j in range(x.shape[0]):
        tmp[j] = x[j] - y[j]
    _mv_add(A, tmp, out)


@njit(cache=True, inline="always")
def hybrid_compliant_acceleration(t, dt, x, xd, h, ref, p, s, ws, a, hc):  # pragma: no cover - compiled
    """(9.77) ``α = S_v α_ν + Ĉ′ S_f f_λ`` with (9.80) and (9.81); advances ``∫(ν_d − ν)``.

    ``α_ν = ν̇_d + K_Pν (ν_d − ν) + K_Iν ∫(ν_d − ν)`` (9.80), ``ν = S_v† ẋ_e`` (9.60) (or, with
    ``position_mode``, the pose servo (9.95) ``r̈_d + K_Dr (ṙ_d − ν) + K_Pr (r_d − r)``, as the 6-D
    hybrid on the desired frame uses it);
    ``f_λ = λ̈_d + K_Dλ (λ̇_d − λ̇) + K_Pλ (λ_d − λ)`` (9.81), ``λ = S_f† h_e`` (9.54),
    ``λ̇ = L̂ ẋ_e`` (9.82); ``Ĉ′ = (I − P_v) Ĉ`` (9.72) (C′, not C: with C the force and
    velocity loops would not decouple). Closed loop ``ν̇ = α_ν`` (9.78), ``λ̈ = f_λ`` (9.79).
    """
    d = int(p[0])
    k = int(p[1])
    l = d - k
    S_v, S_v_pinv, S_f_pinv, CpS_f, L_hat, K_1, K_2, K_Dlam, K_Plam = _blocks9(
        p, 3, (d, l), (l, d), (k, d), (d, k), (k, d), (l, l), (l, l), (k, k), (k, k)
    )
    nu, nu_d, alpha, tmp, f_lam, lam_a, lam_b = _motion_servo(S_v_pinv, K_1, K_2, p[2] != 0.0, x, xd, ref, d, k, s, ws)
    mv_into(S_f_pinv, ref[5 * d : 6 * d], f_lam)  # λ̈_d
    mv_into(S_f_pinv, ref[4 * d : 5 * d], lam_a)  # λ̇_d
    mv_into(L_hat, xd, lam_b)  # λ̇
    _mv_diff_add(K_Dlam, lam_a, lam_b, f_lam, tmp)
    mv_into(S_f_pinv, ref[3 * d : 4 * d], lam_a)  # λ_d
    mv_into(S_f_pinv, h, lam_b)  # λ
    _mv_diff_add(K_Plam, lam_a, lam_b, f_lam, tmp)
    mv_into(S_v, alpha, a)
    _mv_add(CpS_f, f_lam, a)
    for j in range(l):
        s[j] += dt * (nu_d[j] - nu[j])
    for j in range(d):
        hc[j] = h[j]
    return True


@njit(cache=True, inline="always")
def hybrid_rigid_acceleration(t, dt, x, xd, h, ref, p, s, ws, a, hc):  # pragma: no cover - compiled
    """(9.91): ``a = S_v α_ν + Ṡ_v ν`` and ``h_c = S_f f_λ``; advances the integrals.

    Motion: (9.80) ``α_ν = ν̇_d + K_Pν (ν_d − ν) + K_Iν ∫(ν_d − ν)`` or (9.95)
    ``α_ν = r̈_d + K_Dr (ṙ_d − ν) + K_Pr (r_d − r)``, ``r = S_v† x_e``. Force: (9.92)–(9.94)
    ``f_λ = λ_d + K_Pλ (λ_d − λ) + K_Iλ ∫(λ_d − λ)``, ``λ = S_f† h_e`` (9.54). With the inner
    loop (9.30), ``u = B J⁻¹ (a − J̇ q̇) + n + Jᵀ S_f f_λ``: the closed loop ``ν̇ = α_ν``,
    ``λ = f_λ``.
    """
    d = int(p[0])
    k = int(p[1])
    position_mode = p[2] != 0.0
    l = d - k
    S_v, S_v_pinv, S_f, S_f_pinv, K_1, K_2, K_Plam, K_Ilam, S_v_dot = _blocks9(
        p, 3, (d, l), (l, d), (d, k), (k, d), (l, l), (l, l), (k, k), (k, k), (d, l)
    )
    nu, nu_d, alpha, tmp, f_lam, lam_d, lam = _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, k, s, ws)
    mv_into(S_f_pinv, ref[3 * d : 4 * d], lam_d)
    mv_into(S_f_pinv, h, lam)
    for j in range(k):
        f_lam[j] = lam_d[j]
    _mv_diff_add(K_Plam, lam_d, lam, f_lam, tmp)
    _mv_add(K_Ilam, s[l : l + k], f_lam)
    mv_into(S_v, alpha, a)
    _mv_add(S_v_dot, nu, a)
    mv_into(S_f, f_lam, hc)
    for j in range(l):
        s[j] += dt * (nu_d[j] - nu[j])
    for j in range(k):
        s[l + j] += dt * (lam_d[j] - lam[j])
    return True


#: Hybrid control on a compliant environment: (9.77) through the inner loop (9.30) (+ Jᵀ h_e).
hybrid_compliant = inverse_dynamics_law(hybrid_compliant_acceleration, "hybrid_compliant")
#: Hybrid control on a rigid environment: (9.91) through the inner loop (9.30) (+ Jᵀ S_f f_λ).
hybrid_rigid = inverse_dynamics_law(hybrid_rigid_acceleration, "hybrid_rigid")
