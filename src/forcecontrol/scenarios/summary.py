"""A run's summary as plain rows: what ``forcecontrol run`` prints and what a notebook shows.

One source for both front ends: the CLI prints :func:`settled_table` and :func:`checks_table`
with rich; :meth:`ScenarioRun._repr_html_ <forcecontrol.scenarios.model.ScenarioRun._repr_html_>`
writes the same rows as escaped HTML (:func:`html_summary`). Units are in the column names
(``"x [m]"``), as in every table and JSON field of the command line.
"""

from __future__ import annotations

import html
from typing import TYPE_CHECKING, Any

import numpy as np

from .units import with_unit

if TYPE_CHECKING:  # pragma: no cover
    from .model import CaseResult, ScenarioRun

__all__ = ["settled_table", "checks_table", "contact_warnings", "case_events", "case_warnings", "config_warnings",
           "html_summary", "not_settled", "task_axes"]

#: the logged events that are warnings (a limit or a protective layer changed what was asked, or contact was
#: lost); the others (a contact transition) are reported in ``events`` only.
WARNING_EVENTS = frozenset({"servo-limit", "ik-limit", "force-mode-deviation", "safety", "stability", "contact lost",
                            "hole not found", "contact-projection"})

def task_axes(run: ScenarioRun) -> tuple[list[str], list[str]]:
    """The position and force axes every case of the run has (``x y`` planar; ``x y z``, ``fx fy fz``
    in 3-D and 6-D: the task's z and f_z are shown, not hidden)."""
    from ..core.axes import axis_names

    m = max(c.result.m for c in run.cases) if run.cases else 2
    pose, _, wrench = axis_names(m)
    return [a for a in pose if a in ("x", "y", "z")], [f for f in wrench if f in ("fx", "fy", "fz")]


def settled_table(run: ScenarioRun) -> tuple[list[str], list[list[str]]]:
    """Columns (with units) and rows of the settled values: per case ``t_end``, the settled tip
    position and contact force along every translational task axis, the peak |f| and the engine."""
    pose, force = task_axes(run)
    cols = ["case", "t_end [s]", *(f"{a} [m]" for a in pose), *(f"{_force_name(f)} [N]" for f in force),
            "peak |f| [N]", "engine"]
    rows = []
    for spec, c in zip(run.scenario.cases, run.cases):
        values = c.result.settled_values(float(spec.config.get("settle_window", 0.1)))
        row = [c.label, f"{c.result.t[-1]:.3f}"]
        row += [f"{c.metrics.get(a, values.get(a, float('nan'))):.5f}" if a in values else "" for a in pose]
        row += [f"{c.metrics.get(f, values.get(f, float('nan'))):.3f}" if f in values else "" for f in force]
        row += [f"{c.result.peak_contact_force_norm():.3f}", str(c.result.metadata.get("engine"))]
        rows.append(row)
    return cols, rows


def _force_name(f: str) -> str:
    return f"f_{f[1:]}"


def checks_table(run: ScenarioRun) -> tuple[list[str], list[list[str]]]:
    """Columns and rows of the comparison with the book (or the closed form): simulated, expected,
    tolerance, relative error ("—" when the expected value is 0) and ok/MISSED per checked quantity (no rows
    when nothing is checked)."""
    cols = ["case", "quantity", "simulated", "expected", "tolerance", "rel. error", ""]
    rows = []
    for c in run.cases:
        for ch in c.checks:
            # no relative error of a quantity expected to be 0 (its JSON relative_error is then the difference itself)
            rel = f"{100 * ch['relative_error']:+.3f} %" if ch["expected"] else "—"
            rows.append([c.label, with_unit(ch["metric"]), f"{ch['value']:.6g}", f"{ch['expected']:.6g}",
                         f"±{ch['tolerance']:.3g}", rel, "ok" if ch["ok"] else "MISSED"])
    return cols, rows


def never_touched(case: CaseResult) -> str | None:
    """When the case's reference asks a contact force (f_d ≠ 0 at some sample) and the tool never touched the
    environment (no contact force at any sample), what the run says of it; else None."""
    from ..core.axes import REFERENCE_FIELDS

    r = case.result
    if getattr(r, "reference", None) is None:  # a result without its sampled reference: nothing to compare
        return None
    ref = np.asarray(r.reference, dtype=np.float64)
    m = ref.shape[1] // len(REFERENCE_FIELDS) if ref.ndim == 2 else 0
    fd = ref[:, 3 * m : 4 * m]
    asked = float(np.max(np.abs(fd))) if fd.size else 0.0
    if not asked > 0.0 or r.peak_contact_force_norm() != 0.0:
        return None
    return (f"the reference asks a contact force (up to {asked:.4g} N along an axis) but the tool never touched "
            f"the environment in {float(r.t[-1]):.4g} s")


#: a case has not settled when its contact force's range over the run's tail exceeds this share of its level
UNSETTLED_SWING = 0.1


def not_settled(case: CaseResult) -> str | None:
    """When the case's contact force still swings at the end of the run, what the run says of it; else None.

    The tail is the last ``max(settle_window, 10 % of the run)``; the force |f| (translational part) has not settled
    when its range there exceeds :data:`UNSETTLED_SWING` of ``max(mean |f|, 1 % of the peak |f|, 1 N)``: a bounce, an
    oscillation, a loop beyond its stability limit. Its settled values, a mean over the last ``settle_window``, are
    then not a steady state. A force that only ripples (a tool following a curve) stays within it."""
    r = case.result
    if getattr(r, "t", None) is None or getattr(r, "wrench", None) is None:  # a stand-in without a log
        return None
    window = float(r.metadata.get("settle_window", 0.1))
    span = float(r.t[-1] - r.t[0])
    tail = max(window, 0.1 * span)
    sel = r.t >= r.t[-1] - tail - 1e-12
    f = np.linalg.norm(r.wrench[sel][:, : min(int(r.m), 3)], axis=1)
    f = f[np.isfinite(f)]
    if f.size < 2:
        return None
    level = max(float(f.mean()), 0.01 * r.peak_contact_force_norm(), 1.0)
    if float(np.ptp(f)) <= UNSETTLED_SWING * level:
        return None
    return (f"has not settled: its contact force still swings between {float(f.min()):.4g} and {float(f.max()):.4g} N "
            f"over the last {tail:.3g} s, so its settled values (the mean of the last {window:g} s) are not a steady "
            "state")


