"""Limits checked before a simulation allocates or runs anything.

A sample time of 1e-9 s or a duration of 1e12 s would ask for the whole log up front (terabytes),
and a very stiff environment for millions of integration steps per sample; both are refused with
a message that says what was asked, why it is too much, and which option changes it.
"""

from __future__ import annotations

import math
import numbers

from ..errors import ParameterError
from ..sensors.realistic import MAX_DELAY_SAMPLES as _SENSOR_DELAY
from ..sensors.realistic import MAX_ZEROING_SAMPLES as _SENSOR_ZEROING

__all__ = [
    "MAX_LOG_BYTES", "MAX_SUBSTEPS", "MAX_STEPS", "RK4_STABILITY", "check_run_size", "check_substeps",
    "MAX_DELAY_SAMPLES", "MAX_ZEROING_SAMPLES", "MAX_SWEEP_VALUES", "MAX_EXPRESSION_CHARS", "MAX_FORCE", "MAX_TORQUE",
    "MAX_FORCE_RESOLUTION", "MAX_TORQUE_RESOLUTION", "MAX_JOINT_POSITION", "MAX_JOINT_SPEED", "MAX_TOOL_MASS",
    "MAX_ANGLE_DEG", "check_count",
]

#: default memory budget for a run's logs [bytes] (``simulate(max_log_bytes=...)`` changes it).
MAX_LOG_BYTES = 2 * 1024**3
#: RK4 substeps per control sample above which the contact is too stiff for the sample time
#: (500 at Ts = 1 ms resolves contact modes up to 2.5·10⁴ rad/s, e.g. 10⁸ N/m on 0.16 kg).
MAX_SUBSTEPS = 500
#: RK4 steps in a whole run (samples × substeps) above which a run is refused: the compiled loop
#: (about 0.3 µs a step: 10 minutes) and the Python loop (about 50 µs a step: 40 minutes).
MAX_STEPS = {"compiled": 2_000_000_000, "python": 50_000_000}
#: RK4 follows a contact mode of rate ω [rad/s] with step h while ``ω h <= RK4_STABILITY``: its
#: stability interval is 2√2 ≈ 2.83 on the imaginary axis (an undamped spring) and 2.785 on the
#: negative real axis (a damper); beyond it the contact is not resolved (the penetration of one
#: step throws the tool off, or the run blows up).
RK4_STABILITY = 2.78

# ----------------------------------------------------------------------------- sizes and ranges of values
# Every buffer a command allocates from a user's number is bounded here, before it is allocated
# (docs/limits.md lists them): a run's logs (MAX_LOG_BYTES), a sensor's zeroing readings and delay
# line, an actuator's delay line, a sweep's values per parameter, and the text of one expression.

#: longest transport or actuation delay [samples] (also at most the run's samples): 100 s at 1 kHz;
#: most readings a sensor averages at start to estimate its bias (100 s at 1 kHz). Defined with the
#: sensor, which checks them in its constructor.
MAX_DELAY_SAMPLES = _SENSOR_DELAY
MAX_ZEROING_SAMPLES = _SENSOR_ZEROING
#: most values one sweep parameter (logspace/linspace/geomspace/range or a list), or a random design, may have.
MAX_SWEEP_VALUES = 1_000_000
#: longest text of one parameter value (``-p PATH=VALUES`` or a ``[sweep.parameters]`` string) [characters].
MAX_EXPRESSION_CHARS = 10_000
#: largest force magnitude a sensor's noise, bias or drift may have [N] (far beyond any arm's load).
MAX_FORCE = 1e6
#: largest torque magnitude of a friction coefficient [N m] (or [N m s/rad]).
MAX_TORQUE = 1e6
#: largest force quantum [N]: a coarser converter reads every contact force of an arm as zero.
MAX_FORCE_RESOLUTION = 1e3
#: largest torque quantum [N m]: a coarser one rounds every command of an arm to zero.
MAX_TORQUE_RESOLUTION = 1e3
#: largest joint position magnitude [rad] (or [m] for a prismatic joint): 16 turns.
MAX_JOINT_POSITION = 100.0
#: largest joint speed magnitude [rad/s] (initial velocities, the smooth-sign band).
MAX_JOINT_SPEED = 1e3
#: largest tool mass after the sensor [kg].
MAX_TOOL_MASS = 1e3
#: largest angle magnitude [deg] (a plane's or task frame's angle): one turn either way. Refused
#: beyond, not wrapped: 1e300 or 7000 is a units mistake (radians ×1000, or a typo), not a direction.
MAX_ANGLE_DEG = 360.0


def check_count(what: str, count: float, limit: int, fix: str = "") -> int:
    """``count`` as an int after checking it is a whole number in [0, limit] (before anything is allocated).

    Raises:
        ParameterError: naming ``what``, the allowed range and the value.
    """
    if isinstance(count, bool) or not isinstance(count, (int, float)) or (isinstance(count, float) and not math.isfinite(count)):
        raise ParameterError(f"{what} must be a whole number in [0, {limit:,}]; got {count!r}")
    if count < 0 or count > limit or count != int(count):
        shown = f"{count:.6g}" if isinstance(count, float) or abs(count) > 10**15 else f"{count:,}"
        raise ParameterError(f"{what} must be a whole number in [0, {limit:,}]; got {shown}" + (f"; {fix}" if fix else ""))
    return int(count)


