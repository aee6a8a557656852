"""Where a lane-blocked planar kernel's speed comes from: the plain loop over L cases side by side, two trig paths.

Issue 33 item 3 asks the planar sweep to compute several cases per instruction. This benchmark
measures, before any library code is changed, what laying L cases side by side (state arrays
of shape (L,), every inner loop over lanes, no ``fastmath``) gains on the plain hand-written loop
of ``bench_plain_numba.py`` (Example 9.2's impedance control (9.30)-(9.31), the chapter's arm,
ZOH, RK4), and why:

* ``libm``: the lanes with ``math.sin``/``math.cos`` (LLVM has no vector libm here: Numba reports
  SVML off, so the trig stays six scalar calls per dynamics evaluation per lane and the loops
  around them do not vectorise). Its results are checked bit for bit against the plain loop.
* ``vector sincos``: the same lanes with the library's branch-free sin/cos (:func:`forcecontrol.sim.trig.sincos`:
  Cody-Waite reduction by pi/2 in three parts, fdlibm's kernel polynomials, the quadrant by selects), which LLVM vectorises
  across lanes. Its results are checked bit for bit against the same code run with L = 1 (one
  case at a time: the lane layout itself changes no rounding), and its distance to the libm path
  is reported (sin/cos within about 1 ulp of libm, so not bit-identical to today's scalar loop).

Run: ``python benchmarks/bench_lanes_trig.py``; prints a table (arm-steps/s, ratio to the plain
loop measured right before, repeated), asserts nothing.
"""

# ruff: noqa: E702  (the lane loops keep one line per pair of state components, as the plain loop)

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_plain_numba import plain_loop  # noqa: E402

import forcecontrol as fc  # noqa: E402
from forcecontrol.sim.simulation import choose_substeps  # noqa: E402
from forcecontrol.sim.trig import sincos  # noqa: E402


@njit(cache=False, inline="always")
def libm_sincos(x):
    """(sin x, cos x) from libm (what the library's loop computes)."""
    return math.sin(x), math.cos(x)


#: the library's branch-free sin/cos (forcecontrol.sim.trig, what the sweeps' lane kernel runs); its first
#: version lived here (two-part reduction, no tail: off by many ulps next to multiples of pi)
vector_sincos = sincos


