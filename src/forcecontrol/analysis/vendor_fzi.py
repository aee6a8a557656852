"""The sampled loop of FZI's compliance/force controller on a position-interface arm, along one contact normal (issue 30).

One interface cycle (period T) of the 1-DOF loop, written from the controller's documented
equations (survey of issue 30, §2.1–2.5, §2.8) and the servo model of
:mod:`forcecontrol.robots.servo`::

    measured x = q_r (the servo's output; the arm follows it), h = k_e (x − x_e) + m_p q̈_r
        (m_p: a payload after the sensor, its weight compensated: its inertial force, with q̈_r
        the servo's acceleration at the end of the last cycle, FZI #177)
    accumulating solver: q ← x, the virtual velocity v kept, the first pose = the previous command
        N times: e = K (x_t − x_cur) + f_d − h;  f = s (p e + d (e − e_prev)/h_s);  e_prev = e
                 q ← q + h_s v;  v ← 0.9 (v + h_s f/m_v);  x_cur = q
    instantaneous solver (2021): q ← the previous command, each step q ← q + ¼ h_s² f/m_v
    command y = q, applied n_d cycles later, held for T:
        q̈_r = ω² (y − q_r) − 2ζω q̇_r  (exact zero-order-hold discretisation over T)

The map from one cycle's state to the next is linear (the constants x_t, f_d, x_e only move the
equilibrium), so its matrix is built column by column from the map itself; the loop is stable
iff its spectral radius is below 1. :func:`fdcc_stability_limit` bisects the largest stable
environment stiffness. The simulator checks it (tests/test_vendor_issues.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from ..errors import ParameterError

__all__ = ["FdccLoop", "fdcc_loop_matrix", "fdcc_spectral_radius", "fdcc_stability_limit", "fdcc_design_error_scale",
           "fdcc_error_scale_limit"]


@dataclass(frozen=True)
class FdccLoop:
    """The 1-DOF loop's parameters (one translational axis of the controller, the servo, the contact).

    Attributes:
        p, d: the axis's ``pd_gains``; error_scale: ``solver.error_scale``; stiffness: K [N/m]
            (0 for the force controller); iterations: N; virtual_mass: m_v [kg]; solver:
            ``"accumulating"`` or ``"instantaneous"``; internal_period: h_s [s] (0.02);
        rate: the interface rate [Hz]; bandwidth, damping: the servo's ω [rad/s], ζ; delay: n_d [cycles];
        payload_mass: m_p [kg] carried after the sensor (its inertial force is sensed; 0: none).
    """

    p: float
    d: float
    error_scale: float
    stiffness: float
    iterations: int
    rate: float
    bandwidth: float
    damping: float
    delay: int = 1
    virtual_mass: float = 1.3
    solver: str = "accumulating"
    internal_period: float = 0.02
    payload_mass: float = 0.0


def _servo(T: float, w: float, z: float) -> tuple[np.ndarray, np.ndarray]:
    A = np.array([[0.0, 1.0], [-w * w, -2.0 * z * w]])
    B = np.array([[0.0], [w * w]])
    big = np.zeros((3, 3))
    big[:2, :2], big[:2, 2:] = A * T, B * T
    E = expm(big)
    return E[:2, :2], E[:2, 2]


def _cycle(L: FdccLoop, k_e: float, z: np.ndarray, Ad: np.ndarray, Bd: np.ndarray) -> np.ndarray:
    """One cycle of the loop on the state ``[q_r, q̇_r, ring (n_d), v, e_prev, x_prev, y_held]`` (zero constants)."""
    nd = L.delay
    qr, qdr = z[0], z[1]
    ring = list(z[2 : 2 + nd])
    v, e_prev, x_prev, y_held = z[2 + nd], z[3 + nd], z[4 + nd], z[5 + nd]
    w, zeta = L.bandwidth, L.damping
    h = k_e * qr + L.payload_mass * (w * w * (y_held - qr) - 2.0 * zeta * w * qdr)
    hs, s, m = L.internal_period, L.error_scale, L.virtual_mass
    q = x_prev if L.solver == "instantaneous" else qr
    x_cur = x_prev
    for _ in range(L.iterations):
        e = -L.stiffness * x_cur - h
        f = s * (L.p * e + L.d * (e - e_prev) / hs)
        e_prev = e
        if L.solver == "instantaneous":
            v = 0.5 * hs * f / m
            q = q + 0.5 * hs * v
        else:
            q = q + hs * v
            v = 0.9 * (v + hs * f / m)
        x_cur = q
    if nd:
        y = ring[0]
        ring = [*ring[1:], q]
    else:
        y = q
    nxt = Ad @ np.array([qr, qdr]) + Bd * y
    return np.array([nxt[0], nxt[1], *ring, v, e_prev, q, y])


def fdcc_loop_matrix(loop: FdccLoop, environment_stiffness: float) -> np.ndarray:
    """The closed loop's matrix over one interface cycle (size 6 + n_d)."""
    if loop.iterations < 1 or loop.delay < 0 or loop.rate <= 0 or loop.bandwidth <= 0:
        raise ParameterError(f"iterations >= 1, delay >= 0, rate > 0 and bandwidth > 0 are needed; got {loop!r}")
    Ad, Bd = _servo(1.0 / loop.rate, loop.bandwidth, loop.damping)
    n = 6 + loop.delay
    return np.column_stack([_cycle(loop, environment_stiffness, np.eye(n)[i], Ad, Bd) for i in range(n)])


