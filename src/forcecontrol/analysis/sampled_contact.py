"""The sampled contact loop per task axis: spectral radius, speed, and the stability limit in stiffness.

A law held over each sample on the arm in contact (:class:`~forcecontrol.analysis.impedance.HeldLoop`:
impedance (9.30)–(9.31) or (9.28), :func:`~forcecontrol.analysis.impedance.impedance_loop`; active
compliance (8.110), :func:`~forcecontrol.analysis.compliance.compliance_loop`) is one linear loop of
state ``z = [x; ẋ]`` along the base axes. Two axes are coupled when the loop's matrices (``A`` and
``B F``) carry one's position or velocity into the other's acceleration; the axes then split into
groups, the strongly connected components of that coupling. Ordered by group the sampled loop's
matrix ``Φ + Γ F`` is block triangular, so its eigenvalues are those of the groups' diagonal blocks,
and each axis is given the spectral radius of its group's block: whether that group's own motion
settles (< 1) or grows (>= 1).

Example 9.2 (impedance with force measurement, a plane normal to x): the contact axis x is a group
of its own, and y another: the force change within a sample pushes y through the arm's mobility
``J B⁻¹ Jᵀ`` but nothing carries y back into x. On a plane at an angle, or with active compliance
(whose every acceleration goes through the mobility), x and y are one group and share its radius.

The speed of a group is ``ω_n``, the largest |eigenvalue| of the loop's continuous limit (Ts → 0,
``A + B F``) on the group's block; ``ω_n Ts`` says how far the sampled loop is from that limit
(for impedance with force measurement the limit is (9.32), whose ω_n is Example 9.2's).

The stability limit in environment stiffness is the first stiffness at which the radius reaches 1,
found as :func:`~forcecontrol.analysis.force_design.sampled_stability_limit` finds the direct force
schemes' (:func:`first_crossing`: doubling, then Brent's method in ln k).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..core.validate import positive_scalar
from ..errors import ParameterError
from .impedance import HeldLoop

__all__ = ["axis_groups", "axis_spectral_radii", "axis_frequencies", "first_crossing", "stiffness_limit"]


def axis_groups(loop: HeldLoop, *, tol: float = 1e-12) -> list[list[int]]:
    """The axes of a held loop split into coupled groups (strongly connected components), each sorted.

    Axis j drives axis i when an entry of ``A`` or ``B F`` from a state of j (x_j or ẋ_j) to a
    state of i exceeds ``tol`` times that matrix's largest entry (so that the round-off of a plane
    normal written as ``[cos 90°, sin 90°]`` does not couple x and y). Groups are returned in the
    order of their smallest axis.
    """
    m = loop.m
    drive = np.zeros((m, m), dtype=bool)
    for M in (loop.A, loop.B @ loop.F):
        scale = float(np.max(np.abs(M))) if M.size else 0.0
        if scale == 0.0:
            continue
        big = np.abs(M) > tol * scale
        for i in range(m):
            for j in range(m):
                drive[i, j] |= bool(big[np.ix_([i, m + i], [j, m + j])].any())
    reach = drive | np.eye(m, dtype=bool)
    for k in range(m):  # transitive closure (Warshall)
        reach |= reach[:, [k]] & reach[[k], :]
    groups: list[list[int]] = []
    seen: set[int] = set()
    for i in range(m):
        if i in seen:
            continue
        g = [j for j in range(m) if reach[i, j] and reach[j, i]]
        seen.update(g)
        groups.append(g)
    return groups


def _states(group: list[int], m: int) -> list[int]:
    return [*group, *(m + i for i in group)]


def axis_spectral_radii(loop: HeldLoop, sample_time: float) -> np.ndarray:
    """Per base axis, the spectral radius of its group's block of the sampled loop ``Φ + Γ F`` (m,).

    The largest of them is the whole loop's spectral radius (:meth:`HeldLoop.spectral_radius`).
    """
    Acl = loop.closed(sample_time)
    out = np.empty(loop.m)
    for g in axis_groups(loop):
        s = _states(g, loop.m)
        out[g] = float(np.max(np.abs(np.linalg.eigvals(Acl[np.ix_(s, s)]))))
    return out


def axis_frequencies(loop: HeldLoop) -> np.ndarray:
    """Per base axis, ω_n of its group: the largest |eigenvalue| of ``A + B F`` on the group's block (m,) [rad/s]."""
    Ac = loop.continuous()
    out = np.empty(loop.m)
    for g in axis_groups(loop):
        s = _states(g, loop.m)
        out[g] = float(np.max(np.abs(np.linalg.eigvals(Ac[np.ix_(s, s)]))))
    return out


def first_crossing(margin: Callable[[float], float], start: float, top: float, tol: float) -> float | None:
    """The first u in ``(start, top]`` where ``margin(u) >= 0``, given ``margin(start) < 0``.

    ``u`` is advanced in steps of ln 2 (a doubling of k = e^u) until the margin is >= 0; the crossing
    inside that step is found with Brent's method (``scipy.optimize.brentq``, ``xtol = tol``).

    Returns:
        The stable side of the final bracket (``root − tol`` when the margin is >= 0 at the root),
        or None when the margin stays < 0 up to ``top``.
    """
    from scipy.optimize import brentq  # type: ignore[import-untyped]

    a = start
    while a < top:
        b = min(a + math.log(2.0), top)
        if margin(b) >= 0.0:
            root = brentq(margin, a, b, xtol=tol, rtol=4.0 * np.finfo(float).eps)
            return root - tol if margin(root) >= 0.0 else root
        a = b
    return None


def stiffness_limit(radius: Callable[[float], float], *, low: float = 1.0, high: float = 1e12,
                    rtol: float = 1e-6) -> float:
    """The largest environment stiffness k [N/m] with ``radius(k) < 1``, searched from ``low`` up.

    Args:
        radius: k [N/m] -> the spectral radius of the loop at that stiffness.
        low, high: search range [N/m]; rtol: relative tolerance of the result.

    Returns:
        The limit (the stable side of the final bracket); ``inf`` when stable up to ``high``; 0 when
        the loop is unstable already at ``low``.
    """
    low = positive_scalar("low", low, "N/m")
    high = positive_scalar("high", high, "N/m")
    rtol = positive_scalar("rtol", rtol)
    if high <= low:
        raise ParameterError(f"high must be above low; got low = {low!r} N/m and high = {high!r} N/m")
    tol = 0.25 * math.log1p(rtol)

    def margin(u: float) -> float:
        return radius(math.exp(u)) - 1.0

    if margin(math.log(low)) >= 0.0:
        return 0.0
    u = first_crossing(margin, math.log(low), math.log(high), tol)
    return math.inf if u is None else math.exp(u)
