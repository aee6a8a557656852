"""Force/torque sensor calibration as a workflow: plan the poses, identify, compensate, tare, watch for drift.

The model is :class:`~forcecontrol.sensors.ToolGravity`'s: a static reading in free space at
sensor orientation R_S (sensor frame S in the base frame), with ``u = R_Sᵀ g`` gravity in S,

    f_S = −u m + b_f
    τ_S = [u]× p + b_τ                 (3-D)        τ_S = u_x p_y − u_y p_x + b_τ      (planar)

with m the tool's mass, ``p = m c`` its first moment (c the centre of mass in S) and b_f, b_τ the
sensor's biases. Both equations are linear in their unknowns, so :func:`calibrate` solves two
ordinary least-squares problems (forces in (m, b_f), moments in (p, b_τ)) and reports each
parameter's standard uncertainty from the residual covariance ``σ² (AᵀA)⁻¹``, σ² estimated per
problem as ``RSS / (rows − unknowns)``; c = p / m and its uncertainty by first-order propagation.
:func:`~forcecontrol.sensors.identify_tool_gravity` gives the same estimates (same regressors,
tested), without the uncertainty and the checks.

How similar the poses are is read from the *normalised* regressor: the same matrices built
with the unit gravity direction ``û = R_Sᵀ g/|g|``, one block per problem. Its condition number
(largest over smallest singular value) is 1 for ideal force poses (Σ û_i = 0) and grows without
bound as the orientations approach each other; it does not depend on units nor on the number of
poses. :func:`plan_calibration_poses` picks joint configurations that keep it small.

On the arm: :meth:`CalibrationResult.compensate` turns a raw reading into the contact wrench in
any orientation, :func:`tare` re-estimates the biases from readings at one known pose (the
payload kept), and :class:`DriftDetector` compares free-space readings with the model online
and flags a bias change larger than the noise allows.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ._validate import nonnegative_scalar, positive_scalar
from .errors import DimensionError, MeasurementError, ParameterError
from .sensors import ToolGravity, _force_regressor, _gravity_vector, _torque_regressor, planar_sensor_rotation

__all__ = [
    "CalibrationPlan",
    "CalibrationResult",
    "DriftCheck",
    "DriftDetector",
    "calibrate",
    "plan_calibration_poses",
    "regressor_condition",
    "sensor_orientation",
    "tare",
    "calibration_data_from_columns",
    "read_calibration_data",
]

#: default largest condition number of the normalised gravity regressor :func:`calibrate` accepts.
MAX_CONDITION = 100.0


# ----------------------------------------------------------------------------- checks and regressors


def _rotations(value: Any) -> np.ndarray:
    R = np.asarray(value, dtype=np.float64)
    if R.ndim != 3 or R.shape[1] != R.shape[2] or R.shape[1] not in (2, 3):
        raise DimensionError(f"rotations must have shape (k, 2, 2) or (k, 3, 3); got shape {R.shape}")
    if not np.all(np.isfinite(R)):
        i = int(np.argwhere(~np.isfinite(R))[0, 0])
        raise MeasurementError(f"rotations must be finite; rotation {i} holds NaN or inf")
    d = R.shape[1]
    err = np.abs(np.einsum("kij,kil->kjl", R, R) - np.eye(d)).max(axis=(1, 2))
    det = np.linalg.det(R)
    bad = np.flatnonzero((err > 1e-6) | (det < 0.0))
    if bad.size:
        i = int(bad[0])
        raise ParameterError(
            f"rotations must be proper rotation matrices (RᵀR = I, det R = +1); rotation {i} has "
            f"|RᵀR − I| = {err[i]:.3g} and det R = {det[i]:.6g}"
        )
    return R


def _readings(name: str, value: Any, k: int, n: int) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    shapes = f"({k},) or ({k}, 1)" if n == 1 else f"({k}, {n})"
    if a.size != k * n or a.ndim not in (1, 2) or (a.ndim == 2 and a.shape != (k, n)) or (a.ndim == 1 and n != 1):
        raise DimensionError(f"{name} must have shape {shapes} (one reading per rotation); got shape {a.shape}")
    a = a.reshape(k, n)
    if not np.all(np.isfinite(a)):
        i = int(np.argwhere(~np.isfinite(a))[0, 0])
        raise MeasurementError(f"{name} must be finite; reading {i} is {a[i].tolist()}")
    return a


def _gravity_in_sensor(R: np.ndarray, gravity: float) -> np.ndarray:
    """u_i = R_iᵀ g, (k, d)."""
    return np.einsum("kji,j->ki", R, _gravity_vector(R.shape[1], gravity))


def _normalised_blocks(R: np.ndarray, torques: bool) -> list[np.ndarray]:
    uhat = _gravity_in_sensor(R, 1.0)
    blocks = [_force_regressor(uhat)]
    if torques:
        blocks.append(_torque_regressor(uhat))
    return blocks


def _condition(blocks: list[np.ndarray]) -> tuple[float, float]:
    """(condition number, smallest singular value) of the block-diagonal stack of ``blocks``."""
    s = np.concatenate([np.linalg.svd(b, compute_uv=False) for b in blocks])
    smin, smax = float(s.min()), float(s.max())
    if smin <= 1e-12 * smax:
        return math.inf, smin
    return smax / smin, smin


def regressor_condition(rotations: Any, *, torques: bool = True) -> float:
    """Condition number of the normalised gravity regressor of a set of sensor orientations.

    The force block has rows ``[−û_i, I]``, the moment block ``[[û_i]×, I]`` (3-D) or
    ``[−û_y, û_x, 1]`` (planar), ``û_i = R_iᵀ g/|g|``; the number is σ_max/σ_min over the singular
    values of both blocks (inf when rank deficient). 1 is ideal for forces; identical
    orientations give inf.

    Args:
        rotations: sensor orientations R_i in the base frame, (k, d, d) with d = 2 or 3.
        torques: include the moment block (the centre of mass is identified).

    Returns:
        The condition number (>= 1, inf when the poses do not identify the unknowns).

    Raises:
        DimensionError: wrong shape. ParameterError: a matrix is not a rotation.
    """
    return _condition(_normalised_blocks(_rotations(rotations), torques))[0]


# ----------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """Identified tool payload and sensor biases with their standard uncertainties.

    Frames and units: every vector is in the sensor frame S; mass [kg], com [m], force_bias [N],
    torque_bias [N m] ((1,) planar, (3,) in 3-D). ``*_std`` are standard uncertainties (one σ) of
    the estimates. Fields about the moments are None when no moments were given.

    Attributes:
        dim: 2 (planar) or 3.
        gravity: |g| [m/s²] (along −y planar, −z in 3-D).
        mass, mass_std: m and σ_m [kg].
        com, com_std: c and σ_c (d,) [m]; NaN when m is not significantly above 0.
        first_moment: p = m c (d,) [kg m], the quantity the moments identify.
        force_bias, force_bias_std: b_f and its σ (d,) [N].
        torque_bias, torque_bias_std: b_τ and its σ [N m].
        force_noise_std, torque_noise_std: σ of the residuals per component (the noise the fit saw).
        force_residual_rms, torque_residual_rms: RMS of the residuals.
        force_covariance: covariance of (m, b_f), (1 + d, 1 + d).
        torque_covariance: covariance of (p, b_τ), (d + nt, d + nt).
        condition_number: of the normalised gravity regressor (see :func:`regressor_condition`).
        n_readings: number of readings used.
    """

    dim: int
    gravity: float
    mass: float
    mass_std: float
    force_bias: np.ndarray
    force_bias_std: np.ndarray
    force_noise_std: float
    force_residual_rms: float
    force_covariance: np.ndarray
    condition_number: float
    n_readings: int
    com: np.ndarray | None = None
    com_std: np.ndarray | None = None
    first_moment: np.ndarray | None = None
    torque_bias: np.ndarray | None = None
    torque_bias_std: np.ndarray | None = None
    torque_noise_std: float | None = None
    torque_residual_rms: float | None = None
    torque_covariance: np.ndarray | None = None
    notes: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        for name in ("force_bias", "force_bias_std", "force_covariance", "com", "com_std", "first_moment", "torque_bias",
                     "torque_bias_std", "torque_covariance"):
            v = getattr(self, name)
            if v is not None:
                a = np.array(v, dtype=np.float64)
                a.flags.writeable = False
                object.__setattr__(self, name, a)

    @property
    def tool(self) -> ToolGravity:
        """The identified :class:`~forcecontrol.sensors.ToolGravity` (for RealisticForceSensor's tool_estimate)."""
        com = None
        if self.first_moment is not None:
            com = self.first_moment / self.mass if self.mass > 0.0 else np.zeros(self.dim)
        return ToolGravity(max(self.mass, 0.0), com, self.force_bias, self.torque_bias, dim=self.dim, gravity=self.gravity)

    @property
    def has_torques(self) -> bool:
        """True when the moments were identified (centre of mass and moment bias)."""
        return self.torque_bias is not None

    def _u(self, R: Any) -> tuple[np.ndarray, bool]:
        Rs = np.asarray(R, dtype=np.float64)
        single = Rs.ndim == 2
        Rs = Rs[None] if single else Rs
        if Rs.ndim != 3 or Rs.shape[1:] != (self.dim, self.dim):
            d = self.dim
            raise DimensionError(f"R must have shape ({d}, {d}) or (k, {d}, {d}); got shape {np.shape(R)}")
        return _gravity_in_sensor(Rs, self.gravity), single

    def predict(self, R: Any) -> tuple[np.ndarray, np.ndarray | None]:
        """The free-space reading the model expects at orientation(s) R: (force, moment or None).

        Args:
            R: (d, d) or (k, d, d) sensor orientation(s).

        Returns:
            force (d,) or (k, d) [N]; moment (nt,) or (k, nt) [N m], None without moments.

        Raises:
            DimensionError: R has the wrong shape.
        """
        u, single = self._u(R)
        theta_f = np.concatenate([[self.mass], self.force_bias])
        f = (_force_regressor(u) @ theta_f).reshape(len(u), self.dim)
        tau = None
        if self.has_torques:
            nt = 1 if self.dim == 2 else 3
            theta_t = np.concatenate([self.first_moment, self.torque_bias])
            tau = (_torque_regressor(u) @ theta_t).reshape(len(u), nt)
            tau = tau[0] if single else tau
        return (f[0] if single else f), tau

    def prediction_std(self, R: Any) -> tuple[np.ndarray, np.ndarray | None]:
        """Standard uncertainty of :meth:`predict` from the parameters' covariance, same shapes."""
        u, single = self._u(R)
        Af = _force_regressor(u)
        vf = np.einsum("ij,jk,ik->i", Af, self.force_covariance, Af).reshape(len(u), self.dim)
        st = None
        if self.has_torques:
            At = _torque_regressor(u)
            vt = np.einsum("ij,jk,ik->i", At, self.torque_covariance, At).reshape(len(u), -1)
            st = np.sqrt(np.maximum(vt, 0.0))
            st = st[0] if single else st
        sf = np.sqrt(np.maximum(vf, 0.0))
        return (sf[0] if single else sf), st

    def compensate(
        self, R: Any, force: Any, torque: Any = None, *, frame: str = "sensor"
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Gravity and bias compensation in any orientation: see :meth:`ToolGravity.compensate`."""
        return self.tool.compensate(R, force, torque, frame=frame)

    def tare(self, R: Any, forces: Any, torques: Any = None) -> CalibrationResult:
        """Re-estimate the biases at one known pose, keeping the payload: see :func:`tare`."""
        return tare(self, R, forces, torques)

    def parameters(self) -> list[dict[str, Any]]:
        """One row per scalar parameter: name, value, std, unit (the table the CLI prints)."""
        axes = "xyz"
        rows = [{"name": "mass", "value": self.mass, "std": self.mass_std, "unit": "kg"}]
        if self.com is not None and self.com_std is not None:
            rows += [{"name": f"com_{axes[i]}", "value": float(self.com[i]), "std": float(self.com_std[i]), "unit": "m"}
                     for i in range(self.dim)]
        rows += [{"name": f"force_bias_{axes[i]}", "value": float(self.force_bias[i]), "std": float(self.force_bias_std[i]),
                  "unit": "N"} for i in range(self.dim)]
        if self.torque_bias is not None and self.torque_bias_std is not None:
            names = ["z"] if self.dim == 2 else list(axes)
            rows += [{"name": f"torque_bias_{names[i]}", "value": float(self.torque_bias[i]),
                      "std": float(self.torque_bias_std[i]), "unit": "N m"} for i in range(len(names))]
        return rows

    def as_dict(self) -> dict[str, Any]:
        """Plain data (lists and floats; NaN where a value is undefined) for JSON."""
        def lst(a):
            return None if a is None else np.asarray(a).tolist()

        return {
            "dim": self.dim, "gravity": self.gravity, "n_readings": self.n_readings,
            "condition_number": self.condition_number,
            "mass": self.mass, "mass_std": self.mass_std,
            "com": lst(self.com), "com_std": lst(self.com_std),
            "force_bias": lst(self.force_bias), "force_bias_std": lst(self.force_bias_std),
            "torque_bias": lst(self.torque_bias), "torque_bias_std": lst(self.torque_bias_std),
            "force_noise_std": self.force_noise_std, "torque_noise_std": self.torque_noise_std,
            "force_residual_rms": self.force_residual_rms, "torque_residual_rms": self.torque_residual_rms,
            "parameters": self.parameters(), "notes": list(self.notes),
        }


def _fit(A: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """OLS: θ, cov = σ² (AᵀA)⁻¹ with σ² = RSS / (rows − cols), σ, residual RMS."""
    theta, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ theta
    dof = A.shape[0] - A.shape[1]
    s2 = float(r @ r) / dof
    cov = s2 * np.linalg.inv(A.T @ A)
    return theta, cov, math.sqrt(s2), float(np.sqrt(np.mean(r * r)))


def calibrate(
    rotations: Any,
    forces: Any,
    torques: Any = None,
    *,
    gravity: float = 9.81,
    max_condition: float = MAX_CONDITION,
) -> CalibrationResult:
    """Identify a tool's mass, centre of mass and the sensor's biases, with their uncertainty.

    Static free-space readings at k orientations; the model and the least-squares problems are
    in the module's docstring (the convention is :class:`~forcecontrol.sensors.ToolGravity`'s:
    the sensor holds the tool up). Several readings at the same orientation are fine (they count
    as rows). Standard uncertainties come from ``σ² (AᵀA)⁻¹``, which assumes white noise of equal
    variance on the force components (and on the moment components) and a correct model.

    Args:
        rotations: sensor orientations R_i in the base frame, (k, d, d), d = 2 (planar) or 3.
        forces: force readings in the sensor frame, (k, d) [N].
        torques: moment readings, (k,) planar or (k, 3) [N m]; None = forces only (no centre of mass).
        gravity: |g| [m/s²].
        max_condition: largest condition number of the normalised regressor accepted.

    Returns:
        A :class:`CalibrationResult`.

    Raises:
        DimensionError: shapes do not match. MeasurementError: a reading or rotation is NaN/inf.
        ParameterError: not a rotation matrix; too few readings to estimate the noise; the poses
            do not identify the unknowns (rank deficient); the poses are too similar (condition
            number above ``max_condition``); the identified mass is significantly negative.
    """
    g = positive_scalar("gravity", gravity)
    max_condition = positive_scalar("max_condition", max_condition)
    R = _rotations(rotations)
    k, d = R.shape[0], R.shape[1]
    nt = 1 if d == 2 else 3
    F = _readings("forces", forces, k, d)
    T = None if torques is None else _readings("torques", torques, k, nt)
    # too few: every problem needs more rows than unknowns to estimate its noise
    need = [(1 + d) // d + 1]
    if T is not None:
        need.append((d + nt) // nt + 1)
    if k < max(need):
        what = "forces and moments" if T is not None else "forces"
        raise ParameterError(
            f"too few readings to calibrate: got {k}, need at least {max(need)} for the {what} of a "
            f"{'planar' if d == 2 else '3-D'} sensor (more rows than unknowns, to estimate the noise)"
        )
    blocks = _normalised_blocks(R, T is not None)
    for name, b in zip(("the tool mass and force bias", "the centre of mass and moment bias"), blocks):
        rank = int(np.linalg.matrix_rank(b, tol=1e-9 * max(1.0, float(np.abs(b).max()))))
        if rank < b.shape[1]:
            raise ParameterError(
                f"the {k} poses do not identify {name} (regressor rank {rank} < {b.shape[1]} unknowns): give sensor "
                f"orientations with {'at least three non-collinear' if name.startswith('the centre') and d == 3 else 'different'}"
                " directions of gravity in the sensor frame (see plan_calibration_poses)"
            )
    cond, _ = _condition(blocks)
    if cond > max_condition:
        raise ParameterError(
            f"the calibration poses are too similar: the condition number of the normalised gravity regressor is "
            f"{cond:.4g}, above max_condition={max_condition:.4g}; spread the sensor orientations (plan_calibration_poses) "
            "or raise max_condition knowingly"
        )
    u = _gravity_in_sensor(R, g)
    theta_f, cov_f, sf, rms_f = _fit(_force_regressor(u), F.reshape(-1))
    mass, b_f = float(theta_f[0]), theta_f[1:]
    std_f = np.sqrt(np.diag(cov_f))
    notes: list[str] = []
    if mass < -4.0 * std_f[0] - 1e-9:
        raise ParameterError(
            f"the identified tool mass is negative ({mass:.6g} ± {std_f[0]:.2g} kg): check the sign of gravity, the "
            "sense of the readings and the frames of the rotations"
        )
    out: dict[str, Any] = {}
    if T is not None:
        theta_t, cov_t, st, rms_t = _fit(_torque_regressor(u), T.reshape(-1))
        p, b_t = theta_t[:d], theta_t[d:]
        std_t = np.sqrt(np.diag(cov_t))
        if mass > 4.0 * std_f[0] and mass > 0.0:
            com = p / mass
            # c = p / m: J = [I/m, −p/m²]; p and m come from independent problems
            cov_c = cov_t[:d, :d] / mass**2 + np.outer(p, p) * cov_f[0, 0] / mass**4
            com_std = np.sqrt(np.diag(cov_c))
        else:
            com = np.full(d, np.nan)
            com_std = np.full(d, np.nan)
            notes.append(f"mass {mass:.3g} ± {std_f[0]:.2g} kg is not significantly above 0: centre of mass undefined")
        out = {"com": com, "com_std": com_std, "first_moment": p, "torque_bias": b_t, "torque_bias_std": std_t[d:],
               "torque_noise_std": st, "torque_residual_rms": rms_t, "torque_covariance": cov_t}
    return CalibrationResult(
        dim=d, gravity=g, mass=mass, mass_std=float(std_f[0]), force_bias=b_f, force_bias_std=std_f[1:],
        force_noise_std=sf, force_residual_rms=rms_f, force_covariance=cov_f, condition_number=cond,
        n_readings=k, notes=tuple(notes), **out,
    )


# ----------------------------------------------------------------------------- tare


def tare(result: CalibrationResult, R: Any, forces: Any, torques: Any = None) -> CalibrationResult:
    """Re-estimate the sensor biases from static free-space readings at one known pose.

    The payload (m, p) is kept; ``b_f = mean(f) + m u`` and ``b_τ = mean(τ) − [u]× p`` (3-D, the
    planar analogue) with u = R_Sᵀ g. The new biases' uncertainty combines the payload's
    (propagated through the regressor) with the noise of the mean: the readings' own spread
    when two or more are given, else the calibration's residual σ.

    Args:
        result: a calibration.
        R: the sensor orientation of the pose, (d, d).
        forces: one reading (d,) or several (n, d) at that pose [N].
        torques: moment reading(s) (nt,) or (n, nt) [N m]; required when the result has moments.

    Returns:
        A new :class:`CalibrationResult` with the biases (and their σ) replaced.

    Raises:
        DimensionError: shapes. MeasurementError: NaN/inf. ParameterError: moments missing.
    """
    d, nt = result.dim, (1 if result.dim == 2 else 3)
    Rm = np.asarray(R, dtype=np.float64)
    if Rm.shape != (d, d):
        raise DimensionError(f"R must have shape ({d}, {d}) like the calibration; got shape {Rm.shape}")
    _rotations(Rm[None])
    F = np.asarray(forces, dtype=np.float64)
    F = F.reshape(1, -1) if F.ndim == 1 else F
    if F.ndim != 2 or F.shape[1] != d:
        raise DimensionError(f"forces must have shape ({d},) or (n, {d}); got shape {np.shape(forces)}")
    F = _readings("forces", F, F.shape[0], d)
    n = F.shape[0]
    zero = replace(result, force_bias=np.zeros(d), torque_bias=None if result.torque_bias is None else np.zeros(nt))
    payload_f, payload_t = zero.predict(Rm)  # the payload's part of the reading
    pstd_f, pstd_t = _payload_std(result, Rm)
    noise_f = F.std(axis=0, ddof=1) / math.sqrt(n) if n >= 2 else np.full(d, result.force_noise_std)
    b_f = F.mean(axis=0) - payload_f
    changes: dict[str, Any] = {"force_bias": b_f, "force_bias_std": np.sqrt(pstd_f**2 + noise_f**2)}
    if result.has_torques:
        if torques is None:
            raise ParameterError("torques are required to tare a calibration that identified the moments; got None")
        if np.size(torques) != n * nt:
            raise DimensionError(
                f"torques must have {nt} entries per force reading ({n} readings); got shape {np.shape(torques)}"
            )
        T = _readings("torques", np.asarray(torques, dtype=np.float64).reshape(n, nt), n, nt)
        noise_t = T.std(axis=0, ddof=1) / math.sqrt(n) if n >= 2 else np.full(nt, result.torque_noise_std)
        changes["torque_bias"] = T.mean(axis=0) - payload_t
        changes["torque_bias_std"] = np.sqrt(pstd_t**2 + noise_t**2)
    return replace(result, **changes)


def _payload_std(result: CalibrationResult, R: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """σ of the payload's part of the reading at R (mass and first moment only)."""
    u, _ = result._u(R)
    Af = _force_regressor(u)[:, :1]
    sf = np.sqrt(np.maximum(Af[:, 0] ** 2 * result.force_covariance[0, 0], 0.0))
    st = None
    if result.has_torques:
        d = result.dim
        At = _torque_regressor(u)[:, :d]
        st = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", At, result.torque_covariance[:d, :d], At), 0.0))
    return sf, st


# ----------------------------------------------------------------------------- drift detection


@dataclass(frozen=True)
class DriftCheck:
    """One step of :class:`DriftDetector`.

    Attributes:
        drifted: True when a component of the moving-average residual exceeds its threshold.
        ready: False during warm-up (noise being measured, or the window not yet full).
        offset: moving-average residual (measured − model), forces then moments, (d + nt,) or (d,).
        threshold: the per-component threshold, same shape.
        ratio: max |offset| / threshold (>1 means drift).
        component: index of the worst component.
    """

    drifted: bool
    ready: bool
    offset: np.ndarray
    threshold: np.ndarray
    ratio: float
    component: int


class DriftDetector:
    """Online free-space check of the sensor against its calibration: flags a bias change.

    Each free-space reading gives a residual ``r = reading − model(R)`` (forces, then moments).
    Its moving average over ``window`` samples is compared per component with
    ``k_sigma · sqrt(σ_n²/window + σ_model²(R))``: σ_n the per-sample noise (given, or measured on
    the first ``window`` readings as their residuals' standard deviation, which an offset does not
    change), σ_model the uncertainty of the model's prediction at R (:meth:`CalibrationResult.prediction_std`).
    For white noise the false-alarm rate per component and sample is about 2 Φ(−k_sigma) (6e-5
    for k_sigma = 4, but successive averages are correlated, so alarms come in bursts). Filtered
    (coloured) noise averages down more slowly than 1/√window: pass a larger ``noise_std`` or
    ``k_sigma``. Call it only when the arm is in free space (no contact) and moving slowly (the
    model is static).

    Args:
        result: the calibration.
        window: moving-average length [samples], >= 2.
        k_sigma: threshold in standard deviations, > 0.
        noise_std: per-sample noise σ_n, scalar or per component (d + nt,) ((d,) without
            moments); None = measured during warm-up.
        floor: smallest threshold (avoids a zero threshold with noise-free data) [N or N m].

    Raises:
        ParameterError: bad window, k_sigma, floor; noise_std negative. DimensionError: noise_std shape.
    """

    def __init__(self, result: CalibrationResult, *, window: int = 200, k_sigma: float = 5.0,
                 noise_std: Any = None, floor: float = 1e-9) -> None:
        if not isinstance(result, CalibrationResult):
            raise ParameterError(f"result must be a CalibrationResult; got {type(result).__name__}")
        if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 2:
            raise ParameterError(f"window must be an integer >= 2 [samples]; got {window!r}")
        self.result = result
        self.window = int(window)
        self.k_sigma = positive_scalar("k_sigma", k_sigma)
        self.floor = positive_scalar("floor", floor)
        self.n = result.dim + ((1 if result.dim == 2 else 3) if result.has_torques else 0)
        self._given: np.ndarray | None = None
        if noise_std is not None:
            s = np.array(noise_std, dtype=np.float64)
            if s.ndim > 1 or (s.ndim == 1 and s.shape != (self.n,)):
                raise DimensionError(f"noise_std must be a scalar or have shape ({self.n},); got shape {s.shape}")
            if not np.all(np.isfinite(s)) or np.any(s < 0):
                raise ParameterError(f"noise_std must be finite and >= 0; got {s.tolist()}")
            self._given = np.broadcast_to(s, (self.n,)).copy()
        self.reset()

    def reset(self) -> None:
        """Forget the readings (and the measured noise, when it was measured: it is measured again)."""
        self._buf: deque[np.ndarray] = deque(maxlen=self.window)
        self._sum = np.zeros(self.n)
        self._warm: list[np.ndarray] = []
        self.noise_std: np.ndarray | None = None if self._given is None else self._given.copy()
        self.count = 0

    def residual(self, R: Any, force: Any, torque: Any = None) -> np.ndarray:
        """reading − model(R), forces then moments, (d + nt,) or (d,)."""
        f, t = self.result.compensate(R, force, torque if self.result.has_torques else None)
        if self.result.has_torques and t is None:
            raise ParameterError("torque is required: the calibration identified the moments; got None")
        r = np.concatenate([np.ravel(f), np.ravel(t)]) if t is not None else np.ravel(f)
        if r.shape != (self.n,):
            raise DimensionError(f"one reading expected (R (d, d), force (d,)); got a residual of shape {r.shape}")
        if not np.all(np.isfinite(r)):
            raise MeasurementError(f"the reading must be finite; got force {np.ravel(force).tolist()}")
        return r

    def update(self, R: Any, force: Any, torque: Any = None) -> DriftCheck:
        """Add one free-space reading at orientation R and check for drift.

        Args:
            R: sensor orientation (d, d).
            force: force reading in S (d,) [N].
            torque: moment reading in S (nt,) [N m]; required when the calibration has moments.

        Returns:
            A :class:`DriftCheck`.

        Raises:
            DimensionError, MeasurementError, ParameterError: as :meth:`residual`.
        """
        r = self.residual(R, force, torque)
        self.count += 1
        if self.noise_std is None:
            self._warm.append(r)
            if len(self._warm) >= self.window:
                self.noise_std = np.std(np.array(self._warm), axis=0, ddof=1)
                self._warm = []
        if len(self._buf) == self.window:
            self._sum -= self._buf[0]
        self._buf.append(r)
        self._sum += r
        offset = self._sum / len(self._buf)
        sf, st = self.result.prediction_std(R)
        model = np.concatenate([sf, st]) if st is not None else sf
        noise = self.noise_std if self.noise_std is not None else np.zeros(self.n)
        thr = np.maximum(self.k_sigma * np.sqrt(noise**2 / self.window + model**2), self.floor)
        ready = self.noise_std is not None and len(self._buf) == self.window
        ratios = np.abs(offset) / thr
        i = int(np.argmax(ratios))
        return DriftCheck(drifted=bool(ready and ratios[i] > 1.0), ready=ready, offset=offset, threshold=thr,
                          ratio=float(ratios[i]), component=i)


# ----------------------------------------------------------------------------- pose planning


@dataclass(frozen=True)
class CalibrationPlan:
    """Joint configurations for a calibration, and how well they condition it.

    Attributes:
        joint_positions: (n, nq) [rad], within the joint limits (less the margin).
        rotations: sensor orientations at those configurations, (n, d, d).
        condition_number: of the normalised gravity regressor (see :func:`regressor_condition`).
        smallest_singular_value: its smallest singular value divided by √n (1 at best for forces).
    """

    joint_positions: np.ndarray
    rotations: np.ndarray
    condition_number: float
    smallest_singular_value: float


def sensor_orientation(robot: Any) -> Callable[[np.ndarray], np.ndarray]:
    """``q -> R_S`` for a robot: planar arms (task dimension 2) give (2, 2), others (3, 3).

    Planar closed-form arms use :func:`~forcecontrol.sensors.planar_sensor_rotation` (φ = Σ q);
    Pinocchio robots use the controlled frame's orientation (``frame_pose``), its x-y block when
    the task is planar.

    Raises:
        ParameterError: the robot has neither ``frame_pose`` nor a planar task.
    """
    if hasattr(robot, "frame_pose"):
        if getattr(robot, "task_dim", 6) == 2:
            return lambda q: robot.frame_pose(q)[0][:2, :2]
        return lambda q: robot.frame_pose(q)[0]
    if getattr(robot, "task_dim", None) == 2:
        return planar_sensor_rotation
    raise ParameterError(
        f"cannot tell the sensor orientation of {type(robot).__name__}: pass orientation=q -> R_S"
    )


def _joint_limits(robot: Any, nq: int, joint_limits: Any, margin: float) -> tuple[np.ndarray, np.ndarray]:
    if joint_limits is not None:
        lo, hi = (np.asarray(v, dtype=np.float64).reshape(-1) for v in joint_limits)
    elif hasattr(robot, "model") and hasattr(robot.model, "lowerPositionLimit"):
        lo = np.array(robot.model.lowerPositionLimit, dtype=np.float64)
        hi = np.array(robot.model.upperPositionLimit, dtype=np.float64)
    else:
        lo, hi = np.full(nq, -math.pi), np.full(nq, math.pi)
    if lo.shape != (nq,) or hi.shape != (nq,):
        raise DimensionError(f"joint_limits must be two vectors of shape ({nq},); got shapes {lo.shape} and {hi.shape}")
    unlimited = ~np.isfinite(lo) | ~np.isfinite(hi) | (hi - lo > 1e6)
    lo = np.where(unlimited, -math.pi, lo)
    hi = np.where(unlimited, math.pi, hi)
    lo, hi = lo + margin, hi - margin
    if np.any(hi <= lo):
        j = int(np.flatnonzero(hi <= lo)[0])
        raise ParameterError(f"joint {j}'s range is empty after the margin {margin} rad: [{lo[j]:.4g}, {hi[j]:.4g}]")
    return lo, hi


def plan_calibration_poses(
    robot: Any,
    n_poses: int,
    *,
    candidates: int = 1000,
    seed: int = 0,
    torques: bool = True,
    margin: float = 0.05,
    joint_limits: Any = None,
    orientation: Callable[[np.ndarray], np.ndarray] | None = None,
) -> CalibrationPlan:
    """Joint configurations that make a well-conditioned calibration, within the joint limits.

    Draws ``candidates`` configurations uniformly within the limits (the model's, less
    ``margin``; ±π for joints without limits), then picks ``n_poses`` of them: greedily by the
    information ``log det(Σ AᵢᵀAᵢ + εI)`` of the normalised gravity regressor, then exchanges
    (each chosen pose against every candidate) while the condition number drops. Only the
    sensor orientation matters; collisions are not checked beyond the joint limits.

    Args:
        robot: a robot model (the planar chapter arm, a Pinocchio robot such as the Panda).
        n_poses: number of poses, at least 3 (planar: 4 with moments).
        candidates: random configurations to choose from.
        seed: seed of the random draw (the plan is reproducible).
        torques: plan for the moments too (centre of mass).
        margin: distance kept from each joint limit [rad].
        joint_limits: (lower, upper) to use instead of the model's, each (nq,) [rad].
        orientation: ``q -> R_S`` instead of :func:`sensor_orientation` (a sensor on another frame).

    Returns:
        A :class:`CalibrationPlan`.

    Raises:
        ParameterError: n_poses or candidates too small, a negative margin, an empty joint range, an
            unknown robot.
    """
    for name, v, low in (("n_poses", n_poses, 3), ("candidates", candidates, 1)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise ParameterError(f"{name} must be an integer >= {low}; got {v!r}")
    if candidates < n_poses:
        raise ParameterError(f"candidates must be at least n_poses ({n_poses}); got {candidates}")
    nq = int(getattr(robot, "nq", 0))
    if nq < 1:
        raise ParameterError(f"robot must be a robot model with nq joints; got {type(robot).__name__}")
    orient = orientation if orientation is not None else sensor_orientation(robot)
    lo, hi = _joint_limits(robot, nq, joint_limits, nonnegative_scalar("margin", margin))
    rng = np.random.default_rng(seed)
    Q = lo + (hi - lo) * rng.random((candidates, nq))
    Rs = np.array([np.asarray(orient(q), dtype=np.float64) for q in Q])
    _rotations(Rs)
    uhat = _gravity_in_sensor(Rs, 1.0)
    # per-candidate information matrices of the two blocks
    Mf = np.array([_force_regressor(u[None]).T @ _force_regressor(u[None]) for u in uhat])
    Mt = np.array([_torque_regressor(u[None]).T @ _torque_regressor(u[None]) for u in uhat]) if torques else None

    def info(Sf, St):  # batched: log det and eigenvalues of each block
        ef = np.linalg.eigvalsh(Sf)
        et = np.linalg.eigvalsh(St) if St is not None else None
        return ef, et

    eps = 1e-6
    chosen: list[int] = []
    Sf = np.zeros(Mf.shape[1:])
    St = np.zeros(Mt.shape[1:]) if Mt is not None else None
    for _ in range(n_poses):
        cf = Sf[None] + Mf
        ef, et = info(cf, St[None] + Mt if St is not None else None)
        score = np.sum(np.log(ef + eps), axis=1) + (np.sum(np.log(et + eps), axis=1) if et is not None else 0.0)
        score[chosen] = -np.inf
        j = int(np.argmax(score))
        chosen.append(j)
        Sf = Sf + Mf[j]
        if St is not None:
            St = St + Mt[j]

    def cond_of(ef, et):
        e = np.concatenate([ef, et], axis=-1) if et is not None else ef
        e = np.maximum(e, 0.0)
        with np.errstate(divide="ignore"):
            return np.sqrt(e.max(axis=-1) / e.min(axis=-1))

    best = float(cond_of(*info(Sf, St)))
    for _ in range(3):  # exchange passes
        improved = False
        for slot in range(n_poses):
            i = chosen[slot]
            cf = Sf[None] - Mf[i] + Mf
            ct = St[None] - Mt[i] + Mt if St is not None else None
            c = cond_of(*info(cf, ct))
            c[chosen] = np.inf
            j = int(np.argmin(c))
            if c[j] < best * (1 - 1e-9):
                best = float(c[j])
                Sf = cf[j]
                if St is not None:
                    St = ct[j]
                chosen[slot] = j
                improved = True
        if not improved:
            break
    sel = np.array(chosen)
    blocks = _normalised_blocks(Rs[sel], torques)
    cond, smin = _condition(blocks)
    return CalibrationPlan(joint_positions=Q[sel], rotations=Rs[sel], condition_number=cond,
                           smallest_singular_value=smin / math.sqrt(n_poses))


# ----------------------------------------------------------------------------- data files

_FORCE = ("fx", "fy", "fz")
_TORQUE = ("tx", "ty", "tz")
_QUAT = ("qx", "qy", "qz", "qw")
_MATRIX = tuple(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))


def calibration_data_from_columns(columns: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Rotations, forces and moments from named columns (a table read from CSV or Parquet).

    Orientation of the sensor frame in the base frame, one of:

    * ``qx, qy, qz, qw``: unit quaternion, scalar last (ROS order); normalised if within 1e-3 of unit;
    * ``r11 … r33``: rotation matrix, row-major (``rij`` is row i, column j);
    * ``angle``: planar sensor angle φ [rad] (a planar calibration).

    Readings: ``fx, fy, fz`` [N] (``fx, fy`` when planar) and optionally ``tx, ty, tz`` [N m]
    (``tz`` when planar). Column names are matched without regard to case and surrounding spaces.

    Returns:
        (rotations (k, d, d), forces (k, d), torques (k,)/(k, 3) or None).

    Raises:
        ParameterError: no orientation columns, missing force columns (the message lists what
            is there), a quaternion far from unit, text in a numeric column. MeasurementError: NaN/inf.
    """
    cols = {str(k).strip().lower(): v for k, v in columns.items()}
    have = sorted(cols)

    def col(name: str) -> np.ndarray:
        try:
            a = np.asarray(cols[name], dtype=np.float64).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"column {name!r} must hold numbers; got {list(cols[name])[:3]!r}...") from exc
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise MeasurementError(f"column {name!r} must be finite; row {int(bad[0])} is {a[bad[0]]}")
        return a

    def missing(names: tuple[str, ...]) -> list[str]:
        return [n for n in names if n not in cols]

    if not missing(_QUAT):
        q = np.stack([col(n) for n in _QUAT], axis=1)
        norm = np.linalg.norm(q, axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > 1e-3)
        if bad.size:
            raise ParameterError(
                f"quaternion (qx, qy, qz, qw) must be unit; row {int(bad[0])} has norm {norm[bad[0]]:.6g}"
            )
        from scipy.spatial.transform import Rotation

        R = Rotation.from_quat(q / norm[:, None]).as_matrix()
    elif not missing(_MATRIX):
        R = np.stack([col(n) for n in _MATRIX], axis=1).reshape(-1, 3, 3)
    elif "angle" in cols:
        phi = col("angle")
        c, s = np.cos(phi), np.sin(phi)
        R = np.stack([np.stack([c, -s], axis=1), np.stack([s, c], axis=1)], axis=1)
    else:
        raise ParameterError(
            "no orientation columns: give qx, qy, qz, qw (quaternion, scalar last), r11 ... r33 (rotation matrix) or "
            f"angle (planar, rad); the data has columns {have}"
        )
    d = R.shape[1]
    fnames = _FORCE[:d]
    if missing(fnames):
        raise ParameterError(f"missing force column(s) {missing(fnames)} for a {'planar' if d == 2 else '3-D'} "
                             f"calibration; the data has columns {have}")
    F = np.stack([col(n) for n in fnames], axis=1)
    tnames = ("tz",) if d == 2 else _TORQUE
    if d == 2 and any(n in cols for n in ("tx", "ty")):
        raise ParameterError(f"a planar calibration takes the moment about z (tz) only; got column(s) "
                             f"{[n for n in ('tx', 'ty') if n in cols]}")
    T = None
    present = [n for n in tnames if n in cols]
    if present:
        if missing(tnames):
            raise ParameterError(f"missing moment column(s) {missing(tnames)} (moments are all or none); "
                                 f"the data has columns {have}")
        T = col("tz") if d == 2 else np.stack([col(n) for n in tnames], axis=1)
    return R, F, T


def read_calibration_data(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read a calibration table from CSV (header row, comma-separated) or Parquet (needs pyarrow).

    See :func:`calibration_data_from_columns` for the columns.

    Raises:
        ParameterError: the file does not exist, is not CSV/Parquet, is empty or lacks columns.
    """
    p = Path(path)
    if not p.is_file():
        raise ParameterError(f"calibration data file {str(p)!r} does not exist")
    suffix = p.suffix.lower()
    if suffix in (".parquet", ".pq"):
        try:
            import pyarrow.parquet as pq
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ImportError("reading Parquet needs pyarrow: pip install 'forcecontrol[data]'") from exc
        try:
            table = pq.read_table(p)
        except Exception as exc:  # pyarrow raises its own error types
            raise ParameterError(f"cannot read {str(p)!r} as Parquet: {exc}") from exc
        columns = {name: table.column(name).to_numpy(zero_copy_only=False) for name in table.column_names}
    elif suffix in (".csv", ".txt"):
        import csv

        try:
            with p.open(newline="", encoding="utf-8") as fh:
                rows = list(csv.reader(fh))
        except (OSError, UnicodeDecodeError) as exc:
            raise ParameterError(f"cannot read {str(p)!r} as UTF-8 CSV: {exc}") from exc
        if len(rows) < 2:
            raise ParameterError(f"{str(p)!r} holds no data rows (a header row and one row per reading are needed)")
        header, body = rows[0], [r for r in rows[1:] if r]
        if any(len(r) != len(header) for r in body):
            i = next(i for i, r in enumerate(body) if len(r) != len(header))
            raise ParameterError(f"{str(p)!r}: data row {i + 1} has {len(body[i])} fields, the header {len(header)}")
        columns = {}
        for j, name in enumerate(header):
            vals = [r[j] for r in body]
            try:
                columns[name] = np.array([float(v) for v in vals])
            except ValueError:
                columns[name] = np.array(vals, dtype=object)
    else:
        raise ParameterError(f"calibration data must be a .csv or .parquet file; got {str(p)!r}")
    return calibration_data_from_columns(columns)
