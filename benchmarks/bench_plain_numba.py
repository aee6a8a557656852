"""The library's compiled loops against a plain hand-written Numba loop of the same closed loop.

The baseline is written here from the arm's data (two-link-arm.md) and the chapter's equations,
not from the library: Example 9.2's impedance control with force measurement (9.30)–(9.31) on
the chapter's arm against the plane x = 1 (k = 10⁴ N/m), exact force measurement, the torque held
over each 1 ms sample and RK4 with the same number of sub-steps. Scalars only, no allocation, the
2 × 2 solves by hand: the fastest a user could reasonably write for one case on one core.

Compared, in this process, per arm-step (one control sample of one case):

* ``simulate(engine="compiled")`` on the same case (the single-run loop, one case per call);
* the sweeps' batch kernel on one thread (:func:`forcecontrol.sweep.run_block`), 64 cases;
* the plain loop itself, and that both give the same final tip (to 1e-9 m: the same computation).

Issue target: the batch kernel at least the plain loop's arm-steps/s on one core.
Run: ``python benchmarks/bench_plain_numba.py``; prints a table, asserts nothing.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

import forcecontrol as fc
from forcecontrol.sim.simulation import choose_substeps
from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_block


@njit(cache=False, inline="always")
def _terms(q1, q2, v1, v2):
    """B (b11, b12, b22), n = C q̇ + F q̇ + g, tip x, J, J̇ q̇ of the chapter's arm (two-link-arm.md), scalars."""
    c1, s1, c2, s2 = math.cos(q1), math.sin(q1), math.cos(q2), math.sin(q2)
    c12, s12 = math.cos(q1 + q2), math.sin(q1 + q2)
    b11, b12, b22 = 200.01 + 50.0 * c2, 23.5 + 25.0 * c2, 122.5
    h = -25.0 * s2
    n1 = h * v2 * v1 + h * (v1 + v2) * v2 + 100.0 * v1 + 9.81 * (80.0 * c1 + 25.0 * c12)
    n2 = -h * v1 * v1 + 100.0 * v2 + 9.81 * 25.0 * c12
    x1, x2 = c1 + c12, s1 + s12
    j11, j12, j21, j22 = -s1 - s12, -s12, c1 + c12, c12
    w12 = v1 + v2
    jd1 = -c1 * v1 * v1 - c12 * w12 * w12
    jd2 = -s1 * v1 * v1 - s12 * w12 * w12
    return b11, b12, b22, n1, n2, x1, x2, j11, j12, j21, j22, jd1, jd2


@njit(cache=False, inline="always")
def _accel(q1, q2, v1, v2, u1, u2, k):
    b11, b12, b22, n1, n2, x1, _, j11, j12, _, _, _, _ = _terms(q1, q2, v1, v2)
    f1 = k * (x1 - 1.0) if x1 > 1.0 else 0.0  # the plane x = 1, pushed along +x
    r1 = u1 - n1 - j11 * f1
    r2 = u2 - n2 - j12 * f1
    det = b11 * b22 - b12 * b12
    return (b22 * r1 - b12 * r2) / det, (b11 * r2 - b12 * r1) / det


