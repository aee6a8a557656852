"""Direct force control design: gains from (9.42)/(9.47), the sampled-loop stability limit, the operational mass."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import as_square, positive_scalar
from ..errors import ParameterError
from .force import ForceLoopAxis, _scheme

__all__ = ["ForceGains", "design_force_gains", "force_loop_axes", "sampled_stability_limit", "operational_mass"]


@dataclass(frozen=True)
class ForceGains:
    """Gains of one axis from :func:`design_force_gains`.

    Attributes:
        damping: k_D [N s/m]; force_gain: k_F [m/N]; integral_gain: k_I [m/(N s)] (0 for the
            inner velocity loop).
    """

    damping: float
    force_gain: float
    integral_gain: float = 0.0


def design_force_gains(
    scheme: str,
    inertia: float,
    stiffness: float,
    environment_stiffness: float,
    natural_frequency: float,
    damping_ratio: float,
    real_pole: float | None = None,
) -> ForceGains:
    """Gains placing the continuous poles at ω_n, ζ (and −p) for a given environment stiffness.

    * inner velocity loop: ``m s² + k_D s + k_P k_F k = m (s² + 2 ζ ω_n s + ω_n²)``, so
      ``k_D = 2 ζ ω_n m``, ``k_F = m ω_n² / (k_P k)``;
    * inner position / parallel (PI): ``m s³ + k_D s² + k_P (1 + k_F k) s + k_P k k_I
      = m (s² + 2 ζ ω_n s + ω_n²)(s + p)``, so ``k_D = m (2 ζ ω_n + p)``,
      ``k_F = (m (ω_n² + 2 ζ ω_n p) / k_P − 1) / k``, ``k_I = m ω_n² p / (k_P k)``.

    Args:
        scheme: ``"inner-position"``, ``"inner-velocity"`` or ``"parallel"``.
        inertia: m_d [kg]; stiffness: k_P [N/m] (kept: it sets the position loop).
        environment_stiffness: k [N/m], > 0.
        natural_frequency: ω_n [rad/s], > 0; damping_ratio: ζ, > 0.
        real_pole: p [rad/s], > 0, the third pole −p (PI schemes only, required there).

    Raises:
        ParameterError: impossible request (e.g. it needs k_F < 0: the position loop is already
            faster than requested; lower stiffness or raise ω_n).
    """
    scheme = _scheme(scheme)
    m = positive_scalar("inertia", inertia)
    kp = positive_scalar("stiffness", stiffness)
    k = positive_scalar("environment_stiffness", environment_stiffness)
    wn = positive_scalar("natural_frequency", natural_frequency)
    zeta = positive_scalar("damping_ratio", damping_ratio)
    if scheme == "inner-velocity":
        if real_pole is not None:
            raise ParameterError(f"real_pole must be None for the inner velocity loop (second order); got {real_pole!r}")
        return ForceGains(2.0 * zeta * wn * m, m * wn * wn / (kp * k), 0.0)
    if real_pole is None:
        raise ParameterError(f"real_pole must be given for the {scheme} scheme (third order); got None")
    p = positive_scalar("real_pole", real_pole)
    kf = (m * (wn * wn + 2.0 * zeta * wn * p) / kp - 1.0) / k
    if kf < 0.0:
        raise ParameterError(
            f"cannot place the poles with stiffness k_P = {kp:.6g} N/m: it needs force_gain "
            f"k_F = {kf:.6g} m/N < 0; expected m (ω_n² + 2 ζ ω_n p) >= k_P"
        )
    return ForceGains(m * (2.0 * zeta * wn + p), kf, m * wn * wn * p / (kp * k))


def sampled_stability_limit(
    axis: ForceLoopAxis,
    sample_time: float,
    *,
    arm_inertia: float | None = None,
    low: float = 1.0,
    high: float = 1e12,
    rtol: float = 1e-6,
) -> float:
    """The largest environment stiffness k [N/m] for which the sampled loop stays stable.

    The boundary is the smallest k at which the largest pole modulus ρ(k) of the sampled loop
    (:meth:`ForceLoopAxis.sampled`) reaches 1: k is doubled from ``low`` until ρ >= 1, and the
    crossing inside the last doubling is found with Brent's method (``scipy.optimize.brentq``) on
    ``ρ − 1`` in ln k (:func:`~forcecontrol.analysis.sampled_contact.first_crossing`).

    With ``arm_inertia`` m_x the contact is an undamped oscillator of θ = Ts √(k / m_x) radians per
    sample. At θ = π (the contact's frequency at the Nyquist frequency) ρ = 1, and just below it
    the loop has a narrow window of slow growth (ρ − 1 of order 1e-6 per sample, found on every
    loop tried); beyond π, windows recur near every θ = nπ. The search therefore ends at
    θ = π: the limit is the first crossing below it, and never more than ``m_x (π / Ts)²``.

    Args:
        axis: the loop (its own environment_stiffness is ignored).
        sample_time: Ts [s].
        arm_inertia: the arm's operational mass along the axis m_x [kg] (see :func:`operational_mass`);
            None: exact inverse dynamics, a double integrator.
        low, high: search range [N/m]; rtol: relative tolerance of the result.

    Returns:
        The limit [N/m] (the stable side of the final bracket); ``inf`` when stable up to ``high``.

    Raises:
        ParameterError: the loop is already unstable at ``low``.
    """
    from .sampled_contact import first_crossing

    low = positive_scalar("low", low)
    high = positive_scalar("high", high)
    rtol = positive_scalar("rtol", rtol)
    Ts = positive_scalar("sample_time", sample_time)
    mx = None if arm_inertia is None else positive_scalar("arm_inertia", arm_inertia)
    tol = 0.25 * math.log1p(rtol)  # in u = ln k: the relative tolerance rtol on k

    def margin(u: float) -> float:
        return axis.with_environment_stiffness(math.exp(u)).spectral_radius(Ts, mx) - 1.0

    a = math.log(low)
    if margin(a) >= 0.0:
        raise ParameterError(f"the sampled loop is unstable already at low = {low:.6g} N/m; expected a stable start")
    top = math.log(high)
    nyquist = mx is not None and 2.0 * math.log(math.pi * (1.0 - 1e-7) / Ts) + math.log(mx) < top
    if nyquist:  # θ = π (1 − 1e-7): inside the window below the Nyquist point (see above)
        top = 2.0 * math.log(math.pi * (1.0 - 1e-7) / Ts) + math.log(mx)
    u = first_crossing(margin, a, top, tol)
    if u is not None:
        return math.exp(u)
    return math.exp(top) if nyquist else math.inf


def force_loop_axes(controller: Any, environment_stiffness: Any) -> list[ForceLoopAxis]:
    """The per-axis linearised loops of a direct force controller on an environment of stiffness K.

    Args:
        controller: an :class:`~forcecontrol.controllers.force.InnerPositionForceController`,
            :class:`~forcecontrol.controllers.force.InnerVelocityForceController` or
            :class:`~forcecontrol.controllers.force.ParallelForcePositionController` with diagonal
            M_d, K_D, K_P.
        environment_stiffness: K (m, m) [N/m] (scalar or (m,) allowed), in the base frame; with the
            controller's gains it must be diagonal in the controller's task frame (the base frame
            unless the controller has a ``task_frame``), where the axes are then numbered.

    Raises:
        ParameterError: a matrix is not diagonal (the axes do not decouple) or the controller is
            not a direct force controller.
    """
    from ..controllers.force import (
        InnerPositionForceController,
        InnerVelocityForceController,
        ParallelForcePositionController,
    )

    names: dict[type, str] = {
        InnerPositionForceController: "inner-position",
        InnerVelocityForceController: "inner-velocity",
        ParallelForcePositionController: "parallel",
    }
    scheme = names.get(type(controller))
    if scheme is None:
        raise ParameterError(
            "controller must be an InnerPositionForceController, InnerVelocityForceController or "
            f"ParallelForcePositionController; got {type(controller).__name__}"
        )
    m = controller.m
    K = as_square(f"environment_stiffness must be a scalar, ({m},) or ({m}, {m})", environment_stiffness, m)
    R = getattr(controller, "task_frame", None)
    frame = "the base frame" if R is None else "the controller's task frame"
    R = np.eye(m) if R is None else np.asarray(R)
    mats = {name: R.T @ np.asarray(M) @ R for name, M in (("inertia", controller.inertia), ("damping", controller.damping),
                                                          ("stiffness", controller.stiffness), ("environment_stiffness", K))}
    for name, M in mats.items():
        if np.any(np.abs(M - np.diag(np.diag(M))) > 1e-9 * max(1.0, float(np.max(np.abs(M))))):
            raise ParameterError(
                f"{name} must be diagonal for a per-axis analysis in {frame} (Sect. 9.4); "
                f"got {np.round(M, 9).tolist()} there"
            )
    controller_inertia, controller_damping, controller_stiffness = mats["inertia"], mats["damping"], mats["stiffness"]
    K = mats["environment_stiffness"]
    return [
        ForceLoopAxis(
            scheme, float(controller_inertia[i, i]), float(controller_damping[i, i]),
            float(controller_stiffness[i, i]), float(controller.force_gain[i]),
            float(controller.integral_gain[i]), float(K[i, i]), getattr(controller, "integrator_start", None),
        )
        for i in range(m)
    ]


def operational_mass(robot: Any, q: Any, direction: Any) -> float:
    """The arm's mass seen by a force along a unit direction ν at q: ``1 / (νᵀ J B⁻¹ Jᵀ ν)`` [kg].

    This is what an uncompensated change of the contact force accelerates within one sample.
    """
    q = np.asarray(q, dtype=np.float64)
    nu = np.asarray(direction, dtype=np.float64)
    nu = nu / np.linalg.norm(nu)
    J = robot.jacobian(q)
    B = robot.mass_matrix(q)
    return float(1.0 / (nu @ J @ np.linalg.solve(B, J.T) @ nu))
