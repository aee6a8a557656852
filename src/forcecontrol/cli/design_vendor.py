"""``forcecontrol design fzi-compliance | fzi-force | ros2-admittance | ur-force-mode --config FILE``: the vendor
controllers' parameters for a stiffness range, written back into the user's own file (issue 30, item 4).

The sampled loop of :mod:`forcecontrol.scenarios.parts_vendor_analysis` (the controller's law along z, the
joint servo ω, ζ and its delay at the interface rate, the contact a spring k_e) must stay stable up to
``margin × k_max`` (margin = the gain margin, 6 dB ≈ 2 by default). The one parameter that scales the loop's
gain is lowered until it does: FZI's ``error_scale`` (and ``iterations`` set to 1 when no error_scale is
enough with several), ros2's ``admittance.mass`` (raised), force mode's ``gain_scaling``. A file whose
loop already has the margin is left as it is (said).
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path
from typing import Any

__all__ = ["VENDOR_SCHEMES", "design_vendor"]

VENDOR_SCHEMES = ("fzi-compliance", "fzi-force", "ros2-admittance", "ur-force-mode")


def _floor4(x: float) -> float:
    """``x`` rounded down to 4 significant digits (a value to paste that keeps the margin)."""
    if x <= 0:
        return x
    q = 10.0 ** (math.floor(math.log10(x)) - 3)
    return float(f"{math.floor(x / q) * q:.4g}")


def _ceil4(x: float) -> float:
    """``x`` rounded up to 4 significant digits."""
    q = 10.0 ** (math.floor(math.log10(x)) - 3)
    return float(f"{math.ceil(x / q - 1e-9) * q:.4g}")


def _bisect(ok: Any, lo: float, hi: float) -> float:
    """The largest x in [lo, hi] with ok(x) (ok monotone: true below), to 1e-3 relative; lo must be ok."""
    while hi - lo > 1e-3 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def _tune(kind: str, params: dict[str, Any], servo: tuple[float, float, float, int], target: float) -> dict[str, Any]:
    """The changed parameters (library names) that put the loop's k_e limit at or above ``target`` [N/m]."""
    from ..analysis.vendor_fzi import fdcc_design_error_scale
    from ..errors import ParameterError
    from ..scenarios.parts_vendor_analysis import loop_limit, vendor_loop

    loop = vendor_loop(kind, params, servo)
    if kind.startswith("fzi"):
        try:
            s = fdcc_design_error_scale(loop, target, margin=1.0)
            return {"error_scale": _floor4(min(s, loop.error_scale))}
        except ParameterError:
            if loop.iterations == 1:
                raise
        s = fdcc_design_error_scale(dataclasses.replace(loop, iterations=1), target, margin=1.0)
        return {"iterations": 1, "error_scale": _floor4(min(s, loop.error_scale))}
    if kind == "ros2-admittance":
        mass = [float(m) for m in params["mass"]]

        def heavy_enough(c: float) -> bool:  # c: the translational masses' factor
            return loop_limit(vendor_loop(kind, {**params, "mass": [m * c for m in mass[:3]] + mass[3:]}, servo)) >= target

        hi = 2.0
        while not heavy_enough(hi):
            hi *= 2.0
            if hi > 1e6:
                raise ParameterError(f"no admittance.mass below 1e6 x the file's keeps the loop stable up to {target:g} N/m")
        lo = hi / 2.0  # fails (c = 1 failed, or the previous doubling did)
        while hi - lo > 1e-3 * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if heavy_enough(mid) else (mid, hi)
        return {"mass": [_ceil4(m * hi) for m in mass[:3]] + mass[3:]}
    s0 = float(params.get("gain_scaling", 1.0))

    def ok_gain(s: float) -> bool:
        return loop_limit(dataclasses.replace(loop, gain_scaling=s)) >= target

    lo = s0
    while not ok_gain(lo):
        lo /= 2.0
        if lo < 1e-9:
            raise ParameterError(f"no gain_scaling > 0 keeps the loop stable up to {target:g} N/m")
    return {"gain_scaling": _floor4(_bisect(ok_gain, lo, min(2.0 * lo, s0))) if lo < s0 else s0}


