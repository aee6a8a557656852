"""The normal-force error to expect when following a curved surface in an estimated frame (issue 31, item 5).

Setting: the compliant hybrid scheme (9.77), (9.80)–(9.82) in the constraint frame estimated online
(:class:`~forcecontrol.task.estimation.ConstraintFrameEstimator`, first-order filter of time
constant τ), the tool outside a convex contour of radius R (a circle, or a sphere's or cylinder's
great circle) of stiffness k, traced at the tangential speed v with the desired normal force f_d; the
controller's stiffness estimate is k̂ = 1/ĉ. Steady tracing, the tip runs on the circle of radius
ρ = R − f_n/k at the angular rate ω = v/ρ.

Derivation. The inverse-dynamics inner loop makes ẍ = α = S_v α_ν + ĉ S_f f_λ exactly (the
chapter's (9.77) with Ĉ′ S_f = ĉ n̂ for an orthonormal estimated frame). On the circle the tip's
acceleration is the centripetal one, v²/ρ towards the centre, i.e. along the true normal n, and the
estimate n̂ lags n by δ = atan(ωτ) (see :func:`~forcecontrol.task.estimation.circle_lag`). So

* n̂ᵀẍ = (v²/ρ) cos δ = ĉ f_λ: the force loop must supply the centripetal acceleration;
* λ̇ is measured as L̂ ẋ = k̂ n̂ᵀẋ (9.82), and ẋ (along the true tangent) has the component
  v sin δ along the lagging n̂ (the "tangential leak" of the motion into the force direction), while
  λ_d is constant: λ̇_d − λ̇ = −k̂ v sin δ;
* (9.81) in steady state, f_λ = K_Dλ (λ̇_d − λ̇) + K_Pλ (λ_d − λ), gives the regulated error

      e_λ = λ_d − λ = (k̂ / K_Pλ) (v²/ρ · cos δ + K_Dλ v sin δ)
                    = k̂ v² cos δ / (ρ ω_f²) + 2 ζ k̂ v sin δ / ω_f      (K_Pλ = ω_f², K_Dλ = 2ζω_f)

  the first term is the curvature demand seen through the force loop's bandwidth ω_f (the
  centripetal acceleration v²/ρ turned into a force error by k̂/ω_f²: for a known frame it is the
  whole error), the second the frame-lag term;
* the regulated λ = n̂ᵀh_e is the force along the wrong normal: with a frictionless contact h_e is
  along n, so the true normal force is f_n = λ / cos δ (the cosine error λ (1/cos δ − 1) ≈ f_d (1 − cos δ))
  and the estimated tangent sees f_n sin δ of it (the tangential force leak).

Bound. |f_d − f_n| <= e_λ + λ (1/cos δ − 1) with every term non-negative on a convex contour (they
add: this is the bound and, in steady state, the value; the tests find the simulation within 2 %).
On a concave contour (tool inside) the curvature term changes sign and the bound is the sum of the
magnitudes. With integral force action (the parallel scheme (9.48) with (9.43) in the estimated frame)
both constant terms are integrated away: λ = f_d and f_n = f_d / cos δ, the cosine error alone.
Friction adds μ f_n sin δ to λ (its component along the lagging normal), not modelled here: see
:mod:`forcecontrol.analysis.friction`.

A surface of varying curvature (a height field: crests, inflections, troughs) traced slowly against the
force loop (the curvature changing over a time much longer than 1/ω_f and τ) is, at each point, a circle
of the local normal curvature κ along the path: :func:`path_following_bound` evaluates the bound at the
largest |κ| met (ρ = 1/|κ| − f_d/k: the convex side's, the larger error; on the concave side the
curvature term changes sign and its magnitude is smaller).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import ParameterError
from ..task.estimation import circle_lag

__all__ = ["SurfaceFollowingError", "surface_following_error", "path_following_bound"]


@dataclass(frozen=True)
class SurfaceFollowingError:
    """The steady normal-force error on a circle (see the module docstring). Forces [N], angles [rad].

    Attributes:
        lag: δ, the estimate's lag behind the true normal.
        tip_radius: ρ = R − f_n/k [m].
        curvature_error: k̂ v² cos δ / (ρ K_Pλ), the centripetal demand through the force loop.
        lag_error: k̂ K_Dλ v sin δ / K_Pλ, the tangential velocity leaking into λ̇.
        regulated_force: λ = f_d − curvature_error − lag_error, the force along the estimated normal.
        cosine_error: λ (1/cos δ − 1), the true normal force above λ.
        normal_force: f_n = λ / cos δ, the true normal force.
        tangential_leak: f_n sin δ, the contact force along the estimated tangent.
        bound: |f_d − f_n| <= curvature_error + lag_error + cosine_error.
    """

    lag: float
    tip_radius: float
    curvature_error: float
    lag_error: float
    regulated_force: float
    cosine_error: float
    normal_force: float
    tangential_leak: float
    bound: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def surface_following_error(desired_force: float, speed: float, radius: float, stiffness: float, force_gain: float,
                            force_rate_gain: float, time_constant: float, *, stiffness_estimate: float | None = None,
                            sample_time: float | None = None, integral_action: bool = False) -> SurfaceFollowingError:
    """The steady normal-force error tracing a convex circle of ``radius`` [m] and ``stiffness`` k [N/m] at
    ``speed`` v [m/s] with ``desired_force`` f_d [N], force gains K_Pλ = ``force_gain`` [1/s²] and
    K_Dλ = ``force_rate_gain`` [1/s] of (9.81), the frame estimated with the first-order ``time_constant``
    τ [s] (the discrete filter's lag when ``sample_time`` is given); k̂ = ``stiffness_estimate``
    (default: k). With ``integral_action`` (the parallel scheme (9.48) with the PI (9.43) in the estimated
    frame) the integral removes the constant curvature and lag terms in steady state: λ = f_d and only the
    cosine error remains (the gains are then unused). Derivation and assumptions in the module docstring.
    """
    f_d = positive_scalar("desired_force", desired_force, "N")
    v = nonnegative_scalar("speed", speed, "m/s")
    R = positive_scalar("radius", radius, "m")
    k = positive_scalar("stiffness", stiffness, "N/m")
    kp = positive_scalar("force_gain", force_gain, "1/s²")
    kd = nonnegative_scalar("force_rate_gain", force_rate_gain, "1/s")
    tau = positive_scalar("time_constant", time_constant, "s")
    k_hat = k if stiffness_estimate is None else positive_scalar("stiffness_estimate", stiffness_estimate, "N/m")
    if not f_d / k < R:
        raise ParameterError(f"desired_force / stiffness must be below radius (the tip stays outside the centre); "
                             f"got {f_d / k:.6g} m for radius {R:.6g} m")
    fn = f_d
    for _ in range(50):  # ρ depends on f_n, f_n on ρ: a contraction (the correction is O(f_d/(k R)))
        rho = R - fn / k
        delta = circle_lag(v, rho, tau, sample_time)
        curvature = 0.0 if integral_action else k_hat * v * v * math.cos(delta) / (rho * kp)
        lag = 0.0 if integral_action else k_hat * kd * v * math.sin(delta) / kp
        lam = f_d - curvature - lag
        new = lam / math.cos(delta)
        if abs(new - fn) < 1e-12:
            fn = new
            break
        fn = new
    cosine = lam * (1.0 / math.cos(delta) - 1.0)
    return SurfaceFollowingError(
        lag=delta, tip_radius=rho, curvature_error=curvature, lag_error=lag, regulated_force=lam, cosine_error=cosine,
        normal_force=fn, tangential_leak=fn * math.sin(delta), bound=curvature + lag + abs(cosine),
    )


def path_following_bound(desired_force: float, speed: float, curvatures: Any, stiffness: float, force_gain: float,
                         force_rate_gain: float, time_constant: float, *, stiffness_estimate: float | None = None,
                         sample_time: float | None = None) -> SurfaceFollowingError:
    """The first-order bound on |f_d − f_n| along a path of varying normal curvature ``curvatures`` [1/m]
    (any sign: convex or concave; e.g. sampled along the path), traced at ``speed`` [m/s]: the circle's
    error (:func:`surface_following_error`) at the largest |κ| (module docstring); zero curvature
    everywhere gives a zero bound. Other arguments as for :func:`surface_following_error`."""
    import numpy as np

    k = np.abs(np.asarray(curvatures, dtype=np.float64)).ravel()
    if k.size == 0 or not np.all(np.isfinite(k)):
        raise ParameterError(f"curvatures must be a non-empty array of finite numbers [1/m]; got {k.size} values")
    kmax = float(k.max())
    if kmax == 0.0:
        return SurfaceFollowingError(lag=0.0, tip_radius=math.inf, curvature_error=0.0, lag_error=0.0,
                                     regulated_force=float(desired_force), cosine_error=0.0, normal_force=float(desired_force),
                                     tangential_leak=0.0, bound=0.0)
    return surface_following_error(desired_force, speed, 1.0 / kmax, stiffness, force_gain, force_rate_gain, time_constant,
                                   stiffness_estimate=stiffness_estimate, sample_time=sample_time)
