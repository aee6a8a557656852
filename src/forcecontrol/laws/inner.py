"""The inverse-dynamics inner loop (9.30), shared by every inverse-dynamics scheme."""

from __future__ import annotations

import math
from typing import Any

from numba import njit

from ..core.linalg import solve2, solve_in_place


@njit(cache=True, inline="always")
def inverse_dynamics(B, nv, J, Jdq, a, hc, compensate, ws, u):  # pragma: no cover - compiled
    """(9.30): ``u = B(q) y + n(q, q̇) [+ Jᵀ(q) h_c]`` with ``y = J⁻¹(q) (a − J̇ q̇)``.

    The operational-space acceleration ``a`` is what each scheme chooses: impedance (9.28)/(9.31),
    inner position loop (9.39), inner velocity loop (9.45), parallel (9.48), hybrid (9.77)/(9.91).
    ``h_c`` is the measured wrench h_e (it cancels the contact force, (9.30)) or, on a rigid
    environment, the commanded ``S_f f_λ`` of (9.91).

    Args:
        B: inertia matrix (n, n); nv: ``C q̇ + F q̇ + g`` (n,); J: the Jacobian, square (m, m);
            Jdq: ``J̇ q̇`` (m,); a: the requested acceleration (m,); hc: the wrench to compensate (m,).
        compensate: add ``Jᵀ h_c``.
        ws: scratch of at least m² + m floats.
        u: the torques (n,), written.

    Returns:
        False (and u = NaN) when J is numerically singular.

    For m = n = 2 (the chapter's arm) the same operations run in the same order on scalars, with
    no scratch: the results are those of the general path to the bit (tested), and inside the
    compiled loop, whose sizes are constants, the compiler keeps them in registers.
    """
    if a.shape[0] == 2 and B.shape[0] == 2:  # the chapter's arm: the same operations, in the same order, on scalars
        return inverse_dynamics_2x2(B, nv, J, Jdq, a, hc, compensate, ws, u)
    return _inverse_dynamics_general(B, nv, J, Jdq, a, hc, compensate, ws, u)


@njit(cache=True, inline="always")
def inverse_dynamics_2x2(B, nv, J, Jdq, a, hc, compensate, ws, u):  # pragma: no cover - compiled
    """:func:`inverse_dynamics` for m = n = 2 (the chapter's arm), on scalars; other sizes: u = NaN, False.

    The inner loop of the laws built for the chapter's arm (:func:`on_planar_arm`): without the
    general path, a law compiles in 0.8 s less on a cold cache.
    """
    if a.shape[0] != 2 or B.shape[0] != 2:
        for i in range(u.shape[0]):
            u[i] = math.nan
        return False
    c0 = 0.0 + J[0, 0] * hc[0] + J[1, 0] * hc[1]  # Jᵀ h_c, off the solve's critical path
    c1 = 0.0 + J[0, 1] * hc[0] + J[1, 1] * hc[1]
    ok, y0, y1 = solve2(J[0, 0], J[0, 1], J[1, 0], J[1, 1], a[0] - Jdq[0], a[1] - Jdq[1])
    u0 = nv[0] + B[0, 0] * y0 + B[0, 1] * y1
    u1 = nv[1] + B[1, 0] * y0 + B[1, 1] * y1
    if compensate:
        u0 += c0
        u1 += c1
    u[0] = u0 if ok else math.nan
    u[1] = u1 if ok else math.nan
    return ok


@njit(cache=True)
def _inverse_dynamics_general(B, nv, J, Jdq, a, hc, compensate, ws, u):  # pragma: no cover - compiled
    """:func:`inverse_dynamics` for any m and n (its general path, with the LU solve).

    Compiled once as a function of its own (cached, shared by every law) rather than inlined:
    Numba's inliner copies an inlined function's IR once per variable scope and block at each
    level, and this path with its inlined LU solve made every law cost 1 s more to compile.
    """
    m = a.shape[0]
    n = B.shape[0]
    y = ws[0:m]
    for i in range(m):
        y[i] = a[i] - Jdq[i]
    if not solve_in_place(J, y, ws[m : m + m * m]):
        for i in range(n):
            u[i] = math.nan
        return False
    for i in range(n):
        acc = nv[i]
        for j in range(n):
            acc += B[i, j] * y[j]
        u[i] = acc
    if compensate:
        for i in range(n):
            acc = 0.0
            for j in range(m):
                acc += J[j, i] * hc[j]
            u[i] += acc
    return True


