"""Friction's effect on surface following in an estimated frame (issue 31, items 2 and 5): closed forms.

Setting: a tool sliding at the speed v over an elastic surface with Coulomb friction (kinetic coefficient
μ_k, viscous b; :class:`~forcecontrol.environments.friction.FrictionalContact`) under the hybrid scheme
(9.77)–(9.84) in the constraint frame estimated online
(:class:`~forcecontrol.task.estimation.ConstraintFrameEstimator`). f_n is the normal force, s the sliding
direction (the tip's velocity, tangent to the surface). Conventions of the chapter: h_e is the force the
tool exerts on the environment, n points into the surface.

1. **The tangential force.** While sliding, the friction on the tool is −(μ_k f_n + b v) s, so the measured
   wrench is ``h_e = f_n n + f_t s`` with ``f_t = μ_k f_n + b v`` (:func:`sliding_friction_force`); below
   μ_s f_n the tool sticks (the environment's own model; no analysis needed).

2. **The measured force tilts.** h_e makes the angle ``θ_μ = atan(f_t/f_n)`` (= atan μ_k without viscous
   friction) with the true normal, towards the direction of motion (:func:`friction_tilt`). The estimate's
   lag tilts it the same way on a convex contour (the normal a moment ago, behind the tool, leans towards
   the motion): e = δ, δ = atan(vτ/ρ) (:func:`~forcecontrol.task.estimation.circle_lag`). An estimator that
   takes the force's direction for the normal (friction *not* removed) follows the tilted direction, lagging
   it by δ: ``e = θ_μ + δ``. Removing the force's component along the measured velocity (the estimator's
   default while sliding) leaves ``h_e − (h_e·s) s = f_n n``: ``e = δ`` (:func:`estimated_normal_error`).

3. **The normal force loop.** n̂ at the angle e from n towards s couples friction into λ twice:

   * the projection: ``λ = n̂ᵀh_e = f_n (cos e + (f_t/f_n) sin e)``;
   * the rate: the planar tangent is n̂ turned by 90°, so the velocity loop drives the tool along a direction e
     off the true tangent while it slides along the true one: λ̇ is measured as k̂ n̂ᵀẋ = k̂ v sin e, and the
     regulated error of :mod:`forcecontrol.analysis.surface_following` becomes
     ``e_λ = k̂ (v² cos e / ρ + K_Dλ v sin e) / K_Pλ`` with e in place of δ.

   So ``λ* = f_d − e_λ(e)`` and ``f_n = λ* / (cos e + (f_t/f_n) sin e)`` (:func:`friction_effect`). Friction not
   removed (e = θ_μ + δ), the rate term dominates: k̂ K_Dλ v sin(θ_μ + δ)/K_Pλ = 4.2 N of 10 N at μ_k = 0.2,
   v = 5 cm/s, k̂ = 10⁴ N/m, K_Dλ/K_Pλ = 0.04 s (the force loop presses less, the motion loop steering
   out of the surface); removed (e = δ): the lag's terms and the leak μ_k f_n sin δ only.

4. **Through the arm's Jacobian.** The inverse-dynamics inner loop (9.30) adds Jᵀh_e with the *measured*
   wrench, so the friction force, like the normal force, is fed forward exactly: to first order it disturbs
   neither the motion loop along S_v nor the force loop beyond 3. With an inexact model the friction is a
   disturbance f_t along the tangent, rejected by the velocity loop's integral (9.80) in steady state; its
   transient coupling into λ is through the model's error, which this first-order analysis does not state.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import ParameterError

__all__ = ["sliding_friction_force", "friction_tilt", "estimated_normal_error", "friction_normal_force", "FrictionEffect",
           "friction_effect"]


def sliding_friction_force(normal_force: float, kinetic: float, viscous: float = 0.0, speed: float = 0.0) -> float:
    """f_t = μ_k f_n + b v [N]: the tangential force while sliding (item 1 of the module docstring)."""
    fn = nonnegative_scalar("normal_force", normal_force, "N")
    mu = nonnegative_scalar("kinetic", kinetic, "-")
    b = nonnegative_scalar("viscous", viscous, "N s/m")
    v = nonnegative_scalar("speed", speed, "m/s")
    return mu * fn + b * v


def friction_tilt(kinetic: float, viscous: float = 0.0, speed: float = 0.0, normal_force: float = 1.0) -> float:
    """θ_μ = atan(f_t/f_n) [rad]: the measured force's angle from the true normal, towards the motion
    (= atan μ_k without viscous friction; ``normal_force`` matters only with ``viscous``)."""
    fn = positive_scalar("normal_force", normal_force, "N")
    return math.atan2(sliding_friction_force(fn, kinetic, viscous, speed), fn)


def estimated_normal_error(kinetic: float, *, removed: bool, lag: float = 0.0, viscous: float = 0.0, speed: float = 0.0,
                           normal_force: float = 1.0) -> float:
    """The estimate's steady angle from the true normal [rad], positive towards the motion: θ_μ + δ when the
    friction is not removed, δ when it is (``lag`` δ >= 0 on a convex contour, e.g.
    :func:`~forcecontrol.task.estimation.circle_lag`)."""
    d = nonnegative_scalar("lag", lag, "rad")
    if removed:
        nonnegative_scalar("kinetic", kinetic, "-")
        return d
    return friction_tilt(kinetic, viscous, speed, normal_force) + d


def friction_normal_force(regulated_force: float, kinetic: float, error_angle: float) -> float:
    """f_n [N] when the force loop holds λ = n̂ᵀh_e at ``regulated_force`` with n̂ at ``error_angle`` e [rad] from
    the true normal towards the motion: ``f_n = λ/(cos e + μ_k sin e)`` (item 3, the projection)."""
    lam = positive_scalar("regulated_force", regulated_force, "N")
    mu = nonnegative_scalar("kinetic", kinetic, "-")
    e = float(error_angle)
    den = math.cos(e) + mu * math.sin(e)
    if not (math.isfinite(e) and den > 0.0):
        raise ParameterError(f"error_angle must leave n̂ within 90° of the force; got {error_angle!r} rad with kinetic = {mu!r}")
    return lam / den


@dataclass(frozen=True)
class FrictionEffect:
    """Friction's steady effect on a circle, with the friction removed and not (module docstring). Forces [N], angles [rad].

    Attributes:
        tilt: θ_μ = atan(f_t/f_n) at the removed case's normal force.
        lag: δ, the estimate's lag (convex contour).
        error_removed, error_not_removed: e, the estimate's angle from the true normal towards the motion.
        regulated_removed, regulated_not_removed: λ* = f_d − e_λ(e), the force along n̂.
        normal_force_removed, normal_force_not_removed: f_n.
        tangential_force_removed, tangential_force_not_removed: f_t = μ_k f_n + b v.
    """

    tilt: float
    lag: float
    error_removed: float
    error_not_removed: float
    regulated_removed: float
    regulated_not_removed: float
    normal_force_removed: float
    normal_force_not_removed: float
    tangential_force_removed: float
    tangential_force_not_removed: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def friction_effect(desired_force: float, speed: float, radius: float, stiffness: float, force_gain: float,
                    force_rate_gain: float, time_constant: float, kinetic: float, *, viscous: float = 0.0,
                    stiffness_estimate: float | None = None, sample_time: float | None = None) -> FrictionEffect:
    """Items 1–3 of the module docstring on a convex circle (the arguments of
    :func:`~forcecontrol.analysis.surface_following.surface_following_error`, plus μ_k = ``kinetic`` and b =
    ``viscous`` [N s/m]): the steady estimate error, regulated and normal force, friction removed and not."""
    from ..task.estimation import circle_lag

    f_d = positive_scalar("desired_force", desired_force, "N")
    v = nonnegative_scalar("speed", speed, "m/s")
    R = positive_scalar("radius", radius, "m")
    k = positive_scalar("stiffness", stiffness, "N/m")
    kp = positive_scalar("force_gain", force_gain, "1/s²")
    kd = nonnegative_scalar("force_rate_gain", force_rate_gain, "1/s")
    tau = positive_scalar("time_constant", time_constant, "s")
    mu = nonnegative_scalar("kinetic", kinetic, "-")
    b = nonnegative_scalar("viscous", viscous, "N s/m")
    k_hat = k if stiffness_estimate is None else positive_scalar("stiffness_estimate", stiffness_estimate, "N/m")
    if not f_d / k < R:
        raise ParameterError(f"desired_force / stiffness must be below radius; got {f_d / k:.6g} m for radius {R:.6g} m")
    out = []
    for removed in (True, False):
        fn = f_d
        for _ in range(100):  # fixed point: ρ, θ_μ (viscous) and f_n depend on each other weakly
            rho = R - fn / k
            delta = circle_lag(v, rho, tau, sample_time)
            theta = math.atan2(mu * fn + b * v, fn)
            e = delta if removed else theta + delta
            lam = f_d - k_hat * (v * v * math.cos(e) / rho + kd * v * math.sin(e)) / kp
            if not lam > 0.0:
                raise ParameterError(f"the force loop would lose contact (λ* = {lam:.4g} N <= 0) at this speed and friction")
            new = lam / (math.cos(e) + math.tan(theta) * math.sin(e))
            done = abs(new - fn) < 1e-12
            fn = new
            if done:
                break
        out.append((e, lam, fn, mu * fn + b * v, theta, delta))
    (e_on, lam_on, fn_on, ft_on, theta, delta), (e_off, lam_off, fn_off, ft_off, _, _) = out
    return FrictionEffect(tilt=theta, lag=delta, error_removed=e_on, error_not_removed=e_off, regulated_removed=lam_on,
                          regulated_not_removed=lam_off, normal_force_removed=fn_on, normal_force_not_removed=fn_off,
                          tangential_force_removed=ft_on, tangential_force_not_removed=ft_off)
