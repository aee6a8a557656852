"""``forcecontrol report``: one self-contained interactive HTML file (plotly) of a run or a sweep.

* A run folder (what ``forcecontrol run NAME --data csv|parquet`` writes: per case a data file
  and its JSON metadata, :meth:`~forcecontrol.sim.simulation.SimulationResult.save`) gives the time
  responses of every case: positions and contact forces (and the joint torques), one line per case.
* A sweep table (``forcecontrol sweep``'s Parquet file, or a folder holding it) gives, per case
  of the scenario, a map of each metric over the first two swept parameters (other parameters at
  their first value), the cases the simulation found unstable, and the analytic sampled-loop
  boundary ρ = 1 (:func:`forcecontrol.sweep.stability_boundary`) where the analysis applies;
  with one swept parameter, the metrics against it with the analytic limit.

plotly.js is written into the file (``include_plotlyjs=True``): the report opens with no network.
"""

from __future__ import annotations

import html
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..core.text import TITLE_LIMIT, plain_text
from ..errors import OutputError, ParameterError

__all__ = ["write_report", "default_report_path", "find_runs", "find_sweep", "run_figure", "sweep_figures"]

_METRICS = ("settling_time", "overshoot", "steady_state_force_error", "peak_force")
_METRIC_LABELS = {
    "settling_time": "settling time [s]", "overshoot": "overshoot [%]",
    "steady_state_force_error": "steady-state force error [N]", "peak_force": "peak force [N]",
}
_SIGNAL_LABELS = {"x": "x [m]", "y": "y [m]", "z": "z [m]", "fx": "f_x [N]", "fy": "f_y [N]", "fz": "f_z [N]",
                  "u1": "u_1 [N m]", "u2": "u_2 [N m]"}


# ----------------------------------------------------------------------------- inputs


def _is_sweep_table(path: Path) -> bool:
    try:
        import pyarrow.parquet as pq  # type: ignore[import-untyped]

        from ..sweep.prepare import META_KEY

        return META_KEY in (pq.read_schema(path).metadata or {})
    except Exception:  # noqa: BLE001 - not a readable Parquet file: not a sweep table
        return False


def find_sweep(source: Path) -> Path | None:
    """The sweep table ``source`` is, or the only one directly in the folder ``source`` (else None).

    Raises:
        ParameterError: the folder holds several sweep tables (name one).
    """
    if source.is_file():
        return source if source.suffix == ".parquet" and _is_sweep_table(source) else None
    tables = [p for p in sorted(source.glob("*.parquet")) if _is_sweep_table(p)]
    if len(tables) > 1:
        raise ParameterError(f"{str(source)!r} holds {len(tables)} sweep tables ({', '.join(p.name for p in tables)}); "
                             "name one of them")
    return tables[0] if tables else None


def find_runs(source: Path) -> list[tuple[Path, Path]]:
    """(data file, metadata JSON) pairs of saved runs in the folder ``source`` and its subfolders (one level)."""
    pairs = []
    for meta in sorted(list(source.glob("*.json")) + list(source.glob("*/*.json"))):
        for ext in (".csv", ".parquet"):
            data = meta.with_suffix(ext)
            if data.exists():
                pairs.append((data, meta))
                break
    return pairs


