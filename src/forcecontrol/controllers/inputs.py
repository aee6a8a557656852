"""What ``Controller.step`` checks before it runs: argument types, signal shapes and finiteness, time.

Split from :mod:`.base` (which wraps every ``step`` and ``reset`` with these checks); the names
stay importable from there.
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import DimensionError, MeasurementError, ParameterError
from .signals import REFERENCE_FIELDS, Measurement, Reference

if TYPE_CHECKING:
    from .base import Controller


def _shape(v: Any) -> tuple[int, ...]:
    return v.shape if type(v) is np.ndarray else np.shape(v)


def _flat_sum(v: Any) -> float:
    """Sum of a vector's entries as a Python float (inf/NaN propagate); cheap for small vectors."""
    return sum(v.tolist()) if type(v) is np.ndarray else sum(np.asarray(v, dtype=np.float64).ravel().tolist())


def _frozen(ref: Reference) -> bool:
    """True when every array of the reference is read-only (so a checked reference stays valid)."""
    return all(type(a) is np.ndarray and not a.flags.writeable for a in (getattr(ref, f) for f in REFERENCE_FIELDS))


def _io_shapes(ctl: Controller) -> tuple[tuple[int], tuple[int]]:
    """The shapes of q (and q̇) and of the wrench and references: ((n,), (m,)), kept on the controller."""
    shapes = ctl.__dict__.get("_io_shapes")
    if shapes is None:
        shapes = ctl.__dict__["_io_shapes"] = ((int(ctl.robot.nq),), (int(ctl.robot.task_dim),))
    return shapes


def _check_inputs(ctl: Controller, t: float, measurement: Measurement | None, reference: Reference | None) -> None:
    """Shapes and finiteness of a controller's inputs, before any state is touched.

    A reference whose arrays are all read-only (such as ``Setpoint.at``'s) is checked once and
    then recognised by identity, so a constant reference costs nothing per sample. A NaN in a
    reference makes the torque non-finite; the step wrapper then restores the controller's state
    and names the field (:func:`_check_reference_finite`), so it costs nothing when all is well.

    Raises:
        DimensionError: a signal has the wrong shape (the compiled laws do no bounds checks).
        MeasurementError: a measured signal is NaN or infinite (named, with the time).
    """
    ns, ms = _io_shapes(ctl)
    if measurement is not None:
        q, qd, w = measurement.q, measurement.qd, measurement.wrench
        if type(w) is not np.ndarray and hasattr(w, "frame") and hasattr(w, "vector"):
            w = w.vector  # a frame-tagged Wrench: its frame is the law's to check
        signals = (("q", q, ns), ("qd", qd, ns), ("wrench", w, ms))
        if _shape(q) != ns or _shape(qd) != ns or _shape(w) != ms:
            for name, v, shape in signals:
                if _shape(v) != shape:
                    raise DimensionError(f"measurement.{name} must have shape {shape}; got shape {_shape(v)}")
        try:
            ok = math.isfinite(_flat_sum(q) + _flat_sum(qd) + _flat_sum(w))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            for name, v, _ in signals:
                a = np.asarray(v)
                if not (a.dtype.kind in "fiu" and np.all(np.isfinite(a))):
                    raise MeasurementError(f"measurement.{name} is not finite at t = {t:.6g} s: {a.tolist()}")
    if reference is not None and reference is not ctl.__dict__.get("_checked_reference"):
        for name in REFERENCE_FIELDS:
            v = getattr(reference, name)
            if _shape(v) != ms:
                raise DimensionError(f"reference.{name} must have shape {ms}; got shape {_shape(v)}")
        if _frozen(reference):
            ctl.__dict__["_checked_reference"] = reference


def _check_reference_finite(t: float, reference: Reference) -> None:
    """Name the reference field that is NaN or infinite (called when a step has failed)."""
    for name in REFERENCE_FIELDS:
        a = np.asarray(getattr(reference, name))
        if not np.all(np.isfinite(a)):
            raise ParameterError(f"reference.{name} is not finite at t = {t:.6g} s: {a.tolist()}")