def design_vendor(scheme: str, config: Path | None, k_min: float, k_max: float, *, rate: float | None, servo_bandwidth: float,
                  servo_damping: float, delay: int | None, gain_margin: float, solver: str | None, out: Path | None,
                  force: bool, json_out: bool) -> None:
    """The ``design`` command for a vendor scheme (see the module); the range k_min, k_max is checked by the command."""
    import numpy as np

    from ..errors import ForceControlError, OutputError, ParameterError
    from ..realarm.conventions.configs import read_config
    from ..scenarios.parts_vendor import check_vendor_parameters
    from ..scenarios.parts_vendor_analysis import (
        compliant_axis,
        loop_limit,
        loop_quantities,
        loop_summary,
        unselected_reason,
        vendor_loop,
    )
    from .app import _fail, print_json, say_note
    from .owned import claim_output, mark_output

    notes: list[str] = []
    try:
        if config is None:
            raise ParameterError(f"the {scheme} scheme tunes a file: give --config FILE (the controller's own YAML, .cfg or "
                                 "UR script)")
        cfg = read_config(config, None if scheme.startswith("fzi") else scheme)
        if cfg.kind != scheme:
            raise ParameterError(f"--config {config}: is a {cfg.kind} configuration; the scheme is {scheme!r}")
        check_vendor_parameters(cfg)  # values the controller refuses: an error, not a loop designed around them
        notes += cfg.notes  # what reading the file did (values clamped as the parameter server does, defaults used)
        params = dict(cfg.parameters)
        if solver is not None:
            if not scheme.startswith("fzi"):
                raise ParameterError(f"--solver applies to the fzi schemes; the scheme is {scheme!r}")
            params["solver"] = solver
            notes.append(f"--solver {solver}: the loop is analysed with that solver (not a key of the file)")
        if rate is None:  # the file's own rate, else the project's usual 500 Hz (said)
            rate = cfg.rate if cfg.rate is not None else 500.0
            if cfg.rate is None:
                notes.append("no update_rate in the file: the loop is analysed at 500 Hz (--rate sets another)")
        elif cfg.rate is not None and abs(cfg.rate - rate) > 1e-9 * rate:
            notes.append(f"the file's update_rate {cfg.rate:g} Hz differs from --rate {rate:g} Hz: the loop runs at --rate")
        # the axis designed for: z; a force mode's loop is the same on each compliant axis (its gains are not per axis)
        axis = compliant_axis(params.get("selection_vector") if scheme == "ur-force-mode" else None)
        axis = 2 if axis is None else axis
        skipped = unselected_reason(scheme, params, np.eye(3)[axis])
        if skipped is not None:
            raise ParameterError(f"--config {config}: design tunes the contact loop along a compliant axis (z), but "
                                 f"{skipped}; make the contact's axis compliant in the file to design that loop")
        if axis != 2:
            notes.append(f"selection_vector makes {'xyz'[axis]} compliant, not z: the loop designed is the force mode's "
                         f"along {'xyz'[axis]} (its gains are the same on every compliant axis)")
        servo = (rate, servo_bandwidth, servo_damping, 1 if delay is None else int(delay))
        margin = 10.0 ** (gain_margin / 20.0)
        target = margin * k_max
        old_loop = vendor_loop(scheme, params, servo)
        old_limit = loop_limit(old_loop)
        changes = {} if old_limit >= target else _tune(scheme, params, servo, target)
        new_params = {**params, **changes}
        new_loop = vendor_loop(scheme, new_params, servo)
        new_limit = loop_limit(new_loop)
        why = (f"k_e limit {old_limit:.4g} N/m < {margin:.3g} x k_max = {target:.4g} N/m ({gain_margin:g} dB); "
               f"now {new_limit:.4g} N/m (margin {new_limit / k_max:.3g} at k_max)")
        changed = [{"key": k, "old": cfg.parameters.get(k), "new": v, "why": why} for k, v in changes.items()]
        if not changes:
            notes.append(f"the file's loop already has the margin: k_e limit {old_limit:.4g} N/m >= {target:.4g} N/m; "
                         "nothing changed")
        checks = [loop_quantities(new_loop, k) for k in (k_min, math.sqrt(k_min * k_max), k_max)]
        written = None
        if out is not None:
            notes += claim_output(out, "design", force)
            text = cfg.write(**changes) if changes else cfg.text
            try:
                out.parent.mkdir(parents=True, exist_ok=True)
                out.write_text(text, encoding="utf-8")
            except OSError as exc:
                raise OutputError(f"cannot write {str(out)!r}: {exc.strerror or exc}") from exc
            mark_output(out, "design")
            written = str(out)
    except ForceControlError as exc:
        _fail(exc)
    for n in notes:
        say_note(n)
    doc = {"scheme": scheme, "config": str(config), "stiffness_range": [k_min, k_max], "loop": loop_summary(scheme, new_loop),
           "requirements": {"gain_margin_db": gain_margin, "margin": margin, "rate": rate, "servo_bandwidth": servo_bandwidth,
                            "servo_damping": servo_damping, "delay_cycles": servo[3]},
           "stability_limit_before": old_limit, "stability_limit": new_limit, "changed": changed, "checks": checks,
           "config_out": written, "notes": notes,
           "units": {"stiffness_range": "N/m", "stability_limit_before": "N/m", "stability_limit": "N/m",
                     "environment_stiffness": "N/m", "vendor_loop_stability_limit": "N/m", "rate": "Hz",
                     "servo_bandwidth": "rad/s", "gain_margin_db": "dB", "delay_cycles": "cycles"}}
    if json_out:
        print_json(doc)
        return
    from rich.console import Console
    from rich.table import Table

    from .safe import escape

    console = Console(width=None if sys.stdout.isatty() else 132)
    console.print(escape(f"{scheme} from {config} for k in [{k_min:g}, {k_max:g}] N/m: {doc['loop']}"), highlight=False)
    g = Table(title="changed parameters", title_justify="left")
    for col in ("key", "old", "new", "why"):
        g.add_column(col)
    for c in changed:
        g.add_row(escape(c["key"]), escape(str(c["old"])), escape(str(c["new"])), escape(c["why"]))
    if not changed:
        g.add_row("(none)", "", "", escape(notes[-1] if notes else ""))
    console.print(g)
    t = Table(title="the sampled loop at the ends and the middle of the range", title_justify="left")
    for col in ("k [N/m]", "spectral radius", "k_e limit [N/m]", "margin (limit / k)", "verdict"):
        t.add_column(escape(col), justify="right")
    for c in checks:
        t.add_row(f"{c['environment_stiffness']:.6g}", f"{c['vendor_loop_spectral_radius']:.4f}",
                  f"{c['vendor_loop_stability_limit']:.6g}", f"{c['vendor_loop_margin']:.3g}", c["vendor_loop_verdict"])
    console.print(t)
    if written:
        console.print(escape(f"written: {written} (the file with only the changed keys rewritten; paste it or use it as "
                             "the scenario's config)"), highlight=False)
