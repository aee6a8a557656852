"""Input checks shared by constructors and loaders (never ``assert``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import DimensionError, ParameterError

__all__ = [
    "as_vector",
    "as_matrix",
    "as_gain_matrix",
    "positive_scalar",
    "nonnegative_scalar",
    "gain_scalar",
    "check_gain_size",
    "readonly",
]


def readonly(a: np.ndarray) -> np.ndarray:
    """Return ``a`` made read-only (it must already be a private copy)."""
    a.flags.writeable = False
    return a


def _numbers(name: str, value: Any, what: str) -> None:
    """Refuse text, booleans and objects where numbers are expected (``float("100")`` would pass)."""
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_)):
        return  # the common scalar case, at no cost
    if isinstance(value, (str, bytes)):
        kind = "U"
    else:
        try:
            kind = np.asarray(value).dtype.kind
        except (TypeError, ValueError):  # ragged nesting: the caller's conversion names it
            return
    if kind not in "iuf":
        raise ParameterError(f"{name} must be {what} (numbers, not text or booleans); got {value!r}")


def _plain_number(x: Any) -> bool:
    """A Python int or float (not a bool): what a TOML file or a literal gives for a number."""
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _finite(name: str, a: np.ndarray) -> None:
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{name} must be finite; got {a.tolist()}")


def as_vector(name: str, value: Any, size: int | None = None) -> np.ndarray:
    """Copy ``value`` into a read-only float64 vector, checking its length and finiteness."""
    _numbers(name, value, "a vector of numbers")
    try:
        a = np.array(value, dtype=np.float64).reshape(-1) if np.ndim(value) <= 1 else None
    except (TypeError, ValueError, OverflowError) as exc:
        raise ParameterError(f"{name} must be a vector of numbers; got {value!r}") from exc
    if a is None:
        raise DimensionError(f"{name} must be a vector; got shape {np.shape(value)}")
    if size is not None and a.shape != (size,):
        raise DimensionError(f"{name} must have shape ({size},); got shape {a.shape}")
    _finite(name, a)
    return readonly(a)


def as_matrix(name: str, value: Any, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Copy ``value`` into a read-only float64 matrix of the given shape."""
    _numbers(name, value, "a matrix of numbers")
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ParameterError(f"{name} must be a matrix of numbers; got {value!r}") from exc
    if a.ndim != 2 or (shape is not None and a.shape != shape):
        want = f"{shape}" if shape is not None else "a 2-D matrix"
        raise DimensionError(f"{name} must have shape {want}; got shape {a.shape}")
    _finite(name, a)
    return readonly(a)


def as_square(what: str, value: Any, size: int) -> np.ndarray:
    """A finite (size, size) float matrix: a scalar means ``value * I``, a (size,) vector ``diag(value)``.

    ``what`` starts every message (e.g. ``"stiffness must be a (2, 2) matrix"``): ParameterError for
    values that are not numbers or not finite, DimensionError for another shape.
    """
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ParameterError(f"{what}; got {value!r}"[:2000]) from exc
    if a.ndim == 0:
        a = float(a) * np.eye(size)
    elif a.shape == (size,):
        a = np.diag(a)
    if a.shape != (size, size):
        raise DimensionError(f"{what}; got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{what}; got non-finite entries {a.tolist()}")
    return a


def as_gain_matrix(
    name: str,
    value: Any,
    size: int,
    *,
    definite: bool = True,
    diagonal_ok: bool = True,
) -> np.ndarray:
    """A symmetric positive (semi-)definite ``(size, size)`` gain or stiffness matrix.

    A scalar means ``value * I``; a vector of length ``size`` means ``diag(value)``.

    Args:
        name: the parameter's public name, used in messages.
        value: scalar, vector or matrix.
        size: the matrix dimension.
        definite: require positive definite (else positive semi-definite).
        diagonal_ok: accept scalars and vectors as diagonal shorthands.
    """
    kind = "positive definite" if definite else "positive semi-definite"
    if diagonal_ok and _plain_number(value):
        # a Python scalar (most gains): value * I, its eigenvalue is value (no array work)
        v = _float(name, value, "finite")
        if not math.isfinite(v):
            raise ParameterError(f"{name} must be finite; got {v}")
        _check_eigenvalues(name, kind, size, [v] * size, definite)
        return readonly(v * np.eye(size))
    if diagonal_ok and isinstance(value, (list, tuple)) and len(value) == size and all(map(_plain_number, value)):
        # a diagonal written as a list (a TOML file's gains): its entries are its eigenvalues
        d = [_float(name, x, "finite") for x in value]
        if not all(map(math.isfinite, d)):
            raise ParameterError(f"{name} must be finite; got {d}")
        _check_eigenvalues(name, kind, size, d, definite)
        return readonly(np.diag(d))
    _numbers(name, value, f"a symmetric {kind} ({size}, {size}) matrix, a vector or a scalar")
    try:
        a = np.array(value, dtype=np.float64)
    except OverflowError:
        raise ParameterError(f"{name} must be finite; got an integer too large for a float (above 1.8e308)") from None
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a symmetric {kind} ({size}, {size}) matrix; got {value!r}") from exc
    if a.dtype == object or not np.all(np.isfinite(a)):
        raise ParameterError(f"{name} must be finite; got {a.tolist()}")
    if diagonal_ok and a.ndim <= 1 and a.size in (1, size) and (a.ndim == 0 or a.shape == (size,)):
        # a scalar or a diagonal: symmetric, its eigenvalues are its entries (no eigensolver)
        d = np.broadcast_to(a, (size,)).astype(np.float64)
        _check_eigenvalues(name, kind, size, d.tolist(), definite)
        return readonly(np.diag(d))
    if a.shape != (size, size):
        raise DimensionError(
            f"{name} must be a symmetric {kind} ({size}, {size}) matrix; got shape {a.shape}"
        )
    off = a - np.diag(np.diagonal(a))
    if not off.any():  # a diagonal matrix (e.g. a plane's k n nᵀ along an axis): its entries are its eigenvalues
        _check_eigenvalues(name, kind, size, np.diagonal(a).tolist(), definite)
        return readonly(a)
    scale = max(1.0, float(np.max(np.abs(a))))
    if float(np.max(np.abs(a - a.T))) > 1e-12 * scale:  # allclose(a, aᵀ, rtol=0), at a tenth of its cost
        raise ParameterError(f"{name} must be a symmetric {kind} ({size}, {size}) matrix; got a non-symmetric matrix")
    a = 0.5 * (a + a.T)
    _check_eigenvalues(name, kind, size, np.linalg.eigvalsh(a).tolist(), definite, scale)
    return readonly(a)