def make_lanes(sc):
    """The plain loop of bench_plain_numba over L lanes, with trig function ``sc``."""
    @njit(cache=False)
    def accel(q1, q2, v1, v2, u1, u2, k, a1, a2, L, C1, S1, C2, S2, C12, S12):
        for l in range(L):
            S1[l], C1[l] = sc(q1[l])
            S2[l], C2[l] = sc(q2[l])
            S12[l], C12[l] = sc(q1[l] + q2[l])
        for l in range(L):
            c1, s1, c2, s2, c12, s12 = C1[l], S1[l], C2[l], S2[l], C12[l], S12[l]
            w1, w2 = v1[l], v2[l]
            b11, b12, b22 = 200.01 + 50.0 * c2, 23.5 + 25.0 * c2, 122.5
            h = -25.0 * s2
            n1 = h * w2 * w1 + h * (w1 + w2) * w2 + 100.0 * w1 + 9.81 * (80.0 * c1 + 25.0 * c12)
            n2 = -h * w1 * w1 + 100.0 * w2 + 9.81 * 25.0 * c12
            x1 = c1 + c12
            j11, j12 = -s1 - s12, -s12
            f1 = k[l] * (x1 - 1.0) if x1 > 1.0 else 0.0
            r1 = u1[l] - n1 - j11 * f1
            r2 = u2[l] - n2 - j12 * f1
            det = b11 * b22 - b12 * b12
            a1[l] = (b22 * r1 - b12 * r2) / det
            a2[l] = (b11 * r2 - b12 * r1) / det

    @njit(cache=False)
    def lanes_loop(Q1, Q2, xd0, xd1_d, k, md, kd, kp, N, Ts, nsub, L):
        q1 = Q1.copy(); q2 = Q2.copy(); v1 = np.zeros(L); v2 = np.zeros(L)
        u1 = np.empty(L); u2 = np.empty(L)
        C1 = np.empty(L); S1 = np.empty(L); C2 = np.empty(L); S2 = np.empty(L); C12 = np.empty(L); S12 = np.empty(L)
        k1a = np.empty(L); k1b = np.empty(L); k2a = np.empty(L); k2b = np.empty(L); k3a = np.empty(L); k3b = np.empty(L)
        k4a = np.empty(L); k4b = np.empty(L)
        tq1 = np.empty(L); tq2 = np.empty(L); tv1 = np.empty(L); tv2 = np.empty(L)
        h = Ts / nsub
        for _ in range(N):
            for l in range(L):
                a, b = q1[l], q2[l]
                S1[l], C1[l] = sc(a)
                S2[l], C2[l] = sc(b)
                S12[l], C12[l] = sc(a + b)
            for l in range(L):
                c1, s1, c2, s2, c12, s12 = C1[l], S1[l], C2[l], S2[l], C12[l], S12[l]
                w1, w2 = v1[l], v2[l]
                b11, b12, b22 = 200.01 + 50.0 * c2, 23.5 + 25.0 * c2, 122.5
                hh = -25.0 * s2
                n1 = hh * w2 * w1 + hh * (w1 + w2) * w2 + 100.0 * w1 + 9.81 * (80.0 * c1 + 25.0 * c12)
                n2 = -hh * w1 * w1 + 100.0 * w2 + 9.81 * 25.0 * c12
                x1, x2 = c1 + c12, s1 + s12
                j11, j12, j21, j22 = -s1 - s12, -s12, c1 + c12, c12
                w12 = w1 + w2
                jd1 = -c1 * w1 * w1 - c12 * w12 * w12
                jd2 = -s1 * w1 * w1 - s12 * w12 * w12
                f1 = k[l] * (x1 - 1.0) if x1 > 1.0 else 0.0
                xd1, xd2 = j11 * w1 + j12 * w2, j21 * w1 + j22 * w2
                a1 = (-kd * xd1 + kp * (xd0 - x1) - f1) / md - jd1
                a2 = (-kd * xd2 + kp * (xd1_d - x2)) / md - jd2
                det = j11 * j22 - j12 * j21
                y1, y2 = (j22 * a1 - j12 * a2) / det, (j11 * a2 - j21 * a1) / det
                u1[l] = b11 * y1 + b12 * y2 + n1 + j11 * f1
                u2[l] = b12 * y1 + b22 * y2 + n2 + j12 * f1
            for _s in range(nsub):
                accel(q1, q2, v1, v2, u1, u2, k, k1a, k1b, L, C1, S1, C2, S2, C12, S12)
                for l in range(L):
                    tq1[l] = q1[l] + 0.5 * h * v1[l]; tq2[l] = q2[l] + 0.5 * h * v2[l]
                    tv1[l] = v1[l] + 0.5 * h * k1a[l]; tv2[l] = v2[l] + 0.5 * h * k1b[l]
                accel(tq1, tq2, tv1, tv2, u1, u2, k, k2a, k2b, L, C1, S1, C2, S2, C12, S12)
                for l in range(L):
                    tq1[l] = q1[l] + 0.5 * h * (v1[l] + 0.5 * h * k1a[l]); tq2[l] = q2[l] + 0.5 * h * (v2[l] + 0.5 * h * k1b[l])
                    tv1[l] = v1[l] + 0.5 * h * k2a[l]; tv2[l] = v2[l] + 0.5 * h * k2b[l]
                accel(tq1, tq2, tv1, tv2, u1, u2, k, k3a, k3b, L, C1, S1, C2, S2, C12, S12)
                for l in range(L):
                    tq1[l] = q1[l] + h * (v1[l] + 0.5 * h * k2a[l]); tq2[l] = q2[l] + h * (v2[l] + 0.5 * h * k2b[l])
                    tv1[l] = v1[l] + h * k3a[l]; tv2[l] = v2[l] + h * k3b[l]
                accel(tq1, tq2, tv1, tv2, u1, u2, k, k4a, k4b, L, C1, S1, C2, S2, C12, S12)
                for l in range(L):
                    a1, a2, a3, b1, b2, b3 = k1a[l], k2a[l], k3a[l], k1b[l], k2b[l], k3b[l]
                    w1, w2 = v1[l], v2[l]
                    q1[l] += h / 6.0 * (w1 + 2.0 * (w1 + 0.5 * h * a1) + 2.0 * (w1 + 0.5 * h * a2) + (w1 + h * a3))
                    q2[l] += h / 6.0 * (w2 + 2.0 * (w2 + 0.5 * h * b1) + 2.0 * (w2 + 0.5 * h * b2) + (w2 + h * b3))
                    v1[l] += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + k4a[l])
                    v2[l] += h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + k4b[l])
        return q1, q2

    return lanes_loop


