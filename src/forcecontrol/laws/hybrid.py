"""Hybrid force/motion control (Sect. 9.7): compliant (9.77)–(9.82) and rigid (9.91)–(9.95) environments.

Packed parameters (row-major blocks; d = task dimension, k = force-controlled, l = d − k), declared
in :mod:`forcecontrol.laws.layout`:

* compliant: :data:`~forcecontrol.laws.layout.HYBRID_COMPLIANT`, the blocks ``task_dim`` (d),
  ``force_dim`` (k), ``position_mode``, ``S_v`` (d l), ``S_v_pinv`` = S_v† (l d), ``S_f_pinv`` = S_f† (k d),
  ``CpS_f`` = C′ S_f (d k), ``L_hat`` = L̂ (k d), ``K_1``, ``K_2`` (l²), ``K_Dlam`` = K_Dλ, ``K_Plam`` = K_Pλ (k²)
  with ``L̂ = (S_fᵀ Ĉ S_f)⁻¹ S_fᵀ`` (λ̇ = L̂ v_e, (9.82)) and K_1, K_2 as for the rigid law; state: the
  block ``nu_integral`` = ∫(ν_d − ν) (l) of :data:`~forcecontrol.laws.layout.HYBRID_STATE`.
* rigid: :data:`~forcecontrol.laws.layout.HYBRID_RIGID`, the same three scalars, then ``S_v`` (d l),
  ``S_v_pinv`` (l d), ``S_f`` (d k), ``S_f_pinv`` (k d), ``K_1``, ``K_2`` (l²), ``K_Plam`` = K_Pλ,
  ``K_Ilam`` = K_Iλ (k²), ``S_v_dot`` = Ṡ_v (d l); velocity motion: ``K_1 = K_Pν, K_2 = K_Iν``
  (9.80); position motion: ``K_1 = K_Dr, K_2 = K_Pr`` (9.95) with ``r = S_v† x``; state: both
  blocks of :data:`~forcecontrol.laws.layout.HYBRID_STATE`, ∫(ν_d − ν) (l) and ∫(λ_d − λ) (k).

The reference row is :data:`~forcecontrol.laws.layout.REFERENCE` with m = d.
"""

from __future__ import annotations

from numba import njit

from ..core.linalg import mv_into
from .inner import inverse_dynamics_law
from .layout import (
    HYBRID_COMPLIANT_FORCE_DIM,
    HYBRID_COMPLIANT_POSITION_MODE,
    HYBRID_COMPLIANT_S_V,
    HYBRID_COMPLIANT_TASK_DIM,
    HYBRID_RIGID_FORCE_DIM,
    HYBRID_RIGID_POSITION_MODE,
    HYBRID_RIGID_S_V,
    HYBRID_RIGID_TASK_DIM,
    HYBRID_STATE_NU_INTEGRAL,
    REF_X_D,
    hybrid_compliant_CpS_f,
    hybrid_compliant_K_1,
    hybrid_compliant_K_2,
    hybrid_compliant_K_Dlam,
    hybrid_compliant_K_Plam,
    hybrid_compliant_L_hat,
    hybrid_compliant_S_f_pinv,
    hybrid_compliant_S_v_pinv,
    hybrid_rigid_K_1,
    hybrid_rigid_K_2,
    hybrid_rigid_K_Ilam,
    hybrid_rigid_K_Plam,
    hybrid_rigid_S_f,
    hybrid_rigid_S_f_pinv,
    hybrid_rigid_S_v_dot,
    hybrid_rigid_S_v_pinv,
    hybrid_state_lam_integral,
    ref_a_d,
    ref_f_d,
    ref_fddot_d,
    ref_fdot_d,
    ref_v_d,
)


@njit(cache=True, inline="always")
def _block(p, o, rows, cols):  # pragma: no cover - compiled
    """The row-major (rows, cols) block of p at offset o (a view)."""
    return p[o : o + rows * cols].reshape((rows, cols))


