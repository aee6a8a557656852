"""Identified-vs-true table of the F/T calibration on the set-ups of tests/test_calibration.py.

A simulated sensor with known payload, centre of mass, biases and Gaussian noise (readings from
the hand-written physics: f_S = −m R_Sᵀ g + b_f, τ_S = −c × (m R_Sᵀ g) + b_τ) is calibrated with
:func:`forcecontrol.realarm.calibration.calibrate`; each parameter is printed with its estimate, its
standard uncertainty σ and the error in units of σ; then, over 1000 noise draws, whether σ is the
actual scatter (the error/σ has standard deviation 1 when it is).

Run: ``python tools/calibration_table.py``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from forcecontrol.realarm.calibration import calibrate

G = 9.81


def readings(true, Rs, rng, sf, st):
    d = Rs.shape[1]
    g = np.array([0.0, -G]) if d == 2 else np.array([0.0, 0.0, -G])
    w = true["mass"] * np.einsum("kji,j->ki", Rs, g)
    F = -w + true["force_bias"] + sf * rng.standard_normal(w.shape)
    c = true["com"]
    M = (-(c[0] * w[:, 1] - c[1] * w[:, 0]))[:, None] if d == 2 else -np.cross(c, w)
    T = M + true["torque_bias"] + st * rng.standard_normal(M.shape)
    return F, (T[:, 0] if d == 2 else T)


def table(title, true, Rs, rng, sf=0.05, st=0.005):
    r = calibrate(Rs, *readings(true, Rs, rng, sf, st))
    print(f"\n{title}: {len(Rs)} poses, noise σ_f = {sf} N, σ_τ = {st} N m; condition number {r.condition_number:.3g}; "
          f"estimated noise σ_f = {r.force_noise_std:.4f} N, σ_τ = {r.torque_noise_std:.5f} N m")
    print(f"{'parameter':<15}{'true':>11}{'identified':>13}{'σ':>11}{'error/σ':>9}  unit")
    flat = {"mass": [true["mass"]], "com": true["com"], "force_bias": true["force_bias"], "torque_bias": true["torque_bias"]}
    truth = {}
    for key, vals in flat.items():
        names = ["mass"] if key == "mass" else [f"{key}_{a}" for a in ("z" if key == "torque_bias" and len(vals) == 1 else "xyz")]
        truth.update(zip(names, vals))
    worst = 0.0
    for row in r.parameters():
        t = truth[row["name"]]
        z = (row["value"] - t) / row["std"]
        worst = max(worst, abs(z))
        print(f"{row['name']:<15}{t:>11.5g}{row['value']:>13.6g}{row['std']:>11.2g}{z:>9.2f}  {row['unit']}")
    print(f"largest |error|/σ: {worst:.2f} (tests require <= 4)")


def coverage(true, Rs, draws=1000):
    """Over many noise draws: the std of (estimate − true)/σ per parameter (1 when σ is right)."""
    Z = []
    for seed in range(draws):
        r = calibrate(Rs, *readings(true, Rs, np.random.default_rng(seed), 0.05, 0.005))
        est = np.concatenate([[r.mass], r.com, r.force_bias, r.torque_bias])
        std = np.concatenate([[r.mass_std], r.com_std, r.force_bias_std, r.torque_bias_std])
        tru = np.concatenate([[true["mass"]], true["com"], true["force_bias"], true["torque_bias"]])
        Z.append((est - tru) / std)
    Z = np.array(Z)
    print(f"over {draws} noise draws: std of error/σ per parameter {np.round(Z.std(axis=0), 3).tolist()}, "
          f"|error| > 2σ in {100 * np.mean(np.abs(Z) > 2):.1f} % (normal: 4.6 %), > 4σ: {int(np.sum(np.abs(Z) > 4))}")


def main():
    true3 = {"mass": 2.3, "com": np.array([0.01, -0.02, 0.08]), "force_bias": np.array([0.5, -0.3, 1.2]),
             "torque_bias": np.array([0.05, 0.02, -0.01])}
    table("3-D sensor", true3, Rotation.random(30, random_state=3).as_matrix(), np.random.default_rng(7))
    coverage(true3, Rotation.random(30, random_state=3).as_matrix())
    true2 = {"mass": 1.2, "com": np.array([0.10, 0.03]), "force_bias": np.array([0.8, -0.4]), "torque_bias": np.array([0.02])}
    Rs = np.array([[[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]] for a in np.linspace(-2.5, 2.5, 12)])
    table("planar sensor", true2, Rs, np.random.default_rng(11))


if __name__ == "__main__":
    main()
