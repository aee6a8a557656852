"""Registrations for variable impedance with an energy tank (issue 18): controller and metrics."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from ..controllers.variable import DirectionalStiffness, EnergyTank, SinusoidalStiffness, VariableImpedanceController
from ..errors import ParameterError
from .core import register_metric
from .schema import Field, register_controller


def _as_keys(exc: ParameterError, names: dict[str, str]) -> ParameterError:
    """The error of a class built from scenario keys, its argument names replaced by those keys."""
    text = re.sub(r"\b(" + "|".join(names) + r")\b", lambda m: names[m.group(1)], str(exc))
    return ParameterError(text)


def _schedule(p: dict[str, Any]) -> Any:
    try:
        return _make_schedule(p)
    except ParameterError as exc:
        raise _as_keys(exc, {"low": "stiffness_low", "high": "stiffness_high", "mean": "stiffness_low"}) from None


def _make_schedule(p: dict[str, Any]) -> Any:
    kind = p["schedule"]
    if kind == "constant":
        return None
    if kind == "directional":
        if p["stiffness_high"] is None:
            raise ParameterError("stiffness_high is required for schedule = 'directional'")
        return DirectionalStiffness(p["stiffness_low"], p["stiffness_high"])
    if p["amplitude"] is None or p["frequency"] is None:
        raise ParameterError("amplitude and frequency are required for schedule = 'sinusoidal'")
    return SinusoidalStiffness(p["stiffness_low"], p["amplitude"], p["frequency"])


def _variable(p: dict[str, Any], ctx: dict[str, Any]) -> VariableImpedanceController:
    tank = None
    if p["tank"]:
        try:
            tank = EnergyTank(p["tank_initial"], minimum=p["tank_minimum"], maximum=p["tank_maximum"],
                              dissipation_fraction=p["dissipation_fraction"])
        except ParameterError as exc:
            raise _as_keys(exc, {"initial": "tank_initial", "minimum": "tank_minimum", "maximum": "tank_maximum"}) from None
    return VariableImpedanceController(
        ctx["robot"], p["inertia"], p["damping"], p["stiffness_low"], stiffness_schedule=_schedule(p), tank=tank,
        sample_time=ctx["sample_time"],
    )


_DIRECTIONAL, _SINUSOIDAL, _TANK = ("schedule", ("directional",)), ("schedule", ("sinusoidal",)), ("tank", (True,))

register_controller(
    "variable-impedance",
    {
        "inertia": Field("gain", True, doc="M_d [kg]"),
        "damping": Field("gain", True, doc="K_D [N s/m]"),
        "stiffness_low": Field("number", True, doc="K_P at t = 0, the low stiffness or the sinusoid's mean [N/m]"),
        "schedule": Field("str", default="directional", choices=("constant", "directional", "sinusoidal"),
                          doc="directional: high while the error shrinks; sinusoidal: mean + amplitude sin(2π f t)"),
        "stiffness_high": Field("number", doc="directional schedule: the high stiffness [N/m]", used_when=_DIRECTIONAL),
        "amplitude": Field("number", doc="sinusoidal schedule: amplitude [N/m]", used_when=_SINUSOIDAL),
        "frequency": Field("number", doc="sinusoidal schedule: frequency [Hz]", used_when=_SINUSOIDAL),
        "tank": Field("bool", default=True, doc="pay stiffness changes from an energy tank (passive) or not (naive)"),
        "tank_initial": Field("number", default=0.05, doc="T₀ [J]", used_when=_TANK),
        "tank_minimum": Field("number", default=0.01, doc="T_min [J]", used_when=_TANK),
        "tank_maximum": Field("number", default=0.1, doc="T_max [J]", used_when=_TANK),
        "dissipation_fraction": Field("number", default=0.5, doc="σ: share of the damper's dissipation stored",
                                      used_when=_TANK),
    },
    _variable,
    "impedance with force measurement (9.30)-(9.31), scheduled stiffness, optional energy tank",
)


def _peak_force_last_second(res: Any, parts: dict[str, Any], window: float) -> float:
    sel = res.t >= res.t[-1] - 1.0 - 1e-12
    return float(np.linalg.norm(res.wrench[sel], axis=1).max())


def _tank_energy_min(res: Any, parts: dict[str, Any], window: float) -> float:
    e = res.signals.get("tank_energy")
    return math.nan if e is None else float(np.nanmin(e))


register_metric("peak_force_last_second", _peak_force_last_second)
register_metric("tank_energy_min", _tank_energy_min)
