"""Identify a joint servo (ω_s, ζ_s, transport delay n_d) from a recorded step response.

The model is the one :class:`~forcecontrol.robots.servo.JointServo` simulates, sampled at the
recording's period T (one row per interface cycle, e.g. UR RTDE at 500 Hz)::

    y_k = r_{k − n_d}                                   (the target sent n_d cycles earlier, held)
    [q; q̇]_{k+1} = Φ(ω, ζ) [q; q̇]_k + Γ(ω, ζ) y_k       (exact ZOH of q̈ = ω² (y − q) − 2ζω q̇)

For each whole delay n_d in 0..``max_delay``, (ω, ζ) minimise the squared error between the
model's and the recorded joint positions (``scipy.optimize.least_squares``, from a small grid
of starts); the delay with the smallest error wins. The recorded velocities give the initial
state. Each joint is fitted on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeasurementError, ParameterError

__all__ = ["ServoFit", "identify_servo", "identify_servo_from_file", "servo_step_response"]


@dataclass(frozen=True)
class ServoFit:
    """The identified servo of each joint.

    Attributes:
        bandwidth: ω_s per joint (n,) [rad/s]; damping: ζ_s (n,); delay: n_d per joint (n,) [cycles].
        period: the recording's sample period T [s] (the interface period).
        rms: the fit's RMS position error per joint (n,) [rad]; moved: whether each joint's target moved.
    """

    bandwidth: np.ndarray
    damping: np.ndarray
    delay: np.ndarray
    period: float
    rms: np.ndarray
    moved: np.ndarray

    def as_dict(self) -> dict[str, Any]:
        return {"bandwidth": self.bandwidth.tolist(), "damping": self.damping.tolist(), "delay": self.delay.tolist(),
                "period": self.period, "rate": 1.0 / self.period, "rms": self.rms.tolist(), "moved": self.moved.tolist()}


def _zoh(w: float, z: float, T: float) -> tuple[np.ndarray, np.ndarray]:
    from scipy.linalg import expm  # type: ignore[import-untyped]

    big = np.zeros((3, 3))
    big[0, 1] = T
    big[1, 0], big[1, 1], big[1, 2] = -w * w * T, -2 * z * w * T, w * w * T
    E = expm(big)
    return E[:2, :2], E[:2, 2]


def servo_step_response(
    target: Any, q0: float, qd0: float, bandwidth: float, damping: float, delay: int, period: float
) -> np.ndarray:
    """The model's joint positions (N,) for a target sequence (N,) sampled at ``period``."""
    r = np.asarray(target, dtype=np.float64)
    Phi, Gam = _zoh(bandwidth, damping, period)
    x = np.array([q0, qd0], dtype=np.float64)
    out = np.empty(r.size)
    for k in range(r.size):
        out[k] = x[0]
        x = Phi @ x + Gam * r[max(k - delay, 0)]  # before the recording: its first target
    return out


