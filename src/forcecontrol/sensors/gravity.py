"""The tool's weight on a force/torque sensor: its model (ToolGravity) and its identification from static poses."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.validate import nonnegative_scalar, positive_scalar
from ..errors import DimensionError, ParameterError

__all__ = ["planar_sensor_rotation", "ToolGravity", "identify_tool_gravity"]


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
        self.mass = nonnegative_scalar("tool mass", mass, "kg")
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