def _digits(value: int) -> str:
    """How many digits an integer has, for a message (without printing it)."""
    try:
        return f"{len(str(abs(value)))} digits"
    except ValueError:  # beyond Python's int-to-str limit
        return f"about {int(abs(value).bit_length() * math.log10(2)) + 1} digits"


def _float(name: str, value: Any, want: str) -> float:
    """``float(value)``; an integer too large for a float is a ParameterError naming its digit count (not OverflowError)."""
    try:
        return float(value)
    except OverflowError:
        n = _digits(int(value)) if isinstance(value, int) else "too large"
        raise ParameterError(f"{name} must be {want}; got an integer of {n}, beyond a float's range (1.8e308)") from None


#: the largest gain, stiffness or inertia entry accepted by :func:`as_gain_matrix` (SI units)
MAX_GAIN = 1e12


def _check_eigenvalues(name: str, kind: str, size: int, w: list[float], definite: bool, scale: float | None = None) -> None:
    """Refuse eigenvalues ``w`` of a symmetric gain that are not (semi-)positive, at 1e-12 of its scale.

    ``scale`` is ``max(1, max |a_ij|)`` (the largest |eigenvalue| when the matrix is diagonal).
    """
    top = max(abs(x) for x in w)
    if top > MAX_GAIN:  # 1e300 N/m passed every check and overflowed in the loop (every torque inf or 0)
        raise ParameterError(f"{name} must have entries of at most {MAX_GAIN:.0e} in magnitude (far beyond any arm or "
                             f"contact); got an eigenvalue of {top:.4g}")
    if scale is None:
        scale = max(1.0, top)
    tol = 1e-12 * scale
    if (min(w) <= tol) if definite else (min(w) < -tol):
        raise ParameterError(
            f"{name} must be a symmetric {kind} ({size}, {size}) matrix; got eigenvalues {np.round(np.sort(w), 9).tolist()}"
        )


def _scalar(name: str, value: Any, what: str, unit: str, ok: Any) -> float:
    """A finite float for which ``ok(v)`` holds, else ParameterError naming ``what`` (and ``unit``)."""
    _numbers(name, value, what)
    want = f"{what} [{unit}]" if unit else what
    try:
        v = _float(name, value, want)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be {want}; got {value!r}") from exc
    if not math.isfinite(v) or not ok(v):
        raise ParameterError(f"{name} must be {want}; got {value!r}")
    return v


def positive_scalar(name: str, value: Any, unit: str = "") -> float:
    """A finite number > 0 (``unit`` is named in the message)."""
    return _scalar(name, value, "a positive number", unit, lambda v: v > 0.0)


def nonnegative_scalar(name: str, value: Any, unit: str = "") -> float:
    """A finite number >= 0 (``unit`` is named in the message)."""
    return _scalar(name, value, "a non-negative number", unit, lambda v: v >= 0.0)


def check_gain_size(name: str, values: Any, unit: str = "") -> None:
    """Refuse a gain with an entry above :data:`MAX_GAIN` in magnitude (a finite 1.7e308 passed every other check).

    Raises:
        ParameterError: naming ``name``, the bound and the largest entry.
    """
    a = np.abs(np.asarray(values, dtype=np.float64))
    top = float(np.max(a)) if a.size else 0.0
    if top > MAX_GAIN:
        u = f" {unit}" if unit else ""
        raise ParameterError(f"{name} must have entries of at most {MAX_GAIN:.0e}{u} in magnitude (far beyond any arm or "
                             f"contact); got {top:.4g}")


def gain_scalar(name: str, value: Any, unit: str = "", *, positive: bool = False) -> float:
    """A finite gain ``>= 0`` (``> 0`` when ``positive``) of at most :data:`MAX_GAIN` (``unit`` named in messages)."""
    v = positive_scalar(name, value, unit) if positive else nonnegative_scalar(name, value, unit)
    check_gain_size(name, v, unit)
    return v


def is_number(value: Any) -> bool:
    """Whether ``float(value)`` succeeds (a table cell that reads as a number)."""
    try:
        float(value)
    except (TypeError, ValueError):
        return False
    return True


def stiffness_range_arg(stiffness_range: Any) -> tuple[float, float]:
    """``(k_min, k_max)`` in N/m with ``0 < k_min <= k_max < inf`` (a design's environment range).

    Raises:
        ParameterError: not two numbers, or not in that order and range.
    """
    try:
        k_min, k_max = (float(v) for v in stiffness_range)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"stiffness_range must be (k_min, k_max) in N/m; got {stiffness_range!r}") from exc
    if not (0.0 < k_min <= k_max < math.inf):
        raise ParameterError(f"stiffness_range must satisfy 0 < k_min <= k_max < inf; got {stiffness_range!r}")
    return k_min, k_max