def _read_run(data: Path, meta: Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    try:
        info = json.loads(meta.read_text(encoding="utf-8"))
        if data.suffix == ".csv":
            with data.open(encoding="utf-8") as f:
                names = f.readline().strip().split(",")
            arr = np.loadtxt(data, delimiter=",", skiprows=1, ndmin=2)
            if arr.shape[1] != len(names):
                raise ValueError(f"{arr.shape[1]} columns for {len(names)} names")
            cols = {n: arr[:, i] for i, n in enumerate(names)}
        else:
            import pyarrow.parquet as pq  # type: ignore[import-untyped]

            table = pq.read_table(data)
            cols = {n: np.asarray(table.column(n).to_numpy(), dtype=float) for n in table.column_names}
    except (OSError, ValueError, json.JSONDecodeError) as exc:
        raise OutputError(f"cannot read the run {str(data)!r}: {exc}") from exc
    if "t" not in cols:
        raise OutputError(f"{str(data)!r} has no time column 't'; expected a file written by SimulationResult.save")
    return cols, info


def default_report_path(source: str | Path) -> Path:
    """``SOURCE/report.html`` for a folder, ``TABLE.html`` beside a sweep table."""
    source = Path(source)
    return source.with_suffix(".html") if source.is_file() else source / "report.html"


# ----------------------------------------------------------------------------- figures


def run_figure(runs: list[tuple[dict[str, np.ndarray], dict[str, Any]]]) -> Any:
    """A plotly figure of saved runs: one row per signal (pose, contact force, torques), one line per case."""
    from plotly.subplots import make_subplots

    first = runs[0][0]
    pose = [s for s in ("x", "y", "z", "rx", "ry", "rz") if s in first]
    force = [s for s in ("fx", "fy", "fz", "mx", "my", "mz") if s in first]
    torque = [s for s in first if s.startswith("u") and s[1:].isdigit()]
    signals = pose + force + torque
    fig = make_subplots(rows=len(signals), cols=1, shared_xaxes=True, vertical_spacing=0.02 + 0.1 / len(signals),
                        subplot_titles=[_SIGNAL_LABELS.get(s, s) for s in signals])
    palette = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"]
    for i, (cols, info) in enumerate(runs):
        label = html.escape(plain_text(info.get("label") or f"case {i + 1}"), quote=False)  # plotly draws tags: the label as text
        for r, sig in enumerate(signals, start=1):
            if sig not in cols:
                continue
            fig.add_scatter(x=cols["t"], y=cols[sig], mode="lines", name=label, legendgroup=label, showlegend=(r == 1),
                            line={"color": palette[i % len(palette)]}, row=r, col=1)
            fig.update_yaxes(title_text=_SIGNAL_LABELS.get(sig, sig), row=r, col=1)
    fig.update_xaxes(title_text="t [s]", row=len(signals), col=1)
    fig.update_layout(height=230 * len(signals) + 120, hovermode="x unified", template="plotly_white",
                      legend={"orientation": "h", "y": 1.02, "yanchor": "bottom"})
    return fig


def _log_axis(values: np.ndarray) -> bool:
    v = values[np.isfinite(values)]
    return bool(v.size and v.min() > 0 and v.max() / v.min() > 100)


def _fine(values: np.ndarray, n: int) -> np.ndarray:
    lo, hi = float(np.min(values)), float(np.max(values))
    return np.geomspace(lo, hi, n) if _log_axis(values) else np.linspace(lo, hi, n)


def sweep_figures(df: Any, meta: dict[str, Any], *, resolution: int = 30, boundary: bool = True) -> list[tuple[str, Any]]:
    """Plotly figures of a sweep table: one per scenario case, a map (or curve) per metric.

    Args:
        df, meta: the table and its definition (:func:`forcecontrol.sweep.read_sweep`).
        resolution: points per axis of the analytic boundary; boundary: draw it where the analysis applies.

    Returns:
        ``[(title, figure)]``.

    Raises:
        ParameterError: the table has no swept parameter.
    """
    from plotly.subplots import make_subplots

    from ..sweep.figures import _plain, _radius, stability_boundary

    params = [p for p in meta.get("parameters", []) if p in df.columns]
    if not params:
        raise ParameterError("the sweep table names no swept parameter in its metadata; expected 'parameters'")
    metrics = [m for m in _METRICS if m in df.columns]
    cases = {c["label"]: c["config"] for c in meta.get("cases", []) if "label" in c and "config" in c}
    x = params[0]
    y = params[1] if len(params) > 1 else None
    fixed = {p: _plain(df[p].iloc[0]) for p in params[2:]}
    sel = np.ones(len(df), dtype=bool)
    for p, v in fixed.items():
        sel &= (df[p] == v).to_numpy()
    out = []
    for label, sub in df[sel].groupby("case", sort=False):
        xs = np.sort(sub[x].unique().astype(float))
        fig = make_subplots(rows=1, cols=len(metrics), subplot_titles=[_METRIC_LABELS.get(m, m) for m in metrics],
                            horizontal_spacing=0.09)
        cfg = _case_config(cases, str(label))
        stable = sub["stable"].to_numpy(dtype=bool) if "stable" in sub else np.ones(len(sub), dtype=bool)
        if y is not None:
            ys = np.sort(sub[y].unique().astype(float))
            rho = None
            if boundary and cfg is not None:
                fx, fy = _fine(xs, resolution), _fine(ys, resolution)
                rho = stability_boundary(cfg, x, y, fx, fy, label, fixed)
                if not np.any(np.isfinite(rho)):
                    rho = None
            for c, metric in enumerate(metrics, start=1):
                Z = np.full((len(ys), len(xs)), np.nan)
                ix = np.searchsorted(xs, sub[x].to_numpy(dtype=float))
                iy = np.searchsorted(ys, sub[y].to_numpy(dtype=float))
                bad = ~stable
                # the colour scale is the stable cases' (an unstable case's metric would swamp it); unstable cells grey
                Z[iy, ix] = np.where(bad, np.nan, sub[metric].to_numpy(dtype=float))
                U = np.full((len(ys), len(xs)), np.nan)
                U[iy[bad], ix[bad]] = 1.0
                domain = fig.layout[f"xaxis{'' if c == 1 else c}"].domain
                bar_x = domain[1] + 0.005
                fig.add_heatmap(x=xs, y=ys, z=Z, colorscale="Viridis", name=metric, row=1, col=c,
                                colorbar={"x": bar_x, "len": 0.8, "thickness": 10},
                                hovertemplate=f"{x}=%{{x:.4g}}<br>{y}=%{{y:.4g}}<br>{metric}=%{{z:.4g}}<extra>{html.escape(label)}</extra>")
                if bad.any():
                    fig.add_heatmap(x=xs, y=ys, z=U, colorscale=[[0, "#c4c4c4"], [1, "#c4c4c4"]], showscale=False,
                                    name="unstable", hoverinfo="skip", row=1, col=c)
                fig.add_scatter(x=sub[x][bad], y=sub[y][bad], mode="markers", marker={"symbol": "x", "color": "red", "size": 8},
                                name="unstable (simulated): grey cells, not in the colour scale", legendgroup="unstable",
                                showlegend=(c == 1), row=1, col=c)
                if rho is not None:
                    fig.add_contour(x=fx, y=fy, z=rho, contours={"start": 1.0, "end": 1.0, "size": 1.0, "coloring": "lines"},
                                    line={"color": "black", "width": 2}, colorscale=[[0, "black"], [1, "black"]],
                                    showscale=False, name="analytic ρ = 1",
                                    showlegend=(c == 1), hoverinfo="skip", row=1, col=c)
                fig.update_xaxes(title_text=x, type="log" if _log_axis(xs) else "linear", row=1, col=c)
                fig.update_yaxes(title_text=y, type="log" if _log_axis(ys) else "linear", row=1, col=c)
        else:
            limit = None
            if boundary and cfg is not None:
                fx = _fine(xs, resolution * 4)
                rho = np.array([_safe_radius(_radius, cfg, label, {**fixed, x: float(v)}) for v in fx])
                crossing = np.nonzero(np.isfinite(rho[:-1]) & ((rho[:-1] < 1.0) != (rho[1:] < 1.0)))[0]
                limit = [float(fx[i]) for i in crossing]
            order = np.argsort(sub[x].to_numpy(dtype=float))
            for c, metric in enumerate(metrics, start=1):
                fig.add_scatter(x=sub[x].to_numpy(dtype=float)[order], y=sub[metric].to_numpy(dtype=float)[order],
                                mode="lines+markers", name=metric, showlegend=False, row=1, col=c)
                bad = ~stable[order]
                fig.add_scatter(x=sub[x].to_numpy(dtype=float)[order][bad], y=sub[metric].to_numpy(dtype=float)[order][bad],
                                mode="markers", marker={"symbol": "x", "color": "red", "size": 9},
                                name="unstable (simulated)", showlegend=(c == 1), row=1, col=c)
                for xl in limit or []:
                    fig.add_vline(x=xl, line_dash="dash", line_color="black", row=1, col=c)
                fig.update_xaxes(title_text=x, type="log" if _log_axis(xs) else "linear", row=1, col=c)
        title = plain_text(f"{label}" + (f" ({json.dumps(fixed, default=str)})" if fixed else ""), TITLE_LIMIT)
        fig.update_layout(height=420, template="plotly_white", title=html.escape(title, quote=False), margin={"r": 40},
                          legend={"orientation": "h", "y": -0.25})
        out.append((title, fig))
    return out


def _case_config(cases: dict[str, Any], row_label: str) -> dict[str, Any] | None:
    """The scenario case of a table row: its label, or its label marked ``"<label> [<paths> swept]"``
    (:func:`forcecontrol.sweep.paths.sweep_label`)."""
    if row_label in cases:
        return cases[row_label]
    for label, cfg in cases.items():
        if row_label.startswith(label + " [") and row_label.endswith(" swept]"):
            return cfg
    return None


def _safe_radius(radius, cfg: dict[str, Any], label: str, assign: dict[str, Any]) -> float:
    try:
        return float(radius(cfg, label, assign))
    except Exception:  # noqa: BLE001 - a point the scenario rejects has no radius
        return math.nan


# ----------------------------------------------------------------------------- the file


def _page(title: str, intro: str, figures: list[tuple[str, Any]]) -> str:
    title = plain_text(title, TITLE_LIMIT)
    parts = []
    for i, (sub, fig) in enumerate(figures):
        div = fig.to_html(full_html=False, include_plotlyjs=(i == 0), div_id=f"plot-{i}",
                          config={"displaylogo": False, "responsive": True})
        parts.append(f"<h2>{html.escape(sub)}</h2>\n{div}" if sub else div)
    body = "\n".join(parts)
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        f"<title>{html.escape(title)}</title>\n"
        "<style>body{font-family:sans-serif;margin:1.5em;max-width:1600px} h1{font-size:1.4em} h2{font-size:1.1em}"
        " p{color:#333}</style>\n</head>\n<body>\n"
        f"<h1>{html.escape(title)}</h1>\n<p>{intro}</p>\n{body}\n</body>\n</html>\n"
    )


