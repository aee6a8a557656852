"""The tuning page's metrics table: what one evaluation of a case measures, by the library's own code.

Rows (:func:`page_metrics`), each a quantity with its SI unit (:func:`forcecontrol.scenarios.units.unit`):

* the force step of the force axis (the axis of the largest |f_d|, else of the largest settled
  |f|): overshoot [%], settling time [s] and, with a force reference, the steady-state error
  f − f_d [N], by :func:`forcecontrol.sim.metrics.step_metrics` over the scenario's settle window;
* peak |f| [N] (:meth:`SimulationResult.peak_contact_force_norm`);
* gain [dB] and phase [deg] margins of the sampled force loop at the case's environment stiffness,
  for the direct force schemes (:meth:`forcecontrol.analysis.design.LoopModel.margins` of the
  loop :func:`~forcecontrol.analysis.design.loop_model` builds from the case's gains and the arm's
  operational mass, the loop whose spectral radius the stability plot shows);
* every quantity the case checks against the book (``[case.expected]``), computed as
  ``forcecontrol run`` computes it (:data:`forcecontrol.scenarios.METRICS`, the scenario
  analysis for ``analysis.*``), with the book's printed value and tolerance
  (:func:`forcecontrol.scenarios.checks.check_expected`).
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["MetricRow", "page_metrics", "metrics_html"]


@dataclass(frozen=True)
class MetricRow:
    """One row: ``key`` (stable name), ``label`` (shown, with unit), ``value`` (NaN: not available),
    ``book`` (the book's printed value or None), ``tolerance`` (for the book's value), ``ok`` (within it)."""

    key: str
    label: str
    value: float
    book: float | None = None
    tolerance: float | None = None
    ok: bool | None = None


def _force_axis(ev: Any) -> tuple[int, float]:
    """(index of the force axis, f_d along it at the end)."""
    parts, res = ev.parts, ev.result
    f_d = np.asarray(parts["reference"].at(float(parts["duration"])).force, dtype=float)
    if np.any(f_d):
        i = int(np.argmax(np.abs(f_d)))
        return i, float(f_d[i])
    n = min(3, res.wrench.shape[1])
    tail = np.abs(res.wrench[-max(1, res.wrench.shape[0] // 20):, :n]).mean(axis=0)
    return int(np.argmax(tail)), 0.0


def loop_margins(loop: tuple[Any, float, float]) -> tuple[float, float]:
    """(gain margin [dB], phase margin [deg]) of the sampled force loop of a :class:`ForceLoopAxis`."""
    from ..analysis.design import loop_model

    ax, mx, Ts = loop
    gains = {"inertia": ax.inertia, "damping": ax.damping, "stiffness": ax.stiffness, "force_gain": ax.force_gain,
             "integral_gain": ax.integral_gain}
    return loop_model(ax.scheme, gains, ax.environment_stiffness, Ts, arm_inertia=mx).margins()


def page_metrics(session: Any, ev: Any) -> list[MetricRow]:
    """The metrics rows of one :class:`~forcecontrol.workbench.session.Evaluation` of ``session``'s case
    (see the module text); NaN values where the evaluation has no run (an error) or no analysis."""
    from ..scenarios import METRICS
    from ..scenarios.checks import check_expected
    from ..scenarios.units import with_unit
    from ..sim.metrics import step_metrics

    rows: list[MetricRow] = []
    nan = math.nan
    ok_run = ev.result is not None and ev.parts is not None and ev.error is None
    names = ("x", "y", "z")
    if ok_run:
        i, fd = _force_axis(ev)
        sig = f"f_{names[i] if i < 3 else i}"
        window = float(ev.parts.get("settle_window", 0.1))
        sm = step_metrics(ev.result.t, ev.result.wrench[:, i], window=window, reference=fd)
        over, settle, err = sm.overshoot_percent, sm.settling_time, sm.steady_state_error if fd else nan
        peak = float(ev.result.peak_contact_force_norm())
    else:
        sig, over, settle, err, peak = "f", nan, nan, nan, nan
        fd = 0.0
    rows.append(MetricRow("overshoot", f"overshoot of {sig} [%]", over))
    rows.append(MetricRow("settling_time", f"settling time of {sig} (2 %) [s]", settle))
    rows.append(MetricRow("steady_state_force_error", f"steady-state error {sig} − f_d [N]", err))
    rows.append(MetricRow("peak_force", "peak |f| [N]", peak))
    if ev.loop is not None:
        gm, pm = loop_margins(ev.loop)
        rows.append(MetricRow("gain_margin_db", "gain margin (sampled force loop) [dB]", gm))
        rows.append(MetricRow("phase_margin_deg", "phase margin (sampled force loop) [deg]", pm))
    tol = float(session.case.config.get("tolerance", 0.01)) if isinstance(session.case.config.get("tolerance"), (int, float)) \
        else 0.01
    for key, spec in session.case.expected.items():
        value = nan
        if ok_run:
            try:
                if key.startswith("analysis."):
                    value = float(ev.analysis[key.split(".", 1)[1]])
                else:
                    value = float(METRICS[key](ev.result, ev.parts, float(ev.parts.get("settle_window", 0.1))))
            except (KeyError, ValueError, ArithmeticError):
                value = nan
            except Exception:  # noqa: BLE001 - a metric the tuned case cannot give (the page shows "—")
                value = nan
        if ev.parts is not None:
            tol = float(ev.parts.get("tolerance", tol))
        chk = check_expected(key, value if math.isfinite(value) else 0.0, spec, tol)
        rows.append(MetricRow(key, with_unit(key), value, float(chk["expected"]), float(chk["tolerance"]),
                              bool(chk["ok"]) if math.isfinite(value) else None))
    return rows


def _num(v: float | None) -> str:
    if v is None:
        return ""
    if isinstance(v, float) and math.isnan(v):
        return "—"
    if isinstance(v, float) and math.isinf(v):
        return "∞" if v > 0 else "−∞"
    return f"{v:.4g}"


def metrics_html(now: list[MetricRow], previous: list[MetricRow] | None, book_gains: list[MetricRow]) -> str:
    """The table as escaped HTML: quantity | now | previous setting | at the book's gains | the book prints."""
    prev = {r.key: r for r in previous or []}
    base = {r.key: r for r in book_gains}
    out = ['<table class="fc-metrics" style="border-collapse:collapse;font-size:11px;line-height:1.25" data-testid="metrics">',
           "<thead><tr>" + "".join(f'<th style="text-align:{a};padding:1px 6px;border-bottom:1px solid #999">{h}</th>'
                                   for h, a in (("quantity", "left"), ("now", "right"), ("previous", "right"),
                                                ("book's gains", "right"), ("book prints", "right"))) + "</tr></thead><tbody>"]
    for r in now:
        p, b = prev.get(r.key), base.get(r.key)
        book = "" if r.book is None else f"{_num(r.book)} ± {_num(r.tolerance)}"
        mark = "" if r.ok is None else (' <span style="color:#2a7">✓</span>' if r.ok else ' <span style="color:#c22">✗</span>')
        cells = [html.escape(r.label), _num(r.value) + mark, _num(p.value) if p else "", _num(b.value) if b else "",
                 html.escape(book)]
        out.append(f'<tr data-key="{html.escape(r.key)}">' + "".join(
            f'<td style="text-align:{"left" if j == 0 else "right"};padding:0 6px">{c}</td>' for j, c in enumerate(cells))
            + "</tr>")
    out.append("</tbody></table>")
    return "".join(out)
