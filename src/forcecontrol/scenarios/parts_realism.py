"""Registrations for running like a real arm: contact supervisor, safety layer, impact metrics.

Controller types:

* ``contact-supervisor``: motion control in free space (``[controller.approach]``, any
  registered controller type), force control in contact (``[controller.contact]``), switching on
  the measured normal force with hysteresis (:class:`~forcecontrol.supervision.transitions.ContactSupervisor`);
* ``safety``: any registered controller (``[controller.wrapped]``) inside the safety layer
  (:class:`~forcecontrol.supervision.safety.Safety`), limits as keys.

Metrics: ``impact_peak_force`` [N], ``bounce_count``, ``bounced`` (1 when the contact was lost
after the first impact, else 0), ``first_contact_time`` [s] (from the true contact force, along
the supervisor's direction when there is one), ``safety_events`` (number of logged reactions),
``safety_stops`` (number of reactions that were a safe stop).
"""

from __future__ import annotations

from typing import Any

from ..errors import ScenarioError
from ..supervision.safety import Safety
from ..supervision.transitions import ContactSupervisor, impact_report
from .core import register_metric
from .schema import CONTROLLERS, Field, check_table, register_controller


def _nested(name: str, table: Any, ctx: dict[str, Any]):
    """Build a controller from a nested table (``type`` + that type's keys)."""
    where = f"[controller.{name}]"  # the schema has checked that the table is a table
    kind = table.get("type")
    if not isinstance(kind, str) or kind not in CONTROLLERS:  # a list or table is not hashable: no TypeError
        raise ScenarioError(f"{where}: key 'type' must be one of {', '.join(sorted(CONTROLLERS))}; got {kind!r}")
    spec = CONTROLLERS[kind]
    params = check_table(f"{where} (type '{kind}')", table, spec.fields, extra_ok=("type",))
    return spec.build(params, ctx)


register_controller(
    "contact-supervisor",
    {
        "approach": Field("table", True, doc="free-space (motion) controller table, with its own 'type'"),
        "contact": Field("table", True, doc="in-contact (force) controller table, with its own 'type'"),
        "direction": Field("vector", True, doc="ν_f, direction of the controlled contact force (into the surface)"),
        "contact_force": Field("number", default=2.0, doc="normal force declaring contact [N]"),
        "release_force": Field("number", default=0.5, doc="normal force below which contact is lost [N]"),
        "release_samples": Field("int", default=5, doc="samples below release_force before handing back"),
    },
    lambda p, ctx: ContactSupervisor(
        _nested("approach", p["approach"], ctx), _nested("contact", p["contact"], ctx), p["direction"],
        contact_force=p["contact_force"], release_force=p["release_force"], release_samples=p["release_samples"],
    ),
    "motion control in free space, force control in contact, logged transitions",
)

register_controller(
    "safety",
    {
        "wrapped": Field("table", True, doc="the protected controller's table, with its own 'type'"),
        "max_torque": Field("gain", doc="τ_max per joint [N m]"),
        "max_torque_rate": Field("gain", doc="τ̇_max per joint [N m/s]"),
        "max_force": Field("number", doc="largest contact force norm [N]"),
        "max_speed": Field("number", doc="largest tip speed [m/s]"),
        "max_path_deviation": Field("number", doc="largest deviation from x_d on deviation_axes [m]"),
        "torque_reaction": Field("str", default="clamp", choices=("clamp", "stop"), doc="actuator-limit reaction"),
    },
    lambda p, ctx: Safety(
        _nested("wrapped", p["wrapped"], ctx), max_torque=p["max_torque"], max_torque_rate=p["max_torque_rate"],
        max_force=p["max_force"], max_speed=p["max_speed"], max_path_deviation=p["max_path_deviation"],
        torque_reaction=p["torque_reaction"],
    ),
    "any controller inside the safety layer (limits, safe stop, logged reactions)",
)


def _report(res, parts: dict[str, Any]) -> dict[str, Any]:
    ctl = parts["controller"]
    return impact_report(res, getattr(ctl, "direction", None))


register_metric("impact_peak_force", lambda r, p, w: float(_report(r, p)["peak_force"]))
register_metric("bounce_count", lambda r, p, w: float(_report(r, p)["bounces"]))
register_metric("bounced", lambda r, p, w: float(_report(r, p)["bounces"] > 0))
register_metric("first_contact_time", lambda r, p, w: float(_report(r, p)["first_contact_time"]))
register_metric("safety_events", lambda r, p, w: float(sum(1 for e in r.events if e.get("event") == "safety")))
register_metric("safety_stops", lambda r, p, w: float(sum(1 for e in r.events if e.get("reaction") == "stop")))