def main() -> None:
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    N, Ts = 4000, 1e-3
    nsub = choose_substeps(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4), q0, Ts)
    xd = np.array([1.1, 0.1])
    # the sin/cos against libm over the joint angles a sweep meets
    xs = np.random.default_rng(0).uniform(-8.0, 8.0, 200_000)
    ulp = 0.0
    for x in xs:
        s, c = vector_sincos(x)
        ulp = max(ulp, abs(s - math.sin(x)) / np.spacing(abs(math.sin(x))), abs(c - math.cos(x)) / np.spacing(abs(math.cos(x))))
    print(f"vector sincos vs libm on 2e5 angles in [-8, 8]: max {ulp:.2f} ulp; {nsub} RK4 sub-step(s), {N} samples of 1 ms")
    plain_loop(q0, xd, 1e4, 100.0, 500.0, 2500.0, 2, Ts, nsub)  # compile the baseline outside the timings
    loops = {"libm": make_lanes(libm_sincos), "vector sincos": make_lanes(vector_sincos)}
    print(f"{'trig':<14} {'L':>3} {'lanes arm-steps/s':>18} {'plain arm-steps/s':>18} {'ratio (min-max)':>20}  check")
    for name, loop in loops.items():
        for L in (1, 4, 8, 16):
            ks = np.logspace(3, 5, L)  # the plane's stiffness per lane (contact on every lane)
            Q1, Q2 = np.full(L, q0[0]), np.full(L, q0[1])
            loop(Q1, Q2, xd[0], xd[1], ks, 100.0, 500.0, 2500.0, 2, Ts, nsub, L)  # compile
            ratios, lanes_r, plain_r = [], [], []
            for _ in range(3):
                t0 = time.perf_counter()
                ref = [plain_loop(q0, xd, ks[i], 100.0, 500.0, 2500.0, N, Ts, nsub) for i in range(L)]
                tp = time.perf_counter() - t0
                t0 = time.perf_counter()
                q1, q2 = loop(Q1, Q2, xd[0], xd[1], ks, 100.0, 500.0, 2500.0, N, Ts, nsub, L)
                tl = time.perf_counter() - t0
                ratios.append(tp / tl)
                lanes_r.append(L * N / tl)
                plain_r.append(L * N / tp)
            if name == "libm":
                same = all(ref[i][0] == q1[i] and ref[i][1] == q2[i] for i in range(L))
                check = f"bit-identical to the plain loop: {same}"
            else:
                one = [loop(Q1[i:i + 1], Q2[i:i + 1], xd[0], xd[1], ks[i:i + 1], 100.0, 500.0, 2500.0, N, Ts, nsub, 1)
                       for i in range(L)]
                same = all(one[i][0][0] == q1[i] and one[i][1][0] == q2[i] for i in range(L))
                dev = max(max(abs(ref[i][0] - q1[i]), abs(ref[i][1] - q2[i])) for i in range(L))
                check = f"bit-identical to L = 1: {same}; vs the libm loop: {dev:.1e} rad after 4 s"
            print(f"{name:<14} {L:>3} {statistics.median(lanes_r):>18.3g} {statistics.median(plain_r):>18.3g} "
                  f"{statistics.median(ratios):>8.2f}x ({min(ratios):.2f}-{max(ratios):.2f})  {check}")


if __name__ == "__main__":
    main()
