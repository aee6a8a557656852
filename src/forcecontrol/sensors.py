"""Force sensor models: the simple one (bias, white noise, first-order low-pass) and a realistic one.

:class:`ForceSensor` is exact by default and the compiled simulator loop runs it inline.
:class:`RealisticForceSensor` adds what a real wrist F/T sensor does to the signal: a bias and a
drift in the sensor frame, the weight of the tool mounted after it, quantisation of the
converter, a configurable digital filter, transport delay, and the two corrections applied on
real arms, zeroing at start (bias estimation) and tool gravity compensation. It is stateful and
runs in the Python loop (``compiled_ok`` is False). :func:`identify_tool_gravity` identifies a
tool's mass, centre of mass and the sensor bias from a few static poses (least squares).

Derivative-free by design: none of the chapter's direct force schemes (9.39)–(9.48) or the
impedance laws differentiates the measured force; their derivative terms act on ẋ_e = J q̇, and
on a real arm q̇ comes from differences of encoder positions (see :mod:`forcecontrol.encoders`).
Sensor noise therefore enters through proportional and integral paths only and is not
amplified by a numerical derivative; a first-order filter is enough to keep it out of the
torques.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from ._validate import positive_scalar
from .errors import DimensionError, ParameterError

__all__ = [
    "ForceSensor",
    "RealisticForceSensor",
    "ToolGravity",
    "identify_tool_gravity",
    "planar_sensor_rotation",
    "first_order_alpha",
]


def first_order_alpha(name: str, cutoff: float, sample_time: float) -> float:
    """α = 1 − exp(−2π f_c Ts) of the first-order low-pass ``y_k = y_{k−1} + α (x_k − y_{k−1})``.

    Raises:
        ParameterError: the cut-off ``name`` is at or above the Nyquist frequency 1/(2 Ts).
    """
    nyquist = 0.5 / sample_time
    if cutoff >= nyquist:
        raise ParameterError(
            f"{name} must be below the Nyquist frequency {nyquist:.6g} Hz for sample_time "
            f"{sample_time:.6g} s; got {cutoff:.6g} Hz"
        )
    return 1.0 - math.exp(-2.0 * math.pi * cutoff * sample_time)


class ForceSensor:
    """A wrist force sensor sampled at the control rate.

    Measurement at sample k: ``raw_k = h_e(t_k) + bias + noise_k`` with ``noise_k`` Gaussian of
    standard deviation ``noise_std`` (per component), then a first-order low-pass
    ``y_k = y_{k−1} + α (raw_k − y_{k−1})``, ``α = 1 − exp(−2π f_c Ts)``, started at ``y_0 = raw_0``.
    The noise sequence is drawn once per run from ``seed`` so that the Python and compiled loops
    see the same numbers.

    Args:
        noise_std: standard deviation of the noise [N], scalar or per component; 0 = none.
        bias: constant offset [N], scalar or per component.
        cutoff: low-pass cut-off frequency f_c [Hz]; None = no filter. Must be below Nyquist.
        seed: seed of the noise generator.
    """

    def __init__(self, noise_std: Any = 0.0, bias: Any = 0.0, cutoff: float | None = None, seed: int = 0) -> None:
        self.noise_std = np.array(noise_std, dtype=np.float64)
        self.bias = np.array(bias, dtype=np.float64)
        for name, v in (("noise_std", self.noise_std), ("bias", self.bias)):
            if v.ndim > 1:
                raise DimensionError(f"{name} must be a scalar or a vector; got shape {v.shape}")
            if not np.all(np.isfinite(v)):
                raise ParameterError(f"{name} must be finite; got {v.tolist()}")
        if np.any(self.noise_std < 0):
            raise ParameterError(f"noise_std must be non-negative; got {self.noise_std.tolist()}")
        self.cutoff = None if cutoff is None else positive_scalar("cutoff", cutoff)
        if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or not 0 <= int(seed) < 2**63:
            raise ParameterError(f"seed must be an integer in [0, 2**63); got {seed!r}")
        self.seed = int(seed)

    @property
    def compiled_ok(self) -> bool:
        """True when the simulator may run this sensor inline in its compiled loop (simple kind)."""
        return True

    @property
    def exact(self) -> bool:
        """True when the sensor returns the true wrench unchanged."""
        return self.cutoff is None and not np.any(self.noise_std) and not np.any(self.bias)

    def alpha(self, sample_time: float) -> float:
        """Low-pass coefficient α for the sample time; 1 when there is no filter.

        Raises:
            ParameterError: the cut-off is at or above the Nyquist frequency 1/(2 Ts).
        """
        return 1.0 if self.cutoff is None else first_order_alpha("cutoff", self.cutoff, sample_time)

    def sequences(self, n_samples: int, dim: int) -> tuple[np.ndarray, np.ndarray]:
        """The bias (dim,) and the noise (n_samples, dim) of one run."""
        try:
            bias = np.broadcast_to(self.bias, (dim,)).astype(np.float64)
            std = np.broadcast_to(self.noise_std, (dim,)).astype(np.float64)
        except ValueError as exc:
            raise DimensionError(
                f"bias and noise_std must be scalars or have shape ({dim},); got shapes "
                f"{self.bias.shape} and {self.noise_std.shape}"
            ) from exc
        if np.any(std):
            noise = np.random.default_rng(self.seed).standard_normal((n_samples, dim)) * std
        else:
            noise = np.zeros((n_samples, dim))
        return bias, noise

    def describe(self) -> dict[str, Any]:
        return {
            "noise_std": self.noise_std.tolist(),
            "bias": self.bias.tolist(),
            "cutoff": self.cutoff,
            "seed": self.seed,
        }



# --------------------------------------------------------------------------- realistic sensor

_FILTERS = ("none", "first-order", "butterworth")


def planar_sensor_rotation(q: np.ndarray) -> np.ndarray:
    """R_S, the (2, 2) rotation of a wrist sensor on a planar arm: angle φ = Σ q_i (base to sensor)."""
    phi = float(np.sum(q))
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


def _gravity_vector(dim: int, g: float) -> np.ndarray:
    """Gravity acceleration in the base frame: −y for planar arms (vertical plane), −z in 3-D."""
    out = np.zeros(dim)
    out[1 if dim == 2 else 2] = -g
    return out


def _skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _force_regressor(u: np.ndarray) -> np.ndarray:
    """Stacked regressor of ``f_i = −u_i m + b_f`` in (m, b_f): rows ``[−u_i, I]``, (k d, 1 + d).

    ``u_i = R_iᵀ g`` is gravity in the sensor frame of pose i, (k, d).
    """
    k, d = u.shape
    A = np.zeros((k * d, 1 + d))
    for i in range(k):
        A[i * d : (i + 1) * d, 0] = -u[i]
        A[i * d : (i + 1) * d, 1:] = np.eye(d)
    return A


def _torque_regressor(w: np.ndarray) -> np.ndarray:
    """Stacked regressor of the moments in (c, b_τ) given the tool weights ``w_i`` in S, (k, d).

    ``τ_i = [w_i]× c + b_τ`` (3-D, rows (3 k, 6)) or ``τ_i = w_x c_y − w_y c_x + b_τ`` (planar,
    rows (k, 3)). With ``w_i = u_i`` (unit mass) the unknowns are the first moment ``p = m c``.
    """
    k, d = w.shape
    nt = 1 if d == 2 else 3
    At = np.zeros((k * nt, d + nt))
    for i in range(k):
        if d == 2:
            At[i, 0:2] = [-w[i, 1], w[i, 0]]
            At[i, 2] = 1.0
        else:
            At[3 * i : 3 * i + 3, 0:3] = _skew(w[i])
            At[3 * i : 3 * i + 3, 3:] = np.eye(3)
    return At


class ToolGravity:
    """The tool mounted after the sensor: mass, centre of mass and the sensor's bias.

    Sign convention (the library's): with no tool the sensor reads h_e, the force the
    end-effector exerts on the environment. A static tool is held by the sensor against its
    weight ``w = m g`` and the environment's push ``−h_e``: ``f_sensor→tool + m g − h_e = 0``, so
    the sensor reads ``h_e − m g``, and in free space ``−m R_Sᵀ g`` (it holds the tool up).
    With ``w_S = m R_Sᵀ g`` (g the gravity vector in the base frame, R_S the sensor's orientation)
    and c the centre of mass in S, a free-space reading is ``f_S = −w_S + b_f`` and
    ``τ_S = −c × w_S + b_τ`` (3-D) or ``−(c_x w_y − c_y w_x) + b_τ`` (planar).

    Args:
        mass: tool mass m [kg], >= 0.
        com: centre of mass c in the sensor frame, (d,) [m]; zeros by default.
        force_bias: sensor force bias b_f in S, (d,) [N]; zeros by default.
        torque_bias: sensor moment bias b_τ in S, scalar (planar) or (3,) [N m]; zeros by default.
        dim: 2 (planar) or 3.
        gravity: |g| [m/s²] along −y (planar) or −z (3-D).
    """

    def __init__(self, mass: float, com: Any = None, force_bias: Any = None, torque_bias: Any = None,
                 *, dim: int = 2, gravity: float = 9.81) -> None:
        if dim not in (2, 3):
            raise ParameterError(f"dim must be 2 (planar) or 3; got {dim!r}")
        try:
            m = float(mass)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"tool mass must be a non-negative number [kg]; got {mass!r}") from exc
        if not math.isfinite(m) or m < 0.0:
            raise ParameterError(f"tool mass must be a non-negative number [kg]; got {mass!r}")
        self.mass = m
        self.dim = dim
        self.gravity = positive_scalar("gravity", gravity)
        self.com = self._vec("com", com, dim)
        self.force_bias = self._vec("force_bias", force_bias, dim)
        nt = 1 if dim == 2 else 3
        self.torque_bias = self._vec("torque_bias", torque_bias, nt)

    @staticmethod
    def _vec(name: str, v: Any, n: int) -> np.ndarray:
        a = np.zeros(n) if v is None else np.array(v, dtype=np.float64).reshape(-1)
        if a.shape != (n,):
            raise DimensionError(f"{name} must have {n} entries; got shape {np.shape(v)}")
        if not np.all(np.isfinite(a)):
            raise ParameterError(f"{name} must be finite; got {a.tolist()}")
        return a

    def weight_in_sensor(self, R: np.ndarray) -> np.ndarray:
        """w_S = m R_Sᵀ g, the tool's weight (the gravity force on it) in the sensor frame, (d,) [N]."""
        return self.mass * (np.asarray(R).T @ _gravity_vector(self.dim, self.gravity))

    def reading(self, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The static reading (force (d,) [N], moment (1,) or (3,) [N m]) with no contact."""
        w = self.weight_in_sensor(R)
        if self.dim == 2:
            tau = np.array([-(self.com[0] * w[1] - self.com[1] * w[0])])
        else:
            tau = -np.cross(self.com, w)
        return -w + self.force_bias, tau + self.torque_bias

    def compensate(
        self, R: Any, force: Any, torque: Any = None, *, frame: str = "sensor"
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Gravity compensation in any orientation: the contact wrench h_e from a raw reading.

        ``h_S = f_S − (−w_S + b_f)`` and ``μ_S = τ_S − (−c × w_S + b_τ)``: the reading minus the
        free-space reading :meth:`reading` predicts at orientation R (the library's sense, the
        force the end-effector exerts on the environment).

        Args:
            R: sensor orientation R_S, (d, d), or one per reading (k, d, d).
            force: force reading(s) in the sensor frame, (d,) or (k, d) [N].
            torque: moment reading(s), (1,)/(3,) or (k, 1)/(k,)/(k, 3) [N m]; None = forces only.
            frame: ``"sensor"`` (S) or ``"base"`` (rotated by R_S; the planar moment is unchanged).

        Returns:
            (force, moment) with the shapes of the inputs; moment None when ``torque`` is None.

        Raises:
            DimensionError: shapes do not match the tool's dimension. ParameterError: unknown frame.
        """
        if frame not in ("sensor", "base"):
            raise ParameterError(f"frame must be 'sensor' or 'base'; got {frame!r}")
        d, nt = self.dim, (1 if self.dim == 2 else 3)
        Rs = np.asarray(R, dtype=np.float64)
        single = Rs.ndim == 2
        Rs = Rs.reshape(-1, *Rs.shape[-2:]) if Rs.ndim in (2, 3) else Rs
        if Rs.ndim != 3 or Rs.shape[1:] != (d, d):
            raise DimensionError(f"R must have shape ({d}, {d}) or (k, {d}, {d}); got shape {np.shape(R)}")
        k = Rs.shape[0]
        F = np.asarray(force, dtype=np.float64)
        if F.size != k * d:
            raise DimensionError(f"force must have shape {(d,) if single else (k, d)}; got shape {F.shape}")
        u = np.einsum("kji,j->ki", Rs, _gravity_vector(d, self.gravity))
        w = self.mass * u
        f = F.reshape(k, d) + w - self.force_bias
        if frame == "base":
            f = np.einsum("kij,kj->ki", Rs, f)
        tau_out = None
        if torque is not None:
            T = np.asarray(torque, dtype=np.float64)
            if T.size != k * nt:
                raise DimensionError(f"torque must have {nt} entries per reading ({k} readings); got shape {T.shape}")
            if d == 2:
                pred = -(self.com[0] * w[:, 1] - self.com[1] * w[:, 0])[:, None]
            else:
                pred = -np.cross(self.com, w)
            tau = T.reshape(k, nt) - pred - self.torque_bias
            if frame == "base" and d == 3:
                tau = np.einsum("kij,kj->ki", Rs, tau)
            tau_out = tau[0] if single else tau.reshape(T.shape)
        return (f[0] if single else f), tau_out

    def describe(self) -> dict[str, Any]:
        return {"mass": self.mass, "com": self.com.tolist(), "force_bias": self.force_bias.tolist(),
                "torque_bias": self.torque_bias.tolist()}


def identify_tool_gravity(rotations: Any, forces: Any, torques: Any = None, *, gravity: float = 9.81) -> ToolGravity:
    """Tool mass, centre of mass and sensor bias from static readings in a few poses (least squares).

    The readings follow :class:`ToolGravity`'s convention (the sensor holds the tool up). Forces
    first, linear in (m, b_f): ``f_i = −(R_iᵀ g) m + b_f``. Then, with ``w_i = m R_iᵀ g``, moments
    linear in (c, b_τ): ``τ_i = [w_i]× c + b_τ`` (3-D) or ``τ_i = w_x c_y − w_y c_x + b_τ``
    (planar). Needs at least two tool orientations relative to gravity for the forces and, for
    the centre of mass, three in 3-D (two in the plane).

    Args:
        rotations: sensor orientations R_i, (k, d, d) with d = 2 or 3.
        forces: force readings in the sensor frame, (k, d) [N].
        torques: moment readings, (k,) planar or (k, 3) [N m]; None = centre of mass not identified.
        gravity: |g| [m/s²].

    Raises:
        DimensionError: shapes do not match. ParameterError: the poses do not excite the
            unknowns (rank deficient), or the identified mass is negative.
    """
    R = np.asarray(rotations, dtype=np.float64)
    F = np.asarray(forces, dtype=np.float64)
    if R.ndim != 3 or R.shape[1] != R.shape[2] or R.shape[1] not in (2, 3):
        raise DimensionError(f"rotations must have shape (k, 2, 2) or (k, 3, 3); got shape {R.shape}")
    k, d = R.shape[0], R.shape[1]
    if F.shape != (k, d):
        raise DimensionError(f"forces must have shape ({k}, {d}) like the rotations; got shape {F.shape}")
    g = _gravity_vector(d, positive_scalar("gravity", gravity))
    A = _force_regressor(np.einsum("kji,j->ki", R, g))  # u_i = R_iᵀ g
    if np.linalg.matrix_rank(A) < 1 + d:
        raise ParameterError(
            f"the {k} poses do not excite the tool mass: give at least two sensor orientations with "
            "different directions of gravity in the sensor frame"
        )
    x = np.linalg.lstsq(A, F.reshape(-1), rcond=None)[0]
    mass, b_f = float(x[0]), x[1:]
    if mass < -1e-9 * (1.0 + float(np.abs(F).max()) / float(np.linalg.norm(g))):
        raise ParameterError(f"the identified tool mass is negative ({mass:.6g} kg): check the sign of gravity and the frames")
    tool = ToolGravity(max(mass, 0.0), None, b_f, None, dim=d, gravity=gravity)
    if torques is None:
        return tool
    T = np.asarray(torques, dtype=np.float64)
    nt = 1 if d == 2 else 3
    if T.reshape(k, -1).shape != (k, nt) or T.size != k * nt:
        raise DimensionError(f"torques must have shape ({k},) (planar) or ({k}, 3); got shape {T.shape}")
    T = T.reshape(k, nt)
    At = _torque_regressor(np.array([tool.weight_in_sensor(R[i]) for i in range(k)]))
    if np.linalg.matrix_rank(At) < d + nt:
        need = "two" if d == 2 else "three"
        raise ParameterError(
            f"the {k} poses do not excite the centre of mass: give at least {need} sensor orientations "
            "with non-parallel gravity directions in the sensor frame"
        )
    y = np.linalg.lstsq(At, T.reshape(-1), rcond=None)[0]
    return ToolGravity(tool.mass, y[:d], b_f, y[d:], dim=d, gravity=gravity)


class RealisticForceSensor(ForceSensor):
    """A wrist F/T sensor as on a real arm, with the usual corrections; runs in the Python loop.

    At sample k (t_k = k Ts), with R_S(q) the sensor orientation and h_e the true contact force
    (base frame), the chain is::

        raw_k  = R_Sᵀ (h_e − m_tool g) + b + ḃ t_k + n_k                 (sensor frame)
        qnt_k  = Δ round(raw_k / Δ)                                      (converter, Δ = resolution)
        flt_k  = filter(qnt_k)                                           (none | first-order | butterworth)
        out_k  = flt_{k−d}  (d = delay_samples; flt_0 before the first d samples)
        h_m,k  = R_S out_k + m̂_tool g − R_S b̂                           (base frame, compensated)

    ``b̂`` comes from zeroing: at start, ``zeroing_samples`` readings of the arm at rest (in free
    space: contact at start gets zeroed away, as on a real arm) are averaged and the expected
    tool reading ``−R_Sᵀ m̂ g`` is removed from the mean. The tool's sign convention is
    :class:`ToolGravity`'s (the sensor holds the tool up against gravity). ``m̂`` is ``tool_estimate.mass`` (from
    :func:`identify_tool_gravity`), zero when not given. Zeroing does not remove drift: a force
    loop regulates the measured force, so in contact the true force moves by about −ḃ t; on a
    real arm re-zero in free space between contacts.

    The first-order filter is ForceSensor's ``y_k = y_{k−1} + α (x_k − y_{k−1})``,
    ``α = 1 − exp(−2π f_c Ts)``; ``"butterworth"`` is the second-order Butterworth low-pass by the
    bilinear transform with pre-warping (``K = tan(π f_c Ts)``). Both start at rest on the first
    sample (no start-up transient).

    Args:
        noise_std, bias, cutoff, seed: as :class:`ForceSensor` (bias in the sensor frame).
        filter: ``"first-order"`` (default when a cutoff is given), ``"butterworth"`` or ``"none"``.
        drift: bias drift rate ḃ in the sensor frame [N/s], scalar or per component.
        resolution: quantisation step Δ [N], >= 0 (0 = none).
        delay_samples: transport delay d [samples], integer >= 0.
        tool: the true tool (its weight is measured); None = no tool.
        tool_estimate: the tool model used for compensation; None = no compensation.
        zeroing_samples: readings averaged at start to estimate the bias; 0 = no zeroing.
        orientation: ``q -> R_S`` (d, d); :func:`planar_sensor_rotation` when a tool is given
            on a planar arm, identity otherwise.
    """

    def __init__(
        self,
        noise_std: Any = 0.0,
        bias: Any = 0.0,
        cutoff: float | None = None,
        seed: int = 0,
        *,
        filter: str | None = None,
        drift: Any = 0.0,
        resolution: float = 0.0,
        delay_samples: int = 0,
        tool: ToolGravity | None = None,
        tool_estimate: ToolGravity | None = None,
        zeroing_samples: int = 0,
        orientation: Any = None,
    ) -> None:
        super().__init__(noise_std, bias, cutoff, seed)
        kind = ("first-order" if cutoff is not None else "none") if filter is None else filter
        if kind not in _FILTERS:
            raise ParameterError(f"filter must be one of {', '.join(repr(f) for f in _FILTERS)}; got {filter!r}")
        if kind != "none" and cutoff is None:
            raise ParameterError(f"filter {kind!r} needs a cutoff [Hz]; got cutoff=None")
        if kind == "none" and cutoff is not None:
            raise ParameterError(f"filter 'none' takes no cutoff; got cutoff={cutoff!r}")
        self.filter = kind
        self.drift = np.array(drift, dtype=np.float64)
        if self.drift.ndim > 1:
            raise DimensionError(f"drift must be a scalar or a vector; got shape {self.drift.shape}")
        if not np.all(np.isfinite(self.drift)):
            raise ParameterError(f"drift must be finite [N/s]; got {self.drift.tolist()}")
        try:
            res = float(resolution)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"resolution must be a non-negative number [N]; got {resolution!r}") from exc
        if not math.isfinite(res) or res < 0.0:
            raise ParameterError(f"resolution must be a non-negative number [N]; got {resolution!r}")
        self.resolution = res
        for name, v in (("delay_samples", delay_samples), ("zeroing_samples", zeroing_samples)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
                raise ParameterError(f"{name} must be a non-negative integer; got {v!r}")
        self.delay_samples = int(delay_samples)
        self.zeroing_samples = int(zeroing_samples)
        for name, part in (("tool", tool), ("tool_estimate", tool_estimate)):
            if part is not None and not isinstance(part, ToolGravity):
                raise ParameterError(f"{name} must be a ToolGravity or None; got {type(part).__name__}")
        self.tool = tool
        self.tool_estimate = tool_estimate
        if orientation is not None and not callable(orientation):
            raise ParameterError(f"orientation must be a callable q -> R_S or None; got {type(orientation).__name__}")
        self.orientation = orientation
        self.bias_estimate: np.ndarray | None = None
        self._k = -1
        self._last = np.zeros(0)

    @property
    def compiled_ok(self) -> bool:
        """False: this sensor is stateful and runs in the simulator's Python loop."""
        return False

    @property
    def exact(self) -> bool:
        """True when the sensor returns the true wrench unchanged."""
        return (
            super().exact and not np.any(self.drift) and self.resolution == 0.0 and self.delay_samples == 0
            and (self.tool is None or self.tool.mass == 0.0) and self.zeroing_samples == 0
            and (self.tool_estimate is None or self.tool_estimate.mass == 0.0)
        )

    def _rotation(self, q: np.ndarray | None, dim: int) -> np.ndarray:
        if self.orientation is not None:
            R = np.asarray(self.orientation(q), dtype=np.float64)
            if R.shape != (dim, dim):
                raise DimensionError(f"orientation(q) must return a ({dim}, {dim}) rotation; got shape {R.shape}")
            return R
        if self.tool is not None and dim == 2 and q is not None:
            return planar_sensor_rotation(q)
        return np.eye(dim)

    def filter_coefficients(self, sample_time: float) -> tuple[np.ndarray, np.ndarray]:
        """Digital filter (b, a), ``a[0] = 1``, of ``y_k = Σ b_i x_{k−i} − Σ_{i≥1} a_i y_{k−i}``.

        Raises:
            ParameterError: the cut-off is at or above the Nyquist frequency.
        """
        if self.filter == "none":
            return np.array([1.0]), np.array([1.0])
        alpha = self.alpha(sample_time)  # checks the Nyquist limit
        if self.filter == "first-order":
            return np.array([alpha]), np.array([1.0, alpha - 1.0])
        K = math.tan(math.pi * float(self.cutoff or 0.0) * sample_time)  # cutoff is set: the filter is not 'none'
        norm = 1.0 / (1.0 + math.sqrt(2.0) * K + K * K)
        b0 = K * K * norm
        a1 = 2.0 * (K * K - 1.0) * norm
        a2 = (1.0 - math.sqrt(2.0) * K + K * K) * norm
        return np.array([b0, 2.0 * b0, b0]), np.array([1.0, a1, a2])

    def _quantise(self, x: np.ndarray) -> np.ndarray:
        return self.resolution * np.round(x / self.resolution) if self.resolution > 0.0 else x

    def _raw(self, t: float, h: np.ndarray, R: np.ndarray, noise: np.ndarray) -> np.ndarray:
        w = np.asarray(h, dtype=np.float64)
        if self.tool is not None:
            w = w - self.tool.mass * _gravity_vector(w.shape[0], self.tool.gravity)
        return self._quantise(R.T @ w + self._b + self._drift * t + noise)

    def start(self, n_samples: int, dim: int, sample_time: float, h0: Any, q0: Any = None) -> np.ndarray:
        """Prepare a run of ``n_samples`` samples: draw the noise, zero the sensor, reset the filter.

        Returns:
            The measurement at sample 0 (the same value ``measure(0, …)`` then returns).
        """
        bias, noise = self.sequences(n_samples + self.zeroing_samples, dim)
        try:
            self._drift = np.broadcast_to(self.drift, (dim,)).astype(np.float64)
        except ValueError as exc:
            raise DimensionError(f"drift must be a scalar or have shape ({dim},); got shape {self.drift.shape}") from exc
        self._b = bias
        self._noise = noise[self.zeroing_samples :]
        self._b_num, self._a_den = self.filter_coefficients(sample_time)
        self._dim = dim
        q0a = None if q0 is None else np.asarray(q0, dtype=np.float64)
        R0 = self._rotation(q0a, dim)
        g = _gravity_vector(dim, self.tool_estimate.gravity if self.tool_estimate else 9.81)
        self._m_hat = self.tool_estimate.mass if self.tool_estimate is not None else 0.0
        self._g = g
        if self.zeroing_samples:
            z = np.array([self._raw(0.0, h0, R0, noise[j]) for j in range(self.zeroing_samples)])
            self.bias_estimate = z.mean(axis=0) + R0.T @ (self._m_hat * g)
        else:
            self.bias_estimate = np.zeros(dim)
        self._x_hist: list[np.ndarray] = []
        self._y_hist: list[np.ndarray] = []
        self._out: deque[np.ndarray] = deque(maxlen=self.delay_samples + 1)
        self._k = -1
        return self.measure(0, 0.0, h0, q0a)

    def measure(self, k: int, t: float, h: Any, q: Any = None) -> np.ndarray:
        """The compensated measurement (base frame) at sample k; the same k twice gives the same value.

        Args:
            k: sample index (0, 1, 2, ... in order); t: its time [s].
            h: true contact force h_e (base frame), (d,) [N]; q: joint positions (for R_S).
        """
        if k == self._k:
            return self._last.copy()
        if k != self._k + 1:
            raise ParameterError(f"measure must be called for samples 0, 1, 2, ... in order; got {k} after {self._k}")
        if k >= len(self._noise):
            raise ParameterError(f"measure: sample {k} is beyond the {len(self._noise)} samples prepared by start()")
        qa = None if q is None else np.asarray(q, dtype=np.float64)
        R = self._rotation(qa, self._dim)
        x = self._raw(t, h, R, self._noise[k])
        b, a = self._b_num, self._a_den
        if k == 0:  # start at rest on the first sample
            self._x_hist = [x] * len(b)
            self._y_hist = [x] * (len(a) - 1)  # y_{k−1}, y_{k−2}, ...
        self._x_hist = [x, *self._x_hist[:-1]]
        y = sum(b[i] * self._x_hist[i] for i in range(len(b))) - sum(a[i] * self._y_hist[i - 1] for i in range(1, len(a)))
        self._y_hist = [y, *self._y_hist[:-1]]
        self._out.append(y)  # holds flt_{k−d} ... flt_k (flt_0 ... flt_k while k < d)
        out_s = self._out[0]
        hm = R @ out_s + self._m_hat * self._g - R @ self.bias_estimate
        self._k = k
        self._last = hm
        return hm.copy()

    def describe(self) -> dict[str, Any]:
        return {
            **super().describe(),
            "kind": "realistic",
            "filter": self.filter,
            "drift": self.drift.tolist(),
            "resolution": self.resolution,
            "delay_samples": self.delay_samples,
            "zeroing_samples": self.zeroing_samples,
            "tool": None if self.tool is None else self.tool.describe(),
            "tool_estimate": None if self.tool_estimate is None else self.tool_estimate.describe(),
        }
