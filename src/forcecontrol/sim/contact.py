"""The contact's fastest mode, the RK4 step it needs, and the guard against a contact RK4 cannot follow.

:func:`choose_substeps` picks the RK4 substeps per sample from :func:`contact_rate` (``ω h <= 0.05``);
an explicit ``substeps`` must at least keep ``ω h <= RK4_STABILITY`` (:func:`forcecontrol.sim.limits.check_substeps`);
during a run, a contact met where ``ω h`` exceeds that bound stops the run (status 5 of the loops).
"""

from __future__ import annotations

import math

import numpy as np

from ..environments.base import Environment
from ..robots.base import RobotModel
from .limits import RK4_STABILITY

__all__ = ["contact_mobility", "choose_substeps", "contact_rate"]

def contact_mobility(robot: RobotModel, q0: np.ndarray) -> np.ndarray:
    """``B_x⁻¹ = J B⁻¹ Jᵀ`` at q0 (any Jacobian shape), what :func:`choose_substeps` weighs the
    contact stiffness with. Raises ``numpy.linalg.LinAlgError`` when B is singular."""
    J = np.asarray(robot.jacobian(q0))
    return J @ np.linalg.solve(np.asarray(robot.mass_matrix(q0)), J.T)


def _largest_real_eigenvalue(A: np.ndarray) -> float:
    """The largest real part among A's eigenvalues; a 2 x 2 (the planar task) in closed form,
    ``tr/2 + sqrt((tr/2)² − det)`` (a tenth of ``numpy.linalg.eigvals``' cost: a sweep calls this
    once per case built), larger matrices (and a 2 x 2 whose square overflows) by ``eigvals``."""
    if A.shape == (2, 2):
        a, b, c, d = A.ravel().tolist()  # Python floats: an overflow is inf, without NumPy's warning
        half = 0.5 * (a + d)
        disc = half * half - (a * d - b * c)
        if math.isfinite(half) and math.isfinite(disc):
            return float(half + math.sqrt(disc)) if disc > 0.0 else float(half)
        # entries beyond 1e154 overflow the square, or a NaN: eigvals (which refuses a non-finite matrix)
    return float(np.max(np.linalg.eigvals(A).real))


def choose_substeps(robot: RobotModel, environment: Environment, q0: np.ndarray, sample_time: float, *,
                    mobility: np.ndarray | None = None) -> int:
    """Integration substeps per sample so that the stiffest contact mode is resolved.

    ω is the fastest contact mode at q0 (:func:`contact_rate`); the RK4 step h is chosen with
    ``ω h <= 0.05`` (relative error per step below 1e-8), and at least 1. ``mobility``:
    :func:`contact_mobility` at q0, when the caller already has it (a sweep over the environment
    keeps the arm and q0).
    """
    rate = contact_rate(robot, environment, q0, mobility=mobility)
    return max(1, int(math.ceil(rate * sample_time / 0.05)))


