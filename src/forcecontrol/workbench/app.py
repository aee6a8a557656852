"""``forcecontrol tune``: a local page (Panel on Bokeh) to tune a scenario's gains and see the loop change.

One slider with a typed entry for every knob that acts (:func:`~forcecontrol.workbench.labels.split_knobs`),
named by the chapter's symbol and unit (``K_P,x [N/m]``); Reset (the book's gains), Undo (the last
50 settings) and Save (the tuned case as a scenario TOML file) at the top. Each change re-simulates
the case with the compiled simulator and updates, in place, the time responses over the book's
settings (dashed) and printed values (dotted), the closed-loop poles (the axes rescale to hold
every pole), for the direct force schemes the sampled loop's spectral radius against the
environment stiffness, and the metrics table (:mod:`.metrics`: now, previous setting, the book's
gains, the book's printed value). The browser shows "computing…" from the change until the new
data arrive.

Why Panel: it serves Bokeh documents from Python callbacks over one websocket with no JavaScript to
write, and Bokeh's ``ColumnDataSource`` updates send only the changed arrays: an update sends the
response columns (not the unchanged time grid), the poles, the axes' ranges and the table, never
the figures' layout again.
"""

from __future__ import annotations

import math
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from ..core.text import plain_text
from .labels import knob_label, split_knobs
from .metrics import metrics_html, page_metrics
from .server import free_port, page_url
from .session import Evaluation, TuneSession

__all__ = ["TuneApp", "serve", "free_port", "page_url", "UNDO_DEPTH"]

#: settings Undo goes back through.
UNDO_DEPTH = 50
_LABELS = {
    "x": "tip x [m]", "y": "tip y [m]", "z": "tip z [m]", "fx": "f_x [N]", "fy": "f_y [N]", "fz": "f_z [N]",
    "vx": "tip ẋ [m/s]", "vy": "tip ẏ [m/s]",
}
_BUSY_JS = "busy.text = '<span style=\"color:#b35900\">computing…</span>';"
_FIG = {"width": 293, "height": 205}


def _labelled(widget: Any, label: str, **kwargs: Any) -> Any:
    """A Panel widget with its label (``label=`` from Panel 1.9 on, ``name=`` before)."""
    return widget(label=label, **kwargs) if "label" in widget.param else widget(name=label, **kwargs)


def _md_escape(text: str) -> str:
    """Text shown literally in a Markdown pane (no markup, no HTML)."""
    import html

    return "".join("\\" + c if c in "\\`*_{}[]()#+-.!|<>$~" else c for c in html.escape(text, quote=False))


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def _legend_above(fig: Any, items: list[tuple[str, Any]]) -> None:
    """The legend above the plot area (never over the data)."""
    from bokeh.models import Legend

    fig.add_layout(Legend(items=[(label, [r]) for label, r in items], orientation="horizontal", label_text_font_size="8pt",
                          spacing=6, padding=0, margin=0, glyph_width=16, label_standoff=3), "above")


