"""``forcecontrol tune``: a local page (Panel on Bokeh) to tune a scenario's gains and see the loop change.

Sliders for every knob of a case (:func:`~forcecontrol.workbench.session.discover_knobs`); each
change re-simulates the case with the compiled simulator and updates, in place (Bokeh data
sources), the time responses over the book's settings (the case as the scenario gives it, dashed)
and the book's printed values (dotted), the closed-loop poles, and for the direct force schemes the
sampled loop's spectral radius against the environment stiffness with the current point on it. A
button writes the tuned case as a scenario TOML file.

Why Panel: it serves Bokeh documents from Python callbacks over one websocket with no
JavaScript to write, Bokeh's ``ColumnDataSource`` updates send only the changed arrays (fast
enough for the 200 ms target), it is installed and maintained by the HoloViz project, and the
server runs in a thread of this process (the browser tests serve it the same way).
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..core.text import plain_text
from .session import Evaluation, TuneSession

__all__ = ["TuneApp", "serve", "free_port", "page_url"]

_LABELS = {
    "x": "tip x [m]", "y": "tip y [m]", "z": "tip z [m]", "fx": "f_x [N]", "fy": "f_y [N]", "fz": "f_z [N]",
    "vx": "tip ẋ [m/s]", "vy": "tip ẏ [m/s]",
}


def _labelled(widget: Any, label: str, **kwargs: Any) -> Any:
    """A Panel widget with its label (``label=`` from Panel 1.9 on, ``name=`` before)."""
    return widget(label=label, **kwargs) if "label" in widget.param else widget(name=label, **kwargs)


def _md_escape(text: str) -> str:
    """Text shown literally in a Markdown pane (no markup, no HTML)."""
    import html

    return "".join("\\" + c if c in "\\`*_{}[]()#+-.!|<>$~" else c for c in html.escape(text, quote=False))


def _fmt(v: float) -> str:
    return f"{v:.4g}"


class TuneApp:
    """The tuning page for one scenario: build with :meth:`panel`, or drive it from Python (tests, timing).

    Args:
        scenario: a loaded scenario, a built-in name or a TOML path.
        save_path: where the Save button writes the tuned scenario (TOML).
        case: the case shown first (label or 0-based index).
        overwrite: Save may replace an existing file this server did not create (else it refuses).
        created: the files this server has written (shared by its browser sessions; Save may rewrite them).
    """

    def __init__(self, scenario: Any, save_path: str | Path, case: int | str = 0, *, overwrite: bool = False,
                 created: set[Path] | None = None) -> None:
        import panel as pn

        self._pn = pn
        self.save_path = Path(save_path)
        self.overwrite = overwrite
        self.created = created if created is not None else set()  # files this server wrote (may be rewritten)
        self.session = TuneSession(scenario, case)
        self.scenario = self.session.scenario
        self.latencies: list[float] = []  # seconds, slider change to updated data sources
        self.last: Evaluation | None = None
        self._root = pn.Column(sizing_mode="stretch_width")
        self.case_select = _labelled(
            pn.widgets.Select, "case", options=self._case_options(), value=self.session.case.label, width=420,
        )
        self.case_select.param.watch(self._on_case, "value")
        color = {"color": "primary"} if "color" in pn.widgets.Button.param else {"button_type": "primary"}
        self.save_button = _labelled(pn.widgets.Button, "Save tuned scenario (TOML)", width=260, **color)
        self.save_button.on_click(self._on_save)
        self.save_message = pn.pane.Markdown(f"writes `{self.save_path}`", width=600)
        self.status = pn.pane.Markdown("", sizing_mode="stretch_width")
        self._build_case()

    def _case_options(self) -> list[str] | dict[str, str]:
        """The case labels, shown as plain bounded text (a dict display -> label when one had to change)."""
        labels = self.session.labels
        shown = {plain_text(lb): lb for lb in labels}
        return labels if len(shown) == len(labels) and all(k == v for k, v in shown.items()) else shown

    # ------------------------------------------------------------------ layout
    def _build_case(self) -> None:
        from bokeh.models import ColumnDataSource, Span
        from bokeh.plotting import figure

        pn, s = self._pn, self.session
        self.sliders = {}
        for k in s.knobs:
            opts = {_fmt(v): v for v in k.options}
            label = _fmt(k.value)
            opts[label] = k.value
            w = _labelled(pn.widgets.DiscreteSlider, f"{k.name} [{k.unit}]" if k.unit else k.name, options=opts,
                          value=k.value, width=300)
            w.param.watch(lambda ev, name=k.name: self._on_slider(name, ev.new), "value")
            self.sliders[k.name] = w
        book = s.evaluate()
        self.book = book
        self.sources: dict[str, Any] = {}
        figs = []
        t_max = s.t_max
        for sig in s.signals:
            f = figure(width=460, height=300, title=sig, x_axis_label="t [s]", y_axis_label=_LABELS.get(sig, sig),
                       tools="pan,wheel_zoom,box_zoom,reset,save")
            if t_max is not None:
                f.x_range.start, f.x_range.end = 0.0, float(t_max)
            src = ColumnDataSource({"t": [], "v": []}, name=f"response-{sig}")
            ref = ColumnDataSource(self._series(book, sig), name=f"book-{sig}")
            f.line("t", "v", source=ref, line_dash="dashed", color="gray", line_width=1.5, legend_label="book's settings")
            f.line("t", "v", source=src, color="#1f77b4", line_width=2.0, legend_label="tuned")
            t_end = float(t_max if t_max is not None else s.case.config["duration"])
            if sig in s.book_values:
                v = s.book_values[sig]
                f.line([0.0, t_end], [v, v], line_dash="dotted", color="black", line_width=1.5,
                       legend_label=f"book's value: {sig} = {_fmt(v)}")
            steady = ColumnDataSource({"t": [], "v": []}, name=f"steady-{sig}")
            f.line("t", "v", source=steady, line_dash="dotdash", color="#d62728", line_width=1.2,
                   legend_label="analysis: settled value (tuned)")
            self._t_end = t_end
            f.legend.location = "bottom_right"
            f.legend.label_text_font_size = "8pt"
            self.sources[sig] = (src, steady)
            figs.append(f)
        pf = figure(width=460, height=300, title="closed-loop poles (continuous, per axis)", x_axis_label="Re [1/s]",
                    y_axis_label="Im [rad/s]", tools="pan,wheel_zoom,box_zoom,reset,save")
        self.pole_source = ColumnDataSource({"re": [], "im": [], "axis": []}, name="poles")
        book_poles = ColumnDataSource(self._poles(book), name="book-poles")
        pf.scatter([0.0], [0.0], marker="cross", size=10, color="black", legend_label="origin (Re < 0: stable)")
        pf.scatter("re", "im", source=book_poles, marker="circle", size=9, fill_alpha=0.0, color="gray",
                   legend_label="book's settings")
        pf.scatter("re", "im", source=self.pole_source, marker="x", size=11, line_width=2.5, color="#1f77b4",
                   legend_label="tuned")
        pf.legend.location = "top_left"
        pf.legend.label_text_font_size = "8pt"
        figs.append(pf)
        self.stability_source = ColumnDataSource({"k": [], "rho": []}, name="stability")
        self.stability_point = ColumnDataSource({"k": [], "rho": []}, name="stability-point")
        if book.stability is not None:
            sf = figure(width=460, height=300, x_axis_type="log", x_axis_label="environment stiffness k [N/m]",
                        y_axis_label="spectral radius ρ (stable < 1)", tools="pan,wheel_zoom,box_zoom,reset,save",
                        title=f"sampled loop along {book.stability.axis} (Ts = {s.case.config.get('sample_time', 1e-3)} s)")
            bsrc = ColumnDataSource({"k": book.stability.stiffness, "rho": book.stability.radius}, name="book-stability")
            sf.line("k", "rho", source=bsrc, line_dash="dashed", color="gray", legend_label="book's settings")
            sf.line("k", "rho", source=self.stability_source, color="#1f77b4", line_width=2, legend_label="tuned")
            sf.scatter("k", "rho", source=self.stability_point, size=11, color="#d62728", legend_label="current k")
            sf.add_layout(Span(location=1.0, dimension="width", line_color="black", line_dash="dotted"))
            self.limit_span = Span(location=float("nan"), dimension="height", line_color="#d62728", line_dash="dashed")
            sf.add_layout(self.limit_span)
            sf.legend.location = "top_left"
            sf.legend.label_text_font_size = "8pt"
            figs.append(sf)
        else:
            self.limit_span = None
        self.figures = figs
        self.analysis_note = pn.pane.Markdown("", width=460)
        plots = pn.GridBox(*[pn.pane.Bokeh(f) for f in figs], ncols=2)
        head = pn.pane.Markdown(
            f"## {_md_escape(plain_text(self.scenario.title or self.scenario.name, 500))}\n"
            f"Tuning case **{_md_escape(plain_text(s.case.label))}**: each slider change re-simulates it "
            f"({s.case.config['duration']} s) "
            "and re-analyses it. Dashed grey: the book's settings; dotted: the book's printed values.",
            sizing_mode="stretch_width",
        )
        controls = pn.Column(
            self.case_select, *self.sliders.values(), self.save_button, self.save_message, width=340,
        )
        self._root.objects = [head, pn.Row(controls, pn.Column(plots, self.analysis_note, self.status))]
        self.update()

    # ------------------------------------------------------------------ data
    @staticmethod
    def _series(ev: Evaluation, sig: str) -> dict[str, Any]:
        if ev.result is None:
            return {"t": [], "v": []}
        cols = ev.result.columns()
        return {"t": ev.result.t, "v": cols[sig] if sig in cols else np.full(ev.result.t.shape, np.nan)}

    @staticmethod
    def _poles(ev: Evaluation) -> dict[str, Any]:
        re, im, axis = [], [], []
        for a, p in ev.poles.items():
            re += np.real(p).tolist()
            im += np.imag(p).tolist()
            axis += [a] * len(p)
        return {"re": re, "im": im, "axis": axis}

    def update(self) -> Evaluation:
        """Re-simulate with the sliders' values and update every plot; returns the evaluation."""
        t0 = time.perf_counter()
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
        self.pole_source.data = self._poles(ev)
        if ev.stability is not None and self.limit_span is not None:
            self.stability_source.data = {"k": ev.stability.stiffness, "rho": ev.stability.radius}
            self.stability_point.data = {"k": [ev.stability.current[0]], "rho": [ev.stability.current[1]]}
            lim = ev.stability.limit
            self.limit_span.location = lim if math.isfinite(lim) else float("nan")
        t2 = time.perf_counter()
        self.last = ev
        self.latencies.append(t2 - t0)
        self._status(ev, t1 - t0, t2 - t1)
        return ev

    def _status(self, ev: Evaluation, t_eval: float, t_draw: float) -> None:
        lines = []
        if ev.error:
            lines.append(f"**Not simulated to the end:** {ev.error}")
        if ev.result is not None:
            settled = ev.result.settled_values()
            lines.append("Settled (last 0.1 s): " + ", ".join(
                f"{k} = {_fmt(v)}" + (f" (book {_fmt(self.session.book_values[k])})" if k in self.session.book_values else "")
                for k, v in settled.items() if k in self.session.signals or k in self.session.book_values))
        an = []
        for a, p in ev.poles.items():
            an.append(f"poles {a}: " + ", ".join(f"{z.real:.3g}{z.imag:+.3g}j" if abs(z.imag) > 1e-9 else f"{z.real:.3g}"
                                                 for z in p))
        if ev.stability is not None:
            st = ev.stability
            lim = "∞" if math.isinf(st.limit) else _fmt(st.limit)
            an.append(f"sampled loop along {st.axis}: ρ = {st.current[1]:.5f} at k = {_fmt(st.current[0])} N/m "
                      f"({'stable' if st.current[1] < 1 else '**unstable**'}); limit k = {lim} N/m")
        an += ev.notes
        self.analysis_note.object = "\n\n".join(an)
        lines.append(f"updated in {1000 * (t_eval + t_draw):.0f} ms (simulation and analysis "
                     f"{1000 * t_eval:.0f} ms, of which simulation {1000 * ev.seconds.get('simulate', 0.0):.0f} ms)")
        self.status.object = "\n\n".join(lines)

    # ------------------------------------------------------------------ callbacks
    def _on_slider(self, name: str, value: float) -> None:
        self.session.set(name, float(value))
        self.update()

    def _on_case(self, event: Any) -> None:
        self.session = TuneSession(self.scenario, event.new)  # the new case starts from its own values
        self._build_case()

    def _on_save(self, event: Any = None) -> Path | None:
        from ..errors import ForceControlError

        target = self.save_path.resolve()
        try:
            path = self.session.save(self.save_path, overwrite=self.overwrite or target in self.created)
        except ForceControlError as exc:
            self.save_message.object = f"**not saved:** {_md_escape(str(exc))}"
            return None
        self.created.add(target)
        self.save_message.object = f"saved `{path}` ({time.strftime('%H:%M:%S')})"
        return path

    def panel(self) -> Any:
        """The page's root Panel object."""
        return self._root


