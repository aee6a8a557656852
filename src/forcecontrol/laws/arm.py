"""One step of a control law on the chapter's two-link arm, in one compiled call.

``Controller.step`` on the built-in arm calls :func:`on_arm` of its law: :func:`arm_inputs`
(checks, the arm's terms in closed form, two-link-arm.md), the law, then :func:`arm_finish`,
with no Python in between.
"""

from __future__ import annotations

import math
from typing import Any

from numba import njit, types

from ..core.numba_cache import build_once, kernel_identity, stable_identities
from ..robots.planar_2r import _terms_into
from .inner import law_parts, on_planar_arm
from .layout import REF_X_D, ref_a_d, ref_f_d, ref_fddot_d, ref_fdot_d, ref_size, ref_v_d

__all__ = ["on_arm", "arm_inputs", "arm_finish"]


@njit(cache=True)
def arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws):  # pragma: no cover - compiled
    """Check a step's inputs on the chapter's arm and lay out what a law reads, in ``ws``.

    Returns ``(ok, x, ẋ, J, J̇q̇, B, n, g, ref, rest)`` (views of ``ws``; ``ref`` packed as
    :data:`~forcecontrol.laws.layout.REFERENCE`; ``rest`` is the law's scratch). ``ok`` is False
    when an input has the wrong length or (t, q, q̇, h_e or a reference, used by the law or not) is
    not finite; the terms are then not computed. The state ``s`` is saved for :func:`arm_finish`.
    """
    n = 2
    m = 2
    ok = q.shape[0] == n and qd.shape[0] == n and h.shape[0] == m and x_d.shape[0] == m and v_d.shape[0] == m
    ok = ok and a_d.shape[0] == m and f_d.shape[0] == m and fd_d.shape[0] == m and fdd_d.shape[0] == m
    o = 0
    x = ws[o : o + m]
    o += m
    xd = ws[o : o + m]
    o += m
    J = ws[o : o + m * n].reshape((m, n))
    o += m * n
    Jdq = ws[o : o + m]
    o += m
    B = ws[o : o + n * n].reshape((n, n))
    o += n * n
    nv = ws[o : o + n]
    o += n
    g = ws[o : o + n]
    o += n
    ref = ws[o : o + ref_size(m)]
    o += ref_size(m)
    saved = ws[o : o + s.shape[0]]
    o += s.shape[0]
    if not ok:
        return False, x, xd, J, Jdq, B, nv, g, ref, ws[o:]
    ok = math.isfinite(t)
    for i in range(n):
        ok = ok and math.isfinite(q[i]) and math.isfinite(qd[i])
    for i in range(m):
        ok = ok and math.isfinite(h[i])
        ref[REF_X_D + i] = x_d[i]
        ref[ref_v_d(m) + i] = v_d[i]
        ref[ref_a_d(m) + i] = a_d[i]
        ref[ref_f_d(m) + i] = f_d[i]
        ref[ref_fdot_d(m) + i] = fd_d[i]
        ref[ref_fddot_d(m) + i] = fdd_d[i]
    for i in range(ref_size(m)):
        ok = ok and math.isfinite(ref[i])
    if ok:
        _terms_into(q, qd, K, x, xd, J, Jdq, B, nv, g)
        for i in range(s.shape[0]):
            saved[i] = s[i]
    return ok, x, xd, J, Jdq, B, nv, g, ref, ws[o:]


@njit(cache=True)
def arm_finish(ok, s, ws, u):  # pragma: no cover - compiled
    """After the law ran (its result ``ok``): True when it applied and u is finite; else u = NaN and the state restored."""
    n = u.shape[0]
    for j in range(n):
        ok = ok and math.isfinite(u[j])
    if ok:
        return True
    for j in range(n):
        u[j] = math.nan
    o = 30  # arm_inputs' layout: x, ẋ, J, J̇q̇, B, n, g, ref (2+2+4+2+4+2+2+12), then the saved state
    for i in range(s.shape[0]):  # a failed sample leaves the state as it was
        s[i] = ws[o + i]
    return False


def on_arm(law: Any) -> Any:
    """``law`` on the chapter's arm in one compiled call: what ``Controller.step`` runs there.

    ``on_arm(law)(K, t, dt, q, q̇, h, x_d, ẋ_d, ẍ_d, f_d, ḟ_d, f̈_d, p, s, ws, u) -> ok``: the
    input checks and the arm's terms (:func:`arm_inputs`), the law, and the state restored when
    it failed (:func:`arm_finish`). Built once per law (the law inlined) and cached on disk;
    Python calls it through Numba's typed dispatcher (about 1 µs), whereas passing the law as an
    argument from Python would cost 5 µs of type resolution per call.

    Compiled for one signature, inputs typed read-only (writable arrays convert to it at no cost):
    a reference whose arrays are read-only (a path's constant force) and one whose arrays are
    not run the same machine code, so no new specialisation is compiled or loaded in the middle
    of a user's real-time loop (that cost one 8 ms cycle at the first contact). Inputs of another
    layout (non-contiguous views) raise TypeError, and ``Controller.step`` takes its checked path.
    """
    def build() -> Any:
        stable_identities()
        arm_law = on_planar_arm(law)  # m = n = 2: its general-size path is not compiled
        split, acceleration, inner = law_parts(arm_law)  # an inverse-dynamics law: its two parts called here

        def run(K, t, dt, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, p, s, ws, u):  # pragma: no cover - compiled
            ok, x, xd, J, Jdq, B, nv, g, ref, rest = arm_inputs(K, t, q, qd, h, x_d, v_d, a_d, f_d, fd_d, fdd_d, s, ws)
            if not ok:
                return False
            if split:  # a constant: Numba compiles one branch
                m = x.shape[0]
                comp = acceleration(t, dt, x, xd, h, ref, p, s, rest[2 * m :], rest[0:m], rest[m : 2 * m])
                done = inner(B, nv, J, Jdq, rest[0:m], rest[m : 2 * m], comp, rest[2 * m :], u)
            else:
                done = arm_law(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, rest, u)
            return arm_finish(done, s, ws, u)

        step = njit(_ON_ARM_SIGNATURE, cache=True)(run)
        kernel_identity(step, f"forcecontrol:laws.arm.on_arm:{law._uuid}")  # its own uuid and cache files, per law
        return step

    return build_once(_ON_ARM, law, build)  # once, even from several threads


_ON_ARM: dict[Any, Any] = {}
_IN = types.Array(types.float64, 1, "C", readonly=True)
_OUT = types.Array(types.float64, 1, "C")
#: (K, t, dt, q, q̇, h, x_d, ẋ_d, ẍ_d, f_d, ḟ_d, f̈_d, p) read, (s, ws, u) written.
_ON_ARM_SIGNATURE = types.boolean(_IN, types.float64, types.float64, *([_IN] * 10), _OUT, _OUT, _OUT)
