"""Maps of sweep metrics over two swept parameters, with the analytic sampled-loop stability boundary.

The boundary comes from :mod:`forcecontrol.analysis.force`: for a direct force controller with
diagonal gains on an elastic environment, the sampled loop along the force axis (the chapter's
per-axis model, zero-order hold at Ts, the arm's operational mass at q0) is stable when its
spectral radius is below 1 (:meth:`ForceLoopAxis.spectral_radius`). The map draws the simulated
metric per case, marks the cases the simulation found unstable, and the contour ρ = 1 computed on
a finer grid of the same two parameters.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..core.text import TITLE_LIMIT, figure_safe
from .spec import SweepError, parse_parameter

__all__ = ["analytic_spectral_radius", "stability_boundary", "plot_sweep_map", "plot_sweep_curves", "plot_sweep"]


def analytic_spectral_radius(parts: dict[str, Any]) -> float:
    """Spectral radius of the sampled force loop of a built case along its force axis (NaN if n/a).

    Applies to the three direct force schemes (Sect. 9.4) with diagonal gains on an elastic
    environment with a diagonal stiffness; the force axis is the base axis of the largest
    component of the final reference force (x when f_d = 0).
    """
    from ..analysis.force_design import force_loop_axes, operational_mass
    from ..errors import ForceControlError

    ctl, env, ref, robot = parts["controller"], parts["environment"], parts["reference"], parts["robot"]
    if not hasattr(env, "stiffness_matrix"):
        return math.nan
    try:
        axes = force_loop_axes(ctl, env.stiffness_matrix())
    except ForceControlError:
        return math.nan
    f_d = np.asarray(ref.at(float(parts["duration"])).force, dtype=np.float64)
    i = int(np.argmax(np.abs(f_d))) if np.any(f_d) else 0
    axis = axes[i]
    if axis.environment_stiffness <= 0.0:
        return math.nan
    nu = np.zeros(ctl.m)
    nu[i] = 1.0
    mx = operational_mass(robot, parts["q0"], nu)
    return float(axis.spectral_radius(ctl.sample_time, mx))


_RHO_CACHE: dict[str, float] = {}


def _radius(config: dict[str, Any], label: str, assign: dict[str, Any]) -> float:
    """ρ of the case ``config`` with ``assign`` applied (memoised on the resulting configuration:
    cases that differ only in a swept parameter share their boundary)."""
    from ..scenarios import CaseSpec, build_case
    from .paths import _apply

    cfg = copy.deepcopy(config)
    for path, v in assign.items():
        _apply(cfg, parse_parameter(path, [v]), v, label)
    key = json.dumps(cfg, sort_keys=True, default=str)
    if key not in _RHO_CACHE:
        if len(_RHO_CACHE) > 100_000:
            _RHO_CACHE.clear()
        _RHO_CACHE[key] = analytic_spectral_radius(build_case(CaseSpec(label, cfg, {}), where=f"boundary ({label})"))
    return _RHO_CACHE[key]


def stability_boundary(
    config: dict[str, Any],
    x_path: str,
    y_path: str,
    x_values: Any,
    y_values: Any,
    label: str = "case",
    fixed: dict[str, Any] | None = None,
) -> np.ndarray:
    """Analytic spectral radius ρ on the grid ``x_values × y_values`` (shape (ny, nx)).

    Args:
        config: a scenario case configuration (``CaseSpec.config`` or the sweep metadata's).
        x_path, y_path: the two parameter paths; fixed: other parameters to set first.
    """
    rho = np.full((len(y_values), len(x_values)), np.nan)
    with np.errstate(all="ignore"):
        for iy, yv in enumerate(y_values):
            for ix, xv in enumerate(x_values):
                assign = dict(fixed or {})
                assign[x_path] = _plain(xv)
                assign[y_path] = _plain(yv)
                try:
                    rho[iy, ix] = _radius(config, label, assign)
                except Exception:  # noqa: BLE001 - a grid point the scenario rejects stays NaN
                    pass
                if iy == 0 and ix == 0 and math.isnan(rho[0, 0]):
                    return rho  # the analysis does not apply to this case (not a direct force scheme)
    return rho


def _plain(v: Any) -> Any:
    return v.item() if isinstance(v, np.generic) else v


def _fine(values: np.ndarray, n: int) -> np.ndarray:
    lo, hi = float(np.min(values)), float(np.max(values))
    if lo > 0 and hi / lo > 100:
        return np.geomspace(lo, hi, n)
    return np.linspace(lo, hi, n)


def _numeric(df: Any, p: str) -> np.ndarray:
    """A swept column as floats, or SweepError naming it (a figure axis must be a number)."""
    try:
        vals = df[p].to_numpy(dtype=float)
    except (TypeError, ValueError):
        vals = None
    if vals is None or df[p].dtype == bool:
        shown = ", ".join(str(v) for v in list(dict.fromkeys(df[p].astype(str)))[:4])
        raise SweepError(f"figure axis '{p}' is not a number (values {shown}); expected a numeric swept parameter")
    return vals


def _is_number(df: Any, p: str) -> bool:
    try:
        _numeric(df, p)
    except SweepError:
        return False
    return True


def _case_config(cases: list[dict[str, Any]], row_label: str) -> dict[str, Any] | None:
    """The scenario case of a table row: its label, or its label marked ``"<label> [<paths> swept]"``."""
    for c in cases:
        if c.get("label") == row_label:
            return c.get("config")
    for c in cases:
        lab = str(c.get("label"))
        if row_label.startswith(lab + " [") and row_label.endswith(" swept]"):
            return c.get("config")
    return None


def _log(values: np.ndarray) -> bool:
    v = values[np.isfinite(values)]
    return bool(v.size and v.min() > 0 and v.max() / v.min() > 100)


def _source(source: Any) -> tuple[Any, dict[str, Any]]:
    from .run import read_sweep

    if isinstance(source, tuple):  # (table, metadata), already read
        return source
    return (source.table, source.metadata) if hasattr(source, "table") else read_sweep(source)


def _select(df: Any, meta: dict[str, Any], axes: tuple[str, ...], fixed: dict[str, Any] | None) -> tuple[Any, dict[str, Any]]:
    """The rows the figure shows: the other swept parameters at ``fixed`` (default: their first value);
    a random design keeps every row (its draws rarely share a value)."""
    params = meta.get("parameters", [])
    for p in axes:
        if p not in params:
            raise SweepError(f"figure axis '{p}' is not a swept parameter; expected one of {', '.join(params)}")
    fixed = dict(fixed or {})
    if meta.get("definition", {}).get("design") != "random":
        for p in params:
            if p not in axes and p not in fixed:
                fixed[p] = _plain(df[p].iloc[0])
    sel = np.ones(len(df), dtype=bool)
    for p, v in fixed.items():
        sel &= (df[p] == v).to_numpy()
    return df[sel], fixed


def plot_sweep_map(
    source: Any,
    x: str,
    y: str,
    out: str | Path,
    metrics: tuple[str, ...] = ("settling_time", "overshoot", "steady_state_force_error", "peak_force"),
    fixed: dict[str, Any] | None = None,
    boundary: bool = True,
    resolution: int = 20,
    overwrite: bool | None = False,
) -> Path:
    """One figure: a row per scenario case, a column per metric, over swept parameters x and y.

    Cells are the simulated metric of the stable cases (grid designs; random designs are scattered),
    on a colour scale of the stable cases only; a case the simulation found unstable is a grey,
    hatched cell with a red ``×`` (legend: "unstable"), outside the colour scale; the black line is the analytic sampled-loop
    boundary ρ = 1 (on a ``resolution``² grid, a few ms per point), drawn when the analysis applies.

    Args:
        source: a :class:`~forcecontrol.sweep.SweepResult` or the table's path.
        x, y: swept parameter paths (numbers); fixed: values for the other swept parameters (default:
            the first of each; a random design shows every case).
        out: the PNG file; overwrite: replace a file there that this library did not write
            (a :class:`SweepWarning` says so); a figure of its own (its mark
            ``.<name>.forcecontrol-sweep.json`` names it) is replaced anyway.

    Raises:
        SweepError: an axis is not a swept parameter or not a number; x and y are the same.
        OutputError: ``out`` is a folder, or a file this library did not write (and not ``overwrite``).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Rectangle

    df, meta = _source(source)
    _claim(out, overwrite, meta.get("sweep_id"))
    if x == y:
        raise SweepError(f"figure axes x and y must be two different swept parameters; got '{x}' for both")
    df, fixed = _select(df, meta, (x, y), fixed)
    for p in (x, y):
        _numeric(df, p)
    cases = meta.get("cases", [])
    labels = list(dict.fromkeys(df["case"]))
    fig, axs = plt.subplots(len(labels), len(metrics), figsize=(4.2 * len(metrics), 3.4 * len(labels)), squeeze=False)
    for r, label in enumerate(labels):
        sub = df[df["case"] == label]
        xs = np.sort(sub[x].unique().astype(float))
        ys = np.sort(sub[y].unique().astype(float))
        grid = len(xs) * len(ys) == len(sub)
        rho = None
        if boundary:
            cfg = _case_config(cases, label)
            if cfg is not None:
                fx, fy = _fine(xs, resolution), _fine(ys, resolution)
                rho = stability_boundary(cfg, x, y, fx, fy, label, {k: _plain(v) for k, v in fixed.items()})
                if not np.any(np.isfinite(rho)):
                    rho = None
        for c, metric in enumerate(metrics):
            ax = axs[r, c]
            bad = ~sub["stable"].to_numpy(dtype=bool)
            # the colour scale is the stable cases' (an unstable case's metric would swamp it): unstable ones grey, hatched
            vals = np.where(bad, np.nan, sub[metric].to_numpy(dtype=float))
            if grid:
                Z = np.full((len(ys), len(xs)), np.nan)
                U = np.zeros((len(ys), len(xs)), dtype=bool)
                ix = np.searchsorted(xs, sub[x].to_numpy(dtype=float))
                iy = np.searchsorted(ys, sub[y].to_numpy(dtype=float))
                Z[iy, ix] = vals
                U[iy, ix] = bad
                mesh = ax.pcolormesh(xs, ys, np.ma.masked_invalid(Z), shading="nearest", cmap="viridis")
                if U.any():
                    grey = ax.pcolor(xs, ys, np.ma.masked_where(~U, U.astype(float)), shading="nearest",
                                     cmap=ListedColormap(["0.78"]), edgecolors="0.45", linewidth=0.0)
                    grey.set_hatch("///")
            else:
                mesh = ax.scatter(sub[x][~bad], sub[y][~bad], c=vals[~bad], cmap="viridis", s=12)
            fig.colorbar(mesh, ax=ax, label=f"{_with_unit(metric)} (stable cases)")
            ax.scatter(sub[x][bad], sub[y][bad], marker="x", color="red", s=18, linewidths=1.0)
            if bad.any():
                ax.add_patch(Rectangle((0, 0), 0, 0, facecolor="0.78", edgecolor="red", hatch="///", visible=False,
                                       label="unstable (simulated): grey, not in the colour scale"))
            if rho is not None:
                ax.contour(fx, fy, rho, levels=[1.0], colors="black", linewidths=1.5)
                ax.plot([], [], color="black", label="analytic ρ = 1")
            for vals_, axis_set in ((xs, ax.set_xscale), (ys, ax.set_yscale)):
                if _log(vals_):
                    axis_set("log")
            ax.set_xlabel(x)
            ax.set_ylabel(y)
            ax.set_title(f"{figure_safe(label)}\n{_with_unit(metric)}", fontsize=9)
            if c == 0 and ax.get_legend_handles_labels()[0]:  # a row's cases are stable or not alike in every column
                ax.legend(fontsize=7, loc="best")  # (nothing to explain: no legend, and no matplotlib warning)
    title = meta.get("title") or meta.get("scenario", "")
    fig.suptitle(figure_safe(f"{title}: sweep over {x} and {y}" + (f" ({json.dumps(fixed, default=str)})" if fixed else ""),
                             TITLE_LIMIT), fontsize=10)
    return _save(fig, plt, out, meta.get("sweep_id"))


def _with_unit(metric: str) -> str:
    """A metric's name with its unit in brackets (``settled_force [N]``), as the tables show them."""
    from ..scenarios.units import SWEEP_METRIC_UNITS

    u = SWEEP_METRIC_UNITS.get(metric, "")
    return f"{metric} [{u}]" if u else metric


def _claim(out: str | Path, overwrite: bool | None, sweep_id: Any = None) -> None:
    """Refuse a figure path holding a file this library did not write, or another sweep's figure (unless
    ``overwrite``; then warn). ``overwrite=None``: checked by the caller (:func:`plot_sweep`)."""
    if overwrite is None:
        return
    import warnings

    from .spec import SweepWarning
    from .store import check_file_output

    note = check_file_output(Path(out), overwrite, sweep_id=sweep_id)
    if note:
        warnings.warn(note, SweepWarning, stacklevel=3)


def _save(fig: Any, plt: Any, out: str | Path, sweep_id: Any = None) -> Path:
    from .store import mark_file

    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.35 / fig.get_figheight()))
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    mark_file(out, str(sweep_id))  # the library's own: a later sweep may replace it
    return out