def free_port(address: str = "localhost") -> int:
    """A TCP port nobody listens on at ``address`` now (the OS picks it)."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((address, 0))
        return int(s.getsockname()[1])


def serve(scenario: Any, *, port: int = 0, show: bool = True, save_path: str | Path = "tuned.toml",
          threaded: bool = False, address: str = "localhost", token: str | None = None,
          overwrite: bool = False) -> Any:
    """Serve the tuning page at ``http://address:port/`` (one :class:`TuneApp` per browser session).

    Every request (page, static file, websocket) must name this server in its Host header (and
    Origin, when it has one) and, when a token is set, carry it (:mod:`.guard`). Listening beyond
    loopback (``address="0.0.0.0"``, a LAN address) always needs a token: without one a random
    token is made, and a :class:`UserWarning` gives the address with it.

    Args:
        scenario: a loaded scenario, a built-in name or a TOML path (loaded once, checked here).
        port: the port (0: a free one); show: open the browser; threaded: run the server in a
            background thread and return it (``.stop()`` ends it) instead of blocking.
        address: the interface to listen on; token: the access token (``?token=...``).
        overwrite: Save may replace an existing ``save_path`` this server did not write.

    Returns:
        The Panel server (threaded; its ``url`` attribute is the address with the token) or
        nothing once the blocking server stops.
    """
    import uuid
    import warnings
    import webbrowser

    from panel.io.server import get_server
    from tornado.ioloop import IOLoop

    from ..scenarios import Scenario, load_scenario
    from .guard import RequestGuard, is_loopback, new_token

    scn = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    if port == 0:
        port = free_port(address)
    local = is_loopback(address)
    if token is None and not local:
        token = new_token()
    url = page_url(address, port, token)
    if not local:
        warnings.warn(f"the tuning server listens on {address}:{port}, beyond this machine: anyone who can reach it "
                      f"and has the token can read the scenario and write {save_path}; open {url}", UserWarning,
                      stacklevel=2)
    guard = RequestGuard(address, port, token)
    TuneSession(scn).evaluate()  # compile (or load) the simulator's kernels now, not on the first page load
    created: set[Path] = set()

    def page() -> Any:
        return TuneApp(scn, save_path, overwrite=overwrite, created=created).panel()

    origins = [f"localhost:{port}", f"127.0.0.1:{port}", f"{address}:{port}"] if local else [f"*:{port}"]  # + the guard

    def run(**kwargs: Any) -> Any:
        server = get_server({"/": page}, **kwargs)
        guard.install(server._tornado)  # the Host/Origin/token check before any handler
        if show:
            server.io_loop.add_callback(webbrowser.open, url)
        server.start()
        try:
            server.io_loop.start()
        except RuntimeError:
            pass
        return server

    kwargs = {"port": port, "address": address, "show": False, "start": False, "title": f"forcecontrol tune: {scn.name}",
              "websocket_origin": origins, "verbose": False}
    if not threaded:
        run(**kwargs)
        return None
    from panel.io.state import state
    from panel.io.threads import StoppableThread

    kwargs["loop"] = IOLoop(make_current=False)
    kwargs["server_id"] = uuid.uuid4().hex
    thread = StoppableThread(target=run, io_loop=kwargs["loop"], kwargs=kwargs, owns_loop=True)
    state._threads[kwargs["server_id"]] = thread
    thread.url = url  # type: ignore[attr-defined]
    thread.start()
    return thread


def page_url(address: str, port: int, token: str | None = None) -> str:
    """The address to open: a loopback name when listening on every interface, with ``?token=`` if set."""
    host = "localhost" if address in ("0.0.0.0", "::", "") else (f"[{address}]" if ":" in address else address)
    return f"http://{host}:{port}/" + (f"?token={token}" if token else "")
