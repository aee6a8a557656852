"""The built-in Python engine's cost per sample on the scenarios that run on it (issue 33 item 4).

For each scenario: ``run_scenario(name)`` once to warm (compiles, caches), then ``--repeats`` timed
runs; the cost is the wall time of a run divided by its samples (all cases), in µs per sample. The
baseline, timed between the scenarios in the same process, is a plain NumPy loop of the chapter's
arm (closed-form terms, an impedance law on an elastic plane, RK4 with ``np.linalg.solve``, one
Python iteration per sample): it does not use the library, so its ratio is comparable before and
after a change of the library (run this file with ``PYTHONPATH=<old checkout>/src`` for "before").

Prints, per scenario: the engine of its cases, µs/sample (median and spread over the repeats) and
the ratio to the baseline's median. Wall-clock numbers depend on the machine's load; the ratios less
so. Asserts nothing. Run: ``python benchmarks/bench_python_engine.py [--repeats 3] [NAME ...]``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from forcecontrol.scenarios.core import run_scenario

SCENARIOS = ["arm-unknown-circle", "arm-circle-contour", "arm-unknown-circle-parallel", "hybrid-rigid-plane",
             "variable-stiffness", "servo-admittance", "impact", "impact-safety"]


def plain_loop(samples: int = 2000) -> float:
    """µs per sample of a plain NumPy closed loop of the chapter's arm (no library code)."""
    a1 = a2 = 1.0
    m1 = m2 = 50.0
    l1 = l2 = 0.5
    I1 = I2 = 10.0
    g0 = 9.81
    Ts, dt = 1e-3, 1e-3
    xd_, k_env = np.array([1.01, 0.0]), 5000.0
    Md_inv, KD, KP = np.eye(2) / 100.0, 500.0 * np.eye(2), 2500.0 * np.eye(2)

    def terms(q, qd):
        c1, s1, c2, s2 = np.cos(q[0]), np.sin(q[0]), np.cos(q[1]), np.sin(q[1])
        c12, s12 = np.cos(q[0] + q[1]), np.sin(q[0] + q[1])
        x = np.array([a1 * c1 + a2 * c12, a1 * s1 + a2 * s12])
        J = np.array([[-a1 * s1 - a2 * s12, -a2 * s12], [a1 * c1 + a2 * c12, a2 * c12]])
        w1, w12 = qd[0], qd[0] + qd[1]
        Jdq = np.array([-a1 * c1 * w1 * w1 - a2 * c12 * w12 * w12, -a1 * s1 * w1 * w1 - a2 * s12 * w12 * w12])
        b11 = I1 + m1 * l1 * l1 + I2 + m2 * (a1 * a1 + l2 * l2 + 2 * a1 * l2 * c2)
        b12 = I2 + m2 * (l2 * l2 + a1 * l2 * c2)
        B = np.array([[b11, b12], [b12, I2 + m2 * l2 * l2]])
        h = -m2 * a1 * l2 * s2
        n = np.array([h * qd[1] * qd[0] + h * w12 * qd[1], -h * qd[0] * qd[0]])
        g = np.array([(m1 * l1 + m2 * a1) * g0 * c1 + m2 * l2 * g0 * c12, m2 * l2 * g0 * c12])
        return x, J @ qd, J, Jdq, B, n + g

    def wrench(x):
        return np.array([max(0.0, k_env * (x[0] - 1.0)), 0.0])

    def accel(q, qd, u):
        x, _, J, _, B, n = terms(q, qd)
        return np.linalg.solve(B, u - n - J.T @ wrench(x))

    q, qd = np.array([np.pi / 3, -2 * np.pi / 3]), np.zeros(2)
    t0 = time.perf_counter()
    for _ in range(samples):
        x, xdot, J, Jdq, B, n = terms(q, qd)
        h = wrench(x)
        a = Md_inv @ (-KD @ xdot + KP @ (xd_ - x) - h)
        u = B @ np.linalg.solve(J, a - Jdq) + n + J.T @ h
        a1_ = accel(q, qd, u)
        v2 = qd + 0.5 * dt * a1_
        a2_ = accel(q + 0.5 * dt * qd, v2, u)
        v3 = qd + 0.5 * dt * a2_
        a3_ = accel(q + 0.5 * dt * v2, v3, u)
        v4 = qd + dt * a3_
        a4_ = accel(q + dt * v3, v4, u)
        q = q + dt / 6.0 * (qd + 2 * v2 + 2 * v3 + v4)
        qd = qd + dt / 6.0 * (a1_ + 2 * a2_ + 2 * a3_ + a4_)
    assert Ts == dt and np.all(np.isfinite(q))
    return (time.perf_counter() - t0) / samples * 1e6


def scenario_cost(name: str) -> tuple[float, str]:
    """(µs per sample of one warm run, the engines of its cases)."""
    t0 = time.perf_counter()
    run = run_scenario(name)
    wall = time.perf_counter() - t0
    samples = sum(c.result.t.shape[0] for c in run.cases)
    engines = ",".join(sorted({str(c.result.metadata["engine"]) for c in run.cases}))
    return wall / samples * 1e6, engines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=SCENARIOS)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    base: list[float] = []
    rows = []
    plain_loop(200)  # warm
    for name in a.names:
        scenario_cost(name)  # warm: compiles and caches
        times = []
        engines = ""
        for _ in range(a.repeats):
            base.append(plain_loop())
            us, engines = scenario_cost(name)
            times.append(us)
        rows.append((name, engines, times))
    base.append(plain_loop())
    b = statistics.median(base)
    print(f"baseline (plain NumPy loop of the arm): {b:7.1f} µs/sample, spread {min(base):.1f}–{max(base):.1f}")
    print("ratio: median / baseline median; best: fastest / baseline's fastest (less sensitive to a busy machine)")
    print(f"{'scenario':30s} {'engine':8s} {'µs/sample':>10s} {'spread':>15s} {'ratio':>7s} {'best':>6s}")
    for name, engines, times in rows:
        m = statistics.median(times)
        print(f"{name:30s} {engines:8s} {m:10.1f} {min(times):7.1f}–{max(times):<7.1f} {m / b:7.2f} "
              f"{min(times) / min(base):6.2f}")


if __name__ == "__main__":
    main()
