"""The built-in simulator against another engine: contact-force metrics side by side, and why they differ.

Needs no engine itself: it compares two finished runs (:class:`~forcecontrol.sim.result.SimulationResult`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..sim.result import SimulationResult

__all__ = ["compare_engines", "DIFFERENCES"]

#: why the two engines can differ, for reports.
DIFFERENCES = (
    "MuJoCo contact is a soft constraint (solref/solimp): f = (a_ref - a1)/R; its static stiffness and damping are "
    "matched to the environment's, but the constraint also carries an apparent mass 1/R along the normal "
    "(reported as apparent_contact_mass) that the built-in spring does not have: it slows the contact transient",
    "MuJoCo's contact acts at the surface of a sphere of radius contact_radius around the end-effector frame, "
    "the built-in one at the frame's origin (planes are shifted by the radius so the penetrations agree)",
    "chapter arm: the rotor coupling k_r2 I_m2 = 1 kg m^2 of b12 has no MuJoCo counterpart (transients only)",
    "integration: MuJoCo RK4 with the constraint solver vs the built-in RK4 on the unconstrained ODE",
    "payload: MuJoCo's F/T sensor reads the acceleration at t_k with the last torque held; the built-in payload sensor "
    "forms q'' by backward differences of q (1.5 a on the sample after a step a): sample-level readings differ",
)


def _transient(t: np.ndarray, f: np.ndarray) -> dict[str, float]:
    """The contact force's transient by the library's one definition (:func:`forcecontrol.sim.metrics.step_metrics`)."""
    from ..sim.metrics import step_metrics

    m = step_metrics(t, f, window=0.1)
    return {
        "steady": m.steady,
        "peak": m.peak,
        "peak_time": m.peak_time,
        "overshoot_percent": m.overshoot_percent,
        "settling_time_2pc": m.settling_time,
    }


def compare_engines(builtin: SimulationResult, mujoco: SimulationResult, axis: int | None = None) -> dict[str, Any]:
    """Side-by-side contact-force metrics of the same scenario on both engines, with the reasons they differ.

    Args:
        builtin, mujoco: the two runs (same times).
        axis: the force component to compare; default the one with the largest steady magnitude.
    """
    if axis is None:
        axis = int(np.argmax(np.abs(builtin.settled("wrench"))))
    a = _transient(builtin.t, builtin.wrench[:, axis])
    b = _transient(mujoco.t, mujoco.wrench[:, axis])
    diff = abs(b["steady"] - a["steady"]) / max(abs(a["steady"]), 1e-12)
    fa, fb = builtin.wrench[:, axis], mujoco.wrench[:, axis]
    shape = float(np.max(np.abs(fa - fb)) / max(np.max(np.abs(fa)), 1e-12))
    return {
        "axis": axis,
        "builtin": a,
        "mujoco": b,
        "steady_force_difference_percent": 100.0 * diff,
        "max_force_difference_over_peak_percent": 100.0 * shape,
        "why_they_differ": list(DIFFERENCES),
        "mujoco_parameters": mujoco.metadata.get("mujoco", {}),
    }