def inverse_dynamics_law(acceleration: Any, name: str) -> Any:
    """The torque law of an inverse-dynamics scheme: its ``acceleration`` through the inner loop (9.30).

    ``acceleration(t, dt, x, ẋ, h, ref, p, s, ws, a, h_c) -> compensate`` is the scheme's own
    equation (it writes the requested ``a`` and the wrench ``h_c`` the loop compensates); the
    returned law has the common signature of :mod:`forcecontrol.laws`. Compiled once per scheme,
    with the acceleration inlined, and cached on disk under a name-derived identity.
    Its twin for the chapter's arm, the same acceleration through :func:`inverse_dynamics_2x2`,
    is :func:`on_planar_arm`'s answer for it.
    """
    fn = _composed(acceleration, inverse_dynamics, name)
    planar = _composed(acceleration, inverse_dynamics_2x2, f"{name}_planar")
    _ON_PLANAR_ARM[fn] = planar
    _PARTS[fn] = (acceleration, inverse_dynamics)
    _PARTS[planar] = (acceleration, inverse_dynamics_2x2)
    return fn


def _composed(acceleration: Any, inner: Any, name: str) -> Any:
    """``acceleration`` through ``inner`` (:func:`inverse_dynamics` or its 2 x 2 path), compiled as ``name``."""

    def law(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, ws, u):  # pragma: no cover - compiled
        m = x.shape[0]  # (the kernels that call the two parts themselves, see law_parts, call them so too)
        comp = acceleration(t, dt, x, xd, h, ref, p, s, ws[2 * m :], ws[0:m], ws[m : 2 * m])
        return inner(B, nv, J, Jdq, ws[0:m], ws[m : 2 * m], comp, ws[2 * m :], u)

    law.__name__ = law.__qualname__ = name
    law.__module__ = acceleration.py_func.__module__
    law.__doc__ = (f"{name}: :func:`{acceleration.py_func.__name__}` through the inner loop (9.30) "
                   f"(:func:`{inner.py_func.__name__}`).")
    fn = njit(cache=True, inline="always")(law)
    if fn._MemoMixin__uuid is None:  # named at creation (core.numba_cache) unless Numba's dispatcher was not patched
        fn._set_uuid(f"forcecontrol:{law.__module__}.{name}")
    return fn


_ON_PLANAR_ARM: dict[Any, Any] = {}
_PARTS: dict[Any, Any] = {}


def law_parts(law: Any) -> tuple[bool, Any, Any]:
    """``(True, acceleration, inner)`` of an inverse-dynamics law (or of its twin for the chapter's arm), else
    ``(False, law, law)``.

    A compiled kernel that calls these two in turn, as the law does (``comp = acceleration(t, dt,
    x, ẋ, h, ref, p, s, ws[2m:], ws[:m], ws[m:2m])``, then ``inner(B, n, J, J̇q̇, ws[:m], ws[m:2m],
    comp, ws[2m:], u)``), runs the law's operations in the law's order, and compiles about 0.5 s
    faster per law than one that calls the law: Numba inlines a function by copying its IR, once
    per level it is inlined through, and the acceleration is the bulk of the law. The flag is a
    constant of the kernel, so Numba compiles only the branch it selects.
    """
    parts = _PARTS.get(law)
    return (True, *parts) if parts is not None else (False, law, law)


def on_planar_arm(law: Any) -> Any:
    """The law to compile into a kernel for the chapter's arm (m = n = 2): the same equations, not its general sizes.

    An inverse-dynamics law (:func:`inverse_dynamics_law`) has a twin whose inner loop is
    :func:`inverse_dynamics_2x2`: the operations the law runs for m = n = 2, in the same order
    (results equal to the bit), without compiling the general path it never takes there (LU
    solve; 0.8 s of a cold first run). Any other law is returned as it is.
    """
    return _ON_PLANAR_ARM.get(law, law)