def identify_servo(t: Any, target: Any, q: Any, qd: Any = None, *, max_delay: int = 5) -> ServoFit:
    """Fit (ω_s, ζ_s, n_d) per joint to a recorded response (see the module docstring).

    Args:
        t: sample times (N,) [s], uniformly spaced (the interface period).
        target: commanded joint positions (N, n) [rad]; q: measured ones (N, n); qd: measured
            velocities (N, n) (the initial state; zeros when None).
        max_delay: largest delay tried [cycles].

    Raises:
        MeasurementError: non-uniform time, too few samples, a target that never moves.
        DimensionError/ParameterError: shapes or options.
    """
    from scipy.optimize import least_squares  # type: ignore[import-untyped]

    t = np.asarray(t, dtype=np.float64).reshape(-1)
    r = np.asarray(target, dtype=np.float64)
    y = np.asarray(q, dtype=np.float64)
    r = r[:, None] if r.ndim == 1 else r
    y = y[:, None] if y.ndim == 1 else y
    if r.shape != y.shape or r.shape[0] != t.size:
        raise ParameterError(f"target and q must both have shape (N, n) with N = len(t) = {t.size}; got {r.shape}, {y.shape}")
    v = np.zeros_like(y) if qd is None else np.asarray(qd, dtype=np.float64).reshape(y.shape)
    if t.size < 10:
        raise MeasurementError(f"a step response needs at least 10 samples; got {t.size}")
    dt = np.diff(t)
    T = float(np.median(dt))
    if not np.all(np.abs(dt - T) <= 1e-3 * T):
        i = int(np.flatnonzero(np.abs(dt - T) > 1e-3 * T)[0])
        raise MeasurementError(
            f"the recording must be sampled uniformly (one row per interface cycle, period {T:.6g} s); "
            f"row {i + 1} comes {dt[i]:.6g} s after row {i}"
        )
    if isinstance(max_delay, bool) or int(max_delay) != max_delay or max_delay < 0:
        raise ParameterError(f"max_delay must be a whole number of cycles >= 0; got {max_delay!r}")
    n = r.shape[1]
    W, Z, D, R = np.full(n, np.nan), np.full(n, np.nan), np.zeros(n, dtype=int), np.full(n, np.nan)
    moved = np.ptp(r, axis=0) > 0
    if not moved.any():
        raise MeasurementError("no joint's target moves in the recording: a step response is needed to identify the servo")
    nyq = math.pi / T
    for j in np.flatnonzero(moved):
        scale = float(np.ptp(r[:, j]))
        best = (math.inf, math.nan, math.nan, 0)
        for d in range(int(max_delay) + 1):
            def res(p: np.ndarray, d: int = d, j: int = j, scale: float = scale) -> np.ndarray:
                w, z = math.exp(p[0]), p[1]
                return (servo_step_response(r[:, j], y[0, j], v[0, j], w, z, d, T) - y[:, j]) / scale

            for w0 in (0.05 * nyq, 0.2 * nyq):
                for z0 in (0.5, 1.0):
                    sol = least_squares(res, [math.log(w0), z0], bounds=([math.log(1e-3 * nyq), 0.0], [math.log(2 * nyq), 10.0]),
                                        xtol=1e-12, ftol=1e-12, gtol=1e-12)
                    cost = float(np.sqrt(np.mean(sol.fun**2))) * scale
                    if cost < best[0]:
                        best = (cost, math.exp(sol.x[0]), float(sol.x[1]), d)
        R[j], W[j], Z[j], D[j] = best
    return ServoFit(bandwidth=W, damping=Z, delay=D, period=T, rms=R, moved=moved)


def identify_servo_from_file(path: str | Path, *, target_prefix: str = "target_q", max_delay: int = 5, **read: Any) -> ServoFit:
    """:func:`identify_servo` on a recorded table (CSV/Parquet) read with the library's recording reader.

    The file has the columns of a recorded run (``t, q1..qn, qd1..qn``, read by
    :func:`forcecontrol.realarm.io.read_recording`) and the commanded joint positions
    ``<target_prefix>1..n`` (also ``<target_prefix>_0..n−1``, the UR RTDE spelling ``target_q_0``).

    Raises:
        ParameterError: the target columns are missing (the message names them).
    """
    import pandas as pd

    from ..realarm.io import read_recording

    run = read_recording(path, **read)
    path = Path(path)
    df = pd.read_csv(path) if path.suffix.lower() == ".csv" else pd.read_parquet(path)
    cols = [str(c).strip() for c in df.columns]
    df.columns = cols
    n = run.n
    for names in ([f"{target_prefix}{i + 1}" for i in range(n)], [f"{target_prefix}_{i}" for i in range(n)]):
        if all(c in cols for c in names):
            target = df[names].to_numpy(dtype=np.float64)
            break
    else:
        raise ParameterError(
            f"{path}: the commanded joint positions {target_prefix}1..{target_prefix}{n} (or {target_prefix}_0..{n - 1}) "
            f"are missing; the file has {', '.join(cols[:20])}"
        )
    return identify_servo(run.t, target, run.q, run.qd, max_delay=max_delay)
