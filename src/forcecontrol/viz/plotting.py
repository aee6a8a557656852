"""Figures like the chapter's (matplotlib is imported here only)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.paths import inside, safe_name

if TYPE_CHECKING:  # pragma: no cover
    from ..scenarios.core import ScenarioRun
    from ..sim.simulation import SimulationResult

__all__ = [
    "plot_results", "plot_run", "plot_run_figures", "figure_jobs", "finish_figure", "case_style", "panel_grid", "SIGNAL_LABELS",
    "CASE_STYLES",
]

#: axis labels of the plottable columns.
SIGNAL_LABELS: dict[str, str] = {
    "tank_energy": "tank energy T [J]",
    "stiffness_scale": "tr applied / tr scheduled stiffness [-]",
    "stiffness_refused": "schedule refused ‖K_s − K‖/‖K_s‖ [-]",
    "storage": "impedance storage H [J]",
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

#: one style per case, the same in every panel and figure: colour-blind-safe colours (Okabe-Ito),
#: each with its own dash pattern so that cases stay apart in grey print too.
CASE_STYLES: tuple[tuple[str, str], ...] = (
    ("#000000", "-"),
    ("#0072B2", "--"),
    ("#D55E00", "-."),
    ("#009E73", ":"),
    ("#CC79A7", (0, (5, 1, 1, 1, 1, 1))),  # type: ignore[assignment]
    ("#E69F00", (0, (8, 2))),  # type: ignore[assignment]
    ("#56B4E9", (0, (1, 2))),  # type: ignore[assignment]
)

#: panel size [in] and the most panels in a row.
PANEL_SIZE = (4.4, 3.0)
MAX_COLUMNS = 3


def finish_figure(fig: Any, path: str | Path | None, dpi: int = 110) -> Any:
    """Save ``fig`` as a PNG at ``path`` (folders created), close it and return the path; or return ``fig`` (no path)."""
    if path is None:
        return fig
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def case_style(i: int) -> dict[str, Any]:
    """Line properties of case ``i`` (0-based): colour and dash pattern from :data:`CASE_STYLES`, cycling."""
    color, ls = CASE_STYLES[i % len(CASE_STYLES)]
    return {"color": color, "linestyle": ls, "lw": 1.3}


def panel_grid(n: int) -> tuple[int, int]:
    """Rows and columns for ``n`` panels: one row up to three panels, 2 x 2 for four, rows of three beyond.

    Raises:
        ParameterError: ``n`` is not a positive integer.
    """
    from ..errors import ParameterError

    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
        raise ParameterError(f"the number of panels must be a positive integer; got {n!r}")
    if n == 4:
        return 2, 2
    cols = min(int(n), MAX_COLUMNS)
    return -(-int(n) // cols), cols


def _series(result: SimulationResult, signal: str) -> np.ndarray:
    cols = result.columns()
    if signal in cols:
        return cols[signal]
    raise KeyError(f"unknown signal {signal!r}; expected one of {', '.join(cols)} (derived metrics are not plotted)")


def _reads_position_reference(result: SimulationResult) -> bool:
    """Whether the run's controller reads ``reference.position`` (its class's ``reads_position_reference``, True
    unless the class says otherwise)."""
    from .. import controllers

    name = str((result.metadata.get("controller") or {}).get("type", ""))
    return bool(getattr(getattr(controllers, name, None), "reads_position_reference", True))


def _reference_series(result: SimulationResult, signal: str) -> tuple[np.ndarray, str] | None:
    """The reference logged for a position or force signal (x_d, f_d) with its legend label, if any."""
    cols = result.columns()
    if signal in ("x", "y", "z", "rx", "ry", "rz"):
        if not _reads_position_reference(result):
            return None  # a position the controller never tracks (the inner position and velocity loops' x_F)
        key, sym = f"ref_position_{signal}", "desired"
    elif signal in ("fx", "fy", "fz", "mx", "my", "mz"):
        axis = {"f": "", "m": "r"}[signal[0]] + signal[1]
        key, sym = f"ref_force_{axis}", "desired"
    else:
        return None
    if key not in cols:
        return None
    return cols[key], sym


def plot_results(
    results: list[SimulationResult],
    signals: list[str],
    *,
    title: str = "",
    t_max: float | None = None,
    overlays: dict[str, list[tuple[np.ndarray, np.ndarray, str]]] | None = None,
    expected: dict[str, list[tuple[float, str]]] | None = None,
    references: bool = True,
    zoom: float | None = None,
    note: str = "",
    path: str | Path | None = None,
    mathtext: bool = False,
) -> Any:
    """One panel per signal against time, one line style per result, the same in every panel.

    The panels are laid out in a grid (:func:`panel_grid`), the figure sized to the panel count
    (:data:`PANEL_SIZE` each) with constrained layout, and one legend for the whole figure below
    the panels, so that no legend covers a curve.

    Args:
        results: simulated cases; their labels make the legend.
        signals: column names (``"x"``, ``"y"``, ``"fx"``, ...); axis labels with units from
            :data:`SIGNAL_LABELS`.
        title: figure title; t_max: time-axis limit [s].
        overlays: extra lines per signal, ``(t, values, label)`` (e.g. a linear model's prediction).
        expected: horizontal marks per signal, ``(value, label)``: the book's printed settled
            values (or the closed form), drawn dotted in grey.
        references: draw the logged reference (x_d, f_d) of each distinct reference, thin grey
            (an all-zero reference, e.g. f_d of a scheme without force reference, is not drawn).
        zoom: when given, each force/moment panel gets an inset with the first ``zoom`` seconds,
            one marker per control sample (shows start-up transients sample by sample) [s].
        note: a caption printed under the panels (what the reader should know to read the figure).
        path: where to save a PNG; the figure is closed afterwards when given.
        mathtext: draw ``$...$`` in the title, the note and the case labels as matplotlib mathtext
            (a scenario's ``[figure] mathtext = true``); by default every character is drawn as written.

    Returns:
        The matplotlib Figure (or the saved path when ``path`` is given).

    Raises:
        KeyError: a signal is not a column of the results.
    """
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import textwrap

    import matplotlib.pyplot as plt

    rows, cols = panel_grid(len(signals))
    # legend entries (at most): cases, the reference, overlays, the expected mark; rows of one or two
    from ..core.text import TITLE_LIMIT, figure_safe  # text from files drawn literally (no mathtext), bounded

    case_labels = [figure_safe(r.label or f"case {i + 1}", mathtext=mathtext) for i, r in enumerate(results)]
    legend_labels = case_labels + sorted({figure_safe(lab) for lines in (overlays or {}).values() for _, _, lab in lines})
    legend_cols = 1 if max(map(len, legend_labels)) > 45 else 2
    legend_rows = -(-(len(legend_labels) + 2) // legend_cols)
    note_text = " ".join(figure_safe(note, 4 * TITLE_LIMIT, mathtext=mathtext).split())
    note_lines = textwrap.wrap(note_text, int(16 * PANEL_SIZE[0] * cols)) if note else []
    footer = 0.15 + 0.19 * legend_rows + 0.14 * len(note_lines)  # [in]
    panels_h = PANEL_SIZE[1] * rows + (0.3 if title else 0.0)
    fig = plt.figure(figsize=(PANEL_SIZE[0] * cols, panels_h + footer), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[panels_h, footer])
    axes = top.subplots(rows, cols, squeeze=False)
    flat = axes.ravel()
    for ax in flat[len(signals):]:
        ax.set_visible(False)
    for ax, sig in zip(flat, signals):
        span = []
        for i, r in enumerate(results):
            y = _series(r, sig)
            if np.any(np.isfinite(y)):  # a signal a case does not log (NaN) draws nothing, sets no range
                span += [float(np.nanmin(y)), float(np.nanmax(y))]
            ax.plot(r.t, y, label=case_labels[i], zorder=3, **case_style(i))
        refs = _draw_references(ax, results, sig) if references else []
        for t, v, lab in (overlays or {}).get(sig, []):
            ax.plot(t, v, lw=0.9, color="tab:red", alpha=0.8, label=figure_safe(lab), zorder=2)
        for value, lab in (expected or {}).get(sig, []):
            ax.axhline(value, color="0.35", lw=0.9, ls=":", zorder=2)
            ax.annotate(figure_safe(lab), xy=(1.0, value), xycoords=("axes fraction", "data"), xytext=(-3, 2),
                        textcoords="offset points", ha="right", va="bottom", fontsize=7, color="0.25")
        _set_ylim(ax, (min(span), max(span)) if span else (0.0, 1.0), refs, [v for v, _ in (expected or {}).get(sig, [])])
        ax.set_xlabel("t [s]")
        ax.set_ylabel(SIGNAL_LABELS.get(sig) or figure_safe(sig))
        ax.grid(True, lw=0.3)
        if t_max is not None:
            ax.set_xlim(0, t_max)
        if zoom is not None and sig[:1] in ("f", "m"):
            _zoom_inset(ax, results, sig, zoom)
    handles, labels = _unique_legend(flat[: len(signals)])
    if any((expected or {}).get(sig) for sig in signals):
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], color="0.35", lw=0.9, ls=":"))
        labels.append("expected settled value (book or closed form)")
    if handles:
        bottom.legend(handles, labels, loc="upper center", ncols=legend_cols,
                      fontsize=8, frameon=False, borderaxespad=0.2)
    if note_lines:
        bottom.text(0.01, 0.02, "\n".join(note_lines), fontsize=7.5, color="0.2", ha="left", va="bottom",
                    transform=bottom.transSubfigure)
    if title:
        top.suptitle(figure_safe(title, TITLE_LIMIT, mathtext=mathtext), fontsize=10)
    return finish_figure(fig, path, dpi=120)


def _draw_references(ax: Any, results: list[SimulationResult], sig: str) -> list[np.ndarray]:
    """Each distinct non-zero reference of ``sig``, thin grey; returns the drawn series."""
    drawn: list[np.ndarray] = []
    for r in results:
        ref = _reference_series(r, sig)
        if ref is None or not np.any(ref[0]) or any(d.shape == ref[0].shape and np.array_equal(d, ref[0]) for d in drawn):
            continue
        drawn.append(ref[0])
        ax.plot(r.t, ref[0], color="0.55", lw=0.8, ls=(0, (4, 2)), label=f"{ref[1]} (reference)", zorder=1)
    return drawn


def _set_ylim(ax: Any, data: tuple[float, float], refs: list[np.ndarray], marks: list[float]) -> None:
    """The y range of the simulated curves and the expected marks, widened for the references by at most
    half the data's span (a far-away x_d, e.g. behind a plane, runs to the edge instead of squashing the data)."""
    lo = min([data[0], *marks])
    hi = max([data[1], *marks])
    width = max(hi - lo, 1e-6 * max(1.0, abs(hi)))
    if refs:
        rlo = min(float(np.nanmin(d)) for d in refs)
        rhi = max(float(np.nanmax(d)) for d in refs)
        lo, hi = max(min(lo, rlo), lo - 0.5 * width), min(max(hi, rhi), hi + 0.5 * width)
    pad = 0.05 * max(hi - lo, width)
    ax.set_ylim(lo - pad, hi + pad)


def _unique_legend(axes: Any) -> tuple[list[Any], list[str]]:
    handles, labels = [], []
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    return handles, labels


def _zoom_inset(ax: Any, results: list[SimulationResult], sig: str, zoom: float) -> None:
    lo, hi = ax.get_ylim()
    last = np.mean([_series(r, sig)[-1] for r in results])
    y0 = 0.08 if (last - lo) > 0.5 * (hi - lo) else 0.45  # away from where the curves settle
    ins = ax.inset_axes((0.45, y0, 0.5, 0.42))
    for i, r in enumerate(results):
        sel = r.t <= zoom + 1e-12
        ins.plot(r.t[sel] * 1e3, _series(r, sig)[sel], marker=".", ms=3, **case_style(i))
    ins.set_xlabel("t [ms]", fontsize=7, labelpad=1)
    ins.tick_params(labelsize=6.5)
    ins.grid(True, lw=0.3)
    ins.set_title(f"first {zoom * 1e3:g} ms, one dot per sample", fontsize=7, pad=2)


def plot_run(run: ScenarioRun, path: str | Path | None = None) -> Any:
    """The scenario's first figure: its ``[figure]`` signals for its cases (all by default)."""
    figs = run.scenario.figures or ({},)
    return _plot_figure(run, figs[0], path)


def plot_run_figures(run: ScenarioRun, folder: str | Path, stem: str) -> list[Path]:
    """Every figure of the scenario as ``folder/stem[-name].png``; returns the paths."""
    return [plot_results(*args, **kwargs) for args, kwargs in figure_jobs(run, folder, stem)]


def figure_jobs(run: ScenarioRun, folder: str | Path, stem: str) -> list[tuple[tuple[Any, ...], dict[str, Any]]]:
    """The :func:`plot_results` calls that draw every figure of the scenario into
    ``folder/stem[-name].png``, as ``(args, kwargs)``: plain data (results, signals, marks, paths)
    that can be sent to another process (:mod:`forcecontrol.viz.render_process`)."""
    figs = run.scenario.figures or ({},)
    jobs = []
    for fig in figs:
        name = f"{stem}-{safe_name(fig['name'])}" if fig.get("name") else stem
        jobs.append(_figure_call(run, fig, inside(folder, f"{safe_name(name)}.png")))
    return jobs


def _plot_figure(run: ScenarioRun, fig: dict[str, Any], path: str | Path | None) -> Any:
    args, kwargs = _figure_call(run, fig, path)
    return plot_results(*args, **kwargs)


def _figure_call(run: ScenarioRun, fig: dict[str, Any], path: str | Path | None) -> tuple[tuple[Any, ...], dict[str, Any]]:
    signals = list(fig.get("signals") or ["x", "fx"])
    wanted = fig.get("cases")
    cases = [c for c in run.cases if not wanted or c.label in wanted]
    return ([c.result for c in cases], signals), dict(
        title=fig.get("title") or run.scenario.title, t_max=fig.get("t_max"),
        expected=expected_marks(cases, signals), zoom=fig.get("zoom"), note=fig.get("note") or "", path=path,
        mathtext=bool(fig.get("mathtext")),
    )


def expected_marks(cases: list[Any], signals: list[str]) -> dict[str, list[tuple[float, str]]]:
    """The cases' expected settled values of plotted signals (``[case.expected]``: the book's printed
    numbers or the closed form), as ``{signal: [(value, label)]}`` for :func:`plot_results`; equal
    values of several cases are marked once."""
    marks: dict[str, list[tuple[float, str]]] = {}
    for c in cases:
        for ch in c.checks:
            sig = ch.get("metric")
            if sig not in signals:
                continue
            value = float(ch["expected"])
            have = marks.setdefault(sig, [])
            if all(abs(v - value) > 1e-9 * max(1.0, abs(value)) for v, _ in have):
                have.append((value, f"expected {value:.4g}"))
    return marks
