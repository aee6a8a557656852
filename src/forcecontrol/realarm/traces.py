"""A simulated trace against a recorded one: time alignment, errors, figure (:func:`compare_traces`).

The time shift that best aligns them (searched over ±``max_shift``), then RMS and maximum force
and joint-position errors, and a figure.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DimensionError, MeasurementError, ParameterError
from ..sim.result import SimulationResult
from ..viz.plotting import finish_figure
from .io import RecordedRun
from .io.recorded import wrench_axis_names
from .wrenches import recorded_wrench_in_base

__all__ = ["compare_traces", "TraceComparison", "recorded_from_simulation"]

#: the largest time shift searched, in samples (each lag is one pass over the traces)
MAX_LAG_SAMPLES = 1_000_000


def recorded_from_simulation(result: SimulationResult, *, wrench: str = "measured") -> RecordedRun:
    """A simulation log as a :class:`~forcecontrol.realarm.io.RecordedRun` (torques: what was applied).

    Args:
        result: the simulation; wrench: ``"measured"`` (what the controller read) or ``"true"``.
    """
    if wrench not in ("measured", "true"):
        raise ParameterError(f"wrench must be 'measured' or 'true'; got {wrench!r}")
    h = result.wrench_measured if wrench == "measured" else result.wrench
    return RecordedRun(t=result.t, q=result.q, qd=result.qd, tau=result.torque, wrench=h,
                       source=f"simulation {result.label!r}" if result.label else "simulation")


@dataclass(frozen=True)
class TraceComparison:
    """A simulated and a recorded trace after time alignment.

    Attributes:
        t: common times (N,) [s] (simulated clock).
        q_simulated, q_recorded: joint positions (N, n) [rad].
        wrench_simulated, wrench_recorded: wrenches (N, m) [N], or None when either has none.
        shift: the recorded trace's time shift that aligns it best [s] (recorded t − shift ≈ simulated t).
        metrics: ``shift``, ``position_error_rms``/``_max`` [rad], ``force_error_rms``/``_max`` [N].
    """

    t: np.ndarray
    q_simulated: np.ndarray
    q_recorded: np.ndarray
    wrench_simulated: np.ndarray | None
    wrench_recorded: np.ndarray | None
    shift: float
    metrics: dict[str, float]

    def plot(self, path: str | Path | None = None) -> Any:
        """Simulated against recorded: joint positions and wrench components over time (matplotlib).

        Args:
            path: save a PNG there (the figure is then closed and the path returned).
        """
        import matplotlib

        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        panels = [("q", self.q_simulated, self.q_recorded, "rad")]
        if self.wrench_simulated is not None and self.wrench_recorded is not None:
            panels.append(("f", self.wrench_simulated, self.wrench_recorded, "N"))
        fig, axes = plt.subplots(len(panels), 1, figsize=(7.5, 3.2 * len(panels)), squeeze=False, sharex=True)
        for ax, (name, a, b, unit) in zip(axes[:, 0], panels):
            names = wrench_axis_names(a.shape[1]) if name == "f" else [f"q{i + 1}" for i in range(a.shape[1])]
            for j, lab in enumerate(names):
                line = ax.plot(self.t, a[:, j], lw=1.2, label=f"{lab} simulated")[0]
                ax.plot(self.t, b[:, j], "--", lw=1.0, color=line.get_color(), label=f"{lab} recorded")
            ax.set_ylabel(f"{'force' if name == 'f' else 'joint position'} [{unit}]")
            ax.grid(True, lw=0.3)
            ax.legend(fontsize=7, ncol=2)
        axes[-1, 0].set_xlabel("t [s]")
        m = self.metrics
        title = f"shift {m['shift'] * 1e3:.1f} ms; RMS position error {m['position_error_rms']:.3g} rad"
        if "force_error_rms" in m:
            title += f", RMS force error {m['force_error_rms']:.3g} N"
        fig.suptitle(title, fontsize=9)
        fig.tight_layout()
        return finish_figure(fig, path)


def _convention(r: RecordedRun) -> tuple[str, str | None]:
    return r.wrench_frame, (r.wrench_point if r.m == 6 else None)


def _same_convention(r: RecordedRun, robot: Any) -> RecordedRun:
    """``r`` with its wrench in base axes about the end-effector (the simulator's convention), converted if need be."""
    from dataclasses import replace

    from ..errors import FrameError

    if _convention(r) == ("base", "end-effector" if r.m == 6 else None):
        return r
    if robot is None:
        raise FrameError(
            f"{r.source}: the wrench is in frame {r.wrench_frame!r} about {r.wrench_point!r}, the simulated one in the base "
            "frame about the end-effector; give the robot (compare-trace with a scenario does) to convert it"
        )
    return replace(r, wrench=recorded_wrench_in_base(r, robot), wrench_frame="base", wrench_point="end-effector")


def compare_traces(
    simulated: RecordedRun | SimulationResult,
    recorded: RecordedRun,
    *,
    period: float | None = None,
    max_shift: float = 0.1,
    max_gap: float | None = None,
    robot: Any = None,
) -> TraceComparison:
    """Align a recorded trace with a simulated one in time and measure how far apart they are.

    Both are resampled onto ``period`` (default: the simulated trace's median step); the shift
    of the recorded trace within ±``max_shift`` that minimises the mean squared difference of the
    joint positions (each joint scaled by its simulated range) and, when both have one, of the
    wrench (scaled likewise) is taken; the errors are then measured on the overlap.

    Returns:
        A :class:`TraceComparison` (``metrics``: shift [s], RMS and max joint-position error
        [rad] over all joints, RMS and max of the force-error norm [N]).

    The wrenches are compared in one convention: a recorded wrench in another frame or about another point than
    the simulated one (the library's: base axes, about the end-effector) is converted with ``robot``'s forward
    kinematics (:func:`~forcecontrol.realarm.replay.recorded_wrench_in_base`).

    Raises:
        DimensionError: different numbers of joints or wrench components.
        FrameError: the wrenches' frames or points differ and no ``robot`` is given to convert them.
        MeasurementError: the traces do not overlap by at least 10 samples after the shift.
    """
    sim = recorded_from_simulation(simulated) if isinstance(simulated, SimulationResult) else simulated
    if sim.n != recorded.n:
        raise DimensionError(f"the simulated trace has {sim.n} joints, the recorded one {recorded.n}")
    both_wrench = sim.wrench is not None and recorded.wrench is not None
    if both_wrench and sim.m != recorded.m:
        raise DimensionError(f"the simulated wrench has {sim.m} components, the recorded one {recorded.m}")
    if period is None:
        period = float(np.median(np.diff(sim.t)))
    a = sim.resample(period, max_gap=max_gap)
    b = recorded.resample(period, max_gap=max_gap)
    if both_wrench:
        a, b = _same_convention(a, robot), _same_convention(b, robot)
    if both_wrench and recorded.wrench_sense != sim.wrench_sense:
        b = RecordedRun(t=b.t, q=b.q, qd=b.qd, tau=b.tau, wrench=-b.wrench, wrench_frame=b.wrench_frame,
                        wrench_point=b.wrench_point, wrench_sense=sim.wrench_sense, source=b.source)

    def stack(r: RecordedRun) -> np.ndarray:
        return np.hstack([r.q, r.wrench]) if both_wrench else r.q

    A, B = stack(a), stack(b)
    scale = np.maximum(np.ptp(A, axis=0), 1e-12)
    ta0, tb0 = a.t[0], b.t[0]
    lags = max_shift / period
    if not lags <= MAX_LAG_SAMPLES:  # NaN too: no OverflowError from int(round(inf)), no 1e300-long loop
        raise ParameterError(f"max_shift must be at most {MAX_LAG_SAMPLES:,} sample periods ({MAX_LAG_SAMPLES * period:.6g} s "
                             f"here); got {max_shift!r} s")
    max_lag = int(round(lags))
    best: tuple[float, int] | None = None
    for lag in range(-max_lag, max_lag + 1):
        # recorded sample j matches simulated sample i when tb0 + j·Ts − shift = ta0 + i·Ts; lag counts samples
        off = int(round((tb0 - ta0) / period)) - lag  # index of a's sample aligned with b's first
        i0, j0 = max(off, 0), max(-off, 0)
        L = min(A.shape[0] - i0, B.shape[0] - j0)
        if L < 10:
            continue
        cost = float(np.mean(((A[i0 : i0 + L] - B[j0 : j0 + L]) / scale) ** 2))
        if best is None or cost < best[0] - 1e-15:
            best = (cost, lag)
    if best is None:
        raise MeasurementError(
            f"the traces overlap by fewer than 10 samples for every shift within ±{max_shift:.6g} s "
            f"(simulated {a.t[0]:.6g}..{a.t[-1]:.6g} s, recorded {b.t[0]:.6g}..{b.t[-1]:.6g} s)"
        )
    lag = best[1]
    off = int(round((tb0 - ta0) / period)) - lag
    i0, j0 = max(off, 0), max(-off, 0)
    L = min(A.shape[0] - i0, B.shape[0] - j0)
    sl_a, sl_b = slice(i0, i0 + L), slice(j0, j0 + L)
    shift = lag * period
    dq = a.q[sl_a] - b.q[sl_b]
    metrics = {
        "shift": shift, "position_error_rms": float(np.sqrt(np.mean(dq**2))), "position_error_max": float(np.max(np.abs(dq))),
    }
    ws = wr = None
    if both_wrench:
        ws, wr = a.wrench[sl_a], b.wrench[sl_b]
        df = np.linalg.norm(ws - wr, axis=1)
        metrics.update({"force_error_rms": float(np.sqrt(np.mean(df**2))), "force_error_max": float(np.max(df))})
    return TraceComparison(t=a.t[sl_a], q_simulated=a.q[sl_a], q_recorded=b.q[sl_b], wrench_simulated=ws,
                           wrench_recorded=wr, shift=shift, metrics=metrics)