@njit(cache=True, inline="always")
def _part(v, o, size):  # pragma: no cover - compiled
    """The block of ``size`` floats of v at offset o (a view)."""
    return v[o : o + size]


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
    mv_into(S_v_pinv, _part(ref, ref_v_d(d), d), nu_d)
    mv_into(S_v_pinv, _part(ref, ref_a_d(d), d), alpha)  # ν̇_d (r̈_d)
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
        mv_into(S_v_pinv, _part(ref, REF_X_D, d), r_d)
        mv_into(S_v_pinv, x, r)
        _mv_diff_add(K_2, r_d, r, alpha, tmp)
    else:
        _mv_add(K_2, _part(s, HYBRID_STATE_NU_INTEGRAL, l), alpha)
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
    d = int(p[HYBRID_COMPLIANT_TASK_DIM])
    k = int(p[HYBRID_COMPLIANT_FORCE_DIM])
    position_mode = p[HYBRID_COMPLIANT_POSITION_MODE] != 0.0
    l = d - k
    S_v = _block(p, HYBRID_COMPLIANT_S_V, d, l)
    S_v_pinv = _block(p, hybrid_compliant_S_v_pinv(d, l, k), l, d)
    S_f_pinv = _block(p, hybrid_compliant_S_f_pinv(d, l, k), k, d)
    CpS_f = _block(p, hybrid_compliant_CpS_f(d, l, k), d, k)
    L_hat = _block(p, hybrid_compliant_L_hat(d, l, k), k, d)
    K_1 = _block(p, hybrid_compliant_K_1(d, l, k), l, l)
    K_2 = _block(p, hybrid_compliant_K_2(d, l, k), l, l)
    K_Dlam = _block(p, hybrid_compliant_K_Dlam(d, l, k), k, k)
    K_Plam = _block(p, hybrid_compliant_K_Plam(d, l, k), k, k)
    nu, nu_d, alpha, tmp, f_lam, lam_a, lam_b = _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, k, s, ws)
    mv_into(S_f_pinv, _part(ref, ref_fddot_d(d), d), f_lam)  # λ̈_d
    mv_into(S_f_pinv, _part(ref, ref_fdot_d(d), d), lam_a)  # λ̇_d
    mv_into(L_hat, xd, lam_b)  # λ̇
    _mv_diff_add(K_Dlam, lam_a, lam_b, f_lam, tmp)
    mv_into(S_f_pinv, _part(ref, ref_f_d(d), d), lam_a)  # λ_d
    mv_into(S_f_pinv, h, lam_b)  # λ
    _mv_diff_add(K_Plam, lam_a, lam_b, f_lam, tmp)
    mv_into(S_v, alpha, a)
    _mv_add(CpS_f, f_lam, a)
    for j in range(l):
        s[HYBRID_STATE_NU_INTEGRAL + j] += dt * (nu_d[j] - nu[j])
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
    d = int(p[HYBRID_RIGID_TASK_DIM])
    k = int(p[HYBRID_RIGID_FORCE_DIM])
    position_mode = p[HYBRID_RIGID_POSITION_MODE] != 0.0
    l = d - k
    S_v = _block(p, HYBRID_RIGID_S_V, d, l)
    S_v_pinv = _block(p, hybrid_rigid_S_v_pinv(d, l, k), l, d)
    S_f = _block(p, hybrid_rigid_S_f(d, l, k), d, k)
    S_f_pinv = _block(p, hybrid_rigid_S_f_pinv(d, l, k), k, d)
    K_1 = _block(p, hybrid_rigid_K_1(d, l, k), l, l)
    K_2 = _block(p, hybrid_rigid_K_2(d, l, k), l, l)
    K_Plam = _block(p, hybrid_rigid_K_Plam(d, l, k), k, k)
    K_Ilam = _block(p, hybrid_rigid_K_Ilam(d, l, k), k, k)
    S_v_dot = _block(p, hybrid_rigid_S_v_dot(d, l, k), d, l)
    nu, nu_d, alpha, tmp, f_lam, lam_d, lam = _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, k, s, ws)
    mv_into(S_f_pinv, _part(ref, ref_f_d(d), d), lam_d)
    mv_into(S_f_pinv, h, lam)
    for j in range(k):
        f_lam[j] = lam_d[j]
    _mv_diff_add(K_Plam, lam_d, lam, f_lam, tmp)
    o_lam = hybrid_state_lam_integral(l, k)
    _mv_add(K_Ilam, _part(s, o_lam, k), f_lam)
    mv_into(S_v, alpha, a)
    _mv_add(S_v_dot, nu, a)
    mv_into(S_f, f_lam, hc)
    for j in range(l):
        s[HYBRID_STATE_NU_INTEGRAL + j] += dt * (nu_d[j] - nu[j])
    for j in range(k):
        s[o_lam + j] += dt * (lam_d[j] - lam[j])
    return True


#: Hybrid control on a compliant environment: (9.77) through the inner loop (9.30) (+ Jᵀ h_e).
hybrid_compliant = inverse_dynamics_law(hybrid_compliant_acceleration, "hybrid_compliant")
#: Hybrid control on a rigid environment: (9.91) through the inner loop (9.30) (+ Jᵀ S_f f_λ).
hybrid_rigid = inverse_dynamics_law(hybrid_rigid_acceleration, "hybrid_rigid")