def plot_sweep_curves(
    source: Any,
    x: str,
    out: str | Path,
    metrics: tuple[str, ...] = ("settling_time", "overshoot", "steady_state_force_error", "peak_force"),
    fixed: dict[str, Any] | None = None,
    boundary: bool = True,
    resolution: int = 80,
    overwrite: bool | None = False,
) -> Path:
    """One figure of a one-parameter view: a panel per metric, a curve per scenario case over ``x``.

    A red ``×`` marks a case the simulation found unstable; a dashed vertical line marks where the
    analytic sampled-loop spectral radius crosses 1 (``resolution`` points over the swept range),
    drawn when the analysis applies.

    Args:
        source: a :class:`~forcecontrol.sweep.SweepResult` or the table's path.
        x: a swept parameter path (numbers); fixed: values for the other swept parameters (default:
            the first of each; a random design shows every case).
        out: the PNG file; overwrite: as for :func:`plot_sweep_map`.

    Raises:
        SweepError: ``x`` is not a swept parameter or not a number.
        OutputError: ``out`` is a folder, or a file this library did not write (and not ``overwrite``).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    df, meta = _source(source)
    _claim(out, overwrite, meta.get("sweep_id"))
    df, fixed = _select(df, meta, (x,), fixed)
    _numeric(df, x)
    cases = meta.get("cases", [])
    fig, axs = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 3.6), squeeze=False)
    for k, label in enumerate(dict.fromkeys(df["case"])):
        sub = df[df["case"] == label]
        order = np.argsort(sub[x].to_numpy(dtype=float), kind="stable")
        xv = sub[x].to_numpy(dtype=float)[order]
        bad = ~sub["stable"].to_numpy(dtype=bool)[order]
        limits: list[float] = []
        cfg = _case_config(cases, label) if boundary else None
        if cfg is not None and len(xv) > 1:
            fx = _fine(xv, resolution)
            rho = np.full(len(fx), np.nan)
            with np.errstate(all="ignore"):
                for i, v in enumerate(fx):
                    try:
                        rho[i] = _radius(cfg, label, {**{p: _plain(w) for p, w in fixed.items()}, x: float(v)})
                    except Exception:  # noqa: BLE001 - a point the scenario rejects stays NaN
                        pass
                    if i == 0 and math.isnan(rho[0]):
                        break  # the analysis does not apply to this case
            ok = np.isfinite(rho[:-1]) & np.isfinite(rho[1:])
            limits = [float(fx[i]) for i in np.flatnonzero(ok & ((rho[:-1] < 1.0) != (rho[1:] < 1.0)))]
        color = f"C{k % 10}"
        for c, metric in enumerate(metrics):
            ax = axs[0, c]
            yv = sub[metric].to_numpy(dtype=float)[order]
            ax.plot(xv, yv, "o-", color=color, markersize=3, label=figure_safe(label))
            ax.scatter(xv[bad], yv[bad], marker="x", color="red", s=24, zorder=3,
                       label="unstable (simulated)" if k == 0 else None)
            for xl in limits:
                ax.axvline(xl, color=color, linestyle="--", linewidth=1.0,
                           label=f"analytic ρ = 1 ({figure_safe(label)})" if c == 0 else None)
            if _log(xv):
                ax.set_xscale("log")
            ax.set_xlabel(x)
            ax.set_title(_with_unit(metric), fontsize=9)
    axs[0, 0].legend(fontsize=7, loc="best")
    title = meta.get("title") or meta.get("scenario", "")
    fig.suptitle(figure_safe(f"{title}: sweep over {x}" + (f" ({json.dumps(fixed, default=str)})" if fixed else ""), TITLE_LIMIT),
                 fontsize=10)
    return _save(fig, plt, out, meta.get("sweep_id"))


def plot_sweep(
    source: Any, out: str | Path, x: str | None = None, y: str | None = None, *, overwrite: bool = False
) -> tuple[Path, list[str]]:
    """The default figure of a sweep (what ``forcecontrol sweep`` draws) and what it leaves out.

    One varied parameter (or ``x`` alone of one): curves over it (:func:`plot_sweep_curves`); two or
    more: maps over ``x`` and ``y`` (default: the first two parameters that take more than one value,
    :func:`plot_sweep_map`).

    ``out`` follows the sweep table's rule: a file there that this library did not write is
    refused, or replaced with ``overwrite`` (``--force``; a note says so); a figure of its own
    (marked ``.<name>.forcecontrol-sweep.json``) is replaced.

    Returns:
        ``(path, notes)``: notes say, in words, which cases the figure does not show (the other
        swept parameters held at their first values) or how it shows them, and a replaced file.

    Raises:
        SweepError: an axis is not a swept parameter or not a number.
        OutputError: ``out`` is a folder, or a file this library did not write (and not ``overwrite``).
    """
    from .store import check_file_output

    df, meta = _source(source)
    replaced = check_file_output(Path(out), overwrite, sweep_id=meta.get("sweep_id"))
    params = list(meta.get("parameters", []))
    for p in (x, y):
        if p is not None and p not in params:
            raise SweepError(f"figure axis '{p}' is not a swept parameter; expected one of {', '.join(params)}")
    if x is not None and x == y:
        raise SweepError(f"figure axes x and y must be two different swept parameters; got '{x}' for both")
    # default axes: the numeric parameters the sweep varies (one given a single value is no axis)
    varied = [p for p in params if df[p].astype(str).nunique() > 1] or params[:1]
    numeric = [p for p in varied if _is_number(df, p)]
    if x is None and y is None:
        if not numeric:
            _numeric(df, varied[0])  # raises, naming the parameter and its values
        axes = tuple(numeric[:2])
    elif y is None:
        axes = (x,) + tuple(p for p in numeric if p != x)[:1]
    elif x is None:
        rest = [p for p in numeric if p != y]
        if not rest:
            raise SweepError(f"figure axis y = '{y}' needs a second varied numeric parameter for x; the sweep has none")
        axes = (rest[0], y)
    else:
        axes = (x, y)
    notes = []
    others = [p for p in varied if p not in axes]
    random = meta.get("definition", {}).get("design") == "random"
    if others and random:
        notes.append(f"the figure over {' and '.join(axes)} shows every case; {', '.join(others)} vary between them "
                     "(random design)")
    elif others:
        shown = ", ".join(f"{p} = {_plain(df[p].iloc[0])!r}" for p in others)
        n = int(np.sum(np.all([(df[p] == df[p].iloc[0]).to_numpy() for p in others], axis=0)))
        notes.append(f"the figure over {' and '.join(axes)} shows {n} of {len(df)} cases, those with {shown} "
                     "(pick other axes with --x/--y)")
    if replaced:
        notes.append(replaced)
    if len(axes) == 1:
        return plot_sweep_curves((df, meta), axes[0], out, overwrite=None), notes
    return plot_sweep_map((df, meta), axes[0], axes[1], out, overwrite=None), notes
