"""The library's error types.

Every error raised on purpose by forcecontrol derives from :class:`ForceControlError`, and each
subclass also derives from the matching built-in exception, so ``except ValueError`` keeps
working for callers that do not know this package.
"""

from __future__ import annotations

__all__ = [
    "ForceControlError",
    "DimensionError",
    "ParameterError",
    "ScenarioError",
    "OutputError",
    "MeasurementError",
    "SimulationDivergedError",
    "WorkspaceError",
    "FrameError",
    "SingularityError",
    "RealtimeError",
    "DriftWarning",
    "BandwidthWarning",
    "SampledLoopWarning",
    "ContactModelWarning",
    "CalibrationMisfitWarning",
]


class ForceControlError(Exception):
    """Base class of every error raised by forcecontrol."""


class DimensionError(ForceControlError, ValueError):
    """An array has the wrong shape."""


class ParameterError(ForceControlError, ValueError):
    """A parameter has an impossible value (negative gain, indefinite matrix, Ts <= 0, ...)."""


class WorkspaceError(ForceControlError, ValueError):
    """A requested pose is outside the robot's workspace."""


class FrameError(ForceControlError, ValueError):
    """Quantities expressed in different frames were mixed."""


class OutputError(ForceControlError, OSError):
    """An output location cannot be written, or writing would overwrite files without ``force``."""


class ScenarioError(ForceControlError, ValueError):
    """A scenario file or dictionary is malformed.

    The message names the file (when there is one), the key, what was expected and what was given.
    """


class MeasurementError(ForceControlError, ValueError):
    """A measurement handed to a controller is not finite."""


class SimulationDivergedError(ForceControlError, RuntimeError):
    """A simulation stopped because its state diverged.

    Attributes:
        time: simulated time [s] at which the divergence was detected.
        step: control-sample index at which it was detected.
        cause: short machine-readable cause (``"non-finite state"``, ``"runaway"``,
            ``"singular jacobian"``, ``"non-finite torque"``).
        q: joint positions at detection [rad], when available.
    """

    def __init__(self, message: str, *, time: float, step: int, cause: str, q=None) -> None:
        super().__init__(message)
        self.time = time
        self.step = step
        self.cause = cause
        self.q = q


class SingularityError(ForceControlError, ArithmeticError):
    """A control law met a singular Jacobian (or another singular matrix) it must invert."""


class RealtimeError(ForceControlError, OSError):
    """The operating system refused a real-time setting asked for with ``strict=True``
    (:func:`forcecontrol.realarm.realtime.realtime_priority`): scheduling policy, CPU pinning or memory locking.
    """


class DriftWarning(UserWarning):
    """A force reference the environment cannot balance (outside R(K), Sect. 9.4.3).

    Direct force control reads such a component as a velocity reference and the end-effector
    drifts along it; along axes where C_F is zero the component is ignored.
    """


class BandwidthWarning(UserWarning):
    """Admittance control (Sect. 9.3) with a motion loop not faster than its impedance loop.

    Stability of the scheme of Fig. 9.5 needs the motion loop's bandwidth to exceed the
    impedance loop's; the message gives both.
    """


class SampledLoopWarning(UserWarning):
    """A case whose sampled closed loop cannot settle: its analysis gives a spectral radius >= 1 at the
    controller's sample time (the held loop of the chapter's law on the plant and the environment, or a
    servo or vendor loop). The continuous model's ω_n, ζ and steady values are then not reached; the run
    bounces or diverges (:func:`forcecontrol.scenarios.parts_sampled.sampled_loop_warnings`).
    """


class ContactModelWarning(UserWarning):
    """An elastic contact evaluated where its model has no clear answer: a curved surface penetrated near or beyond
    its radius of curvature, where the closest surface point (and so the contact normal) stops being unique
    (:meth:`forcecontrol.environments.surfaces.ElasticSurface.take_projection_note`; the run's
    ``contact-projection`` event)."""


class CalibrationMisfitWarning(UserWarning):
    """Static F/T readings that do not follow the gravity model in the orientations they were given with
    (:func:`forcecontrol.realarm.calibration.calibrate`'s frame check): the orientations are most often another frame's
    than the sensor's (a sensor mounted turned on the flange); the message gives the rotation that fits them best."""
