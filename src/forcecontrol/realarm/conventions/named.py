"""Named wrench conventions (the library's and the vendors') and the conversion of recorded arrays between them.

A :class:`WrenchConvention` says three things about recorded wrench samples: the axes they are
expressed in (the robot's ``"base"`` frame, UR's controller base ``"ur-base"`` (Rz(180°) from the
``base_link`` of the UR models) or the ``"end-effector"``/sensor frame, which rotates with the
arm), the point the moment is about (the end-effector origin, or a point fixed in the end-effector
frame such as UR's tool flange) and the sense. :data:`CONVENTIONS` names the ones
the adapters of :mod:`.vendors` and :mod:`.ros` document; :func:`convert_wrenches` converts
(N, m) samples from one to another, given the end-effector's orientation at every sample when
either side uses end-effector axes or an offset point.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import DimensionError, MeasurementError, ParameterError
from .wrench import BY_END_EFFECTOR, ON_END_EFFECTOR

__all__ = ["WrenchConvention", "CONVENTIONS", "AXES", "UR_BASE_IN_BASE_LINK", "convention", "convert_wrenches"]

#: the axes a convention may use (:attr:`WrenchConvention.axes`)
AXES = ("base", "ur-base", "end-effector")
#: the rotation of UR's controller base (ur_description's ``base``) in ``base_link``: Rz(180°), its own inverse
UR_BASE_IN_BASE_LINK = np.diag([-1.0, -1.0, 1.0])
_UR_BASE = np.diag(UR_BASE_IN_BASE_LINK)  # the same, on the rows of f and μ


@dataclass(frozen=True)
class WrenchConvention:
    """How a source reports a wrench.

    Attributes:
        name: the key in :data:`CONVENTIONS`.
        axes: ``"base"``, ``"ur-base"`` (a UR controller's base frame: ur_description's ``base``, rotated 180°
            about z from ``base_link``, the UR models' root and so the library's base) or ``"end-effector"``
            (the end-effector / sensor / K / site frame).
        point: ``"end-effector"`` (its origin) or ``"flange"`` (a point at ``flange_offset`` in the
            end-effector frame, see :func:`convert_wrenches`).
        sense: :data:`~forcecontrol.realarm.conventions.BY_END_EFFECTOR` or ``ON_END_EFFECTOR``.
        doc: what it is, with the vendor's field name.
    """

    name: str
    axes: str
    point: str
    sense: str
    doc: str

    def __post_init__(self) -> None:
        for field, value, allowed in (("axes", self.axes, AXES), ("point", self.point, ("end-effector", "flange")),
                                      ("sense", self.sense, (BY_END_EFFECTOR, ON_END_EFFECTOR))):
            if value not in allowed:
                raise ParameterError(f"WrenchConvention {field} must be one of {allowed}; got {value!r}")

    @property
    def needs_orientation(self) -> bool:
        """True when converting to or from it needs the end-effector's orientation at each sample."""
        return self.axes == "end-effector"

    def describe(self) -> dict[str, str]:
        """Plain values (for file metadata)."""
        return {"name": self.name, "axes": self.axes, "point": self.point, "sense": self.sense, "doc": self.doc}


#: The conventions ``forcecontrol convert`` knows (sources: :mod:`.vendors`, :mod:`.ros`).
CONVENTIONS: dict[str, WrenchConvention] = {
    c.name: c
    for c in (
        WrenchConvention("library", "base", "end-effector", BY_END_EFFECTOR,
                         "the chapter's h_e: by the end-effector on the environment, base axes, about the end-effector"),
        WrenchConvention("franka-O", "base", "end-effector", BY_END_EFFECTOR,
                         "libfranka O_F_ext_hat_K: external wrench at the K frame, positive as the robot applies it, "
                         "base axes, about K"),
        WrenchConvention("franka-K", "end-effector", "end-effector", BY_END_EFFECTOR,
                         "libfranka K_F_ext_hat_K: external wrench at the K frame, positive as the robot applies it, "
                         "K axes, about K"),
        WrenchConvention("ur-tcp", "ur-base", "flange", ON_END_EFFECTOR,
                         "UR RTDE actual_TCP_force: external force on the tool, the controller's base axes (Rz(180°) from "
                         "base_link), about the flange (e-Series)"),
        WrenchConvention("mujoco", "end-effector", "end-effector", BY_END_EFFECTOR,
                         "MuJoCo force/torque sensors at a site on the tool: parent on child, site axes, about the site"),
        WrenchConvention("ros-on", "end-effector", "end-effector", ON_END_EFFECTOR,
                         "geometry_msgs/WrenchStamped in the sensor frame, about its origin, the wrench on the end-effector"),
        WrenchConvention("ros-by", "end-effector", "end-effector", BY_END_EFFECTOR,
                         "geometry_msgs/WrenchStamped in the sensor frame, about its origin, the wrench by the end-effector"),
    )
}


def convention(name: Any) -> WrenchConvention:
    """The convention called ``name`` (a key of :data:`CONVENTIONS`).

    Raises:
        ParameterError: an unknown name (the message lists the known ones).
    """
    if isinstance(name, WrenchConvention):
        return name
    if name not in CONVENTIONS:
        raise ParameterError(f"unknown wrench convention {name!r}; known: {', '.join(CONVENTIONS)}")
    return CONVENTIONS[name]