def write_report(source: str | Path, out: str | Path | None = None) -> Path:
    """Write the HTML report of a run folder or a sweep table (see the module's docstring).

    Args:
        source: a run's output folder, a sweep table (``.parquet``) or a folder holding one.
        out: the HTML file (default :func:`default_report_path`).

    Returns:
        The written file.

    Raises:
        OutputError: ``source`` does not exist, holds neither saved runs nor a sweep table, or the
            report cannot be written.
    """
    source = Path(source)
    if not source.exists():
        raise OutputError(f"{str(source)!r} does not exist; expected a run's output folder or a sweep table")
    out = Path(out) if out is not None else default_report_path(source)
    sweep = find_sweep(source)
    if sweep is not None:
        from ..sweep.run import read_sweep

        df, meta = read_sweep(sweep)
        title = f"Sweep of {meta.get('scenario', sweep.stem)}: {len(df)} cases"
        params = meta.get("parameters", [])
        intro = (f"Table <code>{html.escape(str(sweep))}</code>; swept: {html.escape(', '.join(params))}. "
                 "Cells: the simulated metric of the stable cases (the colour scale is theirs); "
                 "grey with a red ×: cases the simulation found unstable; black line: the analytic "
                 "sampled-loop boundary ρ = 1 (direct force schemes), stable on the side of the lower stiffness.")
        page = _page(title, intro, sweep_figures(df, meta))
    else:
        if source.is_file():
            raise OutputError(f"{str(source)!r} is not a sweep table; expected a run's output folder or a sweep's .parquet")
        pairs = find_runs(source)
        if not pairs:
            raise OutputError(
                f"{str(source)!r} holds no saved runs (data file + .json) and no sweep table; write them with "
                "'forcecontrol run NAME --data csv --out DIR' or 'forcecontrol sweep NAME ... --out DIR/table.parquet'"
            )
        runs = [_read_run(d, m) for d, m in pairs]
        scenarios = sorted({str(info.get("scenario", "")) for _, info in runs} - {""})
        title = f"Run of {', '.join(scenarios) or source.name}: {len(runs)} case(s)"
        intro = f"Folder <code>{html.escape(str(source))}</code>; time responses of each saved case."
        from ..viz.view3d import with_views  # the folder's 3-D views (run --view3d), embedded

        page = with_views(_page(title, intro, [("", run_figure(runs))]), source, out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(page, encoding="utf-8")
    except OSError as exc:
        raise OutputError(f"cannot write the report {str(out)!r}: {exc.strerror or exc}") from exc
    return out
