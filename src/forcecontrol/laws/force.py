"""Direct force control (Sect. 9.4): inner position loop, inner velocity loop, parallel control.

Packed parameters shared by the three laws (m = task dimension, row-major matrices)::

    p = [M_d⁻¹ (m²), K_D (m²), K_P (m²), K_F (m), K_I (m), anti-windup limit (m), R (m²), bumpless (1)]

K_F and K_I are the diagonals of C_F in the task frame whose axes are the columns of R (R = I:
the base frame, the chapter's case). State of the PI schemes: ``s = [ξ (m), ξ₀ (m), f_s (m)]``,
the integral action, the centre of its anti-windup band (its value after reset) and the force
reference ``Rᵀ f_d`` of the previous sample, in task-frame coordinates; the inner velocity loop
has no state. ``bumpless`` = 1 (``integrator_start = "tip"``): along axes with integral action a
change of f_d moves ξ and ξ₀ by ``−K_F Rᵀ Δf_d``, so x_F does not jump (the proportional action
acts on the measured force only, setpoint weight 0); 0: the whole PI acts on the change (9.43).
"""

from __future__ import annotations

from numba import njit

from .inner import inverse_dynamics_law
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
    mm = m * m
    oF = 3 * mm
    oR = 3 * mm + 3 * m
    if integral and p[oR + mm] != 0.0:  # bumpless: a change of f_d does not move x_F
        for i in range(m):
            acc = 0.0
            for j in range(m):
                acc += p[oR + j * m + i] * ref[3 * m + j]
            if p[oF + m + i] > 0.0:
                shift = p[oF + i] * (acc - s[2 * m + i])
                s[i] -= shift
                s[m + i] -= shift
            s[2 * m + i] = acc
    for i in range(m):  # e = Rᵀ (f_d − f_e), the force error in the task frame
        acc = 0.0
        for j in range(m):
            acc += p[oR + j * m + i] * (ref[3 * m + j] - h[j])
        e[i] = acc
    for i in range(m):  # x_F = R (K_F e + ξ)
        acc = 0.0
        for j in range(m):
            xi = s[j] if integral else 0.0
            acc += p[oR + i * m + j] * (p[oF + j] * e[j] + xi)
        x_F[i] = acc
    if integral:
        for i in range(m):
            v = s[i] + dt * p[oF + m + i] * e[i]
            lim = p[oF + 2 * m + i]
            if lim > 0.0:
                lo = s[m + i] - lim
                hi = s[m + i] + lim
                if v < lo:
                    v = lo
                elif v > hi:
                    v = hi
            s[i] = v


@njit(cache=True, inline="always")
def _motion_acceleration(p, d, xd, a, w):  # pragma: no cover - compiled
    """``a = M_d⁻¹ (K_P d − K_D ẋ_e)``, the common form of (9.39), (9.45) and (9.48)."""
    m = d.shape[0]
    mm = m * m
    pd_action(p, 2 * mm, d, mm, xd, -1.0, w)
    for i in range(m):
        acc = 0.0
        for j in range(m):
            acc += p[i * m + j] * w[j]
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
        d[i] = ref[i] - x[i] + d[i]
        hc[i] = h[i]
    _motion_acceleration(p, d, xd, a, ws[m : 2 * m])
    return True


#: Force control with inner position loop: (9.39)+(9.43) through the inner loop (9.30).
inner_position = inverse_dynamics_law(inner_position_acceleration, "inner_position")
#: Force control with inner velocity loop: (9.45)+(9.46) through the inner loop (9.30).
inner_velocity = inverse_dynamics_law(inner_velocity_acceleration, "inner_velocity")
#: Parallel force/position control: (9.48)+(9.43) through the inner loop (9.30).
parallel = inverse_dynamics_law(parallel_acceleration, "parallel")