def _rotations(rotations: Any, N: int) -> np.ndarray:
    if rotations is None:
        raise ParameterError("this conversion needs the end-effector's orientation at every sample (rotations (N, 3, 3))")
    R = np.asarray(rotations, dtype=np.float64)
    if R.shape == (3, 3):
        R = np.broadcast_to(R, (N, 3, 3))
    if R.shape != (N, 3, 3):
        raise DimensionError(f"rotations must have shape ({N}, 3, 3) (one per sample) or (3, 3); got {R.shape}")
    if not np.all(np.isfinite(R)):
        raise MeasurementError("rotations contain NaN or inf")
    err = np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3)).max()
    if err > 1e-3:
        raise ParameterError(f"rotations must be orthonormal (RᵀR = I within 1e-3); the worst deviates by {err:.3g}")
    det = np.linalg.det(R)
    if np.any(det < 0.0):
        k = int(np.flatnonzero(det < 0.0)[0])
        raise ParameterError(f"rotations must be rotations (det R = +1); sample {k} is a reflection (det {det[k]:.3g})")
    if err > 1e-12:  # printed to a few digits (a CSV of 6 decimals is orthonormal to about 1e-6): the nearest rotation
        U, _, Vt = np.linalg.svd(R)
        R = U @ Vt
    return R


def convert_wrenches(
    wrench: Any,
    source: str | WrenchConvention,
    target: str | WrenchConvention,
    *,
    rotations: Any = None,
    flange_offset: Any = None,
) -> np.ndarray:
    """Convert recorded wrench samples from one convention to another.

    Via the library's convention: the sense is flipped when it differs (``h → −h``); end-effector
    axes are rotated into the base with ``R_e`` (``f = R_e f_e``, ``μ = R_e μ_e``), UR's controller
    base by Rz(180°) (x, y and their moments negated); a moment about
    the flange (at ``p`` in the end-effector frame) moves to the end-effector origin with
    ``μ_e = μ_p − r × f``, ``r = −R_e p`` (from the flange to the end-effector origin); then the
    inverse steps towards the target.

    Args:
        wrench: (N, m) samples: ``fx fy`` (m = 2, planar: z taken as 0), ``fx fy fz`` (3) or ``[f; μ]`` (6).
        source, target: convention names (:data:`CONVENTIONS`) or :class:`WrenchConvention` objects.
        rotations: R_e, the end-effector frame's orientation in the base frame, (N, 3, 3) or
            (3, 3); needed when either convention uses end-effector axes, or a flange offset is given.
            Orthonormal within 1e-3 (a matrix printed to a few digits) and projected onto the nearest
            rotation (SVD); a reflection is refused.
        flange_offset: the flange's position in the end-effector frame [m] (3,) for ``"ur-tcp"``
            (e-Series: the TCP's offset, negated); default zero (TCP at the flange, or CB3).

    Returns:
        (N, m) the converted samples.

    Raises:
        ParameterError: an unknown convention; a missing or non-orthonormal rotation.
        DimensionError: a wrench that is not (N, 2|3|6); a flange offset with a wrench without moments.
        MeasurementError: NaN or inf in the wrench or rotations.
    """
    src, dst = convention(source), convention(target)
    h = np.array(wrench, dtype=np.float64)
    if h.ndim == 1:
        h = h[None, :]
    if h.ndim != 2 or h.shape[1] not in (2, 3, 6):
        raise DimensionError(f"wrench must be (N, 2), (N, 3) or (N, 6) (fx fy [fz [mx my mz]]); got shape {h.shape}")
    if not np.all(np.isfinite(h)):
        r, c = np.argwhere(~np.isfinite(h))[0]
        raise MeasurementError(f"wrench[{r}, {c}] is not finite ({h[r, c]!r})")
    N, m = h.shape
    p = np.zeros(3) if flange_offset is None else np.array(flange_offset, dtype=np.float64).reshape(-1)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ParameterError(f"flange_offset must be 3 finite numbers [m]; got {flange_offset!r}")
    moves = (src.point == "flange") != (dst.point == "flange") and np.any(p != 0.0)
    if moves and m != 6:
        raise DimensionError(f"moving the moment to or from the flange needs all 6 components; the wrench has {m}")
    if src == dst:
        return h
    R = _rotations(rotations, N) if (src.needs_orientation or dst.needs_orientation or moves) else None
    f = np.zeros((N, 3))
    f[:, : min(m, 3)] = h[:, : min(m, 3)]
    mu = h[:, 3:].copy() if m == 6 else np.zeros((N, 3))
    if src.sense != BY_END_EFFECTOR:
        f, mu = -f, -mu
    if src.axes == "end-effector":
        f, mu = np.einsum("kij,kj->ki", R, f), np.einsum("kij,kj->ki", R, mu)
    elif src.axes == "ur-base":
        f, mu = f * _UR_BASE, mu * _UR_BASE
    if moves and src.point == "flange":
        r = -np.einsum("kij,j->ki", R, p)  # flange → end-effector origin, base axes
        mu = mu - np.cross(r, f)
    # now the library's convention; towards the target
    if moves and dst.point == "flange":
        r = np.einsum("kij,j->ki", R, p)  # end-effector origin → flange
        mu = mu - np.cross(r, f)
    if dst.axes == "end-effector":
        f, mu = np.einsum("kji,kj->ki", R, f), np.einsum("kji,kj->ki", R, mu)
    elif dst.axes == "ur-base":
        f, mu = f * _UR_BASE, mu * _UR_BASE
    if dst.sense != BY_END_EFFECTOR:
        f, mu = -f, -mu
    return np.hstack([f, mu]) if m == 6 else f[:, :m]
