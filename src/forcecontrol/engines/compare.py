"""The built-in simulator against another engine: contact-force metrics side by side, and why they differ.

Needs no engine itself: it compares two finished runs (:class:`~forcecontrol.sim.result.SimulationResult`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.axes import axis_names
from ..errors import ParameterError
from ..sim.result import SimulationResult
from ..spatial.closed_form import EULER_SINGULARITY_TOL

__all__ = ["compare_engines", "compare_signals", "relative_rotation_angle", "differences", "DIFFERENCES", "SIGNAL_UNITS"]

#: the signals :func:`compare_signals` compares, and the unit of their differences
SIGNAL_UNITS = {"position": "m", "orientation": "rad", "contact_force": "N", "contact_torque": "N m",
                "measured_force": "N", "measured_torque": "N m", "joint_positions": "rad"}

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


def differences(run: SimulationResult) -> list[str]:
    """The reasons of :data:`DIFFERENCES` that apply to this run: the chapter arm's rotor coupling only for the
    chapter's arm, the payload sensor's reading only with a payload sensor."""
    robot = str(run.metadata.get("robot", ""))
    payload = (run.metadata.get("sensor") or {}).get("kind") == "payload"
    return [d for d in DIFFERENCES
            if not (d.startswith("chapter arm:") and robot != "PlanarTwoLink") and not (d.startswith("payload:") and not payload)]


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


def _stats(d: np.ndarray, names: list[str], unit: str) -> dict[str, Any]:
    """Max and RMS over the samples of a difference d (N, k): per component and of its Euclidean norm."""
    norm = np.sqrt(np.sum(d * d, axis=1))
    return {
        "compared": True, "unit": unit, "axes": names,
        "max": np.max(np.abs(d), axis=0).tolist(), "rms": np.sqrt(np.mean(d * d, axis=0)).tolist(),
        "norm_max": float(np.max(norm)), "norm_rms": float(np.sqrt(np.mean(norm * norm))),
    }


def _angle_stats(theta: np.ndarray) -> dict[str, Any]:
    """Max and RMS over the samples of a rotation angle θ (N,) >= 0 [rad]."""
    return {"compared": True, "unit": "rad", "max": float(np.max(theta)), "rms": float(np.sqrt(np.mean(theta * theta)))}


def _absent(why: str) -> dict[str, Any]:
    return {"compared": False, "why": why}


def _rotations(phi: np.ndarray) -> np.ndarray:
    """``R = R_x(φ₁) R_y(φ₂) R_z(φ₃)`` of each row of XYZ angles φ (N, 3) -> (N, 3, 3) (the logs' convention,
    :func:`forcecontrol.spatial.closed_form.euler_xyz_to_rotation`, over all samples at once)."""
    c1, s1, c2, s2, c3, s3 = (f(phi[:, i]) for i in range(3) for f in (np.cos, np.sin))
    return np.stack([
        np.stack([c2 * c3, -c2 * s3, s2], axis=-1),
        np.stack([c1 * s3 + s1 * s2 * c3, c1 * c3 - s1 * s2 * s3, -s1 * c2], axis=-1),
        np.stack([s1 * s3 - c1 * s2 * c3, s1 * c3 + c1 * s2 * s3, c1 * c2], axis=-1),
    ], axis=1)


def relative_rotation_angle(Ra: np.ndarray, Rb: np.ndarray) -> np.ndarray:
    """The angle θ ∈ [0, π] of ``R_aᵀ R_b`` for each pair of rotations (N, 3, 3) [rad].

    ``θ = atan2(|vee(M − Mᵀ)| / 2, (tr M − 1) / 2)`` with ``M = R_aᵀ R_b`` (accurate at small angles, where
    ``acos`` of the trace loses half the digits). ``M`` is formed product by product so that ``M = Mᵀ`` exactly
    when ``R_a = R_b``: a run against itself gives 0, not 1e-8.
    """
    M = np.zeros_like(Ra)
    for i in range(3):
        for j in range(3):
            M[:, i, j] = Ra[:, 0, i] * Rb[:, 0, j] + Ra[:, 1, i] * Rb[:, 1, j] + Ra[:, 2, i] * Rb[:, 2, j]
    w = np.stack([M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0], M[:, 1, 0] - M[:, 0, 1]], axis=-1)
    return np.arctan2(0.5 * np.sqrt(np.sum(w * w, axis=1)), 0.5 * (M[:, 0, 0] + M[:, 1, 1] + M[:, 2, 2] - 1.0))


def _orientation(a: SimulationResult, b: SimulationResult) -> dict[str, Any]:
    """The orientation difference of the controlled frame: 6-D logs from their XYZ angles; the chapter's planar
    arm from φ = q₁ + q₂ (its joints turn about parallel axes); else absent (the log has no orientation).

    Near the XYZ angles' singularity (``|cos φ₂| < EULER_SINGULARITY_TOL``) a log's angles fix the frame only to
    about ``2 |cos φ₂|`` rad (φ₃ is set to 0 there): the entry then carries a ``caveat`` saying so.
    """
    m = a.m
    if m == 6:
        out = _angle_stats(relative_rotation_angle(_rotations(a.x[:, 3:6]), _rotations(b.x[:, 3:6])))
        c2 = float(min(np.min(np.abs(np.cos(a.x[:, 4]))), np.min(np.abs(np.cos(b.x[:, 4])))))
        if c2 < EULER_SINGULARITY_TOL:
            out["caveat"] = (f"the frame comes within |cos φ2| = {c2:.1e} of the XYZ angles' singularity: the logged angles "
                             f"fix its orientation only to about {2.0 * c2:.1e} rad there")
        return out
    if a.metadata.get("robot") == "PlanarTwoLink" and a.q.shape[1] == 2 == b.q.shape[1]:
        d = np.sum(b.q, axis=1) - np.sum(a.q, axis=1)
        out = _angle_stats(np.abs((d + np.pi) % (2.0 * np.pi) - np.pi))
        out["from"] = "the planar arm's frame angle q1 + q2"
        return out
    names = " ".join(axis_names(m)[0])
    return _absent(f"the log holds the position only ({m}-D task space: {names}) and the arm is not the chapter's "
                   "planar arm: orientation [rad] not compared")


def _wrench_part(a: np.ndarray, b: np.ndarray, names: list[str], unit: str, what: str, why_zero: str) -> dict[str, Any]:
    if not (np.any(a) or np.any(b)):  # identically zero in both runs: nothing to compare
        return _absent(f"{why_zero}: {what} [{unit}] not compared")
    return _stats(b - a, names, unit)


def compare_signals(builtin: SimulationResult, mujoco: SimulationResult) -> dict[str, Any]:
    """The differences ``mujoco − builtin`` of the controlled frame's pose, the contact and measured wrench and
    the joint positions, over the samples of the two runs (same times).

    Each signal is ``{"compared": True, "unit", "axes", "max", "rms", "norm_max", "norm_rms"}`` (per component,
    then of the Euclidean norm; the orientation: ``max``/``rms`` of the angle of ``R_aᵀ R_b``) or, when absent
    from the runs, ``{"compared": False, "why": "..."}``: no contact in either run, no moment in a planar or
    position-only log, a sensor that read zero in both.

    Raises:
        ParameterError: the runs do not share their sample times or task-space dimension.
    """
    a, b = builtin, mujoco
    if a.t.shape != b.t.shape or not np.allclose(a.t, b.t, rtol=0.0, atol=1e-9):
        raise ParameterError(f"builtin, mujoco: the two runs must share their sample times; got {a.t.shape[0]} samples "
                             f"to t = {float(a.t[-1]):g} s and {b.t.shape[0]} to t = {float(b.t[-1]):g} s")
    if a.m != b.m:
        raise ParameterError(f"builtin, mujoco: the two runs must have the same task-space dimension; got {a.m} and {b.m}")
    m = a.m
    pose, _, wrench = axis_names(m)
    k = 3 if m == 6 else m
    out: dict[str, Any] = {"position": _stats(b.x[:, :k] - a.x[:, :k], pose[:k], "m"), "orientation": _orientation(a, b)}
    for key, A, B, who, moment in (
        ("contact", a.wrench, b.wrench, "no contact in either run", "no contact moment in either run"),
        ("measured", a.wrench_measured, b.wrench_measured, "the sensor read no force in either run",
         "the sensor read no moment in either run"),
    ):
        out[f"{key}_force"] = _wrench_part(A[:, :k], B[:, :k], wrench[:k], "N", f"{key} force", who)
        if m == 6:
            out[f"{key}_torque"] = _wrench_part(A[:, 3:], B[:, 3:], wrench[3:], "N m", f"{key} torque", moment)
        else:
            out[f"{key}_torque"] = _absent(f"{m}-D task space ({' '.join(pose)}): the log has no moment: "
                                           "contact and measured torque [N m] not compared")
    if a.q.shape == b.q.shape:
        out["joint_positions"] = _stats(b.q - a.q, [f"q{i + 1}" for i in range(a.q.shape[1])], "rad")
    else:
        out["joint_positions"] = _absent(f"the engines log {a.q.shape[1]} and {b.q.shape[1]} joints: joint positions [rad] "
                                         "not compared")
    return out


def compare_engines(builtin: SimulationResult, mujoco: SimulationResult, axis: int | None = None) -> dict[str, Any]:
    """Side-by-side contact-force metrics of the same scenario on both engines, the differences of the pose, the
    wrench and the joints (``signals``, see :func:`compare_signals`), and the reasons they differ.

    Without contact in either run the two force-difference percentages are None (nothing to compare) and
    ``absent`` names that, as every other signal that is not compared: ``{signal: why}``.

    Args:
        builtin, mujoco: the two runs (same times).
        axis: the force component to compare; default the one with the largest steady magnitude.
    """
    signals = compare_signals(builtin, mujoco)
    absent = {name: s["why"] for name, s in signals.items() if not s["compared"]}
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
        "steady_force_difference_percent": None if "contact_force" in absent else 100.0 * diff,
        "max_force_difference_over_peak_percent": None if "contact_force" in absent else 100.0 * shape,
        "signals": signals,
        "absent": absent,
        "why_they_differ": differences(builtin),
        "mujoco_parameters": mujoco.metadata.get("mujoco", {}),
    }