def contact_warnings(run: ScenarioRun) -> list[str]:
    """One line per case that lost contact after touching (allowed by the scenario or not), or that never touched
    although its reference asks a force."""
    out = []
    for c in run.cases:
        untouched = never_touched(c)
        if untouched:
            out.append(f"{c.label}: {untouched}")
        swinging = not_settled(c)
        if swinging:
            out.append(f"{c.label}: {swinging}")
        lost = int(c.metrics.get("contact_losses", 0))
        if lost:
            allowed = all(ch["metric"] != "contact_losses" for ch in c.checks)
            out.append(f"{c.label}: contact lost {lost} time(s) after touching (peak |f| = "
                       f"{c.result.peak_contact_force_norm():.4g} N)" + (" — allowed by the scenario" if allowed else ""))
    return out


def case_events(case: CaseResult) -> list[dict[str, Any]]:
    """The events the case's controller logged (``SimulationResult.events``: servo and IK limits, UR force
    mode's deviation, safety reactions, contact transitions...), each a dict with ``t`` [s], ``event`` and
    ``detail``, in time order: the ``events`` list of a case in ``run --json``."""
    return sorted((dict(e) for e in case.result.events or ()), key=lambda e: float(e.get("t", 0.0)))


def config_warnings(notes: Any) -> list[dict[str, Any]]:
    """The reader's notes on a controller's own configuration file (a vendor controller's ``config_notes``) as
    ``config-note`` warnings: the first entries of a case's ``warnings`` in ``run --json`` and ``analyze --json``."""
    return [{"kind": "config-note", "t": None, "text": str(n)} for n in notes or ()]


def case_warnings(case: CaseResult) -> list[dict[str, Any]]:
    """What the run warned about this case (on stderr), as ``{"kind", "t", "text"}`` (``t`` None when it is
    not an instant): the reader's notes on a controller's configuration file (``config-note``), the logged
    events that are warnings (``WARNING_EVENTS``: ``servo-limit``, ``ik-limit``, ``force-mode-deviation``,
    ``safety``, ``stability``, ``contact lost``, ``hole not found``, ``contact-projection``: a curved surface
    penetrated beyond its radius of curvature), a force asked of a tool that never touched (``no-contact``) and
    contact lost after touching (``contact-lost``, with its count), a contact force still swinging at the end
    (``not-settled``: :func:`not_settled`), and a sampled loop that cannot settle
    (``sampled-unstable``, as ``analyze --json`` gives it: :func:`.parts_sampled.sampled_loop_warnings`): the
    ``warnings`` list of a case in ``run --json``."""
    out = config_warnings((case.result.metadata.get("controller") or {}).get("config_notes") or ())
    out += [dict(w) for w in getattr(case, "analysis_warnings", None) or ()]
    for e in case_events(case):
        kind = str(e.get("event", ""))
        if kind in WARNING_EVENTS:
            out.append({"kind": kind, "t": float(e["t"]) if "t" in e else None, "text": str(e.get("detail", kind))})
    untouched = never_touched(case)
    if untouched:
        out.append({"kind": "no-contact", "t": None, "text": untouched})
    swinging = not_settled(case)
    if swinging:
        out.append({"kind": "not-settled", "t": None, "text": swinging})
    lost = int(case.metrics.get("contact_losses", 0))
    if lost:
        allowed = all(ch["metric"] != "contact_losses" for ch in case.checks)
        peak = case.result.peak_contact_force_norm()
        out.append({"kind": "contact-lost", "t": None, "count": lost,
                    "text": f"contact lost {lost} time(s) after touching (peak |f| = {peak:.4g} N)"
                            + (" — allowed by the scenario" if allowed else "")})
    return out


def _html_table(title: str, cols: list[str], rows: list[list[str]]) -> str:
    e = html.escape
    head = "".join(f"<th>{e(c)}</th>" for c in cols)
    body = "".join("<tr>" + "".join(f"<td>{e(v)}</td>" for v in r) + "</tr>" for r in rows)
    return f"<table><caption>{e(title)}</caption><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def html_summary(run: ScenarioRun) -> str:
    """The summary ``forcecontrol run`` prints, as HTML (every text escaped): title, settled values,
    contact warnings, a sampled loop that cannot settle, the comparison with the book's values and the files written."""
    e = html.escape
    scn = run.scenario
    parts = [f"<div class='forcecontrol-run'><strong>{e(scn.title or scn.name)}</strong>",
             _html_table("Settled values (mean of the last samples) and peak contact force", *settled_table(run))]
    parts += [f"<p>warning: {e(w)}</p>" for w in contact_warnings(run)]
    parts += [f"<p>warning: {e(w['text'])}</p>" for c in run.cases for w in getattr(c, "analysis_warnings", None) or ()]
    cols, rows = checks_table(run)
    if rows:
        parts.append(_html_table("Against the book (or the closed form)", cols, rows))
    if run.files:
        parts.append("<ul>" + "".join(f"<li>{e(k)}: {e(v)}</li>" for k, v in run.files.items()) + "</ul>")
    parts.append("</div>")
    return "".join(parts)
