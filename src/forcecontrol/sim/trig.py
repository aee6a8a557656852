"""sin and cos in arithmetic only, branch-free, so that a loop over cases side by side vectorises.

The compiled loops call libm's ``sin``/``cos``; Numba has no vector libm here (SVML off), so a
loop over lanes that calls them stays scalar (``benchmarks/bench_lanes_trig.py``: 1.04–1.11x).
:func:`sincos` computes both from one argument reduction with operations LLVM vectorises
(multiply, add, ``floor``, selects):

* reduction by π/2 (Cody–Waite in three parts, FreeBSD's ``e_rem_pio2.c`` medium case, both
  rounds always taken): ``x = n π/2 + (r + y)``, ``y`` the tail of ``r``; ``n π/2``'s first two
  parts are exact for ``|n| < 2^20`` (``|x|`` up to about 1.6e6 rad), far beyond the joint
  angles a run reaches before its runaway guard stops it;
* FreeBSD's kernels ``k_sin.c`` / ``k_cos.c`` (fdlibm's minimax polynomials on [−π/4, π/4],
  with the tail), error below 1 ulp;
* the quadrant ``n mod 4`` chooses and signs them by selects.

Against libm (glibc) and NumPy: within 1 ulp over [−4π, 4π] and at the special points
(0, −0, multiples of π/2, tiny and subnormal angles); NaN and ±inf give NaN (tests in
``tests/test_batch_lanes.py``). Not bit-identical to libm: the lane kernel that uses it
(:mod:`forcecontrol.sim.batch_lanes`) states what that changes.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["sincos"]

_INV_PIO2 = 6.36619772367581382433e-01  # 2/π
_PIO2_1 = 1.57079632673412561417e00  # first 33 bits of π/2
_PIO2_2 = 6.07710050630396597660e-11  # second 33 bits of π/2
_PIO2_2T = 2.02226624879595063154e-21  # π/2 − (_PIO2_1 + _PIO2_2)

_S1 = -1.66666666666666324348e-01
_S2 = 8.33333333332248946124e-03
_S3 = -1.98412698298579493134e-04
_S4 = 2.75573137070700676789e-06
_S5 = -2.50507602534068634195e-08
_S6 = 1.58969099521155010221e-10

_C1 = 4.16666666666666019037e-02
_C2 = -1.38888888888741095749e-03
_C3 = 2.48015872894767294178e-05
_C4 = -2.75573143513906633035e-07
_C5 = 2.08757232129817482790e-09
_C6 = -1.13596475577881948265e-11


@njit(cache=True, inline="always")
def sincos(x):  # pragma: no cover - compiled
    """``(sin x, cos x)`` within 1 ulp, in arithmetic only (no calls, no branches): vectorisable.

    See the module text for the method and its range (exact reduction for ``|x| < 1.6e6``).
    """
    n = math.floor(x * _INV_PIO2 + 0.5)
    r0 = x - n * _PIO2_1  # exact (n·_PIO2_1 is exact and close to x)
    w = n * _PIO2_2  # exact
    r1 = r0 - w
    w = n * _PIO2_2T - ((r0 - r1) - w)  # what r1 lost, and the third part
    r = r1 - w
    y = (r1 - r) - w  # the tail of r
    z = r * r
    v = z * z
    # k_sin.c (with the tail y)
    ps = _S2 + z * (_S3 + z * _S4) + z * v * (_S5 + z * _S6)
    vs = z * r
    s = r - ((z * (0.5 * y - vs * ps) - y) - vs * _S1)
    # k_cos.c (with the tail y)
    pc = z * (_C1 + z * (_C2 + z * _C3)) + v * v * (_C4 + z * (_C5 + z * _C6))
    hz = 0.5 * z
    w = 1.0 - hz
    c = w + (((1.0 - w) - hz) + (z * pc - r * y))
    q = n - 4.0 * math.floor(n * 0.25)  # n mod 4: 0, 1, 2, 3
    swap = (q == 1.0) | (q == 3.0)
    sa = c if swap else s
    ca = s if swap else c
    return (-sa if q >= 2.0 else sa), (-ca if ((q == 1.0) | (q == 2.0)) else ca)