class TuneApp:
    """The tuning page for one scenario: build with :meth:`panel`, or drive it from Python (tests, timing).

    Args:
        scenario: a loaded scenario, a built-in name or a TOML path.
        save_path: where the Save button writes the tuned scenario (TOML).
        case: the case shown first (label or 0-based index).
        overwrite: Save may replace an existing file this server did not create (else it refuses).
        created: the files this server has written (shared by its browser sessions; Save may rewrite them).
        deferred: build the layout only; the first simulation runs on :meth:`load` (the server calls
            it once the browser is connected).
    """

    def __init__(self, scenario: Any, save_path: str | Path, case: int | str = 0, *, overwrite: bool = False,
                 created: set[Path] | None = None, deferred: bool = False) -> None:
        import panel as pn

        self._pn = pn
        self.save_path = Path(save_path)
        self.overwrite = overwrite
        self.created = created if created is not None else set()  # files this server wrote (may be rewritten)
        self.session = TuneSession(scenario, case)
        self.scenario = self.session.scenario
        self.latencies: list[float] = []  # seconds, change to updated data sources
        self.last: Evaluation | None = None
        self.history: deque[dict[str, float]] = deque(maxlen=UNDO_DEPTH)
        self._syncing = False
        self._updates = 0
        self._root = pn.Column(sizing_mode="stretch_width", margin=0)
        self.case_select = _labelled(pn.widgets.Select, "case", options=self._case_options(),
                                     value=self.session.case.label, width=330, margin=(0, 5))
        self.case_select.param.watch(self._on_case, "value")
        color = {"color": "primary"} if "color" in pn.widgets.Button.param else {"button_type": "primary"}
        self.save_button = _labelled(pn.widgets.Button, "Save tuned TOML", width=125, margin=(2, 5), **color)
        self.save_button.on_click(self._on_save)
        self.reset_button = _labelled(pn.widgets.Button, "Reset to book", width=110, margin=(2, 5))
        self.reset_button.on_click(lambda event: self.reset())
        self.undo_button = _labelled(pn.widgets.Button, "Undo", width=70, margin=(2, 5), disabled=True)
        self.undo_button.on_click(lambda event: self.undo())
        self.save_message = pn.pane.HTML(f"writes <code>{_html(str(self.save_path))}</code>", width=330, height=16,
                                         margin=(0, 5), styles={"font-size": "11px", "white-space": "nowrap",
                                                                "overflow": "hidden", "text-overflow": "ellipsis"})
        self.status = pn.pane.Markdown("", sizing_mode="stretch_width", margin=(0, 5), styles={"font-size": "11px"})
        self.busy = pn.pane.HTML("", width=330, height=16, margin=(0, 5), name="busy", styles={"font-size": "12px"})
        self.metrics_pane = pn.pane.HTML("", margin=(4, 5), name="metrics", width=455)
        self._build_case(deferred)

    def _case_options(self) -> list[str] | dict[str, str]:
        """The case labels, shown as plain bounded text (a dict display -> label when one had to change)."""
        labels = self.session.labels
        shown = {plain_text(lb): lb for lb in labels}
        return labels if len(shown) == len(labels) and all(k == v for k, v in shown.items()) else shown

    # ------------------------------------------------------------------ layout
    def _knob_widgets(self) -> list[Any]:
        pn, s = self._pn, self.session
        shown, hidden = split_knobs(s.knobs, s.case.config)
        self.sliders, self.entries, self.entry_errors, self.labels = {}, {}, {}, {}
        rows = []
        for k in shown:
            label = knob_label(k, s.case.config)
            opts = {_fmt(v): v for v in k.options}
            opts[_fmt(k.value)] = k.value
            w = _labelled(pn.widgets.DiscreteSlider, label, options=opts, value=k.value, width=215, margin=(0, 5))
            w.param.watch(lambda ev, name=k.name: self._on_slider(name, ev.new), "value")
            e = pn.widgets.TextInput(value=_fmt(k.value), width=85, height=28, margin=(12, 5, 0, 0),
                                     description=f"{label}: {k.name}")
            e.param.watch(lambda ev, name=k.name: self._on_entry(name, ev.new), "value")
            err = pn.pane.HTML("", margin=(0, 5), styles={"color": "#c22", "font-size": "11px"}, visible=False)
            # "computing…" at once in the browser (DiscreteSlider is a composite: its Bokeh slider is ``_slider``)
            for widget in (getattr(w, "_slider", None), e):
                if widget is not None:
                    widget.jscallback(value=_BUSY_JS, args={"busy": self.busy})
            self.sliders[k.name], self.entries[k.name], self.entry_errors[k.name], self.labels[k.name] = w, e, err, label
            rows.append(pn.Column(pn.Row(w, e, margin=0), err, margin=0))
        note = ("Not shown (not acting in this case): " + "; ".join(_html(r) for _, r in hidden) + ".") if hidden else ""
        self.hidden_note = pn.pane.HTML(note, width=330, margin=(0, 5), styles={"font-size": "11px", "color": "#555"})
        return rows

    def _build_case(self, deferred: bool = False) -> None:
        from bokeh.models import ColumnDataSource, Range1d, Span
        from bokeh.plotting import figure

        pn, s = self._pn, self.session
        knob_rows = self._knob_widgets()
        self.book: Evaluation | None = None
        self.book_rows: list[Any] = []
        self.prev_rows: list[Any] | None = None
        self.sources: dict[str, Any] = {}
        self.book_sources: dict[str, Any] = {}
        figs = []
        t_max = s.t_max
        t_end = float(t_max if t_max is not None else s.case.config["duration"])
        self._t_end = t_end
        tools = "pan,wheel_zoom,box_zoom,reset,save"
        for sig in s.signals:
            f = figure(title=None, x_axis_label="t [s]", y_axis_label=_LABELS.get(sig, sig), tools=tools, **_FIG)
            f.x_range = Range1d(0.0, t_end)
            src = ColumnDataSource({"t": [], "v": []}, name=f"response-{sig}")
            ref = ColumnDataSource({"t": [], "v": []}, name=f"book-{sig}")
            items = [("book gains", f.line("t", "v", source=ref, line_dash="dashed", color="gray", line_width=1.5)),
                     ("tuned", f.line("t", "v", source=src, color="#1f77b4", line_width=2.0))]
            if sig in s.book_values:
                v = s.book_values[sig]
                items.append((f"book: {_fmt(v)}", f.line([0.0, t_end], [v, v], line_dash="dotted", color="black",
                                                        line_width=1.5)))
            steady = ColumnDataSource({"t": [], "v": []}, name=f"steady-{sig}")
            items.append(("settled", f.line("t", "v", source=steady, line_dash="dotdash", color="#d62728",
                                                       line_width=1.2)))
            _legend_above(f, items)
            self.sources[sig] = (src, steady)
            self.book_sources[sig] = ref
            figs.append(f)
        pf = figure(x_axis_label="Re [1/s]", y_axis_label="Im [rad/s]", tools=tools, **_FIG,
                    x_range=Range1d(-1.0, 1.0, name="poles-x"), y_range=Range1d(-1.0, 1.0, name="poles-y"))
        self.pole_source = ColumnDataSource({"re": [], "im": []}, name="poles")
        self.book_pole_source = ColumnDataSource({"re": [], "im": []}, name="book-poles")
        _legend_above(pf, [
            ("origin", pf.scatter([0.0], [0.0], marker="cross", size=10, color="black")),
            ("book gains", pf.scatter("re", "im", source=self.book_pole_source, marker="circle", size=9, fill_alpha=0.0,
                                        color="gray")),
            ("tuned", pf.scatter("re", "im", source=self.pole_source, marker="x", size=11,
                                                     line_width=2.5, color="#1f77b4"))])
        figs.append(pf)
        self.pole_figure = pf
        self.stability_source = ColumnDataSource({"k": [], "rho": []}, name="stability")
        self.stability_point = ColumnDataSource({"k": [], "rho": []}, name="stability-point")
        self.book_stability = ColumnDataSource({"k": [], "rho": []}, name="book-stability")
        self.limit_span = None
        if s.has_stability_curve():
            sf = figure(x_axis_type="log", x_axis_label="environment stiffness k_e [N/m]",
                        y_axis_label="spectral radius ρ (< 1 stable)", tools=tools, **_FIG)
            _legend_above(sf, [
                ("book gains", sf.line("k", "rho", source=self.book_stability, line_dash="dashed", color="gray")),
                ("tuned", sf.line("k", "rho", source=self.stability_source, color="#1f77b4", line_width=2)),
                ("k_e now", sf.scatter("k", "rho", source=self.stability_point, size=11, color="#d62728"))])
            sf.add_layout(Span(location=1.0, dimension="width", line_color="black", line_dash="dotted"))
            self.limit_span = Span(location=float("nan"), dimension="height", line_color="#d62728", line_dash="dashed")
            sf.add_layout(self.limit_span)
            figs.append(sf)
        self.figures = figs
        self.analysis_note = pn.pane.Markdown("", sizing_mode="stretch_width", margin=(0, 5), styles={"font-size": "11px"})
        titles = [f"{sig}" for sig in s.signals] + ["closed-loop poles (continuous, per axis)"]
        if self.limit_span is not None:
            titles.append(f"sampled force loop (Ts = {s.case.config.get('sample_time', 1e-3)} s)")
        cells = [pn.Column(pn.pane.HTML(f"<b>{_html(t)}</b>", margin=(0, 5), height=16, styles={"font-size": "12px"}),
                           pn.pane.Bokeh(f), margin=0) for t, f in zip(titles, figs)]
        head = pn.pane.HTML(
            f"<b>{_html(plain_text(self.scenario.title or self.scenario.name, 500))}</b> — case "
            f"<b>{_html(plain_text(s.case.label))}</b>: each change re-simulates it ({s.case.config['duration']} s) and "
            "re-analyses it. Dashed grey: the book's gains; dotted: the book's printed values.",
            sizing_mode="stretch_width", margin=(2, 5), styles={"font-size": "12px"})
        buttons = pn.Row(self.reset_button, self.undo_button, self.save_button, margin=0)
        controls = pn.Column(self.case_select, buttons, self.save_message, self.busy, *knob_rows,
                             self.hidden_note, width=345, margin=0)
        # three plots a row; the metrics table and the notes beside the rest (all of it within 1280 x 800)
        table = pn.Column(self.metrics_pane, self.analysis_note, self.status, width=915 - 303 * len(cells[3:]), margin=0)
        right = pn.Column(pn.Row(*cells[:3], margin=0), pn.Row(*cells[3:], table, margin=0), width=920, margin=0)
        self._root.objects = [head, pn.Row(controls, right, margin=0)]
        if deferred:
            self.busy.object = '<span style="color:#b35900">computing…</span>'
        else:
            self.load()

    def load(self) -> None:
        """The first evaluation (the book's gains) and the plots' reference curves."""
        s = self.session
        t0 = time.perf_counter()
        book = s.evaluate({k.name: k.value for k in s.knobs})
        self.book = book
        self.book_rows = page_metrics(s, book)
        for sig, ref in self.book_sources.items():
            ref.data = self._series(book, sig)
        self.book_pole_source.data = self._poles(book)
        if book.stability is not None:
            self.book_stability.data = {"k": book.stability.stiffness, "rho": book.stability.radius}
        same = all(s.values[k.name] == k.value for k in s.knobs)
        self.update(book if same else None, t0)

    # ------------------------------------------------------------------ data
    @staticmethod
    def _series(ev: Evaluation, sig: str) -> dict[str, Any]:
        if ev.result is None:
            return {"t": [], "v": []}
        cols = ev.result.columns()
        return {"t": ev.result.t, "v": cols[sig] if sig in cols else np.full(ev.result.t.shape, np.nan)}

    @staticmethod
    def _poles(ev: Evaluation | None) -> dict[str, Any]:
        re: list[float] = []
        im: list[float] = []
        for p in (ev.poles.values() if ev is not None else ()):
            re += np.real(p).tolist()
            im += np.imag(p).tolist()
        return {"re": re, "im": im}

    def _rescale_poles(self, tuned: dict[str, Any]) -> None:
        """Axes that hold every pole (tuned and the book's) and the origin, with a margin."""
        re = [0.0, *tuned["re"], *self.book_pole_source.data["re"]]
        im = [0.0, *tuned["im"], *self.book_pole_source.data["im"]]
        re = [v for v in re if math.isfinite(v)]
        im = [v for v in im if math.isfinite(v)]
        span_re = max(max(re) - min(re), 1e-9)
        half_im = max(max(abs(v) for v in im), 0.05 * span_re, 1e-9)
        xr, yr = self.pole_figure.x_range, self.pole_figure.y_range
        xr.start, xr.end = min(re) - 0.08 * span_re, max(re) + 0.08 * span_re
        yr.start, yr.end = -1.12 * half_im, 1.12 * half_im

    def update(self, ev: Evaluation | None = None, t0: float | None = None) -> Evaluation:
        """Re-simulate with the knobs' values (or show ``ev``) and update every plot; returns the evaluation."""
        t0 = time.perf_counter() if t0 is None else t0
        if ev is None:
            ev = self.session.evaluate()
        t1 = time.perf_counter()
        for sig, (src, steady) in self.sources.items():
            new = self._series(ev, sig)
            old_t = src.data["t"]
            if len(old_t) and len(old_t) == len(new["t"]) and np.array_equal(old_t, new["t"]):
                src.data["v"] = new["v"]  # the same time grid: send only the changed column
            else:
                src.data = new
            val = ev.analysis.get(f"steady_{sig}")
            ok = val is not None and math.isfinite(float(val))
            steady.data = {"t": [0.0, self._t_end], "v": [float(val)] * 2} if ok else {"t": [], "v": []}
        poles = self._poles(ev)
        self.pole_source.data = poles
        self._rescale_poles(poles)
        if ev.stability is not None and self.limit_span is not None:
            self.stability_source.data = {"k": ev.stability.stiffness, "rho": ev.stability.radius}
            self.stability_point.data = {"k": [ev.stability.current[0]], "rho": [ev.stability.current[1]]}
            lim = ev.stability.limit
            self.limit_span.location = lim if math.isfinite(lim) else float("nan")
        rows = page_metrics(self.session, ev)
        self.metrics_pane.object = metrics_html(rows, self.prev_rows, self.book_rows)
        self.prev_rows = rows
        t2 = time.perf_counter()
        self.last = ev
        self.latencies.append(t2 - t0)
        self._updates += 1
        self._status(ev, t1 - t0, t2 - t1)
        self.undo_button.disabled = not self.history
        return ev

    def _status(self, ev: Evaluation, t_eval: float, t_draw: float) -> None:
        an = []
        if ev.error:
            an.append(f"**Not simulated to the end:** {_md_escape(ev.error)}")
        for a, p in ev.poles.items():
            an.append(f"poles {a}: " + ", ".join(f"{z.real:.3g}{z.imag:+.3g}j" if abs(z.imag) > 1e-9 else f"{z.real:.3g}"
                                                 for z in p))
        if ev.stability is not None:
            st = ev.stability
            lim = "∞" if math.isinf(st.limit) else _fmt(st.limit)
            an.append(f"sampled loop along {st.axis}: ρ = {st.current[1]:.5f} at k_e = {_fmt(st.current[0])} N/m "
                      f"({'stable' if st.current[1] < 1 else '**unstable**'}); limit k_e = {lim} N/m")
        an += [_md_escape(n) for n in ev.notes]
        self.analysis_note.object = "\n\n".join(an)
        ms = 1000 * (t_eval + t_draw)
        self.status.object = (f"updated in {ms:.0f} ms (simulation and analysis {1000 * t_eval:.0f} ms, of which "
                              f"simulation {1000 * ev.seconds.get('simulate', 0.0):.0f} ms)")
        self.busy.object = f'<span style="color:#2a7">ready</span> <small>(update {self._updates}, {ms:.0f} ms)</small>'

    # ------------------------------------------------------------------ changes
    def _show(self, values: dict[str, float]) -> None:
        """Put ``values`` in the sliders and entries without triggering updates."""
        self._syncing = True
        try:
            for name, v in values.items():
                if name not in self.sliders:
                    continue
                w = self.sliders[name]
                if v not in w.values:
                    opts = dict(w.options) if isinstance(w.options, dict) else {_fmt(o): o for o in w.options}
                    opts[_fmt(v)] = v
                    w.options = dict(sorted(opts.items(), key=lambda kv: kv[1]))
                w.value = v
                self.entries[name].value = _fmt(v)
                self._clear_error(name)
        finally:
            self._syncing = False

    def change(self, values: dict[str, float]) -> Evaluation | None:
        """Set knobs (checked), remember the previous setting for Undo and re-simulate; None when refused."""
        from ..errors import ParameterError

        before = dict(self.session.values)
        try:
            self.session.config(values)
        except ParameterError as exc:
            for name in values:
                if name in self.entry_errors:
                    self._entry_error(name, str(exc))
            return None
        for name, v in values.items():
            self.session.set(name, float(v))
        self.history.append(before)
        self._show(values)
        return self.update()

    def _entry_error(self, name: str, message: str) -> None:
        err = self.entry_errors[name]
        err.object = _html(message)
        err.visible = True
        self.busy.object = '<span style="color:#c22">not applied: see the field</span>'

    def _clear_error(self, name: str) -> None:
        err = self.entry_errors[name]
        if err.visible:
            err.object, err.visible = "", False

    def undo(self) -> Evaluation | None:
        """Go back to the previous setting (up to :data:`UNDO_DEPTH` of them); None when there is none."""
        if not self.history:
            return None
        values = self.history.pop()
        for name, v in values.items():
            self.session.set(name, v)
        self._show(values)
        return self.update()

    def reset(self) -> Evaluation | None:
        """Every knob back to the book's value (the case as the scenario gives it); Undo brings the setting back."""
        return self.change({k.name: k.value for k in self.session.knobs})

    def _on_slider(self, name: str, value: float) -> None:
        if not self._syncing:
            self.change({name: float(value)})

    def _on_entry(self, name: str, text: str) -> None:
        if self._syncing:
            return
        try:
            value = float(str(text).strip().replace(",", "."))
        except ValueError:
            self._entry_error(name, f"{self.labels[name]}: expected a number >= 0 (e.g. 2500 or 2.5e3); got {text!r}")
            return
        if not math.isfinite(value) or value < 0:
            self._entry_error(name, f"{self.labels[name]}: expected a finite number >= 0; got {text!r}")
            return
        self._clear_error(name)
        self.change({name: value})

    def _on_case(self, event: Any) -> None:
        self.session = TuneSession(self.scenario, event.new)  # the new case starts from its own values
        self.history.clear()
        self._build_case()

    def _on_save(self, event: Any = None) -> Path | None:
        from ..errors import ForceControlError

        target = self.save_path.resolve()
        try:
            path = self.session.save(self.save_path, overwrite=self.overwrite or target in self.created)
        except ForceControlError as exc:
            self.save_message.object = f"<b>not saved:</b> {_html(str(exc))}"
            return None
        self.created.add(target)
        self.save_message.object = f"saved <code>{_html(str(path))}</code> ({time.strftime('%H:%M:%S')})"
        return path

    def panel(self) -> Any:
        """The page's root Panel object."""
        return self._root


def _html(text: str) -> str:
    import html

    return html.escape(text, quote=True)


def serve(scenario: Any, **kwargs: Any) -> Any:
    """Serve the tuning page (:func:`forcecontrol.workbench.server.serve` with :class:`TuneApp`; same arguments)."""
    from .server import serve as _serve

    return _serve(scenario, app_class=TuneApp, **kwargs)
