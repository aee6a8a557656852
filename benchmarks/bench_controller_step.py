"""``Controller.step`` from Python against a plain-Python implementation of the same law.

Issue 14, target 5: one ``ImpedanceController.step`` (impedance with force measurement,
(9.30)–(9.31), on the chapter's arm, inputs checked) at most 1.5× a plain-Python ``math``
implementation of the same law (the arm's terms, the law, a 2×2 solve, ``B y + n + Jᵀ h``, no
checks) run in the same process; the same for the three direct force schemes. Both receive
the same ``Measurement`` and ``Reference`` objects and return a NumPy array; the torques are
compared (they must agree to 1e-9 relative) before timing.

Run: ``python benchmarks/bench_controller_step.py`` (prints a table; asserts nothing).
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

import forcecontrol as fc

ARM = fc.CHAPTER_ARM
K = ARM.parameters.kernel_vector().tolist()  # a1, a2, B and g coefficients, friction


def arm_terms(q0: float, q1: float, w0: float, w1: float):
    """x, ẋ, J, J̇q̇, B, n of the chapter's arm (two-link-arm.md), plain Python."""
    a1, a2 = K[0], K[1]
    c1, s1, c2, s2 = math.cos(q0), math.sin(q0), math.cos(q1), math.sin(q1)
    c12, s12 = math.cos(q0 + q1), math.sin(q0 + q1)
    J00, J01 = -a1 * s1 - a2 * s12, -a2 * s12
    J10, J11 = a1 * c1 + a2 * c12, a2 * c12
    x0, x1 = a1 * c1 + a2 * c12, a1 * s1 + a2 * s12
    v0, v1 = J00 * w0 + J01 * w1, J10 * w0 + J11 * w1
    u12 = w0 + w1
    Jdq0 = -a1 * c1 * w0 * w0 - a2 * c12 * u12 * u12
    Jdq1 = -a1 * s1 * w0 * w0 - a2 * s12 * u12 * u12
    B00, B01, B11 = K[2] + K[3] * c2, K[4] + K[5] * c2, K[6]
    h = -K[7] * s2
    g0, g1 = K[8] * c1 + K[9] * c12, K[9] * c12
    n0 = h * w1 * w0 + h * u12 * w1 + K[10] * w0 + g0
    n1 = -h * w0 * w0 + K[11] * w1 + g1
    return x0, x1, v0, v1, J00, J01, J10, J11, Jdq0, Jdq1, B00, B01, B11, n0, n1


def inner_loop(T, a0: float, a1: float, h0: float, h1: float) -> np.ndarray:
    """(9.30): u = B J⁻¹ (a − J̇q̇) + n + Jᵀ h (2×2 by Cramer's rule)."""
    _, _, _, _, J00, J01, J10, J11, Jdq0, Jdq1, B00, B01, B11, n0, n1 = T
    r0, r1 = a0 - Jdq0, a1 - Jdq1
    det = J00 * J11 - J01 * J10
    y0, y1 = (J11 * r0 - J01 * r1) / det, (J00 * r1 - J10 * r0) / det
    return np.array([B00 * y0 + B01 * y1 + n0 + J00 * h0 + J10 * h1,
                     B01 * y0 + B11 * y1 + n1 + J01 * h0 + J11 * h1])


def plain_impedance(md: float, kd: float, kp: float):
    """Impedance with force measurement (9.30)–(9.31), diagonal gains, plain Python."""
    def step(t, meas, ref):
        q0, q1 = meas.q.tolist()
        w0, w1 = meas.qd.tolist()
        h0, h1 = meas.wrench.tolist()
        xd0, xd1 = ref.position.tolist()
        vd0, vd1 = ref.velocity.tolist()
        ad0, ad1 = ref.acceleration.tolist()
        T = arm_terms(q0, q1, w0, w1)
        a0 = ad0 + (kd * (vd0 - T[2]) + kp * (xd0 - T[0]) - h0) / md
        a1 = ad1 + (kd * (vd1 - T[3]) + kp * (xd1 - T[1]) - h1) / md
        return inner_loop(T, a0, a1, h0, h1)
    return step


def plain_inner_velocity(md: float, kd: float, kp: float, kf: float):
    """Inner velocity loop (9.45)–(9.46), diagonal gains, plain Python."""
    def step(t, meas, ref):
        q0, q1 = meas.q.tolist()
        w0, w1 = meas.qd.tolist()
        h0, h1 = meas.wrench.tolist()
        f0, f1 = ref.force.tolist()
        T = arm_terms(q0, q1, w0, w1)
        a0 = (kp * kf * (f0 - h0) - kd * T[2]) / md
        a1 = (kp * kf * (f1 - h1) - kd * T[3]) / md
        return inner_loop(T, a0, a1, h0, h1)
    return step


def _time(fn, args, n: int = 20000, repeats: int = 7) -> float:
    fn(*args)
    runs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            fn(*args)
        runs.append((time.perf_counter() - t0) / n)
    return statistics.median(runs) * 1e6


def main() -> dict[str, float]:
    q = ARM.inverse_kinematics([1.0005, 0.05])
    meas = fc.Measurement(q, np.array([0.01, -0.02]), np.array([5.0, 0.3]))
    ref = fc.Reference.setpoint([1.01, 0.1], [10.0, 0.0])
    pairs = {
        "impedance (9.30)-(9.31)": (fc.ImpedanceController(ARM, 100, 500, 2500), plain_impedance(100, 500, 2500)),
        "inner velocity (9.45)": (fc.InnerVelocityForceController(ARM, 100, 5000, 2500, 0.0024),
                                  plain_inner_velocity(100, 5000, 2500, 0.0024)),
    }
    out: dict[str, float] = {}
    print(f"{'law':28s} {'step [µs]':>10s} {'plain [µs]':>11s} {'ratio':>7s}  target <= 1.5")
    for name, (ctl, plain) in pairs.items():
        want = plain(0.0, meas, ref)
        got = ctl.step(0.0, meas, ref)
        np.testing.assert_allclose(got, want, rtol=1e-9)
        t_ctl = _time(ctl.step, (0.0, meas, ref))
        t_plain = _time(plain, (0.0, meas, ref))
        out[name] = t_ctl / t_plain
        print(f"{name:28s} {t_ctl:10.2f} {t_plain:11.2f} {t_ctl / t_plain:7.2f}")
    return out


if __name__ == "__main__":
    main()