def _human(nbytes: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if nbytes < 1024 or unit == "EiB":
            return f"{nbytes:.3g} {unit}"
        nbytes /= 1024
    return f"{nbytes:.3g} EiB"  # pragma: no cover


def check_run_size(duration: float, sample_time: float, n: int, m: int, max_log_bytes: float = MAX_LOG_BYTES) -> int:
    """The number of samples N of a run, after checking that its logs fit in ``max_log_bytes``.

    Each sample logs q, q̇, u (n each), x, ẋ, h_e, the measured h_e (m each), the reference row
    (6 m) and the time: ``8 (3 n + 10 m + 1)`` bytes.

    Raises:
        ParameterError: the run needs more memory than allowed (message: samples, size, options).
    """
    if isinstance(max_log_bytes, bool) or not isinstance(max_log_bytes, numbers.Real) or not max_log_bytes > 0:
        raise ParameterError(f"max_log_bytes must be a positive number of bytes; got {max_log_bytes!r}")
    ratio = duration / sample_time
    if not math.isfinite(ratio) or ratio > 1e15:
        raise ParameterError(
            f"duration / sample_time = {duration:.6g} s / {sample_time:.6g} s gives {ratio:.3g} samples: too many to simulate"
        )
    N = int(round(ratio))
    nbytes = (N + 1) * 8.0 * (3 * n + 10 * m + 1)
    if nbytes > max_log_bytes:
        raise ParameterError(
            f"the run needs {N + 1:,} samples (duration {duration:.6g} s / sample_time {sample_time:.6g} s) and "
            f"{_human(nbytes)} of logs in memory, more than max_log_bytes = {_human(max_log_bytes)}; shorten the "
            "duration, lengthen the sample time, or pass a larger max_log_bytes to simulate()"
        )
    return N


def check_substeps(
    nsub: int, samples: int, sample_time: float, stiffness: float, engine: str = "python", rate: float | None = None,
    explicit: bool = False,
) -> None:
    """Refuse a sub-step count that would make the run hang (a contact too stiff for the sample time).

    Args:
        nsub: RK4 substeps per sample; samples: samples in the run; sample_time: Ts [s].
        stiffness: the environment's largest stiffness [N/m] (named in the message).
        engine: ``"compiled"`` or ``"python"``: the loop that will run (sets the step budget).
        rate: the fastest contact mode [rad/s] that set ``nsub``, when known.
        explicit: ``nsub`` is the user's ``substeps`` (not chosen from ``rate``): it must at least let
            RK4 follow the contact, ``rate · sample_time / nsub <= RK4_STABILITY``.

    Raises:
        ParameterError: more than :data:`MAX_SUBSTEPS` per sample or :data:`MAX_STEPS` in all; an
            explicit ``substeps`` that does not resolve the contact (named, with the number needed).
    """
    mode = f" (fastest contact mode {rate:.4g} rad/s)" if rate is not None else ""
    if rate is not None and not math.isfinite(rate):
        raise ParameterError(f"the environment's stiffness {stiffness:.4g} N/m gives a non-finite contact mode ({rate}); "
                             "it cannot be simulated")
    if explicit and rate is not None and rate * sample_time / nsub > RK4_STABILITY:
        need = int(math.ceil(rate * sample_time / RK4_STABILITY))
        auto = int(math.ceil(rate * sample_time / 0.05))
        accurate = (f"the automatic choice, substeps omitted, is {auto:,}" if auto <= MAX_SUBSTEPS else
                    f"an accurate step, ω·h <= 0.05, would take {auto:,}, more than {MAX_SUBSTEPS:,}: the contact is too "
                    "stiff for this sample time")
        fix = (f"substeps must be at least {need:,} ({accurate})"
               if need <= MAX_SUBSTEPS else
               f"it needs at least {need:,} substeps, more than {MAX_SUBSTEPS:,}: lower the stiffness, shorten the "
               "sample time, or model the contact as rigid (RigidEnvironment)")
        raise ParameterError(
            f"substeps = {nsub} does not resolve the contact: an environment stiffness of {stiffness:.4g} N/m gives a "
            f"contact mode of {rate:.4g} rad/s, and with the RK4 step h = sample_time / substeps = {sample_time / nsub:.4g} s "
            f"ω·h = {rate * sample_time / nsub:.3g} is beyond RK4's stability bound {RK4_STABILITY} (the contact would be "
            f"thrown off within a step, or blow up); {fix}"
        )
    if nsub > MAX_SUBSTEPS:
        raise ParameterError(
            f"an environment stiffness of {stiffness:.4g} N/m at sample_time {sample_time:.4g} s needs {nsub:,} RK4 "
            f"substeps per sample{mode}, more than {MAX_SUBSTEPS:,}: the contact is too stiff to integrate at this "
            "rate. Lower the stiffness, shorten the sample time, or model the contact as rigid (RigidEnvironment)"
        )
    budget = MAX_STEPS["compiled" if engine == "compiled" else "python"]
    if nsub * samples > budget:
        raise ParameterError(
            f"the run needs {nsub * samples:,} RK4 steps ({samples:,} samples × {nsub} substeps), more than the "
            f"{budget:,} the {engine} loop takes in reasonable time; shorten the duration, lengthen the sample "
            "time or lower the environment stiffness"
        )
