"""Hybrid force/motion control (Sect. 9.7): compliant (9.77)–(9.82) and rigid (9.91)–(9.95) environments.

Packed parameters (:data:`~forcecontrol.laws.layout.HYBRID_COMPLIANT`, :data:`~forcecontrol.laws.layout.HYBRID_RIGID`;
row-major blocks; d = task dimension, k = force-controlled, l = d − k):

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

from ..core.axes import REFERENCE_FIELDS
from ..core.linalg import mv_into
from .inner import inverse_dynamics_law
from .layout import HYBRID_COMPLIANT, HYBRID_RIGID, HYBRID_STATE, REFERENCE

_C_TASK_DIM, _C_FORCE_DIM, _C_POSITION_MODE, _C_S_V, _C_S_V_PINV, _C_S_F_PINV, _C_CPS_F, _C_L_HAT = (
    HYBRID_COMPLIANT.view(b) for b in ("task_dim", "force_dim", "position_mode", "S_v", "S_v_pinv", "S_f_pinv", "CpS_f", "L_hat")
)
_C_K_1, _C_K_2, _C_K_DLAM, _C_K_PLAM = (HYBRID_COMPLIANT.view(b) for b in ("K_1", "K_2", "K_Dlam", "K_Plam"))
_R_TASK_DIM, _R_FORCE_DIM, _R_POSITION_MODE, _R_S_V, _R_S_V_PINV, _R_S_F, _R_S_F_PINV = (
    HYBRID_RIGID.view(b) for b in ("task_dim", "force_dim", "position_mode", "S_v", "S_v_pinv", "S_f", "S_f_pinv")
)
_R_K_1, _R_K_2, _R_K_PLAM, _R_K_ILAM, _R_S_V_DOT = (HYBRID_RIGID.view(b) for b in ("K_1", "K_2", "K_Plam", "K_Ilam", "S_v_dot"))
_NU_INTEGRAL, _LAM_INTEGRAL = HYBRID_STATE.view("nu_integral"), HYBRID_STATE.view("lam_integral")
_X_D, _V_D, _A_D, _F_D, _FD_D, _FDD_D = (REFERENCE.view(f) for f in REFERENCE_FIELDS)


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
    mv_into(S_v_pinv, _V_D(ref, d), nu_d)
    mv_into(S_v_pinv, _A_D(ref, d), alpha)  # ν̇_d (r̈_d)
    _mv_diff_add(K, nu_d, nu, alpha, tmp)
    return nu, nu_d, alpha, tmp, ws[4 * d : 4 * d + k], ws[5 * d : 5 * d + k], ws[6 * d : 6 * d + k]


@njit(cache=True, inline="always")
def _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, k, nu_integral, ws):  # pragma: no cover - compiled
    """α_ν of both hybrid laws: (9.80) ``ν̇_d + K_1 (ν_d − ν) + K_2 ∫(ν_d − ν)`` or, with
    ``position_mode``, (9.95) ``r̈_d + K_1 (ṙ_d − ν) + K_2 (r_d − r)``, ``r = S_v† x``
    (``nu_integral`` = ∫(ν_d − ν), the state's first block); returns the
    views of :func:`_velocity_servo`."""
    l = d - k
    nu, nu_d, alpha, tmp, f_lam, lam_a, lam_b = _velocity_servo(S_v_pinv, K_1, xd, ref, d, k, ws)
    if position_mode:
        r_d = ws[7 * d : 7 * d + l]
        r = ws[8 * d : 8 * d + l]
        mv_into(S_v_pinv, _X_D(ref, d), r_d)
        mv_into(S_v_pinv, x, r)
        _mv_diff_add(K_2, r_d, r, alpha, tmp)
    else:
        _mv_add(K_2, nu_integral, alpha)
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
    d = int(_C_TASK_DIM(p))
    k = int(_C_FORCE_DIM(p))
    l = d - k
    S_v, S_v_pinv, S_f_pinv = _C_S_V(p, d, l), _C_S_V_PINV(p, d, l), _C_S_F_PINV(p, d, l, k)
    CpS_f, L_hat, K_1, K_2 = _C_CPS_F(p, d, l, k), _C_L_HAT(p, d, l, k), _C_K_1(p, d, l, k), _C_K_2(p, d, l, k)
    K_Dlam, K_Plam = _C_K_DLAM(p, d, l, k), _C_K_PLAM(p, d, l, k)
    nu_integral = _NU_INTEGRAL(s, l)
    position_mode = _C_POSITION_MODE(p) != 0.0
    servo = _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, k, nu_integral, ws)
    nu, nu_d, alpha, tmp, f_lam, lam_a, lam_b = servo
    mv_into(S_f_pinv, _FDD_D(ref, d), f_lam)  # λ̈_d
    mv_into(S_f_pinv, _FD_D(ref, d), lam_a)  # λ̇_d
    mv_into(L_hat, xd, lam_b)  # λ̇
    _mv_diff_add(K_Dlam, lam_a, lam_b, f_lam, tmp)
    mv_into(S_f_pinv, _F_D(ref, d), lam_a)  # λ_d
    mv_into(S_f_pinv, h, lam_b)  # λ
    _mv_diff_add(K_Plam, lam_a, lam_b, f_lam, tmp)
    mv_into(S_v, alpha, a)
    _mv_add(CpS_f, f_lam, a)
    for j in range(l):
        nu_integral[j] += dt * (nu_d[j] - nu[j])
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
    d = int(_R_TASK_DIM(p))
    k = int(_R_FORCE_DIM(p))
    position_mode = _R_POSITION_MODE(p) != 0.0
    l = d - k
    S_v, S_v_pinv, S_f, S_f_pinv = _R_S_V(p, d, l), _R_S_V_PINV(p, d, l), _R_S_F(p, d, l, k), _R_S_F_PINV(p, d, l, k)
    K_1, K_2, K_Plam, K_Ilam = _R_K_1(p, d, l, k), _R_K_2(p, d, l, k), _R_K_PLAM(p, d, l, k), _R_K_ILAM(p, d, l, k)
    S_v_dot = _R_S_V_DOT(p, d, l, k)
    nu_integral = _NU_INTEGRAL(s, l)
    lam_integral = _LAM_INTEGRAL(s, l, k)
    nu, nu_d, alpha, tmp, f_lam, lam_d, lam = _motion_servo(S_v_pinv, K_1, K_2, position_mode, x, xd, ref, d, k, nu_integral, ws)
    mv_into(S_f_pinv, _F_D(ref, d), lam_d)
    mv_into(S_f_pinv, h, lam)
    for j in range(k):
        f_lam[j] = lam_d[j]
    _mv_diff_add(K_Plam, lam_d, lam, f_lam, tmp)
    _mv_add(K_Ilam, lam_integral, f_lam)
    mv_into(S_v, alpha, a)
    _mv_add(S_v_dot, nu, a)
    mv_into(S_f, f_lam, hc)
    for j in range(l):
        nu_integral[j] += dt * (nu_d[j] - nu[j])
    for j in range(k):
        lam_integral[j] += dt * (lam_d[j] - lam[j])
    return True


#: Hybrid control on a compliant environment: (9.77) through the inner loop (9.30) (+ Jᵀ h_e).
hybrid_compliant = inverse_dynamics_law(hybrid_compliant_acceleration, "hybrid_compliant")
#: Hybrid control on a rigid environment: (9.91) through the inner loop (9.30) (+ Jᵀ S_f f_λ).
hybrid_rigid = inverse_dynamics_law(hybrid_rigid_acceleration, "hybrid_rigid")
