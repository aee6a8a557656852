"""The tuning page's names for the knobs: the chapter's symbols with units, and which knobs act.

A knob ``controller.stiffness[0]`` is shown as ``K_P,x [N/m]`` (the chapter's matrix K_P, its x
entry), ``environment.stiffness`` as ``k_e [N/m]``. The internal key stays the knob's
identity (``Knob.name``) and is shown as the field's tooltip.

A component of a diagonal gain that is zero on an axis whose other gains of the same family are
zero too is an unused axis (Example 9.3's force loop acts along x only: k_F,y = k_I,y = 0); its
knob is hidden, and :func:`split_knobs` says which and why, for the page to print.
"""

from __future__ import annotations

from typing import Any

from .session import Knob

__all__ = ["knob_label", "knob_symbol", "knob_unit", "split_knobs"]

#: controller field -> the chapter's symbol (Sect. 9.2-9.6); per controller type where it differs
_SYMBOLS = {
    "inertia": "M_d", "damping": "K_D", "stiffness": "K_P", "force_gain": "K_F", "integral_gain": "K_I",
    "compliance": "C", "velocity_gain": "K_Pν", "velocity_integral_gain": "K_Iν", "position_gain": "K_Pr",
    "force_rate_gain": "K_Dλ", "force_integral_gain": "K_Iλ", "posture_stiffness": "K_n", "posture_damping": "D_n",
    "motion_stiffness": "K_P", "motion_damping": "K_D", "environment_stiffness": "k_e", "force_stiffness": "K_Pf",
    "force_damping": "K_Df",
}
_HYBRID_SYMBOLS = {"force_gain": "K_Pλ", "force_rate_gain": "K_Dλ", "velocity_gain": "K_Pν",
                   "velocity_integral_gain": "K_Iν"}
#: units where a controller type's field differs from the generic table of :mod:`.session`
_HYBRID_UNITS = {"force_gain": "1/s²", "force_rate_gain": "1/s", "velocity_gain": "1/s", "velocity_integral_gain": "1/s²"}
_ENVIRONMENT = {"stiffness": ("k_e", "N/m"), "damping": ("d_e", "N s/m")}
_AXES = "xyzabc"


def _controller_type(config: dict[str, Any], table: str) -> str:
    tbl: Any = config
    for part in table.split("."):
        tbl = tbl.get(part, {}) if isinstance(tbl, dict) else {}
    return str(tbl.get("type", "")) if isinstance(tbl, dict) else ""


def knob_symbol(knob: Knob, config: dict[str, Any]) -> str:
    """The chapter's symbol of a knob (``K_P,x``, ``M_d,y``, ``k_e``); the key itself when the chapter has none."""
    if knob.table == "environment":
        sym = _ENVIRONMENT.get(knob.key, (knob.key, ""))[0]
    else:
        hybrid = _controller_type(config, knob.table).startswith("hybrid")
        sym = (_HYBRID_SYMBOLS if hybrid else {}).get(knob.key) or _SYMBOLS.get(knob.key, knob.key)
        if knob.table != "controller":
            sym = f"{sym} ({knob.table.removeprefix('controller.')})"
    return sym if knob.index is None else f"{sym},{_AXES[knob.index] if knob.index < len(_AXES) else knob.index}"


def knob_unit(knob: Knob, config: dict[str, Any]) -> str:
    """The knob's SI unit (the controller type's where it differs from the generic table)."""
    if knob.table == "environment":
        return _ENVIRONMENT.get(knob.key, ("", knob.unit))[1] or knob.unit
    if _controller_type(config, knob.table).startswith("hybrid"):
        return _HYBRID_UNITS.get(knob.key, knob.unit)
    return knob.unit


def knob_label(knob: Knob, config: dict[str, Any]) -> str:
    """``symbol [unit]`` (``K_P,x [N/m]``)."""
    u = knob_unit(knob, config)
    return f"{knob_symbol(knob, config)} [{u}]" if u else knob_symbol(knob, config)


def split_knobs(knobs: list[Knob], config: dict[str, Any]) -> tuple[list[Knob], list[tuple[Knob, str]]]:
    """The knobs the page shows, and the hidden ones with the reason.

    Hidden: a component ``key[i]`` that is zero (an axis the gain does not act on: a zero force
    gain means no force loop along that axis). A scalar at zero stays (its slider starts at 0).
    """
    shown, hidden = [], []
    for k in knobs:
        if k.index is not None and k.value == 0.0:
            axis = _AXES[k.index] if k.index < len(_AXES) else str(k.index)
            hidden.append((k, f"{knob_symbol(k, config)} = 0: the law has no {k.key.replace('_', ' ')} along {axis}"))
        else:
            shown.append(k)
    return shown, hidden
