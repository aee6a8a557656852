"""Speed of the foundation, as ratios against baselines run in the same process.

Measures, for Example 9.2 (chapter arm, impedance with force measurement, stiff plane, 1 ms):

* the compiled closed loop (sensor + controller + plant) per control step, and its real-time
  factor (target: at least 200x real time, i.e. at most 5 µs per step);
* one ``ImpedanceController.step`` called from Python (target: at most 10 µs);
* the baseline: a naive NumPy loop written the obvious way (same physics, same RK4), in this
  process, so that the ratio is meaningful on a noisy machine.

Run: ``python benchmarks/bench_closed_loop.py`` (prints a table; asserts nothing).
"""

from __future__ import annotations

import statistics
import time

import numpy as np

import forcecontrol as fc


def naive_numpy_loop(n_steps: int) -> float:
    """The obvious NumPy implementation of the same closed loop; returns seconds per step."""
    p = fc.PlanarTwoLinkParameters()

    def terms(q, qd):
        c1, s1, c2, s2 = np.cos(q[0]), np.sin(q[0]), np.cos(q[1]), np.sin(q[1])
        c12, s12 = np.cos(q.sum()), np.sin(q.sum())
        x = np.array([c1 + c12, s1 + s12])
        J = np.array([[-s1 - s12, -s12], [c1 + c12, c12]])
        w1, w12 = qd[0], qd.sum()
        Jdq = np.array([-c1 * w1**2 - c12 * w12**2, -s1 * w1**2 - s12 * w12**2])
        B = np.array([[200.01 + 50 * c2, 23.5 + 25 * c2], [23.5 + 25 * c2, 122.5]])
        h = -25 * s2
        C = np.array([[h * qd[1], h * (qd[0] + qd[1])], [-h * qd[0], 0.0]])
        g = 9.81 * np.array([80 * c1 + 25 * c12, 25 * c12])
        n = C @ qd + np.diag([p.F1, p.F2]) @ qd + g
        return x, J @ qd, J, Jdq, B, n

    def wrench(x):
        d = x[0] - 1.0
        return np.array([1e4 * d, 0.0]) if d > 0 else np.zeros(2)

    Md, KD, KP = np.diag([100.0, 100.0]), np.diag([500.0, 500.0]), np.diag([2500.0, 2500.0])
    xd_ref = np.array([1.1, 0.1])
    q, qd = np.array([np.pi / 3, -2 * np.pi / 3]), np.zeros(2)
    Ts = 1e-3

    def accel(q, qd, u):
        x, xd, J, Jdq, B, n = terms(q, qd)
        return np.linalg.solve(B, u - n - J.T @ wrench(x))

    t0 = time.perf_counter()
    for _ in range(n_steps):
        x, xd, J, Jdq, B, n = terms(q, qd)
        h = wrench(x)
        a = np.linalg.solve(Md, KD @ (-xd) + KP @ (xd_ref - x) - h)
        u = B @ np.linalg.solve(J, a - Jdq) + n + J.T @ h
        a1 = accel(q, qd, u)
        a2 = accel(q + 0.5 * Ts * qd, qd + 0.5 * Ts * a1, u)
        a3 = accel(q + 0.5 * Ts * (qd + 0.5 * Ts * a1), qd + 0.5 * Ts * a2, u)
        a4 = accel(q + Ts * (qd + 0.5 * Ts * a2), qd + Ts * a3, u)
        q = q + Ts / 6 * (qd + 2 * (qd + 0.5 * Ts * a1) + 2 * (qd + 0.5 * Ts * a2) + (qd + Ts * a3))
        qd = qd + Ts / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return (time.perf_counter() - t0) / n_steps


def compiled_loop(duration: float) -> float:
    """forcecontrol.simulate (compiled engine) on Example 9.2, stiff plane; seconds per step."""
    arm = fc.CHAPTER_ARM
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4)
    ctl = fc.ImpedanceController(arm, 100, 500, 2500)
    q0 = arm.inverse_kinematics([1.0, 0.0])
    t0 = time.perf_counter()
    r = fc.simulate(arm, env, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=duration)
    dt = time.perf_counter() - t0
    assert r.metadata["engine"] == "compiled"
    return dt / (len(r.t) - 1)


def controller_step(n: int) -> float:
    """One ImpedanceController.step from Python; seconds per call."""
    arm = fc.CHAPTER_ARM
    ctl = fc.ImpedanceController(arm, 100, 500, 2500)
    q = arm.inverse_kinematics([1.05, 0.05])
    meas = fc.Measurement(q, np.array([0.1, -0.2]), np.array([50.0, 0.0]))
    ref = fc.Reference.setpoint([1.1, 0.1])
    ctl.step(0.0, meas, ref)
    t0 = time.perf_counter()
    for k in range(n):
        ctl.step(k * 1e-3, meas, ref)
    return (time.perf_counter() - t0) / n


def best(fn, *args, repeat: int = 5) -> float:
    return min(fn(*args) for _ in range(repeat))


def main() -> dict[str, float]:
    compiled_loop(0.1)  # compile / load the cache
    naive = statistics.median(naive_numpy_loop(2000) for _ in range(3))
    loop = best(compiled_loop, 10.0)
    step = best(controller_step, 20000)
    out = {
        "naive_numpy_us_per_step": naive * 1e6,
        "compiled_loop_us_per_step": loop * 1e6,
        "compiled_loop_real_time_factor": 1e-3 / loop,
        "speedup_vs_naive_numpy": naive / loop,
        "controller_step_us": step * 1e6,
        "controller_step_vs_naive_loop_step": step / naive,
    }
    print(f"{'quantity':40s} {'value':>12s}  target")
    targets = {
        "compiled_loop_us_per_step": "<= 5 µs",
        "compiled_loop_real_time_factor": ">= 200x",
        "controller_step_us": "<= 10 µs",
    }
    for k, v in out.items():
        print(f"{k:40s} {v:12.2f}  {targets.get(k, '')}")
    return out


if __name__ == "__main__":
    main()
