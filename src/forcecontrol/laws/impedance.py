"""Impedance control, (9.28) without and (9.30)–(9.31) with force measurement."""

from __future__ import annotations

from numba import njit

from .inner import inverse_dynamics_law
from .layout import IMPEDANCE_M_D_INV, REF_X_D, impedance_K_D, impedance_K_P, impedance_use_force, ref_a_d, ref_v_d
from .pd import pd_action


@njit(cache=True, inline="always")
def impedance_core(G, x_tilde, x_tilde_dot, a_ff, h, use_force, w, a):  # pragma: no cover - compiled
    """(9.28), (9.31), (9.35): ``a = a_ff + M_d⁻¹ (K_D x̃̇ + K_P x̃ [− h])``, written into ``a``.

    ``G``: the blocks ``M_d_inv``, ``K_D``, ``K_P`` of :data:`~forcecontrol.laws.layout.IMPEDANCE`
    (the first blocks of the planar law's parameters).
    The one impedance equation of the chapter, for any dimension m: in the base frame with
    ``x̃ = x_d − x_e`` and ``a_ff = ẍ_d`` ((9.28) without, (9.31) corrected with force
    measurement); on the desired frame (9.35) with the 6-D error (9.9), ``a_ff`` the part of x̃̈
    that does not depend on q̈ and h the wrench on the desired frame. With R_d = I and position
    only, the desired-frame error is x_d − x_e: the planar law is the m = 2 case of the 6-D one.
    ``w`` (m,) is scratch.
    """
    m = a.shape[0]
    pd_action(G, impedance_K_P(m), x_tilde, impedance_K_D(m), x_tilde_dot, 1.0, w)
    if use_force:
        for i in range(m):
            w[i] = w[i] - h[i]
    for i in range(m):
        acc = 0.0
        for j in range(m):
            acc += G[IMPEDANCE_M_D_INV + i * m + j] * w[j]
        a[i] = a_ff[i] + acc


@njit(cache=True, inline="always")
def impedance_acceleration(t, dt, x, xd, h, ref, p, s, ws, a, hc):  # pragma: no cover - compiled
    """(9.28)/(9.31): ``a = ẍ_d + M_d⁻¹ (K_D x̃̇ + K_P x̃ [− h_A])``, ``x̃ = x_d − x_e`` (:func:`impedance_core`).

    (9.31) in its corrected form: the first term is ``M_d ẍ_d`` as in (9.28), not the printed
    ``M_d x̃̈``. With force measurement the closed loop is (9.32)
    ``M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A``; without, (9.29) (coupled through B_A⁻¹).
    ``p``: :data:`~forcecontrol.laws.layout.IMPEDANCE`, ``ref``: :data:`~forcecontrol.laws.layout.REFERENCE`;
    no state. Writes ``a`` and ``hc = h_e``;
    returns whether the inner loop compensates ``Jᵀ h_e`` (with force measurement).
    """
    m = x.shape[0]
    use_force = p[impedance_use_force(m)] != 0.0
    xt = ws[0:m]
    xtd = ws[m : 2 * m]
    for i in range(m):
        xt[i] = ref[REF_X_D + i] - x[i]
        xtd[i] = ref[ref_v_d(m) + i] - xd[i]
        hc[i] = h[i]
    impedance_core(p, xt, xtd, ref[ref_a_d(m) : ref_a_d(m) + m], h, use_force, ws[2 * m : 3 * m], a)
    return use_force


#: Impedance control, (9.28) or (9.30)–(9.31): :func:`impedance_acceleration` through the inner loop (9.30).
impedance = inverse_dynamics_law(impedance_acceleration, "impedance")