def contact_rate(robot: RobotModel, environment: Environment, q: np.ndarray, *, mobility: np.ndarray | None = None) -> float:
    """The fastest contact mode at q [rad/s]: what the RK4 step must resolve.

    ``ω² = λ_max(B_x⁻¹ K)`` with ``B_x⁻¹ = J B⁻¹ Jᵀ`` (any Jacobian shape) when the environment
    gives its stiffness matrix K, else the conservative ``k_max / λ_min(B_x)``; a normal damping c
    adds its rate ``c / m``, and the larger of the two is returned. RK4 follows the contact while
    ``rate · h <= RK4_STABILITY`` (:mod:`forcecontrol.sim.limits`).
    """
    k = float(environment.max_stiffness())
    c_attr = getattr(environment, "damping", 0.0)
    c = float(c_attr) if isinstance(c_attr, (int, float)) else 0.0  # a scalar damping along the normal [N s/m]
    try:
        if mobility is None:
            mobility = contact_mobility(robot, q)
        K = getattr(environment, "stiffness_matrix", None)
        K = None if K is None else np.asarray(K(), dtype=np.float64)
        if K is not None and K.shape == mobility.shape:
            # the contact modes themselves: ω² = eigenvalues of B_x⁻¹ K (both PSD, so real, >= 0);
            # a normal damping c acts on the same mode: rate c/m_eff = (c/k) ω²
            w2 = max(_largest_real_eigenvalue(mobility @ K), 0.0)
            omega, damping_rate = math.sqrt(w2), (c / k * w2 if k > 0 else 0.0)
        else:
            # a point contact (a surface's or friction's force at the end-effector origin, no moment: ``space``
            # components of the wrench) moves the arm through the translational block of the mobility only; the
            # whole 6 x 6 mixed in the wrist's rotational mobility [1/(kg m²)] and asked 61 RK4 substeps a sample
            # of the Panda on a surface where its table (stiffness_matrix) asked 2
            space = getattr(environment, "space", None)
            M = mobility[:space, :space] if isinstance(space, int) and 0 < space < mobility.shape[0] else mobility
            lam = 1.0 / float(np.linalg.eigvalsh(0.5 * (M + M.T)).max())
            omega, damping_rate = math.sqrt(max(k, 0.0) / max(lam, 1e-9)), c / max(lam, 1e-9)
    except (np.linalg.LinAlgError, ZeroDivisionError):
        lam = float(np.linalg.eigvalsh(np.asarray(robot.mass_matrix(q))).min())
        omega, damping_rate = math.sqrt(max(k, 0.0) / max(lam, 1e-9)), c / max(lam, 1e-9)
    return max(omega, damping_rate)


def _unresolved_note(robot: RobotModel, environment: Environment, q: np.ndarray, h: float) -> str:
    """Why the contact at q is not resolved by the RK4 step h (the message of status 5)."""
    rate = contact_rate(robot, environment, q)
    need = int(math.ceil(rate * h / RK4_STABILITY))
    return (f"the contact's fastest mode there, {rate:.4g} rad/s (stiffness {float(environment.max_stiffness()):.4g} N/m), "
            f"makes rate · h = {rate * h:.3g} with the RK4 step h = {h:.4g} s, beyond RK4's stability bound "
            f"{RK4_STABILITY}: the integrator cannot follow the penetration within one step (at least {need}x more "
            "substeps, a softer contact or a shorter sample time)")


def _contact_guarded(environment: Environment) -> bool:
    """An elastic contact of finite stiffness (a rigid one's constraint is stabilised, not integrated as a spring)."""
    from ..environments.rigid import RigidEnvironment

    k = float(environment.max_stiffness())
    return math.isfinite(k) and k > 0.0 and not isinstance(environment, RigidEnvironment)


def _unresolved_in_log(
    robot: RobotModel, environment: Environment, logs: dict[str, np.ndarray], h: float, last: int
) -> tuple[int, int, str]:
    """(5, sample, note) for the first logged sample (up to ``last``) in contact whose contact mode RK4
    cannot follow at step h, else (0, 0, ""). At most 256 samples in contact are checked, evenly
    spread (the mode changes with the configuration, slowly), the last one always."""
    if not _contact_guarded(environment):
        return 0, 0, ""
    w = logs["wrench"][: last + 1]
    touching = np.flatnonzero(np.any((w != 0.0) & np.isfinite(w), axis=1))
    if touching.size == 0:
        return 0, 0, ""
    picks = touching[np.unique(np.linspace(0, touching.size - 1, min(256, touching.size)).astype(np.int64))]
    for k in picks:
        try:
            rate = contact_rate(robot, environment, logs["q"][k])
        except np.linalg.LinAlgError:
            continue
        if rate * h > RK4_STABILITY:
            return 5, int(k), _unresolved_note(robot, environment, logs["q"][k], h)
    return 0, 0, ""
