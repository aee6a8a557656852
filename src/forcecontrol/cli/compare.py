"""``forcecontrol compare NAME``: a scenario on the built-in simulator and on MuJoCo, side by side.

Compared: the contact force's transient (each engine's metrics), and the differences MuJoCo − built-in over all
samples of the controlled frame's pose (position [m], orientation [rad]), the contact and measured wrench (force [N],
torque [N m] in 6-D) and the joint positions [rad]. A signal absent from both runs (no contact, no moment in a
planar log, a sensor that read nothing) is said to be not compared, with the reason: in the tables' text, in
``--json`` (``absent`` and the signal's ``"compared": false, "why"``) and as a note on stderr.
"""

from __future__ import annotations

import sys
from typing import Annotated, Any

import typer

from .app import JsonOut, _fail, compile_notice, print_json, say_note
from .overrides import SetOption, apply_sets, parse_sets

__all__ = ["compare_command", "compare_scenario", "COMPARE_UNITS"]

#: units of each engine's contact-force metrics, of the differences and of each compared signal in --json
COMPARE_UNITS = {"steady": "N", "peak": "N", "peak_time": "s", "overshoot_percent": "%", "settling_time_2pc": "s",
                 "steady_force_difference_percent": "%", "max_force_difference_over_peak_percent": "%",
                 "position": "m", "orientation": "rad", "contact_force": "N", "contact_torque": "N m",
                 "measured_force": "N", "measured_torque": "N m", "joint_positions": "rad"}

#: the wrench signals of the force and torque tables: (JSON key, row name)
_WRENCH_ROWS = (("contact", "contact"), ("measured", "measured"))


def compare_scenario(name: str, sets: dict[str, Any] | None = None) -> dict[str, Any]:
    """Run every case of a scenario on both engines and compare them (see ``compare_engines``).

    Args:
        name: a built-in scenario or a .toml file.
        sets: ``--set`` changes applied to every case (``{"duration": 0.5}``); their notes are in ``notes``.
    """
    from ..engines.compare import compare_engines
    from ..scenarios import load_scenario, run_scenario

    scn, notes = apply_sets(load_scenario(name), sets or {})
    builtin = run_scenario(scn, engine="auto")
    mujoco = run_scenario(scn, engine="mujoco")
    cases = []
    for a, b in zip(builtin.cases, mujoco.cases):
        rep = compare_engines(a.result, b.result)
        rep["label"] = a.label
        rep["engines"] = [a.result.metadata.get("engine"), "mujoco"]
        cases.append(rep)
    said: dict[str, list[str]] = {}  # each reason once, with the cases it holds for
    for c in cases:
        caveat = c["signals"]["orientation"].get("caveat")
        for why in dict.fromkeys([*c["absent"].values(), *([f"orientation: {caveat}"] if caveat else [])]):
            said.setdefault(why, []).append(repr(c["label"]))
    notes += [f"{'case' if len(labels) == 1 else 'cases'} {', '.join(labels)}: {why}" for why, labels in said.items()]
    return {"scenario": scn.name, "cases": cases, "notes": notes}


def _cell(stats: dict[str, Any], key: str, i: int | None = None) -> str:
    """One number of a compared signal's stats (``max``/``rms`` per component, or of the norm), or '—' if absent."""
    if not stats["compared"]:
        return "—"
    v = stats[key] if i is None else stats[key][i]
    return f"{v:.3e}"


def _words(console: Any, said: list[tuple[str, str]]) -> None:
    """Each reason a signal was not compared, once, after the cases it holds for: ``  'a', 'b': why``."""
    from .safe import escape

    grouped: dict[str, list[str]] = {}
    for label, why in said:
        labels = grouped.setdefault(why, [])
        if repr(label) not in labels:  # a case is named once per reason, not once per signal
            labels.append(repr(label))
    for why, labels in grouped.items():
        console.print(f"  {escape(', '.join(labels))}: {escape(why)}", highlight=False, soft_wrap=True)


def _contact_table(console: Any, report: dict[str, Any]) -> None:
    """Each engine's contact-force transient (the cases with contact) and, in words, the cases without."""
    from rich.table import Table

    from .safe import escape

    touching = [c for c in report["cases"] if "contact_force" not in c["absent"]]
    if touching:
        t = Table(title=escape(f"{report['scenario']}: contact force, built-in simulator vs MuJoCo"), title_justify="left")
        for col in ("case", "axis", "engine", "steady [N]", "peak [N]", "peak time [s]", "overshoot [%]", "settling [s]"):
            t.add_column(escape(col), justify="left" if col in ("case", "engine") else "right")  # '[s]' is a unit, not markup
        for c in touching:
            for eng, key in ((c["engines"][0], "builtin"), ("mujoco", "mujoco")):
                m = c[key]
                t.add_row(
                    escape(c["label"]), str(c["axis"]), str(eng), f"{m['steady']:.4f}", f"{m['peak']:.4f}",
                    f"{m['peak_time']:.3f}", f"{m['overshoot_percent']:.2f}", f"{m['settling_time_2pc']:.3f}",
                )
            t.add_row(
                escape(c["label"]), "", "difference", f"{c['steady_force_difference_percent']:.3f} %", "",
                "", "", f"max |Δf|/peak {c['max_force_difference_over_peak_percent']:.2f} %",
            )
        console.print(t)
    away = [repr(c["label"]) for c in report["cases"] if c not in touching]
    if away and touching:
        console.print(f"  not in this table (no contact in either run): {escape(', '.join(away))}", highlight=False,
                      soft_wrap=True)
    elif away:
        head = escape(f"{report['scenario']}: contact force, built-in simulator vs MuJoCo:")
        console.print(f"[bold]{head}[/] not compared: no contact in either run, in any case", highlight=False, soft_wrap=True)