def fdcc_spectral_radius(loop: FdccLoop, environment_stiffness: float) -> float:
    """max |z| of the loop's poles (< 1: stable)."""
    return float(np.max(np.abs(np.linalg.eigvals(fdcc_loop_matrix(loop, environment_stiffness)))))


def fdcc_stability_limit(loop: FdccLoop, k_max: float = 1e9, rtol: float = 1e-4) -> float:
    """The largest environment stiffness [N/m] at which the loop is stable (bisection on the spectral radius);
    ``inf`` when stable up to ``k_max``, 0 when unstable already in free space."""
    if fdcc_spectral_radius(loop, 0.0) >= 1.0 - 1e-12 and loop.stiffness > 0:
        return 0.0
    hi = 1.0
    while fdcc_spectral_radius(loop, hi) < 1.0:
        hi *= 2.0
        if hi > k_max:
            return math.inf
    lo = hi / 2.0 if hi > 1.0 else 0.0
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if fdcc_spectral_radius(loop, mid) < 1.0:
            lo = mid
        else:
            hi = mid
    return lo


def fdcc_design_error_scale(loop: FdccLoop, environment_stiffness: float, margin: float = 2.0) -> float:
    """The largest ``error_scale`` (the controller's one overall gain, "responsiveness") at which the loop
    stays stable up to ``margin`` times the environment's stiffness (bisection on the stability limit).

    Raises:
        ParameterError: no error_scale > 0 reaches the margin (the servo or the delay alone limit it).
    """
    import dataclasses

    target = margin * environment_stiffness

    def ok(s: float) -> bool:
        return fdcc_stability_limit(dataclasses.replace(loop, error_scale=s), k_max=10.0 * target) >= target

    lo, hi = 0.0, max(loop.error_scale, 1e-6)
    while ok(hi):
        lo, hi = hi, 2.0 * hi
        if hi > 1e6:
            return hi
    if lo == 0.0:
        lo = hi / 2.0
        while not ok(lo):
            lo /= 2.0
            if lo < 1e-9:
                raise ParameterError(f"no error_scale keeps the loop stable up to {target:g} N/m")
    while hi - lo > 1e-3 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def fdcc_error_scale_limit(loop: FdccLoop, environment_stiffness: float = 0.0, s_max: float = 1e3) -> float:
    """The largest ``error_scale`` at which the loop is stable at the given environment stiffness (0: free space),
    by bisection on the spectral radius; ``inf`` when stable up to ``s_max``.

    FZI #177: in free space with a heavy payload after the sensor (``payload_mass``, its weight compensated), the
    payload's inertial force fed back through the sensor is what bounds error_scale; on a rotational axis use
    ``virtual_mass`` = the virtual inertia (1 kg m²) and ``payload_mass`` = the payload's inertia about the axis
    through the sensor, m (|r|² − (r·a)²) + I_aa.
    """
    import dataclasses

    def stable(s: float) -> bool:
        return fdcc_spectral_radius(dataclasses.replace(loop, error_scale=s), environment_stiffness) < 1.0

    lo, hi = 0.0, 1e-3
    while stable(hi):
        lo, hi = hi, 2.0 * hi
        if hi > s_max:
            return math.inf
    while hi - lo > 1e-4 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo
