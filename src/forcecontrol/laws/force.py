"""Direct force control (Sect. 9.4): inner position loop, inner velocity loop, parallel control.

Packed parameters shared by the three laws (m = task dimension, row-major matrices):
:data:`~forcecontrol.laws.layout.FORCE`, the blocks ``M_d_inv, K_D, K_P`` (m²), ``K_F, K_I, limit``
(m, the anti-windup limit), ``R`` (m²), ``bumpless`` (1).

K_F and K_I are the diagonals of C_F in the task frame whose axes are the columns of R (R = I:
the base frame, the chapter's case). State of the PI schemes:
:data:`~forcecontrol.laws.layout.FORCE_STATE`, the blocks ``xi, xi0, f_s`` (m each): ξ, the
integral action, ξ₀, the centre of its anti-windup band (its value after reset) and f_s, the force
reference ``Rᵀ f_d`` of the previous sample, in task-frame coordinates; the inner velocity loop
has no state. ``bumpless`` = 1 (``integrator_start = "tip"``): along axes with integral action a
change of f_d moves ξ and ξ₀ by ``−K_F Rᵀ Δf_d``, so x_F does not jump (the proportional action
acts on the measured force only, setpoint weight 0); 0: the whole PI acts on the change (9.43).
"""

from __future__ import annotations

from numba import njit

from .inner import inverse_dynamics_law
from .layout import (
    FORCE_M_D_INV,
    FORCE_STATE_XI,
    REF_X_D,
    force_bumpless,
    force_K_D,
    force_K_F,
    force_K_I,
    force_K_P,
    force_limit,
    force_R,
    force_state_f_s,
    force_state_xi0,
    ref_f_d,
)
from .pd import pd_action


@njit(cache=True, inline="always")
def force_reference(dt, h, ref, p, s, integral, x_F, e):  # pragma: no cover - compiled
    """(9.41)/(9.43): ``x_F = R (K_F Rᵀ (f_d − f_e) + ξ)``, then ``ξ ← ξ + Ts K_I Rᵀ (f_d − f_e)``.

    ξ = K_I ∫ (f_d − f_e) is the integral action (forward Euler, one sample), clamped to
    ``[ξ₀ − limit, ξ₀ + limit]`` where the limit is positive (anti-windup). With
    ``integral`` False (the inner velocity loop, (9.46)) ``x_F = R K_F Rᵀ (f_d − f_e)``.
    Bumpless (module docstring): first ``ξ, ξ₀ ← ξ, ξ₀ − K_F (Rᵀ f_d − f_s)``, ``f_s ← Rᵀ f_d``
    along axes with K_I > 0. Writes x_F (m,) and uses ``e`` (m,) as scratch.
    """
    m = h.shape[0]
    oF = force_K_F(m)
    oI = force_K_I(m)
    oR = force_R(m)
    o_xi0 = force_state_xi0(m)
    o_fs = force_state_f_s(m)
    o_fd = ref_f_d(m)
    if integral and p[force_bumpless(m)] != 0.0:  # bumpless: a change of f_d does not move x_F
        for i in range(m):
            acc = 0.0
            for j in range(m):
                acc += p[oR + j * m + i] * ref[o_fd + j]
            if p[oI + i] > 0.0:
                shift = p[oF + i] * (acc - s[o_fs + i])
                s[FORCE_STATE_XI + i] -= shift
                s[o_xi0 + i] -= shift
            s[o_fs + i] = acc
    for i in range(m):  # e = Rᵀ (f_d − f_e), the force error in the task frame
        acc = 0.0
        for j in range(m):
            acc += p[oR + j * m + i] * (ref[o_fd + j] - h[j])
        e[i] = acc
    for i in range(m):  # x_F = R (K_F e + ξ)
        acc = 0.0
        for j in range(m):
            xi = s[FORCE_STATE_XI + j] if integral else 0.0
            acc += p[oR + i * m + j] * (p[oF + j] * e[j] + xi)
        x_F[i] = acc
    if integral:
        oL = force_limit(m)
        for i in range(m):
            v = s[FORCE_STATE_XI + i] + dt * p[oI + i] * e[i]
            lim = p[oL + i]
            if lim > 0.0:
                lo = s[o_xi0 + i] - lim
                hi = s[o_xi0 + i] + lim
                if v < lo:
                    v = lo
                elif v > hi:
                    v = hi
            s[FORCE_STATE_XI + i] = v


