"""Actuation realism for simulation: joint friction, actuation delay and torque quantisation.

The chapter's model (9.1) ``B q̈ + C q̇ + F q̇ + g = u − Jᵀ h_e`` has viscous friction ``F q̇`` and
applies the commanded torque exactly and at once. A real arm adds (per joint i):

* Coulomb friction with a smooth sign, ``τ_c,i tanh(q̇_i / v_s,i)``, and extra viscous friction
  ``F_v,i q̇_i``: a torque opposing the joint velocity, part of the *plant* (it acts inside the
  integration, at every RK4 stage);
* an actuation delay of ``d`` whole samples: the torque applied from sample k on is the one
  commanded at sample ``k − d`` (before t = 0: the gravity-holding torque the arm started with);
* torque quantisation with step Δ: the applied torque is ``Δ · round(u / Δ)``, so the error is
  at most Δ/2 per joint.

Delay and quantisation act on the *command*; :func:`forcecontrol.simulate` takes an
``actuator=Actuator(...)`` and runs on its Python engine.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.validate import as_vector
from ..errors import DimensionError, ParameterError
from ..sensors.realistic import MAX_DELAY_SAMPLES

__all__ = ["Actuator", "ActuatorState"]


def _per_joint(name: str, value: Any, n: int | None, *, positive: bool = False) -> np.ndarray:
    """A scalar or an (n,) vector of finite numbers >= 0 (> 0 when ``positive``), as an (n,) or (1,) array."""
    a = np.atleast_1d(np.array(as_vector(name, np.atleast_1d(value))))
    if n is not None and a.size not in (1, n):
        raise DimensionError(f"{name} must be a scalar or have shape ({n},); got shape {a.shape}")
    bad = a <= 0 if positive else a < 0
    if np.any(bad):
        raise ParameterError(f"{name} must be {'positive' if positive else 'non-negative'} per joint; got {a.tolist()}")
    return a


@dataclass(frozen=True)
class Actuator:
    """Joint friction, actuation delay and torque quantisation between a controller and the arm.

    Args:
        coulomb: Coulomb friction torque τ_c [N m], scalar or per joint (n,), >= 0.
        viscous: viscous friction F_v [N m s/rad] added to the robot's own F, scalar or (n,), >= 0.
        coulomb_band: the velocity v_s [rad/s] of the smooth sign ``tanh(q̇ / v_s)``, > 0
            (scalar or (n,)); smaller is closer to a discontinuous sign, and stiffer to integrate.
        delay: actuation delay d [samples], a whole number >= 0.
        resolution: torque quantum Δ [N m], scalar or (n,), >= 0 (0: no quantisation).

    Raises:
        ParameterError: a negative friction or quantum, a non-positive band, a delay that is not a
            whole number >= 0.
    """

    coulomb: Any = 0.0
    viscous: Any = 0.0
    coulomb_band: Any = 1e-2
    delay: int = 0
    resolution: Any = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "coulomb", _per_joint("coulomb", self.coulomb, None))
        object.__setattr__(self, "viscous", _per_joint("viscous", self.viscous, None))
        object.__setattr__(self, "coulomb_band", _per_joint("coulomb_band", self.coulomb_band, None, positive=True))
        object.__setattr__(self, "resolution", _per_joint("resolution", self.resolution, None))
        d = self.delay
        if isinstance(d, int) and abs(d) > MAX_DELAY_SAMPLES:  # before int()/float(): no OverflowError, no huge deque
            raise ParameterError(f"delay must be a whole number of samples in [0, {MAX_DELAY_SAMPLES:,}]; "
                                 f"got an integer of about {int(d.bit_length() * 0.30103) + 1} digits")
        if isinstance(d, bool) or not isinstance(d, (int, np.integer, float)) or not math.isfinite(d) or d != int(d) or d < 0 \
                or d > MAX_DELAY_SAMPLES:
            raise ParameterError(f"delay must be a whole number of samples in [0, {MAX_DELAY_SAMPLES:,}]; got {d!r}")
        object.__setattr__(self, "delay", int(d))

    def check(self, n: int) -> None:
        """Check that every per-joint parameter fits an arm with ``n`` joints.

        Raises:
            DimensionError: a vector parameter has neither 1 nor n entries.
        """
        for name in ("coulomb", "viscous", "coulomb_band", "resolution"):
            _per_joint(name, getattr(self, name), n, positive=name == "coulomb_band")

    @property
    def has_friction(self) -> bool:
        """True when the actuator adds any friction to the plant."""
        return bool(np.any(self.coulomb > 0) or np.any(self.viscous > 0))

    def friction(self, qd: np.ndarray) -> np.ndarray:
        """The friction torque opposing the joint velocities, ``τ_c tanh(q̇ / v_s) + F_v q̇``, (n,) [N m].

        Args:
            qd: joint velocities (n,) [rad/s].
        """
        qd = np.asarray(qd, dtype=np.float64)
        return self.coulomb * np.tanh(qd / self.coulomb_band) + self.viscous * qd

    def quantise(self, u: np.ndarray) -> np.ndarray:
        """``Δ · round(u / Δ)`` per joint (joints with Δ = 0 pass unchanged), (n,) [N m]."""
        u = np.asarray(u, dtype=np.float64)
        res = np.broadcast_to(self.resolution, u.shape)
        if not np.any(res > 0):
            return u.copy()
        safe = np.where(res > 0, res, 1.0)
        return np.where(res > 0, np.round(u / safe) * safe, u)

    def start(self, n: int, u_before: Any) -> ActuatorState:
        """A fresh command pipeline for an arm with n joints.

        Args:
            n: number of joints.
            u_before: the torque held before t = 0 (n,) [N m]: what a delayed actuator applies
                during its first ``delay`` samples.
        """
        self.check(n)
        return ActuatorState(self, np.array(as_vector("u_before", u_before, n)))

    def describe(self) -> dict[str, Any]:
        """Parameters as plain values (for metadata)."""
        return {
            "coulomb": self.coulomb.tolist(), "viscous": self.viscous.tolist(),
            "coulomb_band": self.coulomb_band.tolist(), "delay": self.delay, "resolution": self.resolution.tolist(),
        }


class ActuatorState:
    """The command side of an :class:`Actuator` during one run: quantiser and delay line."""

    def __init__(self, actuator: Actuator, u_before: np.ndarray) -> None:
        self.actuator = actuator
        self._line: deque[np.ndarray] = deque([u_before.copy() for _ in range(actuator.delay)])

    def apply(self, u: np.ndarray) -> np.ndarray:
        """The torque applied from this sample on, given the one commanded now, (n,) [N m]."""
        uq = self.actuator.quantise(u)
        if not self._line:
            return uq
        self._line.append(uq)
        return self._line.popleft()