@njit(cache=False)
def plain_loop(q0, x_d, k, md, kd, kp, N, Ts, nsub):
    """Impedance with force measurement (9.30)-(9.31), ZOH torques, RK4 with nsub sub-steps; scalars only."""
    q1, q2, v1, v2 = q0[0], q0[1], 0.0, 0.0
    h = Ts / nsub
    for _ in range(N):
        b11, b12, b22, n1, n2, x1, x2, j11, j12, j21, j22, jd1, jd2 = _terms(q1, q2, v1, v2)
        f1 = k * (x1 - 1.0) if x1 > 1.0 else 0.0
        xd1, xd2 = j11 * v1 + j12 * v2, j21 * v1 + j22 * v2
        a1 = (-kd * xd1 + kp * (x_d[0] - x1) - f1) / md - jd1
        a2 = (-kd * xd2 + kp * (x_d[1] - x2)) / md - jd2
        det = j11 * j22 - j12 * j21
        y1, y2 = (j22 * a1 - j12 * a2) / det, (j11 * a2 - j21 * a1) / det
        u1 = b11 * y1 + b12 * y2 + n1 + j11 * f1
        u2 = b12 * y1 + b22 * y2 + n2 + j12 * f1
        for _s in range(nsub):
            k1v1, k1v2 = _accel(q1, q2, v1, v2, u1, u2, k)
            k2v1, k2v2 = _accel(q1 + 0.5 * h * v1, q2 + 0.5 * h * v2, v1 + 0.5 * h * k1v1, v2 + 0.5 * h * k1v2, u1, u2, k)
            k3v1, k3v2 = _accel(q1 + 0.5 * h * (v1 + 0.5 * h * k1v1), q2 + 0.5 * h * (v2 + 0.5 * h * k1v2),
                                v1 + 0.5 * h * k2v1, v2 + 0.5 * h * k2v2, u1, u2, k)
            k4v1, k4v2 = _accel(q1 + h * (v1 + 0.5 * h * k2v1), q2 + h * (v2 + 0.5 * h * k2v2),
                                v1 + h * k3v1, v2 + h * k3v2, u1, u2, k)
            q1 += h / 6.0 * (v1 + 2.0 * (v1 + 0.5 * h * k1v1) + 2.0 * (v1 + 0.5 * h * k2v1) + (v1 + h * k3v1))
            q2 += h / 6.0 * (v2 + 2.0 * (v2 + 0.5 * h * k1v2) + 2.0 * (v2 + 0.5 * h * k2v2) + (v2 + h * k3v2))
            v1 += h / 6.0 * (k1v1 + 2.0 * k2v1 + 2.0 * k3v1 + k4v1)
            v2 += h / 6.0 * (k1v2 + 2.0 * k2v2 + 2.0 * k3v2 + k4v2)
    return np.array([q1, q2])


def main() -> None:
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    k, duration, Ts = 1e4, 4.0, 1e-3
    N = int(round(duration / Ts))
    plane = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], k)
    ctl = fc.ImpedanceController(arm, 100.0, 500.0, 2500.0)
    nsub = choose_substeps(arm, plane, q0, Ts)
    x_d = np.array([1.1, 0.1])
    args = (q0, x_d, k, 100.0, 500.0, 2500.0, N, Ts, nsub)
    plain_loop(*args)  # compile
    reps = 5
    t0 = time.perf_counter()
    for _ in range(reps):
        plain_loop(*args)
    t_plain = (time.perf_counter() - t0) / (reps * N)

    res = fc.simulate(arm, plane, ctl, fc.Setpoint(x_d), q0=q0, duration=duration, substeps=nsub, engine="compiled")
    t0 = time.perf_counter()
    for _ in range(reps):
        res = fc.simulate(arm, plane, ctl, fc.Setpoint(x_d), q0=q0, duration=duration, substeps=nsub, engine="compiled")
    t_single = (time.perf_counter() - t0) / (reps * N)
    # the same computation: the tips agree mid-transient (0.3 s), not only at the equilibrium
    mid = 300
    q_mid = plain_loop(q0, x_d, k, 100.0, 500.0, 2500.0, mid, Ts, nsub)
    same = float(np.max(np.abs(arm.forward_kinematics(q_mid) - res.x[mid])))

    d = SweepDefinition.from_options({"environment.stiffness": [k], "controller.damping": "linspace(480, 520, 64)"},
                                     cases=["1"])
    prep = prepare_sweep("example-9.2", d)
    jobs = [j for j in prep.jobs if j.fast]
    run_block(jobs[:1], 0.02, 0.05)  # warm
    t0 = time.perf_counter()
    rows = run_block(jobs, 0.02, 0.05)
    t_batch = (time.perf_counter() - t0) / sum(r["samples"] for r in rows)

    print(f"Example 9.2 (k = 1e4 N/m), {N} samples of 1 ms, {nsub} RK4 sub-steps; "
          f"plain loop and simulate() tips at 0.3 s differ by {same:.2e} m")
    print(f"{'loop':<58} {'µs/arm-step':>12} {'arm-steps/s':>12} {'vs plain':>9}")
    for name, t in (("plain hand-written Numba loop (this file)", t_plain),
                    ("simulate(engine='compiled'), one case per call", t_single),
                    (f"batch kernel, one thread (run_block, {len(jobs)} cases)", t_batch)):
        print(f"{name:<58} {1e6 * t:>12.3f} {1 / t:>12.3g} {t_plain / t:>8.2f}x")
    print("target: batch kernel >= plain loop's arm-steps/s (vs plain >= 1.00x)")


if __name__ == "__main__":
    main()
