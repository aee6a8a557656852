"""Identifying a force/torque sensor's payload and bias from static poses (the package's core)."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ...core.validate import positive_scalar
from ...errors import CalibrationMisfitWarning, DimensionError, MeasurementError, ParameterError
from ...sensors.gravity import ToolGravity, _force_regressor, _gravity_vector, _torque_regressor
from ..io.recorded import MAX_RECORDED_MAGNITUDE

__all__ = ["CalibrationResult", "FrameCheck", "calibrate", "frame_check", "regressor_condition", "tare", "MAX_CONDITION",
           "MISFIT_P"]

#: default largest condition number of the normalised gravity regressor :func:`calibrate` accepts.
MAX_CONDITION = 100.0

#: p-value of :func:`frame_check`'s F-test below which :func:`calibrate` says the force readings do not follow the model
#: in the orientations given (a correct model reaches it by chance once in a thousand calibrations).
MISFIT_P = 1e-3


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
    big = np.abs(a) > MAX_RECORDED_MAGNITUDE
    if np.any(big):  # a corrupt reading (1e200 N gave a tool of 5.5e197 kg ± inf, and an overflow)
        i = int(np.argwhere(big)[0, 0])
        raise MeasurementError(f"{name}: reading {i} is {a[i].tolist()}, beyond any sensor's range (at most "
                               f"{MAX_RECORDED_MAGNITUDE:.0e} in magnitude); clean or drop that reading first")
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
        frame_check: whether the force readings follow the model in the orientations given or in a turned
            sensor frame (:class:`FrameCheck`); None when the readings cannot tell (too few, or gravity
            directions that do not span the sensor's axes).
        notes: what the calibration found or decided that a user must know (a misfit of the frame check and a mass
            clamped to 0 are also warned; the others, such as a centre of mass left undefined, are not).
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
    frame_check: FrameCheck | None = None

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
            "frame_check": None if self.frame_check is None else self.frame_check.as_dict(),
        }


@dataclass(frozen=True, eq=False)
class FrameCheck:
    """Do the force readings follow ``f = −m u + b`` in the orientations given, or in turned ones?

    Three nested fits of the force readings (k readings, d components, ``u_i = R_iᵀ g``):

    * *given*: the model, ``f_i = −m u_i + b`` (1 + d unknowns);
    * *turned*: the model in a sensor frame turned by ``R_es`` from the given one, ``f_i = −m R_esᵀ u_i + b``
      (``R_es`` by nonlinear least squares from the rotation nearest to the linear fit's map; 3 more unknowns in 3-D,
      1 planar);
    * *linear*: any linear map of gravity, ``f_i = A u_i + b`` (d² + d unknowns, fewer when the poses' gravity
      directions span fewer axes: see :func:`frame_check`).

    ``statistic`` and ``p_value`` are the F-test of *given* against *linear* (``dof`` its degrees of
    freedom): a small p-value says the readings do not follow the model in the given orientations.
    ``turned_p_value`` is the same test of *turned* against *linear*: large when a turned sensor frame
    explains the readings (then ``rotation`` is how the sensor frame is turned), small when no rotation does (gains,
    cross-talk, a tool that moves, readings of another sense). The tests assume white noise of equal variance on the
    force components, as the uncertainties of :func:`calibrate` do.

    Attributes:
        statistic, p_value, dof: the F-test of the model in the given orientations.
        turned_p_value: the F-test of the model in the turned sensor frame (NaN when the poses leave it no degree of
            freedom).
        rotation: ``R_es`` (d, d): the sensor frame's orientation in the given frame that fits best.
        angle_deg: its angle [deg]; axis: its unit axis (3,) (planar: (0, 0, ±1)).
        rpy: ``R_es`` as fixed-axis roll, pitch, yaw [rad] (URDF's ``rpy``; planar: (0, 0, θ)).
        rms_given, rms_turned, rms_linear: residual RMS of the three fits [N].
        significant: ``p_value < MISFIT_P``.
    """

    statistic: float
    p_value: float
    dof: tuple[int, int]
    turned_p_value: float
    rotation: np.ndarray
    angle_deg: float
    axis: np.ndarray
    rpy: np.ndarray
    rms_given: float
    rms_turned: float
    rms_linear: float

    @property
    def significant(self) -> bool:
        return self.p_value < MISFIT_P

    def as_dict(self) -> dict[str, Any]:
        return {"statistic": self.statistic, "p_value": self.p_value, "dof": list(self.dof),
                "turned_p_value": self.turned_p_value, "significant": self.significant,
                "rotation": self.rotation.tolist(), "angle_deg": self.angle_deg, "axis": self.axis.tolist(),
                "rpy": self.rpy.tolist(), "rms_given": self.rms_given, "rms_turned": self.rms_turned,
                "rms_linear": self.rms_linear}

    def note(self) -> str:
        """What the check found, in words (the text :func:`calibrate` warns with when it is significant)."""
        r = ",".join(f"{v:.4g}" for v in self.rpy)
        a = ", ".join(f"{v:.3g}" for v in self.axis)
        head = (f"the force readings do not follow the gravity model in the given orientations (F-test p = "
                f"{self.p_value:.2g}; residual RMS {self.rms_given:.3g} N, {self.rms_linear:.3g} N with any linear map "
                "of gravity)")
        if math.isnan(self.turned_p_value):
            return (f"{head}. The poses do not tell which turned sensor frame would explain them (the gravity directions "
                    f"in the sensor frame span too few axes; the best fit is {self.angle_deg:.3g} deg about ({a}), rpy = {r} "
                    "rad): check the frame of the orientations, or spread the poses (calibrate-plan) and calibrate again")
        if self.turned_p_value >= MISFIT_P:
            return (f"{head}: they fit a sensor frame turned by {self.angle_deg:.3g} deg about ({a}) from the given one "
                    f"(rpy = {r} rad; residual RMS {self.rms_turned:.3g} N). The orientations are likely another frame's "
                    f"than the sensor's: give the sensor's rotation on that frame (calibrate ... --sensor-rpy={r}; "
                    "sensor_rotation= in Python) and calibrate again")
        return (f"{head}; no turned sensor frame explains them (the best, {self.angle_deg:.3g} deg about ({a}), leaves "
                f"{self.rms_turned:.3g} N, F-test p = {self.turned_p_value:.2g}): check the sensor's gains and units, the "
                "sense of the readings and that the tool was at rest")


def _rss(A: np.ndarray, y: np.ndarray) -> float:
    theta, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ theta
    return float(r @ r)


def _f_test(rss_small: float, rss_big: float, df1: int, df2: int, scale: float) -> tuple[float, float]:
    """(F, p) of a nested least-squares fit with df1 fewer unknowns; ``scale`` is the data's sum of squares."""
    from scipy.stats import f as fisher  # type: ignore[import-untyped]

    floor = 1e-26 * max(scale, 1e-300)  # round-off: a perfect fit of exact data
    if rss_big <= floor:
        return (math.inf, 0.0) if rss_small > 1e-20 * max(scale, 1e-300) else (0.0, 1.0)
    stat = max(rss_small - rss_big, 0.0) / df1 / (rss_big / df2)
    return float(stat), float(fisher.sf(stat, df1, df2))


def _rank(A: np.ndarray) -> int:
    return int(np.linalg.matrix_rank(A, tol=1e-9 * max(1.0, float(np.abs(A).max()))))


def _turned_fit(u: np.ndarray, y: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, float]:
    """The sensor rotation R_es minimising the residual of ``f = −m R_esᵀ u + b`` ((m, b) solved for each rotation),
    by nonlinear least squares from ``start``; (R_es, RSS)."""
    from scipy.optimize import least_squares  # type: ignore[import-untyped]
    from scipy.spatial.transform import Rotation  # type: ignore[import-untyped]

    d = u.shape[1]

    def rotation(v: np.ndarray) -> np.ndarray:
        if d == 3:
            return Rotation.from_rotvec(v).as_matrix()
        c, s = math.cos(v[0]), math.sin(v[0])
        return np.array([[c, -s], [s, c]])

    def residual(v: np.ndarray) -> np.ndarray:
        A = _force_regressor(u @ rotation(v))  # u_i' = R_esᵀ u_i, as rows
        theta, *_ = np.linalg.lstsq(A, y, rcond=None)
        return y - A @ theta

    v0 = Rotation.from_matrix(start).as_rotvec() if d == 3 else np.array([math.atan2(start[1, 0], start[0, 0])])
    sol = least_squares(residual, v0, xtol=1e-12, ftol=1e-12, gtol=1e-12)
    r0, r1 = residual(v0), sol.fun
    if float(r0 @ r0) <= float(r1 @ r1):  # the start was already the best (an exact fit)
        return start, float(r0 @ r0)
    return rotation(sol.x), float(r1 @ r1)


def frame_check(rotations: Any, forces: Any, *, gravity: float = 9.81) -> FrameCheck | None:
    """The F-tests of :class:`FrameCheck` on static force readings at sensor orientations.

    The linear map's unknowns are those the poses identify: with gravity directions in the sensor frame
    that span only a plane (poses turned about one horizontal axis), ``d·r`` of them (r the rank of ``[u_i, 1]``), and
    the degrees of freedom follow. The turned sensor frame starts from the rotation nearest to the linear fit's map
    (orthogonal Procrustes) and is refined by nonlinear least squares (the Procrustes rotation alone left too large a
    residual when the poses cover gravity directions unevenly).

    Args:
        rotations: sensor orientations R_i in the base frame, (k, d, d); forces: readings in the sensor frame (k, d) [N].
        gravity: |g| [m/s²].

    Returns:
        The check, or None when the readings cannot tell: no more readings than the linear fit has unknowns, or
        gravity directions that leave it no unknown beyond the model's. ``turned_p_value`` is NaN when the poses leave
        the turned model no degree of freedom to test (they do not tell the rotation apart).

    Raises:
        DimensionError, MeasurementError, ParameterError: as :func:`calibrate`.
    """
    g = positive_scalar("gravity", gravity, "m/s^2")
    R = _rotations(rotations)
    F = _readings("forces", forces, R.shape[0], R.shape[1])
    return _frame_check(_gravity_in_sensor(R, g), F)


def _frame_check(u: np.ndarray, F: np.ndarray) -> FrameCheck | None:
    """:func:`frame_check` on checked readings F (k, d) and gravity in the sensor frame u (k, d)."""
    from scipy.spatial.transform import Rotation  # type: ignore[import-untyped]

    k, d = u.shape
    X = np.column_stack([u, np.ones(k)])
    A_given = _force_regressor(u)
    n_lin, n_given = d * _rank(X), _rank(A_given)
    df1, df2 = n_lin - n_given, k * d - n_lin
    if df1 < 1 or df2 < 1:
        return None
    coef, *_ = np.linalg.lstsq(X, F, rcond=None)
    res = F - X @ coef
    rss_lin = float(np.sum(res * res))
    y = F.reshape(-1)
    rss_given = _rss(A_given, y)
    # A = −m R_esᵀ: the nearest rotation to −A (orthogonal Procrustes) is R_esᵀ; refined by least squares
    U, _s, Vt = np.linalg.svd(-coef[:d].T)
    D = np.eye(d)
    D[-1, -1] = np.sign(np.linalg.det(U @ Vt)) or 1.0
    Res, rss_turned = _turned_fit(u, y, (U @ D @ Vt).T)
    scale = float(y @ y)
    stat, p = _f_test(rss_given, rss_lin, df1, df2, scale)
    df1_turned = n_lin - (n_given + (3 if d == 3 else 1))
    p_turned = _f_test(rss_turned, rss_lin, df1_turned, df2, scale)[1] if df1_turned >= 1 else math.nan
    if d == 3:
        rot = Rotation.from_matrix(Res)
        rv = rot.as_rotvec()
        angle = float(np.linalg.norm(rv))
        axis = rv / angle if angle > 0.0 else np.array([0.0, 0.0, 1.0])
        rpy = rot.as_euler("xyz")  # lower case: fixed axes, URDF's roll, pitch, yaw
    else:
        theta = math.atan2(Res[1, 0], Res[0, 0])
        angle = abs(theta)
        axis = np.array([0.0, 0.0, 1.0 if theta >= 0.0 else -1.0])
        rpy = np.array([0.0, 0.0, theta])
    n = k * d
    return FrameCheck(statistic=stat, p_value=p, dof=(df1, df2), turned_p_value=p_turned, rotation=Res,
                      angle_deg=math.degrees(angle), axis=axis, rpy=np.asarray(rpy, dtype=np.float64),
                      rms_given=math.sqrt(rss_given / n), rms_turned=math.sqrt(rss_turned / n),
                      rms_linear=math.sqrt(rss_lin / n))


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
    g = positive_scalar("gravity", gravity, "m/s^2")
    max_condition = positive_scalar("max_condition", max_condition)
    if g > 1e3:  # 1e308 was accepted (fuzz, seed 20261126) and gave a mass of 1e-307 kg
        raise ParameterError(f"gravity must be a positive number of at most 1000 [m/s^2]; got {g:g}")
    if max_condition > 1e16:  # beyond 1/eps every pose set passes and the estimate is noise
        raise ParameterError(f"max_condition must be a positive number of at most 1e16 (1/eps); got {max_condition:g}")
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
            "sense of the readings and the frames of the rotations (orientations in degrees read as radians give "
            "this too: pass --degrees / degrees=True when reading them)"
        )
    clamp_note = None
    if mass < 0.0:
        # negative within the noise: never reported as a mass; the constrained (m >= 0) least-squares estimate is
        # m = 0, where the force bias is the readings' mean (the regressor's bias block is the identity)
        clamp_note = (f"the unconstrained mass estimate {mass:.3g} ± {std_f[0]:.2g} kg is negative but within its noise: "
                      "reported as 0 kg (constrained least squares, force bias refit as the mean reading); likely no "
                      "tool or a tool lighter than the noise")
        warnings.warn(clamp_note, UserWarning, stacklevel=2)
        mass, b_f = 0.0, F.mean(axis=0)
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
    if clamp_note is not None:
        notes.append(clamp_note)
    check = _frame_check(u, F)  # the readings and rotations checked above
    if check is None:
        notes.append(f"the orientations were not checked against the force readings (is the sensor frame turned from "
                     f"the given one?): that needs more readings than a linear map of gravity has unknowns, at least "
                     f"{d + 2} readings whose gravity directions span the sensor's {d} axes; got {k}")
    elif check.significant:
        notes.append(check.note())
        warnings.warn(check.note(), CalibrationMisfitWarning, stacklevel=2)
    return CalibrationResult(
        dim=d, gravity=g, mass=mass, mass_std=float(std_f[0]), force_bias=b_f, force_bias_std=std_f[1:],
        force_noise_std=sf, force_residual_rms=rms_f, force_covariance=cov_f, condition_number=cond,
        n_readings=k, notes=tuple(notes), frame_check=check, **out,
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


# ----------------------------------------------------------------------------- pose planning


# ----------------------------------------------------------------------------- data files


