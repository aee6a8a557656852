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
def _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, s, ws):  # pragma: no cover - compiled
    """α_ν of both hybrid laws: (9.80) ``ν̇_d + K_1 (ν_d − ν) + K_2 ∫(ν_d − ν)`` or, with
    ``position_mode``, (9.95) ``r̈_d + K_1 (ṙ_d − ν) + K_2 (r_d − r)``, ``r = S_v† x``, with
    ``ν = S_v† ẋ_e`` (9.60) and ``ν_d = S_v† ẋ_d``; returns the views (ν, ν_d, α_ν) of ``ws``.

    Written as plain loops rather than calls of small inlined helpers: Numba copies and re-analyses
    an inlined function's IR at each call site, and the hybrid laws' two dozen products cost
    seconds of a first run that way. Each product still sums ``A[i, 0] x[0] + A[i, 1] x[1] + …``
    from 0.0 in column order, and each sum is added to its target in the equations' order, so
    the results are those of ``A @ x`` products taken one at a time, to the bit.
    """
    l = S_v_pinv.shape[0]
    nu = ws[0:l]
    nu_d = ws[d : d + l]
    alpha = ws[2 * d : 2 * d + l]
    v_d = ref[ref_v_d(d) : ref_v_d(d) + d]
    a_d = ref[ref_a_d(d) : ref_a_d(d) + d]
    for i in range(l):  # ν, ν_d and ν̇_d (r̈_d): the three products with S_v† in one pass
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for j in range(d):
            e = S_v_pinv[i, j]
            s0 += e * xd[j]
            s1 += e * v_d[j]
            s2 += e * a_d[j]
        nu[i] = s0
        nu_d[i] = s1
        alpha[i] = s2
    for i in range(l):  # + K_1 (ν_d − ν)
        acc = 0.0
        for j in range(l):
            acc += K_1[i, j] * (nu_d[j] - nu[j])
        alpha[i] += acc
    if position_mode:  # + K_2 (r_d − r), r = S_v† x
        r_d = ws[7 * d : 7 * d + l]
        r = ws[8 * d : 8 * d + l]
        for i in range(l):
            s0 = 0.0
            s1 = 0.0
            for j in range(d):
                e = S_v_pinv[i, j]
                s0 += e * ref[REF_X_D + j]
                s1 += e * x[j]
            r_d[i] = s0
            r[i] = s1
        for i in range(l):
            acc = 0.0
            for j in range(l):
                acc += K_2[i, j] * (r_d[j] - r[j])
            alpha[i] += acc
    else:  # + K_2 ∫(ν_d − ν)
        for i in range(l):
            acc = 0.0
            for j in range(l):
                acc += K_2[i, j] * s[HYBRID_STATE_NU_INTEGRAL + j]
            alpha[i] += acc
    return nu, nu_d, alpha


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
    o = HYBRID_COMPLIANT_S_V
    S_v = p[o : o + d * l].reshape((d, l))
    o = hybrid_compliant_S_v_pinv(d, l, k)
    S_v_pinv = p[o : o + l * d].reshape((l, d))
    o = hybrid_compliant_S_f_pinv(d, l, k)
    S_f_pinv = p[o : o + k * d].reshape((k, d))
    o = hybrid_compliant_CpS_f(d, l, k)
    CpS_f = p[o : o + d * k].reshape((d, k))
    o = hybrid_compliant_L_hat(d, l, k)
    L_hat = p[o : o + k * d].reshape((k, d))
    o = hybrid_compliant_K_1(d, l, k)
    K_1 = p[o : o + l * l].reshape((l, l))
    o = hybrid_compliant_K_2(d, l, k)
    K_2 = p[o : o + l * l].reshape((l, l))
    o = hybrid_compliant_K_Dlam(d, l, k)
    K_Dlam = p[o : o + k * k].reshape((k, k))
    o = hybrid_compliant_K_Plam(d, l, k)
    K_Plam = p[o : o + k * k].reshape((k, k))
    nu, nu_d, alpha = _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, s, ws)
    f_lam = ws[4 * d : 4 * d + k]
    lamdot_d = ws[5 * d : 5 * d + k]
    lamdot = ws[6 * d : 6 * d + k]
    lam_d = ws[7 * d : 7 * d + k]  # r_d and r (position mode) are spent by now
    lam = ws[8 * d : 8 * d + k]
    f_d = ref[ref_f_d(d) : ref_f_d(d) + d]
    fd_d = ref[ref_fdot_d(d) : ref_fdot_d(d) + d]
    fdd_d = ref[ref_fddot_d(d) : ref_fddot_d(d) + d]
    for i in range(k):  # λ̈_d, λ̇_d, λ_d, λ (the products with S_f†) and λ̇ = L̂ ẋ_e in one pass
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        s4 = 0.0
        for j in range(d):
            e = S_f_pinv[i, j]
            s0 += e * fdd_d[j]
            s1 += e * fd_d[j]
            s2 += e * f_d[j]
            s3 += e * h[j]
            s4 += L_hat[i, j] * xd[j]
        f_lam[i] = s0
        lamdot_d[i] = s1
        lam_d[i] = s2
        lam[i] = s3
        lamdot[i] = s4
    for i in range(k):  # f_λ = λ̈_d + K_Dλ (λ̇_d − λ̇) + K_Pλ (λ_d − λ)
        acc = 0.0
        for j in range(k):
            acc += K_Dlam[i, j] * (lamdot_d[j] - lamdot[j])
        f_lam[i] += acc
        acc = 0.0
        for j in range(k):
            acc += K_Plam[i, j] * (lam_d[j] - lam[j])
        f_lam[i] += acc
    for i in range(d):  # α = S_v α_ν + Ĉ′ S_f f_λ
        acc = 0.0
        for j in range(l):
            acc += S_v[i, j] * alpha[j]
        a[i] = acc
        acc = 0.0
        for j in range(k):
            acc += CpS_f[i, j] * f_lam[j]
        a[i] += acc
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
    o = HYBRID_RIGID_S_V
    S_v = p[o : o + d * l].reshape((d, l))
    o = hybrid_rigid_S_v_pinv(d, l, k)
    S_v_pinv = p[o : o + l * d].reshape((l, d))
    o = hybrid_rigid_S_f(d, l, k)
    S_f = p[o : o + d * k].reshape((d, k))
    o = hybrid_rigid_S_f_pinv(d, l, k)
    S_f_pinv = p[o : o + k * d].reshape((k, d))
    o = hybrid_rigid_K_1(d, l, k)
    K_1 = p[o : o + l * l].reshape((l, l))
    o = hybrid_rigid_K_2(d, l, k)
    K_2 = p[o : o + l * l].reshape((l, l))
    o = hybrid_rigid_K_Plam(d, l, k)
    K_Plam = p[o : o + k * k].reshape((k, k))
    o = hybrid_rigid_K_Ilam(d, l, k)
    K_Ilam = p[o : o + k * k].reshape((k, k))
    o = hybrid_rigid_S_v_dot(d, l, k)
    S_v_dot = p[o : o + d * l].reshape((d, l))
    o_lam = hybrid_state_lam_integral(l, k)
    nu, nu_d, alpha = _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, s, ws)
    f_lam = ws[4 * d : 4 * d + k]
    lam_d = ws[5 * d : 5 * d + k]
    lam = ws[6 * d : 6 * d + k]
    f_d = ref[ref_f_d(d) : ref_f_d(d) + d]
    for i in range(k):  # λ_d = S_f† f_d and λ = S_f† h_e in one pass
        s0 = 0.0
        s1 = 0.0
        for j in range(d):
            e = S_f_pinv[i, j]
            s0 += e * f_d[j]
            s1 += e * h[j]
        lam_d[i] = s0
        lam[i] = s1
    for i in range(k):  # f_λ = λ_d + K_Pλ (λ_d − λ) + K_Iλ ∫(λ_d − λ)
        f_lam[i] = lam_d[i]
        acc = 0.0
        for j in range(k):
            acc += K_Plam[i, j] * (lam_d[j] - lam[j])
        f_lam[i] += acc
        acc = 0.0
        for j in range(k):
            acc += K_Ilam[i, j] * s[o_lam + j]
        f_lam[i] += acc
    for i in range(d):  # a = S_v α_ν + Ṡ_v ν, h_c = S_f f_λ
        acc = 0.0
        for j in range(l):
            acc += S_v[i, j] * alpha[j]
        a[i] = acc
        acc = 0.0
        for j in range(l):
            acc += S_v_dot[i, j] * nu[j]
        a[i] += acc
        acc = 0.0
        for j in range(k):
            acc += S_f[i, j] * f_lam[j]
        hc[i] = acc
    for j in range(l):
        s[HYBRID_STATE_NU_INTEGRAL + j] += dt * (nu_d[j] - nu[j])
    for j in range(k):
        s[o_lam + j] += dt * (lam_d[j] - lam[j])
    return True


#: Hybrid control on a compliant environment: (9.77) through the inner loop (9.30) (+ Jᵀ h_e).
hybrid_compliant = inverse_dynamics_law(hybrid_compliant_acceleration, "hybrid_compliant")
#: Hybrid control on a rigid environment: (9.91) through the inner loop (9.30) (+ Jᵀ S_f f_λ).
hybrid_rigid = inverse_dynamics_law(hybrid_rigid_acceleration, "hybrid_rigid")
