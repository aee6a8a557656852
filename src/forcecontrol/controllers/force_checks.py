"""The checks of the direct force schemes (Sect. 9.4): the diagonal C_F, the anti-windup bound,
and whether a force reference lies in the range of the environment's stiffness (Sect. 9.4.3)."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from ..core.validate import _plain_number, as_gain_matrix, check_gain_size, readonly
from ..errors import DimensionError, DriftWarning, ParameterError

__all__ = ["check_force_reference"]


def _diagonal_gain(name: str, value: Any, m: int, unit: str) -> np.ndarray:
    """The diagonal of a diagonal, non-negative (m, m) gain given as scalar, (m,) or (m, m)."""
    if _plain_number(value) or isinstance(value, (list, tuple)):
        # plain Python numbers (a literal or a TOML file): checked without array work
        items = [value] * m if _plain_number(value) else list(value)
        if len(items) == m and all(map(_plain_number, items)):
            d = [float(x) for x in items]
            if not all(map(math.isfinite, d)):
                raise ParameterError(f"{name} must be finite; got {d}")
            if min(d) < 0.0:
                raise ParameterError(f"{name} must be non-negative on every axis [{unit}]; got {d}")
            check_gain_size(name, d, unit)
            return readonly(np.array(d))
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(
            f"{name} must be a non-negative scalar, ({m},) vector or diagonal ({m}, {m}) matrix [{unit}]; got {value!r}"
        ) from exc
    if a.ndim == 0:
        d = np.full(m, float(a))
    elif a.shape == (m,):
        d = a.copy()
    elif a.shape == (m, m):
        if np.any(a - np.diag(np.diag(a))):
            raise ParameterError(
                f"{name} must be diagonal (C_F is a diagonal matrix, (9.41)); got off-diagonal "
                f"entries in {a.tolist()}"
            )
        d = np.diag(a).copy()
    else:
        raise DimensionError(
            f"{name} must be a scalar, a ({m},) vector or a diagonal ({m}, {m}) matrix [{unit}]; "
            f"got shape {a.shape}"
        )
    if not np.all(np.isfinite(d)):
        raise ParameterError(f"{name} must be finite; got {d.tolist()}")
    if np.any(d < 0.0):
        raise ParameterError(f"{name} must be non-negative on every axis [{unit}]; got {d.tolist()}")
    check_gain_size(name, d, unit)
    return readonly(d)


def _limit(value: Any, m: int) -> np.ndarray:
    """The anti-windup bound (m,) [m]; zeros (no clamping) for None.

    Per axis, a positive bound clamps; ``inf`` (or 0) leaves that axis unclamped, so that one
    axis can be clamped alone (e.g. ``[0.02, inf]``). Negative or NaN bounds are refused.
    """
    if value is None:
        return np.zeros(m)
    a = np.asarray(value, dtype=np.float64)
    if a.ndim == 0:
        a = np.full(m, float(a))
    if a.shape != (m,):
        raise DimensionError(f"integral_limit must be a scalar or have shape ({m},) [m]; got shape {a.shape}")
    if np.any(np.isnan(a)) or np.any(a < 0.0) or np.all((a == 0.0) | np.isinf(a)):
        raise ParameterError(
            f"integral_limit must be positive [m] (inf or 0 on an axis = no clamping there, not on all axes); "
            f"got {a.tolist()}"
        )
    return np.where(np.isinf(a), 0.0, a)


def check_force_reference(
    force: Any,
    environment_stiffness: Any,
    force_axes: Any,
    *,
    integral: bool = True,
    tolerance: float = 1e-9,
) -> bool:
    """Warn when the force reference f_d is not consistent with the environment (Sect. 9.4.3).

    A component of f_d outside R(K) cannot be balanced by the environment: along an axis where
    the force loop acts (non-zero C_F) it is read as a velocity reference and the end-effector
    drifts; along an axis where C_F is zero the scheme ignores it. Both are reported with a
    :class:`~forcecontrol.errors.DriftWarning`.

    Args:
        force: f_d, (m,) [N].
        environment_stiffness: K of (9.38), symmetric positive semi-definite (m, m) [N/m].
        force_axes: (m,) booleans, True where C_F has a non-zero entry.
        integral: the force loop has integral action or an integrating inner loop (all three
            chapter schemes do along their force axes).
        tolerance: relative size [–] below which a component counts as zero.

    Returns:
        True when f_d is consistent (no warning issued).
    """
    f = np.asarray(force, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(f)):
        raise ParameterError(f"force must be finite [N]; got {f.tolist()}")
    Kshape = np.shape(environment_stiffness)
    if len(Kshape) == 2 and Kshape[0] != f.shape[0]:
        raise DimensionError(
            f"force must have shape ({Kshape[0]},) like environment_stiffness {Kshape}; got shape {f.shape}"
        )
    m = f.shape[0]
    K = as_gain_matrix("environment_stiffness", environment_stiffness, m, definite=False)
    axes = np.asarray(force_axes, dtype=bool).reshape(-1)
    if axes.shape != (m,):
        raise DimensionError(f"force_axes must have shape ({m},); got shape {axes.shape}")
    return _check_force_reference(f, K, axes, integral, tolerance, stacklevel=3)


def _range_projector(K: np.ndarray) -> np.ndarray:
    """The orthogonal projector onto R(K) of a symmetric PSD K: ``K K⁺`` (``pinv``'s rcond 1e-12).

    A diagonal K projects on its axes with a non-zero entry; any other K through its eigenvectors
    (K symmetric: its singular values are |eigenvalues|).
    """
    if not np.any(K):
        return np.zeros_like(K)
    if not np.any(K - np.diag(np.diagonal(K))):
        d = np.abs(np.diagonal(K))
        return np.diag((d > 1e-12 * d.max()).astype(np.float64))
    w, V = np.linalg.eigh(K)
    s = np.abs(w)
    Vr = V[:, s > 1e-12 * s.max()]
    return Vr @ Vr.T


def _check_force_reference(f: np.ndarray, K: np.ndarray, axes: np.ndarray, integral: bool, tolerance: float,
                           stacklevel: int) -> bool:
    """:func:`check_force_reference` on inputs already checked (f finite (m,), K symmetric PSD, axes (m,) bool)."""
    scale = max(1.0, float(np.linalg.norm(f)))
    outside = f - _range_projector(K) @ f
    ok = True
    acted = np.where(axes, outside, 0.0)
    if np.linalg.norm(acted) > tolerance * scale:
        ok = False
        what = "drifts (the component acts as a velocity reference)" if integral else "is offset"
        warnings.warn(
            f"force reference f_d = {f.tolist()} N has components {np.round(acted, 9).tolist()} N "
            f"outside the range of the environment stiffness K along force-controlled axes "
            f"{np.flatnonzero(axes).tolist()}: the end-effector {what} there (Sect. 9.4.3); "
            f"plan f_d inside R(K)",
            DriftWarning,
            stacklevel=stacklevel,
        )
    ignored = np.where(axes, 0.0, f)
    if np.linalg.norm(ignored) > tolerance * scale:
        ok = False
        warnings.warn(
            f"force reference f_d = {f.tolist()} N has components {np.round(ignored, 9).tolist()} N "
            f"along axes {np.flatnonzero(~axes).tolist()} where C_F is zero: the scheme ignores "
            f"them and that force is not controlled",
            DriftWarning,
            stacklevel=stacklevel,
        )
    return ok