@njit(cache=True, inline="always")
def _motion_acceleration(p, d, xd, a, w):  # pragma: no cover - compiled
    """``a = M_d⁻¹ (K_P d − K_D ẋ_e)``, the common form of (9.39), (9.45) and (9.48)."""
    m = d.shape[0]
    pd_action(p, force_K_P(m), d, force_K_D(m), xd, -1.0, w)
    for i in range(m):
        acc = 0.0
        for j in range(m):
            acc += p[FORCE_M_D_INV + i * m + j] * w[j]
        a[i] = acc


@njit(cache=True, inline="always")
def inner_position_acceleration(t, dt, x, xd, h, ref, p, s, ws, a, hc):  # pragma: no cover - compiled
    """(9.39) with (9.43): ``a = M_d⁻¹ (−K_D ẋ_e + K_P (x_F − x_e))``; advances ξ.

    Closed loop per axis with the environment (9.38) (corrected (9.42), third order):
    ``m s³ + k_D s² + k_P (1 + k_F k_x) s + k_P k_x k_I``; equilibrium f_e = f_d (9.44).
    Writes ``a`` and ``hc = h_e``; the inner loop compensates ``Jᵀ h_e``.
    """
    m = x.shape[0]
    d = ws[0:m]
    force_reference(dt, h, ref, p, s, True, d, ws[m : 2 * m])
    for i in range(m):
        d[i] = d[i] - x[i]
        hc[i] = h[i]
    _motion_acceleration(p, d, xd, a, ws[m : 2 * m])
    return True


@njit(cache=True, inline="always")
def inner_velocity_acceleration(t, dt, x, xd, h, ref, p, s, ws, a, hc):  # pragma: no cover - compiled
    """(9.45) (J̇ q̇ corrected, printed J̈ q̇) with (9.46): ``a = M_d⁻¹ (−K_D ẋ_e + K_P K_F (f_d − f_e))``.

    Closed loop (9.47): ``M_d ẍ_e + K_D ẋ_e + K_P K_F K x_e = K_P K_F (K x_r + f_d)``.
    """
    m = x.shape[0]
    d = ws[0:m]
    force_reference(dt, h, ref, p, s, False, d, ws[m : 2 * m])
    for i in range(m):
        hc[i] = h[i]
    _motion_acceleration(p, d, xd, a, ws[m : 2 * m])
    return True


@njit(cache=True, inline="always")
def parallel_acceleration(t, dt, x, xd, h, ref, p, s, ws, a, hc):  # pragma: no cover - compiled
    """(9.48) with (9.43): ``a = M_d⁻¹ (−K_D ẋ_e + K_P (x̃ + x_F))``, ``x̃ = x_d − x_e``; advances ξ.

    Equilibrium (9.49): ``x_e = x_d + C_F (K (x_r − x_e) + f_d)``.
    """
    m = x.shape[0]
    d = ws[0:m]
    force_reference(dt, h, ref, p, s, True, d, ws[m : 2 * m])
    for i in range(m):
        d[i] = ref[REF_X_D + i] - x[i] + d[i]
        hc[i] = h[i]
    _motion_acceleration(p, d, xd, a, ws[m : 2 * m])
    return True


#: Force control with inner position loop: (9.39)+(9.43) through the inner loop (9.30).
inner_position = inverse_dynamics_law(inner_position_acceleration, "inner_position")
#: Force control with inner velocity loop: (9.45)+(9.46) through the inner loop (9.30).
inner_velocity = inverse_dynamics_law(inner_velocity_acceleration, "inner_velocity")
#: Parallel force/position control: (9.48)+(9.43) through the inner loop (9.30).
parallel = inverse_dynamics_law(parallel_acceleration, "parallel")
