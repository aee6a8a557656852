"""An elastic triangle-mesh surface (STL/OBJ/PLY through trimesh): :class:`ElasticMesh`.

Like the other :class:`~forcecontrol.environments.surfaces.ElasticSurface` s it is one-sided and
elastic along the local normal, ``h_e = max(0, k δ − c ν·ẋ) (−ν)`` while δ = −φ > 0, with φ the signed
distance of the tip to the mesh:

* the contact point p_c is the closest point of the mesh (exact: over every triangle whose centroid
  can be that close, found with k-d trees on the vertices and the centroids);
* the sign of φ comes from the angle-weighted pseudo-normal of the feature p_c lies on (the face's
  normal, the sum of an edge's two face normals, a vertex's angle-weighted normal: Bærentzen and
  Aanæs 2005), which is exact for a closed, consistently wound mesh with outward normals (the only
  closed winding :class:`ElasticMesh` accepts); an open mesh (e.g. a patch of ground) is one-sided:
  the environment is on the side opposite to its faces' normals (the right-hand rule of the vertex
  order);
* the normal is **ν = ∇φ** = sign · (p − p_c)/|p − p_c|: the face normal wherever p_c lies inside a
  face, and, where p_c lies on an edge or a vertex, the direction from it, which turns continuously
  from one face's normal to the next. Not a smoothed (Phong) vertex normal, because ∇φ keeps the
  contact conservative: h_e = ∇(k φ²/2) is a gradient, so a tool sliding round and round over the
  facets gains no energy from the surface. The force's magnitude k δ is continuous everywhere; its
  direction is continuous across concave edges and (for ν, which friction and the frame estimate's
  logs read) outside the solid; inside the solid, on the plane bisecting a convex edge, p_c jumps
  from one face to the other and the force turns by the faces' dihedral angle θ: a step of exactly
  2 k δ sin(θ/2), what the polyhedron implies (a finer mesh, a smaller θ). A mesh of a curved
  surface differs from the surface by its chordal error (the sag of its facets) in φ and by its
  facets' tilt in ν.

The compiled planar loop holds no mesh (a mesh is 3-D: it runs in the Python loop, like the
height field; ``engine='compiled'`` is refused). Needs trimesh only to read files
(``pip install 'forcecontrol[mesh]'``); :class:`ElasticMesh` itself takes vertex and face arrays.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numba import njit

from ..core.files import read_bytes_limited
from ..core.validate import as_vector, positive_scalar
from ..errors import DimensionError, ParameterError
from .surfaces import ElasticSurface

__all__ = ["ElasticMesh", "closest_point_on_triangles"]

#: the mesh files :meth:`ElasticMesh.from_file` reads (trimesh's loaders).
MESH_SUFFIXES = (".stl", ".obj", ".ply")
#: at most this many triangles (a run evaluates the mesh at every integrator stage).
MAX_FACES = 2_000_000


@njit(cache=True)
def closest_point_on_triangles(p, a, b, c, cand):  # pragma: no cover - compiled
    """The closest point to p (3,) over the triangles ``(a[i], b[i], c[i])``, i in ``cand``: (q (3,), i, its
    barycentric coordinates (3,), a coordinate exactly 0 where q lies on the opposite edge): Ericson,
    *Real-Time Collision Detection*, 5.1.5."""
    best = np.inf
    q_best = np.zeros(3)
    w_best = np.zeros(3)
    i_best = -1
    q = np.zeros(3)
    w = np.zeros(3)
    for i in cand:
        ab, ac, ap = b[i] - a[i], c[i] - a[i], p - a[i]
        bp, cp = p - b[i], p - c[i]
        d1, d2 = ab @ ap, ac @ ap
        d3, d4 = ab @ bp, ac @ bp
        d5, d6 = ab @ cp, ac @ cp
        va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
        if d1 <= 0.0 and d2 <= 0.0:  # vertex a
            w[0], w[1], w[2] = 1.0, 0.0, 0.0
        elif d3 >= 0.0 and d4 <= d3:  # vertex b
            w[0], w[1], w[2] = 0.0, 1.0, 0.0
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:  # edge ab
            t = d1 / (d1 - d3)
            w[0], w[1], w[2] = 1.0 - t, t, 0.0
        elif d6 >= 0.0 and d5 <= d6:  # vertex c
            w[0], w[1], w[2] = 0.0, 0.0, 1.0
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:  # edge ac
            t = d2 / (d2 - d6)
            w[0], w[1], w[2] = 1.0 - t, 0.0, t
        elif va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:  # edge bc
            t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            w[0], w[1], w[2] = 0.0, 1.0 - t, t
        else:  # inside the face
            den = va + vb + vc
            w[0], w[1], w[2] = va / den, vb / den, vc / den
        q[:] = w[0] * a[i] + w[1] * b[i] + w[2] * c[i]
        e = q - p
        d = e @ e
        if d < best:
            best, i_best = d, i
            q_best[:] = q
            w_best[:] = w
    return q_best, i_best, w_best


def _check_winding(V: np.ndarray, F: np.ndarray, cross: np.ndarray, edges: np.ndarray, edge_of: np.ndarray,
                   counts: np.ndarray, source: str | None) -> None:
    """Refuse faces that are not one consistently wound surface (see :class:`ElasticMesh`'s Raises).

    ``cross`` (nf, 3) is (b − a) × (c − a) per face; ``edges`` (ne, 2) the undirected edges (sorted vertex
    pairs); ``edge_of`` (3 nf,) the edge of face i's side j (vertex j to j + 1) at 3 i + j; ``counts`` each
    edge's number of faces."""
    name = "faces" if source is None else f"faces of mesh {source!r}"
    nf = F.shape[0]
    tri = np.sort(F, axis=1)
    _, first, again = np.unique(tri, axis=0, return_index=True, return_inverse=True)
    again = again.ravel()
    dup = np.flatnonzero(first[again] != np.arange(nf))
    if dup.size:
        i, j = int(first[again[dup[0]]]), int(dup[0])
        raise ParameterError(f"{name} must each be a distinct triangle; got {dup.size} repeated (triangles {i} and {j} "
                             f"both join vertices {tri[j].tolist()}): remove the repeats")
    forward = (F < np.roll(F, -1, axis=1)).ravel()  # side j runs from the lower vertex index to the higher
    ahead = np.bincount(edge_of, weights=forward, minlength=edges.shape[0])
    same = np.flatnonzero((counts == 2) & (ahead != 1))
    if same.size:
        e = int(same[0])
        f1, f2 = (int(k) for k in np.flatnonzero(edge_of == e) // 3)
        raise ParameterError(
            f"{name} must be wound consistently (two triangles sharing an edge traverse it in opposite directions); "
            f"got {same.size} edge(s) traversed twice in the same direction (e.g. vertices {edges[e].tolist()} by "
            f"triangles {f1} and {f2}): order each triangle's vertices counter-clockwise seen from outside "
            "(e.g. trimesh.repair.fix_normals)")
    if not np.any(counts == 2):
        return
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    ne = edges.shape[0]  # the parts: faces joined through their shared edges
    graph = coo_matrix((np.ones(3 * nf), (np.repeat(np.arange(nf), 3), nf + edge_of)), shape=(nf + ne, nf + ne))
    parts, label = connected_components(graph, directed=False)
    face_part = label[:nf]
    closed = np.ones(parts, dtype=bool)
    closed[label[nf + np.flatnonzero(counts != 2)]] = False
    a = V[F[:, 0]] - V.mean(axis=0)
    volume = np.bincount(face_part, weights=np.einsum("ij,ij->i", a, cross), minlength=parts) / 6.0
    for part in np.flatnonzero(closed & ~(volume > 0.0)):
        mine = face_part == part
        others = np.flatnonzero(closed[face_part] & ~mine)
        k = int(np.flatnonzero(mine)[0])
        if others.size and _winding_number(V[F[k]].mean(axis=0), V, F[others]) > 0.5:
            continue  # a cavity: its faces point into it, out of the solid around it
        raise ParameterError(
            f"{name} must be wound with outward normals (counter-clockwise seen from outside); got a closed surface "
            f"of {int(mine.sum())} triangles (triangle {k} among them) wound inward, its signed volume "
            f"{volume[part]:.6g} m^3 (must be positive), which makes the space outside it solid: reverse each "
            "triangle's vertex order (e.g. trimesh.repair.fix_normals)")


def _winding_number(p: np.ndarray, V: np.ndarray, F: np.ndarray) -> float:
    """The winding number of the triangles F about the point p: the solid angles they subtend over 4π (Van
    Oosterom and Strackee 1983); 1 inside a closed surface with outward normals, 0 outside it."""
    a, b, c = V[F[:, 0]] - p, V[F[:, 1]] - p, V[F[:, 2]] - p
    la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", a, c) * lb + np.einsum("ij,ij->i", b, c) * la
    return float(np.sum(np.arctan2(det, den))) / (2.0 * math.pi)


class ElasticMesh(ElasticSurface):
    """An elastic surface given by a triangle mesh (3-D); see the module's text for φ, p_c and ν.

    Args:
        vertices: (nv, 3) [m]; faces: (nf, 3) vertex indices, counter-clockwise seen from outside
            (the outward normal by the right-hand rule).
        stiffness, damping, task_dim: see :class:`~forcecontrol.environments.surfaces.ElasticSurface`.

    Raises:
        ParameterError: besides bad values, faces that are not one consistently wound surface: a
            triangle given twice (any vertex order); an edge shared by two triangles traversed twice
            in the same direction (one face reversed); a closed part (every edge of it shared by two
            triangles) wound inward, its signed volume Σ (a−o)·((b−a)×(c−a))/6 not positive, unless
            it bounds a cavity (it lies inside another closed part). Each would give φ the wrong
            sign near the faces concerned, or everywhere outside.
    """

    describe_type: ClassVar[str | None] = "mesh"
    described: ClassVar[tuple[str, ...]] = ("stiffness", "damping")

    def __init__(self, vertices: Any, faces: Any, stiffness: float, damping: float = 0.0, *,
                 task_dim: int | None = None, source: str | None = None) -> None:
        V = np.asarray(vertices, dtype=np.float64)
        F = np.asarray(faces)
        if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] < 3:
            raise DimensionError(f"vertices must be an (n, 3) array with n >= 3; got shape {V.shape}")
        if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] < 1 or not np.issubdtype(F.dtype, np.integer):
            raise DimensionError(f"faces must be an (n, 3) array of vertex indices (triangles); got shape {F.shape}, "
                                 f"dtype {F.dtype}")
        if F.shape[0] > MAX_FACES:
            raise ParameterError(f"faces: at most {MAX_FACES} triangles; got {F.shape[0]}")
        if not np.all(np.isfinite(V)):
            raise ParameterError("vertices must be finite [m]; got a NaN or an infinity")
        if F.min() < 0 or F.max() >= V.shape[0]:
            raise ParameterError(f"faces must index the {V.shape[0]} vertices (0..{V.shape[0] - 1}); "
                                 f"got indices {int(F.min())}..{int(F.max())}")
        a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        cross = np.cross(b - a, c - a)
        area2 = np.linalg.norm(cross, axis=1)
        scale = float(np.ptp(V, axis=0).max())
        if not np.all(area2 > 1e-12 * max(scale, 1e-300) ** 2):
            bad = int(np.flatnonzero(~(area2 > 1e-12 * max(scale, 1e-300) ** 2))[0])
            raise ParameterError(f"faces: triangle {bad} is degenerate (zero area); remove it from the mesh")
        self._common(3, stiffness, damping, task_dim)
        self.vertices, self.faces, self.source = V, F.astype(np.int64), source
        self._a, self._b, self._c = (np.ascontiguousarray(v) for v in (a, b, c))
        self.face_normals = cross / area2[:, None]
        # pseudo-normals: vertices angle-weighted, edges the sum of their faces' normals
        angles = np.empty((F.shape[0], 3))
        for i in range(3):
            u = V[F[:, (i + 1) % 3]] - V[F[:, i]]
            w = V[F[:, (i + 2) % 3]] - V[F[:, i]]
            cosang = np.einsum("ij,ij->i", u, w) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
            angles[:, i] = np.arccos(np.clip(cosang, -1.0, 1.0))
        vn = np.zeros_like(V)
        for i in range(3):
            np.add.at(vn, F[:, i], angles[:, i : i + 1] * self.face_normals)
        self._vertex_normals = vn
        edges = np.sort(np.stack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=1).reshape(-1, 2), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        inverse = inverse.reshape(F.shape[0], 3)
        en = np.zeros((unique.shape[0], 3))
        for i in range(3):
            np.add.at(en, inverse[:, i], self.face_normals)
        counts = np.bincount(inverse.ravel(), minlength=unique.shape[0])
        _check_winding(V, F, cross, unique, inverse.ravel(), counts, source)
        #: True when every edge has exactly two faces (a closed surface: inside and outside are defined).
        self.closed = bool(np.all(counts == 2))
        self._edge_normals, self._face_edges = en, inverse  # face edge i joins its vertices i and i + 1
        centroids = (a + b + c) / 3.0
        self._radius = float(np.max(np.linalg.norm(np.stack([a, b, c]) - centroids, axis=2)))
        from scipy.spatial import cKDTree

        self._vtree, self._ctree = cKDTree(V), cKDTree(centroids)

    @classmethod
    def from_file(cls, path: str | Path, stiffness: float, damping: float = 0.0, *, scale: float = 1.0,
                  offset: Any = None, task_dim: int | None = None, max_bytes: int = 64 * 2**20) -> ElasticMesh:
        """A mesh read from an STL, OBJ or PLY file through trimesh (the library's safe reader: regular files
        only, ``max_bytes`` at most), its vertices multiplied by ``scale`` (e.g. 1e-3 for a file in mm) and
        moved by ``offset`` (3,) [m]. Several bodies in one file are merged into one mesh. trimesh merges
        duplicate vertices but keeps the faces' winding as written: a winding :meth:`__init__` refuses is
        refused naming the file."""
        p = Path(path)
        sc = positive_scalar("scale", scale, "")
        off = np.zeros(3) if offset is None else as_vector("offset", offset, 3)
        suffix = p.suffix.lower()
        if suffix not in MESH_SUFFIXES:
            raise ParameterError(f"mesh file must be {', '.join(MESH_SUFFIXES)}; got {suffix or 'no extension'!r} ({str(p)!r})")
        data = read_bytes_limited(p, "mesh", max_bytes)
        try:
            import trimesh
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ImportError("reading a mesh file needs trimesh: pip install 'forcecontrol[mesh]'") from exc
        try:
            mesh = trimesh.load(io.BytesIO(data), file_type=suffix[1:], force="mesh", process=True)
            V, F = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
        except Exception as exc:
            kind = suffix[1:].upper()
            raise ParameterError(f"cannot read mesh {str(p)!r}: not a readable {kind} triangle mesh ({exc})") from None
        if F.ndim != 2 or F.shape[0] == 0:
            raise ParameterError(f"mesh {str(p)!r} has no triangles")
        return cls(V * sc + off, F, stiffness, damping, task_dim=task_dim, source=str(p))

    def _closest(self, p: np.ndarray) -> tuple[np.ndarray, int, np.ndarray]:
        """(p_c, the triangle, its barycentric coordinates) of the closest mesh point to p."""
        dv, _ = self._vtree.query(p)
        cand = np.asarray(self._ctree.query_ball_point(p, float(dv) + self._radius * (1 + 1e-9) + 1e-12), dtype=np.int64)
        if cand.size == 0:  # pragma: no cover - the nearest vertex's triangles always qualify
            cand = np.arange(self.faces.shape[0])
        q, i, bary = closest_point_on_triangles(p, self._a, self._b, self._c, cand)
        return q, int(i), bary

    def _pseudo_normal(self, face: int, bary: np.ndarray) -> np.ndarray:
        zero = bary == 0.0
        nz = int(zero.sum())
        if nz == 0:
            return self.face_normals[face]
        if nz == 2:  # a vertex
            return self._vertex_normals[self.faces[face, int(np.flatnonzero(~zero)[0])]]
        k = int(np.flatnonzero(zero)[0])  # on the edge opposite vertex k: the edge joining vertices k+1, k+2
        return self._edge_normals[self._face_edges[face, (k + 1) % 3]]

    def geometry(self, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        p = np.asarray(p, dtype=np.float64)
        q, face, bary = self._closest(p)
        d = p - q
        dist = math.sqrt(float(d @ d))
        pn = self._pseudo_normal(face, bary)
        sign = -1.0 if float(d @ pn) < 0.0 else 1.0
        if dist > 1e-12:
            return sign * dist, q, sign * d / dist
        return 0.0, q, self.face_normals[face].copy()

    def describe(self) -> dict[str, Any]:
        out = super().describe()
        out.update(source=self.source, vertices=int(self.vertices.shape[0]), faces=int(self.faces.shape[0]), closed=self.closed,
                   bounds=[self.vertices.min(axis=0).tolist(), self.vertices.max(axis=0).tolist()])
        return out