def _pose_table(console: Any, report: dict[str, Any]) -> None:
    """Position per axis and norm [m], orientation angle [rad], joint positions (norm) [rad]: max and RMS."""
    from rich.table import Table

    from .safe import escape

    axes = report["cases"][0]["signals"]["position"]["axes"]
    t = Table(title=escape(f"{report['scenario']}: pose of the controlled frame and joint positions, MuJoCo − built-in "
                    "(over all samples)"), title_justify="left")
    cols = ["case", "statistic", *(f"Δ{a} [m]" for a in axes), "|Δp| [m]", "angle of R_aᵀR_b [rad]", "|Δq| [rad]"]
    for col in cols:
        t.add_column(escape(col), justify="left" if col in ("case", "statistic") else "right")
    said = []
    for c in report["cases"]:
        s = c["signals"]
        for stat, key in (("max", "max"), ("RMS", "rms")):
            p, o, q = s["position"], s["orientation"], s["joint_positions"]
            t.add_row(escape(c["label"]), stat, *(_cell(p, key, i) for i in range(len(axes))), _cell(p, f"norm_{key}"),
                      _cell(o, key) if o["compared"] else "not compared", _cell(q, f"norm_{key}"))
        said += [(c["label"], s[k]["why"]) for k in ("position", "orientation", "joint_positions") if not s[k]["compared"]]
        said += [(c["label"], f"orientation: {s['orientation']['caveat']}")] if "caveat" in s["orientation"] else []
    console.print(t)
    _words(console, said)


def _wrench_table(console: Any, report: dict[str, Any], part: str, unit: str) -> None:
    """The contact and measured force (or torque) differences per axis and norm: max and RMS; absent rows say so."""
    from rich.table import Table

    from .safe import escape

    rows = [(c, name, c["signals"][f"{key}_{part}"]) for c in report["cases"] for key, name in _WRENCH_ROWS]
    compared = [s for _, _, s in rows if s["compared"]]
    if not compared:
        head = escape(f"{report['scenario']}: {part} [{unit}], MuJoCo − built-in:")
        console.print(f"[bold]{head}[/] not compared", highlight=False, soft_wrap=True)
        _words(console, [(c["label"], s["why"]) for c, _, s in rows])
        return
    axes = compared[0]["axes"]
    symbol = "f" if part == "force" else "m"
    t = Table(title=escape(f"{report['scenario']}: {part}, MuJoCo − built-in (over all samples)"), title_justify="left")
    for col in ("case", "signal", "statistic", *(f"Δ{a} [{unit}]" for a in axes), f"|Δ{symbol}| [{unit}]"):
        t.add_column(escape(col), justify="left" if col in ("case", "signal", "statistic") else "right")
    said = []
    for c, name, s in rows:
        if not s["compared"]:
            t.add_row(escape(c["label"]), name, "not compared", *("—" for _ in axes), "—")
            said.append((c["label"], s["why"]))
            continue
        for stat, k in (("max", "max"), ("RMS", "rms")):
            t.add_row(escape(c["label"]), name, stat, *(_cell(s, k, i) for i in range(len(axes))), _cell(s, f"norm_{k}"))
    console.print(t)
    _words(console, said)


def compare_command(
    scenario: Annotated[str, typer.Argument(help="built-in name (see 'forcecontrol list') or a .toml file")],
    json_out: JsonOut = False,
    set_: SetOption = None,
) -> None:
    """Run a scenario on the built-in simulator and on MuJoCo: contact force, pose, wrench and joints; why they differ."""
    from rich.console import Console

    from ..errors import ForceControlError

    compile_notice()
    try:
        sets = parse_sets(set_)
        report = compare_scenario(scenario, sets)
    except (ForceControlError, ImportError) as exc:
        _fail(exc)
    for note in report["notes"]:
        say_note(note)
    if json_out:
        print_json({**report, "set": sets, "units": COMPARE_UNITS})
        return
    console = Console(width=None if sys.stdout.isatty() else 132)  # piped: as the other commands (80 cut the numbers)
    if report["cases"]:
        _contact_table(console, report)
        _pose_table(console, report)
        _wrench_table(console, report, "force", "N")
        _wrench_table(console, report, "torque", "N m")
    console.print("[bold]Where the engines differ, and why:[/]")
    for why in report["cases"][0]["why_they_differ"] if report["cases"] else ():
        console.print(f"  • {why}")
