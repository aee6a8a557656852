"""Contact transitions: approach in free space, impact, contact kept, contact lost.

:class:`ContactSupervisor` is a controller that switches between a motion controller (free
space, approach) and a force controller (in contact), from the measured force along the
contact normal::

    free    → contact  when  ν_fᵀ h_m >= contact_force                      (log "contact")
    contact → free     when  ν_fᵀ h_m <  release_force for release_samples samples
                                                                           (log "contact lost")

with ν_f the direction along which the force is controlled (the plane's inward normal: the
direction the end-effector pushes). On contact the force controller is reset with the current
measurement and reference (an inner-position loop with ``integrator_start="tip"`` then starts its
integrator at the tip: no jump in the position reference, a bumpless switch; with its default
``"hold"`` the force step acts on the whole PI, proportional kick included); on loss the force-controlled direction is handed back
to the motion controller, reset likewise. The hysteresis (release below contact) and the
debounce (``release_samples``) keep sensor noise from chattering the switch.

Gains that keep contact after impact. In contact with an environment of stiffness k_e the
inner velocity loop (9.47) has the contact mode ``m_d s² + k_D s + k_P k_F k_e``. Starting on
the surface with the impact speed v₀ > 0 towards the equilibrium inside it, a second-order mode
with damping ratio ζ >= 1 crosses its equilibrium at most once and never returns to the
surface: the contact is kept for any impact speed. So choose, for the stiffest environment
expected (a softer one only raises ζ)::

    k_D >= 2 sqrt(m_d k_P k_F k_e)                                          (ζ >= 1)

Example 9.3's gains (m_d = 100, k_D = 500, k_P k_F = 6) give ζ = 0.10 on k_e = 10⁴ N/m: the
"naive" choice, which bounces (built-in scenario ``impact``). :func:`critical_damping` gives
the bound; :func:`impact_report` measures peak impact force and bounces in a simulation log.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from ..controllers.base import Controller, Measurement, Reference
from ..core.validate import as_vector, nonnegative_scalar, positive_scalar
from ..errors import ParameterError

__all__ = ["ContactSupervisor", "impact_report", "critical_damping"]


def critical_damping(inertia: float, stiffness: float, force_gain: float, environment_stiffness: float) -> float:
    """k_D giving ζ = 1 on the inner-velocity contact mode ``m_d s² + k_D s + k_P k_F k_e`` [N s/m].

    Raises:
        ParameterError: a non-positive argument.
    """
    md = positive_scalar("inertia", inertia)
    kp = positive_scalar("stiffness", stiffness)
    kf = positive_scalar("force_gain", force_gain)
    ke = positive_scalar("environment_stiffness", environment_stiffness)
    return 2.0 * math.sqrt(md * kp * kf * ke)


class ContactSupervisor(Controller):
    """Motion control in free space, force control in contact, with logged transitions.

    Law: ``u = motion.step(...)`` in phase ``"free"``, ``u = force.step(...)`` in phase
    ``"contact"``; switching as in the module docstring.

    Inputs: ``measurement`` (q, q̇ (n,), h_m (m,) [N]); ``reference`` handed to both controllers
    (position/velocity for the motion controller, force for the force controller).
    Output: torques (n,) [N m]. State: the phase, the debounce counter.

    Args:
        motion: the free-space controller (e.g. impedance (9.28)/(9.30)).
        force: the in-contact controller (e.g. inner velocity loop (9.45)).
        direction: ν_f, the direction (m,) along which contact force is measured and
            controlled (normalised), e.g. [1, 0] for the chapter's plane x = 1.
        contact_force: threshold on ν_fᵀ h_m that declares contact [N], > 0.
        release_force: threshold below which contact counts as lost [N], 0 <= release < contact.
        release_samples: consecutive samples below ``release_force`` before handing back, >= 1.

    Raises:
        ParameterError: controllers with different robots or sample times; thresholds out of order.
    """

    kind: ClassVar[int] = 0

    def __init__(
        self,
        motion: Controller,
        force: Controller,
        direction: Any,
        *,
        contact_force: float = 2.0,
        release_force: float = 0.5,
        release_samples: int = 5,
    ) -> None:
        for name, c in (("motion", motion), ("force", force)):
            if not isinstance(c, Controller):
                raise ParameterError(f"{name} must be a forcecontrol Controller; got {type(c).__name__}")
        if type(motion.robot) is not type(force.robot):
            raise ParameterError("motion and force controllers must drive the same robot model")
        if motion.sample_time != force.sample_time:
            raise ParameterError(
                f"motion and force controllers must share the sample time; got {motion.sample_time:.6g} s "
                f"and {force.sample_time:.6g} s"
            )
        super().__init__(motion.robot, motion.sample_time)
        self.motion, self.force = motion, force
        d = as_vector("direction", direction, self.m)
        nrm = float(np.linalg.norm(d))
        if nrm == 0.0:
            raise ParameterError("direction must be a non-zero vector")
        self.direction = d / nrm
        self.contact_force = positive_scalar("contact_force", contact_force)
        self.release_force = nonnegative_scalar("release_force", release_force)
        if self.release_force >= self.contact_force:
            raise ParameterError(
                f"release_force must be below contact_force (hysteresis); got release_force {self.release_force:.6g} N "
                f">= contact_force {self.contact_force:.6g} N"
            )
        if isinstance(release_samples, bool) or not isinstance(release_samples, (int, np.integer)) or release_samples < 1:
            raise ParameterError(f"release_samples must be a positive integer; got {release_samples!r}")
        self.release_samples = int(release_samples)
        self.phase = "free"
        self._below = 0
        self._events: list[dict[str, Any]] = []

    @property
    def events(self) -> list[dict[str, Any]]:
        """Logged transitions (and the wrapped controllers' events), in time order."""
        inner = list(getattr(self.motion, "events", [])) + list(getattr(self.force, "events", []))
        return sorted(self._events + inner, key=lambda e: e["t"])

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Start in ``"contact"`` when the measured normal force already exceeds the threshold, else ``"free"``."""
        self._events.clear()
        self._below = 0
        fn = 0.0 if measurement is None else float(self.direction @ np.asarray(measurement.wrench, dtype=np.float64))
        self.phase = "contact" if fn >= self.contact_force else "free"
        self.motion.reset(measurement, reference)
        self.force.reset(measurement, reference)

    def gains(self) -> dict[str, Any]:
        return {
            "motion": {"type": type(self.motion).__name__, **self.motion.gains()},
            "force": {"type": type(self.force).__name__, **self.force.gains()},
            "direction": self.direction.tolist(),
            "contact_force": self.contact_force,
            "release_force": self.release_force,
            "release_samples": self.release_samples,
        }

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of the active controller, after updating the phase from the measured force."""
        fn = float(self.direction @ np.asarray(measurement.wrench, dtype=np.float64))
        if self.phase == "free" and fn >= self.contact_force:
            self.phase = "contact"
            self._below = 0
            self.force.reset(measurement, reference)
            x = self.robot.forward_kinematics(np.asarray(measurement.q, dtype=np.float64))
            v = self.robot.jacobian(np.asarray(measurement.q, dtype=np.float64)) @ np.asarray(measurement.qd, dtype=np.float64)
            self._events.append({
                "t": float(t), "event": "contact", "force": fn, "speed": float(self.direction @ v),
                "detail": f"normal force {fn:.6g} N >= {self.contact_force:.6g} N at x = {np.round(x, 6).tolist()}; "
                          "force control on",
            })
        elif self.phase == "contact":
            self._below = self._below + 1 if fn < self.release_force else 0
            if self._below >= self.release_samples:
                self.phase = "free"
                self._below = 0
                self.motion.reset(measurement, reference)
                self._events.append({
                    "t": float(t), "event": "contact lost", "force": fn,
                    "detail": f"normal force below {self.release_force:.6g} N for {self.release_samples} samples; "
                              "force-controlled direction handed back to motion control",
                })
        active = self.force if self.phase == "contact" else self.motion
        return active.step(t, measurement, reference)


def impact_report(result: Any, direction: Any = None) -> dict[str, Any]:
    """Impact metrics from a simulation log's true contact force.

    Contact means ``ν_fᵀ h_e > 0`` (the one-sided environment pushes back); a bounce is a
    return to zero force after the first contact.

    Args:
        result: a :class:`~forcecontrol.sim.simulation.SimulationResult`.
        direction: ν_f (m,); None = the force norm.

    Returns:
        ``first_contact_time`` [s] (NaN if never), ``peak_force`` [N], ``bounces`` (count),
        ``contact_kept`` (no bounce after the first contact), ``final_force`` [N].
    """
    h = np.asarray(result.wrench)
    fn = np.linalg.norm(h, axis=1) if direction is None else h @ (np.asarray(direction, float) / np.linalg.norm(direction))
    touching = fn > 0.0
    if not touching.any():
        return {"first_contact_time": math.nan, "peak_force": 0.0, "bounces": 0, "contact_kept": False,
                "final_force": float(fn[-1])}
    k0 = int(np.argmax(touching))
    after = touching[k0:]
    bounces = int(np.count_nonzero(after[:-1] & ~after[1:]))
    return {
        "first_contact_time": float(result.t[k0]),
        "peak_force": float(fn.max()),
        "bounces": bounces,
        "contact_kept": bounces == 0,
        "final_force": float(fn[-1]),
    }
