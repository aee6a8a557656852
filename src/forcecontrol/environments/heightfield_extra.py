"""A height field given by a formula: bumps and Gaussian dips (holes), for wiping and hole searches (issue 31, item 4).

:class:`BumpField` is a :class:`~forcecontrol.environments.surfaces.HeightField` whose surface is the closed form

    h(x, y) = base + A cos(k (x − x_c)) cos(k (y − y_c)) − Σ_i d_i exp(−((x − x_i)² + (y − y_i)²) / (2 w_i²)),  k = 2π/L

(an egg-crate of bumps with a crest at (x_c, y_c), radius of curvature 1/(A k²) on the crests and in the
troughs; Gaussian dips of depth d_i and width w_i). The heights are also sampled on a grid (the
HeightField's spline, for the engines and drawings that read ``heights``), but the contact uses the formula
itself: the Gauss–Newton projection of the base class on h and its exact gradient, compiled
(:func:`project_on_bump_field`): the contact is evaluated at every integrator stage, about 90,000 times in a
2.6 s run of ``panda-spiral-search``, 28 µs each in Python and 6 µs compiled (the run: 4.2 s, then 3.5 s).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit

from ..core.numba_cache import kernel_array
from ..core.validate import _scalar, as_vector, positive_scalar
from ..errors import ParameterError
from .surfaces import PROJECTION_SETTLED, PROJECTION_STEPS, PROJECTION_STOP, HeightField

__all__ = ["BumpField", "project_on_bump_field"]

@njit(cache=True, inline="always")
def _bump_height_slope(x, y, base, A, k, cx, cy, dips):  # pragma: no cover - compiled
    """(h, h_x, h_y) of the module's formula at (x, y): :meth:`BumpField._height_slope`, compiled."""
    ax, ay = k * (x - cx), k * (y - cy)
    cosx, sinx, cosy, siny = math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay)
    h = base + A * cosx * cosy
    hx, hy = -A * k * sinx * cosy, -A * k * cosx * siny
    for i in range(dips.shape[0]):
        dx, dy = x - dips[i, 0], y - dips[i, 1]
        w = dips[i, 3]
        g = dips[i, 2] * math.exp(-(dx * dx + dy * dy) / (2.0 * w * w))
        w2 = w * w
        h -= g
        hx += g * dx / w2
        hy += g * dy / w2
    return h, hx, hy


@njit(cache=True)
def project_on_bump_field(px, py, pz, base, A, k, cx, cy, dips):  # pragma: no cover - compiled
    """The closest point s = (x, y, h(x, y)) of the field to p = (px, py, pz) by Gauss–Newton on |p − s(u)|²
    from the point straight below/above, and the outward unit normal ν there: (φ = ν·(p − s), x, y, h, ν_x,
    ν_y, ν_z, converged). ``dips`` is (n, 4) rows [x_i, y_i, d_i, w_i]; base, A, k = 2π/L, (cx, cy) as in the
    module's formula. The steps stop below PROJECTION_STOP, after PROJECTION_STEPS at most (the height fields'
    constants of surfaces.py); ``converged`` is False when the last one was still over PROJECTION_SETTLED:
    Gauss–Newton converges at the rate |φ| κ, so not near or beyond the surface's radius of curvature 1/κ,
    where the closest point stops being unique; the last iterate is returned."""
    x, y = px, py
    converged = False
    for _ in range(PROJECTION_STEPS):
        h, hx, hy = _bump_height_slope(x, y, base, A, k, cx, cy, dips)
        # T = [[1, 0], [0, 1], [hx, hy]]: (TᵀT) step = Tᵀ (p − s)
        r0, r1, r2 = px - x, py - y, pz - h
        b0, b1 = r0 + hx * r2, r1 + hy * r2
        a00, a01, a11 = 1.0 + hx * hx, hx * hy, 1.0 + hy * hy
        det = a00 * a11 - a01 * a01
        s0, s1 = (a11 * b0 - a01 * b1) / det, (a00 * b1 - a01 * b0) / det
        x += s0
        y += s1
        converged = abs(s0) <= PROJECTION_SETTLED and abs(s1) <= PROJECTION_SETTLED
        if abs(s0) < PROJECTION_STOP and abs(s1) < PROJECTION_STOP:
            break
    h, hx, hy = _bump_height_slope(x, y, base, A, k, cx, cy, dips)
    nrm = math.sqrt(hx * hx + hy * hy + 1.0)
    n0, n1, n2 = -hx / nrm, -hy / nrm, 1.0 / nrm
    return n0 * (px - x) + n1 * (py - y) + n2 * (pz - h), x, y, h, n0, n1, n2, converged