def _check_step_arguments(t: Any, measurement: Any, reference: Any) -> None:
    """The types of ``step``'s arguments (a wrong type would end in a raw AttributeError deep inside)."""
    if type(t) is not float and (isinstance(t, (bool, np.bool_)) or not isinstance(t, (int, float, np.integer, np.floating))):
        raise ParameterError(f"t must be a number (the sample time instant [s]); got {t!r}")
    if not math.isfinite(t):
        raise ParameterError(f"t must be finite; got {t!r}")
    if not isinstance(measurement, Measurement):
        raise ParameterError(
            "measurement must be a forcecontrol Measurement(q, qd, wrench); got " + type(measurement).__name__
        )
    if not isinstance(reference, Reference):
        raise ParameterError(
            "reference must be a forcecontrol Reference (e.g. Reference.setpoint(x_d) or a ReferenceSignal's "
            f".at(t)); got {type(reference).__name__}"
        )


#: the rules ``Controller.step`` applies to its time t (see its docstring): any finite t, t that
#: does not go back, t that advances.
ANY_TIME, NON_DECREASING, INCREASING = 0, 1, 2
#: a step more than this many sample times after the previous one warns (once until reset()).
JUMP_SAMPLES = 1.5


def _time_rule(ctl: Controller) -> int:
    """The time rule of ``ctl`` (kept on it until ``reset()``): INCREASING with integrator state of
    its own (a non-empty ``state``) or in a controller it wraps, NON_DECREASING for a wrapper of
    stateless controllers (a safety layer, a supervisor, encoder feedback: per-sample memory of its
    own), ANY_TIME for a stateless controller."""
    d = ctl.__dict__
    rule = d.get("_time_rule")
    if rule is None:
        rule = INCREASING if ctl.state.size else ANY_TIME
        for v in list(d.values()):
            if v is not ctl and getattr(getattr(type(v), "step", None), "_validates_inputs", False):  # a Controller
                rule = max(rule, NON_DECREASING, _time_rule(v))
        d["_time_rule"] = rule
        d["_t_gap"] = JUMP_SAMPLES * ctl.sample_time if ctl.state.size else math.inf
    return rule


def _unusual_time(ctl: Controller, t: float, prev: float) -> None:
    """A step whose t does not advance past the previous step's (refused) or jumps ahead (warned once)."""
    name, t = type(ctl).__name__, float(t)  # (a NumPy float prints as a number)
    if t != t or t in (math.inf, -math.inf):
        raise ParameterError(f"t must be finite; got {t!r}")
    if t < prev or (t == prev and _time_rule(ctl) == INCREASING):
        what = "goes back before" if t < prev else "repeats"
        why = (
            "integrator state advances once per call (a repeated t would integrate twice for one sample)"
            if _time_rule(ctl) == INCREASING else "state of its own advances once per call"
        )
        raise ParameterError(
            f"{name}.step: t = {t!r} s {what} the previous step's t = {prev!r} s; a controller whose {why}, so t "
            "must increase from step to step: pass the next sample's time, or call reset() to start again"
        )
    if t > prev + ctl.__dict__["_t_gap"]:
        ctl.__dict__["_t_gap"] = math.inf  # once until reset()
        warnings.warn(
            f"{name}.step: t jumped from {prev!r} s to {t!r} s, {(t - prev) / ctl.sample_time:.6g} sample times; the "
            f"integrators advance by sample_time = {ctl.sample_time!r} s per call whatever t is: call step once per "
            "sample (this warning is shown once until reset())",
            UserWarning,
            stacklevel=3,
        )


def _forget_time(ctl: Controller) -> None:
    """A reset starts the time again (and the time rule is found again from the state)."""
    d = ctl.__dict__
    for key in ("_t_prev", "_time_rule", "_t_gap"):
        d.pop(key, None)
