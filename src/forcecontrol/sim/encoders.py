"""Joint encoders: position quantisation and velocity by differences, as a real arm measures q and q̇.

An incremental encoder with Δ = 2π / counts_per_turn [rad] per count reads ``q_m = Δ round(q / Δ)``
(the motor-side resolution divided by the gear ratio is the joint-side Δ). Joint velocity is not
measured: it is estimated by the backward difference of the quantised positions
``q̇_m,k = (q_m,k − q_m,k−1) / Ts``, optionally through the first-order low-pass
``v_k = v_{k−1} + α (q̇_m,k − v_{k−1})``, ``α = 1 − exp(−2π f_c Ts)``. The difference of a
quantised signal jumps by ±Δ/Ts from one sample to the next; the filter trades that noise for
a lag of about 1/(2π f_c).

:class:`EncoderFeedback` wraps any controller so that it reads the encoder's q_m and q̇_m instead
of the true state (the simulator keeps logging the true state).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from ..controllers.base import Controller, Measurement, Reference
from ..core.validate import positive_scalar
from ..errors import ParameterError
from ..sensors import first_order_alpha

__all__ = ["JointEncoder", "EncoderFeedback"]


class JointEncoder:
    """Quantised joint positions and velocities by backward differences.

    Args:
        counts_per_turn: encoder counts per joint revolution (joint side), > 0; None = exact
            positions (the difference is still used for the velocity).
        sample_time: Ts [s], > 0.
        velocity_cutoff: cut-off f_c [Hz] of the low-pass on the differenced velocity; None =
            raw differences. Must be below the Nyquist frequency 1/(2 Ts).

    Raises:
        ParameterError: non-positive counts or sample time, cut-off at or above Nyquist.
    """

    def __init__(self, counts_per_turn: float | None = None, sample_time: float = 1e-3,
                 velocity_cutoff: float | None = None) -> None:
        self.sample_time = positive_scalar("sample_time", sample_time)
        self.counts_per_turn = None if counts_per_turn is None else positive_scalar("counts_per_turn", counts_per_turn)
        self.resolution = 0.0 if self.counts_per_turn is None else 2.0 * math.pi / self.counts_per_turn
        if velocity_cutoff is None:
            self.velocity_cutoff = None
            self.alpha = 1.0
        else:
            self.velocity_cutoff = positive_scalar("velocity_cutoff", velocity_cutoff)
            self.alpha = first_order_alpha("velocity_cutoff", self.velocity_cutoff, self.sample_time)
        self._q_prev: np.ndarray | None = None
        self._v: np.ndarray | None = None

    def quantise(self, q: Any) -> np.ndarray:
        """q_m = Δ round(q / Δ) [rad] (q itself without quantisation)."""
        q = np.asarray(q, dtype=np.float64)
        return self.resolution * np.round(q / self.resolution) if self.resolution > 0.0 else q.copy()

    def reset(self, q0: Any, qd0: Any = None) -> None:
        """Start from the positions q0 and the velocity estimate qd0 (zeros by default: at rest)."""
        self._q_prev = self.quantise(q0)
        self._v = np.zeros_like(self._q_prev) if qd0 is None else np.array(qd0, dtype=np.float64)

    def read(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """One sample: (q_m, q̇_m) from the true positions q; call once per sample after ``reset``."""
        qm = self.quantise(q)
        if self._q_prev is None or self._v is None:
            self.reset(q)
            return qm, np.zeros_like(qm)
        diff = (qm - self._q_prev) / self.sample_time
        self._v = self._v + self.alpha * (diff - self._v)
        self._q_prev = qm
        return qm, self._v.copy()


class EncoderFeedback(Controller):
    """A controller fed by encoders: it reads ``(q_m, q̇_m)`` from a :class:`JointEncoder`.

    Law: ``u = controller.step(t, Measurement(q_m, q̇_m, h_m), reference)``.

    Args:
        controller: any controller; encoder: the joint encoder (same sample time).

    Raises:
        ParameterError: the encoder's sample time differs from the controller's.
    """

    kind: ClassVar[int] = 0

    def __init__(self, controller: Controller, encoder: JointEncoder) -> None:
        if not isinstance(controller, Controller):
            raise ParameterError(f"controller must be a forcecontrol Controller; got {type(controller).__name__}")
        if not isinstance(encoder, JointEncoder):
            raise ParameterError(f"encoder must be a JointEncoder; got {type(encoder).__name__}")
        if abs(encoder.sample_time - controller.sample_time) > 1e-15:
            raise ParameterError(
                f"encoder.sample_time must equal the controller's {controller.sample_time:.6g} s; "
                f"got {encoder.sample_time:.6g} s"
            )
        super().__init__(controller.robot, controller.sample_time)
        self.controller, self.encoder = controller, encoder
        self.uses_force = controller.uses_force  # type: ignore[misc]

    @property
    def events(self) -> list[dict[str, Any]]:
        """The wrapped controller's events."""
        return list(getattr(self.controller, "events", []))

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Reset the encoder at the measured state (at rest) and the wrapped controller with q_m."""
        if measurement is None:
            self.controller.reset(None, reference)
            return
        self.encoder.reset(measurement.q)
        qm = self.encoder.quantise(measurement.q)
        self.controller.reset(Measurement(qm, np.zeros_like(qm), measurement.wrench), reference)

    def gains(self) -> dict[str, Any]:
        return {"wrapped": {"type": type(self.controller).__name__, **self.controller.gains()},
                "counts_per_turn": self.encoder.counts_per_turn, "velocity_cutoff": self.encoder.velocity_cutoff}

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """The wrapped controller's torques from the encoder's readings."""
        qm, vm = self.encoder.read(measurement.q)
        return self.controller.step(t, Measurement(qm, vm, measurement.wrench), reference)
