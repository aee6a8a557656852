"""Figures like the chapter's (matplotlib is imported here only)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .scenarios.core import ScenarioRun
    from .simulation import SimulationResult

__all__ = ["plot_results", "plot_run", "plot_run_figures", "SIGNAL_LABELS"]

#: axis labels of the plottable columns.
SIGNAL_LABELS: dict[str, str] = {
    "x": "tip x [m]",
    "y": "tip y [m]",
    "z": "tip z [m]",
    "vx": "tip ẋ [m/s]",
    "vy": "tip ẏ [m/s]",
    "fx": "f_x [N]",
    "fy": "f_y [N]",
    "fz": "f_z [N]",
    "vz": "tip ż [m/s]",
    "rx": "φ_x [rad]",
    "ry": "φ_y [rad]",
    "rz": "φ_z [rad]",
    "mx": "μ_x [N m]",
    "my": "μ_y [N m]",
    "mz": "μ_z [N m]",
    "u1": "u_1 [N m]",
    "u2": "u_2 [N m]",
}

_STYLES = ["-", "--", "-.", ":"]


def _series(result: SimulationResult, signal: str) -> np.ndarray:
    cols = result.columns()
    if signal in cols:
        return cols[signal]
    raise KeyError(f"unknown signal {signal!r}; expected one of {', '.join(cols)} (derived metrics are not plotted)")


def plot_results(
    results: list[SimulationResult],
    signals: list[str],
    *,
    title: str = "",
    t_max: float | None = None,
    overlays: dict[str, list[tuple[np.ndarray, np.ndarray, str]]] | None = None,
    path: str | Path | None = None,
) -> Any:
    """One panel per signal against time, one line per result (the chapter's figure style).

    Args:
        results: simulated cases; their labels make the legend.
        signals: column names (``"x"``, ``"y"``, ``"fx"``, ...).
        title: figure title; t_max: time-axis limit [s].
        overlays: extra lines per signal, ``(t, values, label)`` (e.g. a linear model's prediction).
        path: where to save a PNG; the figure is closed afterwards when given.

    Returns:
        The matplotlib Figure (or the saved path when ``path`` is given).
    """
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(signals), figsize=(5.2 * len(signals), 3.8), squeeze=False)
    for ax, sig in zip(axes[0], signals):
        for i, r in enumerate(results):
            ax.plot(r.t, _series(r, sig), _STYLES[i % len(_STYLES)], color="k", lw=1.2, label=r.label or f"case {i + 1}")
        for t, v, lab in (overlays or {}).get(sig, []):
            ax.plot(t, v, lw=0.9, color="tab:red", alpha=0.8, label=lab)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(SIGNAL_LABELS.get(sig, sig))
        ax.grid(True, lw=0.3)
        if t_max is not None:
            ax.set_xlim(0, t_max)
    axes[0][0].legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=120)
        plt.close(fig)
        return path
    return fig


def plot_run(run: ScenarioRun, path: str | Path | None = None) -> Any:
    """The scenario's first figure: its ``[figure]`` signals for its cases (all by default)."""
    figs = run.scenario.figures or ({},)
    return _plot_figure(run, figs[0], path)


def plot_run_figures(run: ScenarioRun, folder: str | Path, stem: str) -> list[Path]:
    """Every figure of the scenario as ``folder/stem[-name].png``; returns the paths."""
    figs = run.scenario.figures or ({},)
    out = []
    for fig in figs:
        name = f"{stem}-{fig['name']}" if fig.get("name") else stem
        out.append(_plot_figure(run, fig, Path(folder) / f"{name}.png"))
    return out


def _plot_figure(run: ScenarioRun, fig: dict[str, Any], path: str | Path | None) -> Any:
    signals = list(fig.get("signals") or ["x", "fx"])
    wanted = fig.get("cases")
    results = [c.result for c in run.cases if not wanted or c.label in wanted]
    return plot_results(
        results, signals, title=fig.get("title") or run.scenario.title, t_max=fig.get("t_max"), path=path,
    )