class BumpField(HeightField):
    """An elastic field of bumps and dips given by the formula of the module docstring (3-D).

    Args:
        origin: the grid's first point (x, y) [m]; spacing: its step [m]; shape: samples (nx, ny), >= 4 each.
        base: the mean height [m]; amplitude: A [m]; wavelength: L [m] > 0; crest: (x_c, y_c) [m] (default: origin).
        dips: rows ``[x_i, y_i, d_i, w_i]`` [m] (w_i > 0), or None.
        stiffness, damping, task_dim: see :class:`~forcecontrol.environments.surfaces.ElasticSurface`.
    """

    describe_type: ClassVar[str | None] = "bump-field"
    described: ClassVar[tuple[str, ...]] = ("origin", "spacing", "base", "amplitude", "wavelength", "stiffness", "damping")

    def __init__(self, origin: Any, spacing: float, shape: Any, base: float, amplitude: float = 0.0, wavelength: float = 1.0,
                 crest: Any = None, dips: Any = None, *, stiffness: float, damping: float = 0.0,
                 task_dim: int | None = None) -> None:
        if len(shape) != 2 or any(int(v) != v or v < 4 for v in shape):
            raise ParameterError(f"shape must be two integers >= 4 (samples along x and y); got {list(shape)!r}")
        # each named here: a NaN or infinity in any of them would only show as non-finite sampled heights
        self.base = _scalar("base", base, "a finite number", "m", math.isfinite)
        self.amplitude = _scalar("amplitude", amplitude, "a finite number", "m", math.isfinite)
        self.wavelength = positive_scalar("wavelength", wavelength, "m")
        sp = positive_scalar("spacing", spacing, "m")
        o = as_vector("origin", origin, 2)
        self.crest = o.copy() if crest is None else np.asarray(crest, dtype=np.float64)
        if self.crest.shape != (2,) or not np.all(np.isfinite(self.crest)):
            raise ParameterError(f"crest must be (x, y), finite [m]; got {np.asarray(crest).tolist()!r}")
        rows = np.zeros((0, 4)) if dips is None else np.asarray(dips, dtype=np.float64).reshape(-1, 4) \
            if np.size(dips) % 4 == 0 else None
        if rows is None or (rows.shape[0] and not (np.all(np.isfinite(rows)) and np.all(rows[:, 3] > 0))):
            raise ParameterError(f"dips must be rows [x, y, depth, width] of finite numbers with width > 0 [m]; got {dips!r}")
        self.dips = kernel_array(rows, frozen=True)  # read-only: what the compiled projection reads
        self._k = 2.0 * math.pi / self.wavelength
        self._dips = [tuple(float(v) for v in r) for r in rows]  # the same rows as floats, for the Python formula
        # Python floats for the contact's scalar arithmetic (NumPy scalars give the same numbers, three times slower)
        self._cx, self._cy = float(self.crest[0]), float(self.crest[1])
        x = o[0] + sp * np.arange(int(shape[0]))
        y = o[1] + sp * np.arange(int(shape[1]))
        H = np.array([[self._height_slope(xi, yj)[0] for yj in y] for xi in x])
        super().__init__(H, o, sp, stiffness, damping, task_dim=task_dim)

    def height_formula(self, x: float, y: float) -> tuple[float, float, float, float, float, float]:
        """(h, h_x, h_y, h_xx, h_xy, h_yy) of the formula at (x, y) [m, -, -, 1/m, 1/m, 1/m]."""
        h, hx, hy = self._height_slope(x, y)
        k, A = self._k, self.amplitude
        ax, ay = k * (x - self._cx), k * (y - self._cy)
        cx, sx, cy, sy = math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay)
        hxx, hxy, hyy = -A * k * k * cx * cy, A * k * k * sx * sy, -A * k * k * cx * cy
        for px, py, d, w in self._dips:
            dx, dy = x - px, y - py
            g = d * math.exp(-(dx * dx + dy * dy) / (2.0 * w * w))
            w2 = w * w
            hxx += g * (1.0 / w2 - dx * dx / (w2 * w2))
            hyy += g * (1.0 / w2 - dy * dy / (w2 * w2))
            hxy -= g * dx * dy / (w2 * w2)
        return h, hx, hy, hxx, hxy, hyy

    def _height_slope(self, x: float, y: float) -> tuple[float, float, float]:
        """(h, h_x, h_y) at (x, y): what the contact's projection reads (:meth:`height_formula` adds the second
        derivatives)."""
        k, A = self._k, self.amplitude
        ax, ay = k * (x - self._cx), k * (y - self._cy)
        cx, sx, cy, sy = math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay)
        h = self.base + A * cx * cy
        hx, hy = -A * k * sx * cy, -A * k * cx * sy
        for px, py, d, w in self._dips:
            dx, dy = x - px, y - py
            g = d * math.exp(-(dx * dx + dy * dy) / (2.0 * w * w))
            w2 = w * w
            h -= g
            hx += g * dx / w2
            hy += g * dy / w2
        return h, hx, hy

    def height(self, u: Any) -> float:
        """h at (x, y) [m] (the formula)."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        return self._height_slope(float(u[0]), float(u[1]))[0]

    def geometry(self, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """(φ, p_c, ν) by Gauss–Newton on |p − s(u)|², s(u) = (u, h(u)), from the point straight below/above
        (:func:`project_on_bump_field`)."""
        phi, x, y, h, n0, n1, n2, converged = project_on_bump_field(
            float(p[0]), float(p[1]), float(p[2]), self.base, self.amplitude, self._k, self._cx, self._cy, self.dips)
        if not converged and phi < 0.0:  # in contact (in free space the force is nil whatever the normal)
            self._projection_unresolved(p, phi, PROJECTION_STEPS)
        return phi, np.array((x, y, h)), np.array((n0, n1, n2))

    def path_curvature(self, x: float, y: float, direction: Any) -> float:
        """The normal curvature κ [1/m] of the surface at (x, y) along the horizontal ``direction`` (2,):
        ``κ = (d_ᵀ ∇²h d) / ((1 + (∇h·d)²) √(1 + |∇h|²))`` for the unit d (> 0: concave, the surface bends up,
        a trough; < 0: convex, a crest)."""
        d = np.asarray(direction, dtype=np.float64)
        d = d / np.linalg.norm(d)
        _h, hx, hy, hxx, hxy, hyy = self.height_formula(x, y)
        g = hx * d[0] + hy * d[1]
        second = hxx * d[0] * d[0] + 2.0 * hxy * d[0] * d[1] + hyy * d[1] * d[1]
        return second / ((1.0 + g * g) * math.sqrt(1.0 + hx * hx + hy * hy))

    def describe(self) -> dict[str, Any]:
        out = super().describe()
        out.update(crest=self.crest.tolist(), dips=self.dips.tolist())
        return out
