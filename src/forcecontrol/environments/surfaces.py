"""Curved elastic surfaces: a sphere (a circle in 2-D), a cylinder and a height field.

Each surface is one-sided and frictionless, like :class:`~forcecontrol.environments.elastic.ElasticPlane`,
with the plane's normal replaced by the geometry's: with φ(x) the signed distance of the tip to the
undeformed surface (negative inside the environment), δ = −φ the penetration, ν = ∇φ the outward
unit normal at the closest surface point p_c = x − φ ν::

    h_e = max(0, k δ − c ν·ẋ) (−ν)   while δ > 0, else 0     (never pulls)

:meth:`ElasticSurface.geometry` gives (φ, p_c, ν). The surfaces work for the chapter's planar arm
(``dim = 2``: a circle is the sphere's cut by the arm's plane) and in 3-D; a 3-D surface with
``task_dim=6`` returns the 6-D wrench ``[f_e; 0]`` of a pose task (the contact acts at the
end-effector origin: no moment), reading the position ``x[:3]`` of the pose.

Add :class:`~forcecontrol.environments.friction.FrictionalContact` around any of them (or an
elastic plane) for Coulomb friction with stiction.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numba import njit

from ..core.files import read_bytes_limited
from ..core.validate import as_matrix, as_vector, nonnegative_scalar, positive_scalar
from ..errors import DimensionError, ParameterError
from .base import Environment, xyz

#: the closest-point Gauss–Newton of the height fields (:class:`HeightField`, ``heightfield_extra.BumpField``): at most
#: this many steps; it stops on a step below PROJECTION_STOP [m] and has settled if its last step was at most
#: PROJECTION_SETTLED [m] (it converges at the rate |φ| κ; see :meth:`ElasticSurface.take_projection_note`)
PROJECTION_STEPS, PROJECTION_STOP, PROJECTION_SETTLED = 50, 1e-13, 1e-9

__all__ = ["ElasticSurface", "ElasticSphere", "ElasticCylinder", "HeightField", "circle_wrench2"]


@njit(cache=True, inline="always")
def circle_wrench2(p, x0, x1, v0, v1):  # pragma: no cover - compiled
    """h_e of an elastic circle for the compiled planar loop (kind 3), ``p = [c0, c1, R, k, c]``: the
    arithmetic of :class:`ElasticSphere` in 2-D (``φ = |x − c| − R``, ``ν = (x − c)/|x − c|``).

    Inlined into its callers (the planar loop's ``wrench2``, ``ElasticPlane``'s circle path): no
    compile of its own, which every cold run paid (0.13 s) though only a circle uses it."""
    d0 = x0 - p[0]
    d1 = x1 - p[1]
    r = math.sqrt(d0 * d0 + d1 * d1)
    phi = r - p[2]
    if phi >= 0.0:
        return 0.0, 0.0
    if r < 1e-12:
        n0, n1 = 1.0, 0.0
    else:
        n0, n1 = d0 / r, d1 / r
    mag = -p[3] * phi - p[4] * (n0 * v0 + n1 * v1)
    if mag <= 0.0:
        return 0.0, 0.0
    return -mag * n0, -mag * n1


def _unit(name: str, value: Any, size: int) -> np.ndarray:
    v = np.array(as_vector(name, value, size))
    norm = float(np.linalg.norm(v))
    if not norm > 1e-12:
        raise ParameterError(f"{name} must be a non-zero vector; got {v.tolist()}")
    return v / norm


def _pushing(f: float) -> float:
    """max(0, f) that keeps a NaN (Python's max(0.0, nan) is 0.0: a NaN position or velocity gave no force)."""
    return f if not f <= 0.0 else 0.0


class ElasticSurface(Environment):
    """A one-sided elastic surface given by its geometry (base class of the curved surfaces).

    Subclasses give :meth:`geometry`; this class turns it into the contact wrench.

    Args (common):
        stiffness: k along the local normal [N/m], > 0.
        damping: c along the local normal [N s/m], >= 0.
        task_dim: the robot's task dimension: the geometry's (2 or 3), or 6 for a 3-D surface under
            a pose task (``x = [o_e; φ_e]``).
    """

    #: the geometry's dimension (2 or 3).
    space: int
    #: the contact is at o_e: the wrench reads x[:space] and ẋ[:space] only.
    reads_orientation: ClassVar[bool] = False

    def _common(self, space: int, stiffness: float, damping: float, task_dim: int | None) -> None:
        self.space = space
        self.stiffness = positive_scalar("stiffness", stiffness, "N/m")
        self.damping = nonnegative_scalar("damping", damping, "N s/m")
        td = space if task_dim is None else task_dim
        if td != space and not (space == 3 and td == 6):
            raise DimensionError(f"task_dim must be {space}" + (" or 6" if space == 3 else "") + f" for this surface; got {td!r}")
        self.dim = int(td)

    def geometry(self, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:  # pragma: no cover - abstract
        """(φ, p_c, ν) at the point p (space,) [m]: the signed distance (negative inside), the closest
        point of the undeformed surface and the outward unit normal there."""
        raise NotImplementedError

    def _projection_unresolved(self, p: Any, phi: float, steps: int) -> None:
        """Record that :meth:`geometry` did not find the closest point to ``p`` in ``steps`` iterations (its last
        step still over 1e-9 m; said by :meth:`take_projection_note`)."""
        count, first = getattr(self, "_unresolved", (0, None))
        if first is None:
            first = (np.array(p[: self.space], dtype=np.float64), float(phi), int(steps))
        self._unresolved = (count + 1, first)

    def take_projection_note(self) -> str | None:
        """Why some contact evaluations since the last call had no unique closest point (the text of a warning),
        or None; the record is cleared. The simulator calls it before and after a run (the ``contact-projection``
        event of the run's log)."""
        count, first = getattr(self, "_unresolved", (0, None))
        self._unresolved = (0, None)
        if not count or first is None:
            return None
        p, phi, steps = first
        where = ", ".join(f"{v:.5g}" for v in p)
        return (f"{type(self).__name__}: the closest surface point was not found at {count} contact evaluation(s) "
                f"in contact (Gauss–Newton did not settle in {steps} steps), first at p = [{where}] m, φ = {phi:.4g} m: "
                "it converges at the rate |φ| κ, so the penetration there is near or beyond the surface's radius of "
                "curvature 1/κ, where the closest point stops being unique; the contact's normal and force there "
                "follow the last iterate (a stiffer surface or a smaller force keeps the penetration within the "
                "curvature)")

    def signed_distance(self, p: Any) -> float:
        """φ(p) [m]: positive in free space, negative inside the environment."""
        return self.geometry(np.asarray(p, dtype=np.float64)[: self.space])[0]

    def penetration(self, x: Any) -> float:
        """δ = −φ [m]: positive inside the environment."""
        return -self.signed_distance(x)

    def contact_point(self, p: Any) -> np.ndarray:
        """The closest point of the undeformed surface to p, (space,) [m]."""
        return self.geometry(np.asarray(p, dtype=np.float64)[: self.space])[1]

    def normal(self, p: Any) -> np.ndarray:
        """The outward unit normal at the closest surface point, (space,)."""
        return self.geometry(np.asarray(p, dtype=np.float64)[: self.space])[2]

    def normal_force(self, x: np.ndarray, xd: np.ndarray) -> tuple[float, np.ndarray, float]:
        """(f_n, ν, δ): the normal force magnitude (>= 0) [N], the normal and the penetration [m]."""
        p = np.asarray(x, dtype=np.float64)[: self.space]
        phi, _, nu = self.geometry(p)
        if phi >= 0.0:
            return 0.0, nu, -phi
        vn = float(nu @ np.asarray(xd, dtype=np.float64)[: self.space])
        return _pushing(-self.stiffness * phi - self.damping * vn), nu, -phi  # NaN φ (a NaN position) included

    def normal_force_at(self, p0: float, p1: float, p2: float, v0: float, v1: float,
                        v2: float) -> tuple[float, float, float, float]:
        """(f_n, ν0, ν1, ν2): :meth:`normal_force` on scalars (a planar surface: p2 = v2 = 0, ν2 = 0), for the
        contact models built on a surface (:class:`~forcecontrol.environments.friction.FrictionalContact`); the
        sphere and the cylinder give it in closed form."""
        fn, nu, _ = self.normal_force(np.array((p0, p1, p2)[: self.space]), np.array((v0, v1, v2)[: self.space]))
        n0, n1, n2 = xyz(np.asarray(nu, dtype=np.float64), self.space)
        return fn, n0, n1, n2

    def _normal_force_of(self, phi: float, n0: float, n1: float, n2: float, v0: float, v1: float,
                         v2: float) -> tuple[float, float, float, float]:
        """:meth:`normal_force_at` from the signed distance φ and the normal (the closed forms' common end)."""
        if phi >= 0.0:
            return 0.0, n0, n1, n2
        return _pushing(-self.stiffness * phi - self.damping * (n0 * v0 + n1 * v1 + n2 * v2)), n0, n1, n2

    def wrench(self, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        out = np.zeros(self.dim)
        fn, nu, _ = self.normal_force(x, xd)
        if not fn <= 0.0:  # a force, or NaN from a NaN position or velocity (never a silent zero)
            out[: self.space] = -fn * nu
        return out

    def max_stiffness(self) -> float:
        return self.stiffness


class ElasticSphere(ElasticSurface):
    """An elastic ball (a disc in 2-D): the environment is inside ``|x − c| < R``.

    φ = |x − c| − R, ν = (x − c)/|x − c|, p_c = c + R ν. In 2-D, the chapter's arm meets the circle
    the sphere leaves in its plane.

    Args:
        center: c, (2,) or (3,) [m]; radius: R [m] > 0; stiffness, damping, task_dim: see
            :class:`ElasticSurface`.
    """

    describe_type: ClassVar[str | None] = "elastic-sphere"
    described: ClassVar[tuple[str, ...]] = ("center", "radius", "stiffness", "damping")

    def __init__(self, center: Any, radius: float, stiffness: float, damping: float = 0.0, *,
                 task_dim: int | None = None) -> None:
        self.center = as_vector("center", center)
        if self.center.shape[0] not in (2, 3):
            raise DimensionError(f"center must have 2 or 3 components; got {self.center.shape[0]}")
        self.radius = positive_scalar("radius", radius, "m")
        self._common(int(self.center.shape[0]), stiffness, damping, task_dim)
        #: a circle of the planar arm runs in the compiled loop (kind 3: :func:`circle_wrench2`).
        self.kind = 3 if self.dim == 2 else 0

    def packed(self) -> np.ndarray:
        """``[c (2), R, k, c]`` (the compiled circle, kind 3)."""
        return np.concatenate([self.center, [self.radius, self.stiffness, self.damping]])

    def normal_force_at(self, p0: float, p1: float, p2: float, v0: float, v1: float,
                        v2: float) -> tuple[float, float, float, float]:
        c0, c1, c2 = xyz(self.center, self.space)
        d0 = p0 - c0
        d1 = p1 - c1
        d2 = p2 - c2
        r = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        n0, n1, n2 = (1.0, 0.0, 0.0) if r < 1e-12 else (d0 / r, d1 / r, d2 / r)  # at the centre: the first axis
        return self._normal_force_of(r - self.radius, n0, n1, n2, v0, v1, v2)

    def geometry(self, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        d = p - self.center
        r = float(math.sqrt(float(d @ d)))
        if r < 1e-12:  # at the centre every direction is a normal: pick the first axis
            nu = np.zeros(self.space)
            nu[0] = 1.0
        else:
            nu = d / r
        return r - self.radius, self.center + self.radius * nu, nu


class ElasticCylinder(ElasticSurface):
    """An elastic solid cylinder of infinite length, its axis in any direction (3-D).

    With a the axis point, u the axis direction and ``r = (x − a) − ((x − a)·u) u``:
    φ = |r| − R, ν = r/|r|. (In 2-D a cylinder whose axis is normal to the arm's plane is the
    circle of :class:`ElasticSphere`.)

    Args:
        point: a point of the axis (3,) [m]; axis: its direction (3,), normalised; radius: R [m] > 0.
    """

    describe_type: ClassVar[str | None] = "elastic-cylinder"
    described: ClassVar[tuple[str, ...]] = ("point", "axis", "radius", "stiffness", "damping")

    def __init__(self, point: Any, axis: Any, radius: float, stiffness: float, damping: float = 0.0, *,
                 task_dim: int | None = None) -> None:
        self.point = as_vector("point", point, 3)
        self.axis = _unit("axis", axis, 3)
        self.radius = positive_scalar("radius", radius, "m")
        self._common(3, stiffness, damping, task_dim)

    def normal_force_at(self, p0: float, p1: float, p2: float, v0: float, v1: float,
                        v2: float) -> tuple[float, float, float, float]:
        u0, u1, u2 = self.axis.tolist()
        a0, a1, a2 = self.point.tolist()
        d0 = p0 - a0
        d1 = p1 - a1
        d2 = p2 - a2
        du = d0 * u0 + d1 * u1 + d2 * u2
        r0 = d0 - du * u0
        r1 = d1 - du * u1
        r2 = d2 - du * u2
        rn = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        if rn < 1e-12:  # on the axis: geometry's choice of a normal
            return super().normal_force_at(p0, p1, p2, v0, v1, v2)
        return self._normal_force_of(rn - self.radius, r0 / rn, r1 / rn, r2 / rn, v0, v1, v2)

    def geometry(self, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        d = p - self.point
        r = d - float(d @ self.axis) * self.axis
        rn = float(math.sqrt(float(r @ r)))
        if rn < 1e-12:
            helper = np.array([1.0, 0.0, 0.0]) if abs(self.axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
            nu = helper - float(helper @ self.axis) * self.axis
            nu /= np.linalg.norm(nu)
        else:
            nu = r / rn
        return rn - self.radius, p - r + self.radius * nu, nu


class HeightField(ElasticSurface):
    """An elastic height field: the environment lies below ``z = h(x, y)`` (3-D) or ``y = h(x)`` (2-D).

    The heights are given on a regular grid and interpolated by a cubic spline (continuous normals,
    so a tool sliding over the grid lines feels no steps). The closest surface point is found by
    Gauss–Newton projection on the spline (from the point straight above/below), so φ is the true
    signed distance to the interpolated surface where the projection is unique (within the
    surface's radius of curvature); ν at p_c is the spline's normal. Outside the grid the surface
    is the edge's spline extrapolated; keep the tool over the grid (a contact beyond it is said after
    the run: a :class:`~forcecontrol.errors.ContactModelWarning` and the ``contact-projection`` event).

    Args:
        heights: h on the grid: (nx,) in 2-D, (nx, ny) in 3-D (``heights[i, j]`` at ``(x_i, y_j)``) [m];
            at least 4 samples along each axis.
        origin: the grid's first point, (1,) in 2-D (its x), (2,) in 3-D [m].
        spacing: the grid steps [m] > 0, scalar or one per axis.
        stiffness, damping, task_dim: see :class:`ElasticSurface`.
    """

    describe_type: ClassVar[str | None] = "height-field"
    described: ClassVar[tuple[str, ...]] = ("origin", "spacing", "stiffness", "damping")

    def __init__(self, heights: Any, origin: Any, spacing: Any, stiffness: float, damping: float = 0.0, *,
                 task_dim: int | None = None) -> None:
        from scipy.interpolate import InterpolatedUnivariateSpline, RectBivariateSpline

        H = np.asarray(heights, dtype=np.float64) if not isinstance(heights, np.ndarray) else heights.astype(np.float64)
        if H.ndim == 1:
            H = as_vector("heights", H)
        elif H.ndim == 2:
            H = as_matrix("heights", H)
        else:
            raise DimensionError(f"heights must be a 1-D (planar) or 2-D (3-D) array; got {H.ndim} dimensions")
        if min(H.shape) < 4:
            raise ParameterError(f"heights must have at least 4 samples along each axis (a cubic spline); got shape {H.shape}")
        axes = H.ndim
        self.heights = H
        self.origin = as_vector("origin", origin, axes)
        sp = np.broadcast_to(np.asarray(spacing, dtype=np.float64), (axes,)).copy() if np.ndim(spacing) == 0 else \
            np.array(as_vector("spacing", spacing, axes))
        if not np.all(np.isfinite(sp)) or np.any(sp <= 0.0):
            raise ParameterError(f"spacing must be positive and finite [m]; got {sp.tolist()}")
        self.spacing = sp
        grids = [self.origin[i] + sp[i] * np.arange(H.shape[i]) for i in range(axes)]
        # the grid's extent (a contact whose foot point lies beyond it is said: take_projection_note)
        self._lo = np.array([g[0] for g in grids])
        self._hi = np.array([g[-1] for g in grids])
        if axes == 1:
            self._spline1 = InterpolatedUnivariateSpline(grids[0], H, k=3)
            self._d1 = self._spline1.derivative(1)
        else:
            self._spline2 = RectBivariateSpline(grids[0], grids[1], H, kx=3, ky=3, s=0)
        self._common(axes + 1, stiffness, damping, task_dim)

    @classmethod
    def from_file(cls, path: str | Path, origin: Any, spacing: Any, stiffness: float, damping: float = 0.0, *,
                  height_scale: float = 1.0, task_dim: int | None = None, max_bytes: int = 16 * 2**20) -> HeightField:
        """A height field read from a CSV table (rows along x, columns along y; one row: a 2-D profile)
        or a grey-scale PNG (pixel value / 255 · ``height_scale``; rows along x), through the
        library's safe reader (regular files only, ``max_bytes`` at most)."""
        p = Path(path)
        scale = positive_scalar("height_scale", height_scale, "m")
        data = read_bytes_limited(p, "height field", max_bytes)
        if p.suffix.lower() == ".png":
            from PIL import Image

            try:
                img = Image.open(io.BytesIO(data))
                img.load()
            except Exception:
                raise ParameterError(f"cannot read height field {str(p)!r}: not a readable PNG image") from None
            if img.width * img.height > 4_000_000:
                raise ParameterError(f"height field {str(p)!r} has {img.width * img.height} pixels; at most 4000000")
            H = np.asarray(img.convert("L"), dtype=np.float64) / 255.0 * scale
        elif p.suffix.lower() in (".csv", ".txt"):
            try:
                H = np.loadtxt(io.StringIO(data.decode("utf-8")), delimiter=",", ndmin=2) * scale
            except (ValueError, UnicodeDecodeError):
                raise ParameterError(
                    f"cannot read height field {str(p)!r}: it must be comma-separated numbers (rows along x)"
                ) from None
            if H.shape[0] == 1:
                H = H[0]
        else:
            raise ParameterError(f"height field file must be .csv or .png; got {p.suffix or 'no extension'!r} ({str(p)!r})")
        return cls(H, origin, spacing, stiffness, damping, task_dim=task_dim)

    def height(self, u: Any) -> float:
        """h at the grid coordinates u: x in 2-D, (x, y) in 3-D [m]."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        if self.space == 2:
            return float(self._spline1(u[0]))
        return float(self._spline2.ev(u[0], u[1]))

    def _surface(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The surface point s(u) and its tangents ∂s/∂u (space, space − 1)."""
        if self.space == 2:
            h = float(self._spline1(u[0]))
            hx = float(self._d1(u[0]))
            return np.array([u[0], h]), np.array([[1.0], [hx]])
        sp = self._spline2
        h = float(sp.ev(u[0], u[1]))
        hx = float(sp.ev(u[0], u[1], dx=1))
        hy = float(sp.ev(u[0], u[1], dy=1))
        return np.array([u[0], u[1], h]), np.array([[1.0, 0.0], [0.0, 1.0], [hx, hy]])

    def geometry(self, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        u = p[: self.space - 1].copy()
        settled = False
        for _ in range(PROJECTION_STEPS):  # Gauss–Newton on |p − s(u)|²: the foot of the perpendicular
            s, T = self._surface(u)
            step = np.linalg.solve(T.T @ T, T.T @ (p - s))
            u += step
            last = float(np.max(np.abs(step)))
            settled = last <= PROJECTION_SETTLED
            if last < PROJECTION_STOP:
                break
        s, T = self._surface(u)
        if self.space == 2:
            nu = np.array([-T[1, 0], 1.0])
        else:
            nu = np.array([-T[2, 0], -T[2, 1], 1.0])
        nu /= np.linalg.norm(nu)
        phi = float(nu @ (p - s))
        if not settled and phi < 0.0:  # in contact deeper than the radius of curvature (see take_projection_note)
            self._projection_unresolved(p, phi, PROJECTION_STEPS)
        if phi < 0.0 and (np.any(u < self._lo - 1e-12) or np.any(u > self._hi + 1e-12)):  # in contact where no height was given
            count, first = getattr(self, "_outside", (0, None))
            self._outside = (count + 1, first if first is not None else np.array(p, dtype=np.float64))
        return phi, s, nu

    def take_projection_note(self) -> str | None:
        """What :meth:`ElasticSurface.take_projection_note` says, and whether the tool was in contact beyond the grid
        (where the surface is the edge's spline extrapolated, not the given heights); both records are cleared."""
        notes = [super().take_projection_note()]
        count, first = getattr(self, "_outside", (0, None))
        self._outside = (0, None)
        if count and first is not None:
            names = "xy"[: self.space - 1]
            span = ", ".join(f"{n} in [{a:.5g}, {b:.5g}]" for n, a, b in zip(names, self._lo, self._hi))
            where = ", ".join(f"{v:.5g}" for v in first)
            notes.append(f"{type(self).__name__}: the tool was in contact beyond the grid at {count} contact "
                         f"evaluation(s), first at p = [{where}] m (the grid covers {span} m): there the surface is "
                         "the edge's spline extrapolated, not given heights; extend the grid over the tool's path")
        return "; ".join(n for n in notes if n) or None

    def describe(self) -> dict[str, Any]:
        out = super().describe()
        out["shape"] = list(self.heights.shape)
        out["height_range"] = [float(self.heights.min()), float(self.heights.max())]
        return out
