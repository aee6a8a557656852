"""The pieces of the 3-D view (:mod:`forcecontrol.viz.view3d`) as meshcat commands (plain dicts).

* :func:`urdf_visuals`: each link's ``<visual>`` elements of a URDF (meshes resolved from
  ``package://`` and relative paths, boxes, cylinders, spheres, their colours);
* :func:`visual_objects`: those as meshcat ``set_object`` / ``set_transform`` commands, the mesh
  files embedded (COLLADA as text, STL as base64) so the page needs no file beside it;
* :func:`surface_objects`: the contact surface of an environment (plane, sphere, cylinder, height
  field, triangle mesh, a rigid plane constraint), or a note saying it is not drawn;
* :func:`arrow_objects`: the force arrow (a shaft and a cone, animated by the caller).

A meshcat path is a ``/``-joined string; an object's ``matrix`` and a ``set_transform``'s matrix
are 4×4 homogeneous transforms sent column-major (three.js' ``Matrix4.fromArray``).
"""

from __future__ import annotations

import base64
import math
import uuid
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.files import read_bytes_limited, read_text_limited
from ..errors import ParameterError

__all__ = ["Visual", "urdf_visuals", "visual_objects", "surface_objects", "arrow_objects", "column_major", "rpy_matrix"]

#: the largest mesh file embedded [bytes] (the Panda's largest visual mesh is 1.7 MB)
MAX_MESH_BYTES = 32 * 2**20


def column_major(T: np.ndarray) -> list[float]:
    """A 4×4 transform as three.js reads it (column-major, 16 floats)."""
    return [float(v) for v in np.asarray(T, dtype=float).T.reshape(-1)]


def rpy_matrix(rpy: Any) -> np.ndarray:
    """URDF's roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _homogeneous(R: np.ndarray, p: Any) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(p, dtype=float)
    return T


@dataclass
class Visual:
    """One ``<visual>`` of a link: its kind (``mesh``, ``box``, ``cylinder``, ``sphere``), its placement in
    the link frame (4×4), its size (mesh: scale (3,); box: sizes (3,); cylinder: radius, length; sphere:
    radius), the mesh file and an RGBA colour (None: the mesh's own)."""

    link: str
    kind: str
    origin: np.ndarray
    size: tuple[float, ...]
    mesh: Path | None = None
    rgba: tuple[float, float, float, float] | None = None


def _floats(text: str | None, n: int, default: tuple[float, ...], where: str) -> tuple[float, ...]:
    if text is None:
        return default
    try:
        vals = tuple(float(v) for v in text.split())
    except ValueError:
        raise ParameterError(f"URDF {where}: expected {n} numbers; got {text[:40]!r}") from None
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise ParameterError(f"URDF {where}: expected {n} finite numbers; got {text[:40]!r}")
    return vals


def resolve_mesh(filename: str, urdf: Path, packages: dict[str, Path]) -> Path:
    """The file a URDF's mesh ``filename`` names: ``package://PKG/rest`` through ``packages`` (or a folder
    named PKG above the URDF), ``file://`` and plain paths relative to the URDF's folder.

    Raises:
        ParameterError: the package is unknown or the file does not exist.
    """
    if filename.startswith("package://"):
        pkg, _, rest = filename[len("package://"):].partition("/")
        roots = [packages[pkg]] if pkg in packages else [p / pkg for p in urdf.resolve().parents if (p / pkg).is_dir()]
        if not roots:
            raise ParameterError(f"URDF {str(urdf)!r}: mesh {filename!r} is in package {pkg!r}, which was not found "
                                 "(no folder of that name above the URDF)")
        path = roots[0] / rest
    elif filename.startswith("file://"):
        path = Path(filename[len("file://"):])
    else:
        path = urdf.parent / filename
    if not path.is_file():
        raise ParameterError(f"URDF {str(urdf)!r}: mesh file {str(path)!r} does not exist")
    return path


def urdf_visuals(urdf: str | Path, packages: dict[str, Path] | None = None) -> list[Visual]:
    """The ``<visual>`` elements of every link of a URDF, in file order.

    Raises:
        ParameterError: malformed XML, numbers or geometry, or a mesh file that cannot be found.
    """
    urdf = Path(urdf)
    text = read_text_limited(urdf, "URDF")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ParameterError(f"URDF {str(urdf)!r}: not well-formed XML ({exc})") from None
    colours: dict[str, tuple[float, ...]] = {}
    for m in root.iter("material"):  # named materials at the top level (and inside visuals)
        c = m.find("color")
        if m.get("name") and c is not None:
            colours[m.get("name", "")] = _floats(c.get("rgba"), 4, (0.7, 0.7, 0.7, 1.0), f"material {m.get('name')!r}")
    out = []
    for link in root.findall("link"):
        lname = link.get("name", "")
        for k, vis in enumerate(link.findall("visual")):
            where = f"link {lname!r} visual #{k + 1}"
            o = vis.find("origin")
            xyz = _floats(None if o is None else o.get("xyz"), 3, (0.0, 0.0, 0.0), where + " origin xyz")
            rpy = _floats(None if o is None else o.get("rpy"), 3, (0.0, 0.0, 0.0), where + " origin rpy")
            origin = _homogeneous(rpy_matrix(rpy), xyz)
            rgba = None
            mat = vis.find("material")
            if mat is not None:
                c = mat.find("color")
                if c is not None:
                    rgba = _floats(c.get("rgba"), 4, (0.7, 0.7, 0.7, 1.0), where + " color")
                elif mat.get("name") in colours:
                    rgba = colours[mat.get("name", "")]
            geom = vis.find("geometry")
            shape = None if geom is None or len(geom) == 0 else geom[0]
            if shape is None:
                raise ParameterError(f"URDF {str(urdf)!r}: {where} has no geometry")
            if shape.tag == "mesh":
                path = resolve_mesh(shape.get("filename", ""), urdf, packages or {})
                scale = _floats(shape.get("scale"), 3, (1.0, 1.0, 1.0), where + " mesh scale")
                out.append(Visual(lname, "mesh", origin, scale, path, rgba))  # type: ignore[arg-type]
            elif shape.tag == "box":
                out.append(Visual(lname, "box", origin, _floats(shape.get("size"), 3, (0.0,) * 3, where + " box"), None, rgba))
            elif shape.tag == "cylinder":
                r = _floats(shape.get("radius"), 1, (0.0,), where + " cylinder radius")[0]
                h = _floats(shape.get("length"), 1, (0.0,), where + " cylinder length")[0]
                out.append(Visual(lname, "cylinder", origin, (r, h), None, rgba))  # type: ignore[arg-type]
            elif shape.tag == "sphere":
                r = _floats(shape.get("radius"), 1, (0.0,), where + " sphere radius")[0]
                out.append(Visual(lname, "sphere", origin, (r,), None, rgba))  # type: ignore[arg-type]
            else:
                raise ParameterError(f"URDF {str(urdf)!r}: {where}: geometry <{shape.tag}> is not drawn "
                                     "(expected mesh, box, cylinder or sphere)")
    return out


# ----------------------------------------------------------------------------- three.js objects


def _uid() -> str:
    return str(uuid.uuid4())


def _rgb(rgba: Any) -> int:
    r, g, b = (min(255, max(0, round(255 * float(c)))) for c in rgba[:3])
    return (r << 16) + (g << 8) + b


def _material(rgba: Any, kind: str = "MeshLambertMaterial") -> dict[str, Any]:
    opacity = float(rgba[3]) if len(rgba) > 3 else 1.0
    return {"uuid": _uid(), "type": kind, "color": _rgb(rgba), "opacity": opacity, "transparent": opacity < 1.0,
            "side": 2, "depthWrite": opacity >= 1.0}


def _object(geometry: dict[str, Any], rgba: Any, matrix: np.ndarray) -> dict[str, Any]:
    """A three.js ``Mesh`` in the JSON object format meshcat's loader reads."""
    mat = _material(rgba)
    return {"metadata": {"version": 4.5, "type": "Object"}, "geometries": [geometry], "materials": [mat],
            "object": {"uuid": _uid(), "type": "Mesh", "geometry": geometry["uuid"], "material": mat["uuid"],
                       "matrix": column_major(matrix)}}


def _eye(matrix: np.ndarray | None) -> np.ndarray:
    return np.eye(4) if matrix is None else np.asarray(matrix, dtype=float)


def box(size: Any, rgba: Any, matrix: np.ndarray | None = None) -> dict[str, Any]:
    """A box of ``size`` (x, y, z) centred at the origin of ``matrix``."""
    w, h, d = (float(v) for v in size)
    return _object({"uuid": _uid(), "type": "BoxGeometry", "width": w, "height": h, "depth": d}, rgba, _eye(matrix))


def sphere(radius: float, rgba: Any, matrix: np.ndarray | None = None) -> dict[str, Any]:
    return _object({"uuid": _uid(), "type": "SphereGeometry", "radius": float(radius), "widthSegments": 40,
                    "heightSegments": 24}, rgba, _eye(matrix))


def cylinder(radius: float, length: float, rgba: Any, matrix: np.ndarray | None = None,
             top: float | None = None) -> dict[str, Any]:
    """A cylinder (a cone with ``top=0``) along the z axis of ``matrix``, centred at its origin
    (three.js' cylinder runs along y: turned here)."""
    turn = _homogeneous(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]), (0.0, 0.0, 0.0))  # y -> z
    return _object({"uuid": _uid(), "type": "CylinderGeometry", "radiusTop": float(radius if top is None else top),
                    "radiusBottom": float(radius), "height": float(length), "radialSegments": 32},
                   rgba, _eye(matrix) @ turn)


def triangles(vertices: Any, faces: Any, rgba: Any) -> dict[str, Any]:
    """A triangle mesh (vertices (n, 3), faces (k, 3)) in the base frame."""
    v = np.asarray(vertices, dtype=np.float32).reshape(-1)
    f = np.asarray(faces, dtype=np.uint32).reshape(-1)
    geom = {"uuid": _uid(), "type": "BufferGeometry", "data": {
        "attributes": {"position": {"itemSize": 3, "type": "Float32Array", "array": [round(float(x), 6) for x in v],
                                    "normalized": False}},
        "index": {"type": "Uint32Array", "array": [int(i) for i in f]}}}
    return _object(geom, rgba, np.eye(4))


def mesh_file(path: Path, scale: Any, rgba: Any, matrix: np.ndarray) -> dict[str, Any]:
    """A mesh file embedded: COLLADA (``.dae``, its own materials kept) as text, STL as base64 (the page decodes
    it), OBJ as text. ``rgba`` (the URDF's colour) replaces the file's for STL and OBJ.

    Raises:
        ParameterError: another format, or a file larger than :data:`MAX_MESH_BYTES`.
    """
    fmt = path.suffix.lower().lstrip(".")
    S = np.diag([*(float(s) for s in scale), 1.0])
    obj: dict[str, Any] = {"uuid": _uid(), "type": "_meshfile_object", "format": fmt, "resources": {},
                           "matrix": column_major(np.asarray(matrix, dtype=float) @ S)}
    if fmt in ("dae", "obj"):
        obj["data"] = read_text_limited(path, "mesh file", MAX_MESH_BYTES)
        if fmt == "dae":
            obj["data"] = split_collada(obj["data"])
    elif fmt == "stl":
        obj["data"] = {"__base64__": base64.b64encode(read_bytes_limited(path, "mesh file", MAX_MESH_BYTES)).decode()}
    else:
        raise ParameterError(f"mesh file {str(path)!r}: format {fmt!r} is not drawn (expected .dae, .stl or .obj)")
    out: dict[str, Any] = {"metadata": {"version": 4.5, "type": "Object"}, "geometries": [], "materials": [], "object": obj}
    if rgba is not None and fmt != "dae":
        mat = _material(rgba)
        out["materials"] = [mat]
        obj["material"] = mat["uuid"]
    return out


_COLLADA = "http://www.collada.org/2005/11/COLLADASchema"
_PRIMITIVES = ("triangles", "polylist", "polygons", "trifans", "tristrips")


def split_collada(text: str) -> str:
    """A COLLADA file whose geometries each have one material, drawing the same triangles.

    meshcat's viewer merges the meshes of a file into one geometry with one material group per mesh, so a
    file with several meshes, one of them with several materials (``<triangles>`` elements: the UR5's
    shoulder, upper arm and wrists), loses that mesh's drawing. Such a mesh is split here into one
    ``<geometry>`` per ``<triangles>`` (sharing copies of its vertex sources) and its instances into one
    ``<instance_geometry>`` each. Any other file is returned unchanged (the same text).
    """
    try:
        root = ET.fromstring(text)
    except ET.ParseError:
        return text  # the viewer reports it
    tag = lambda name: f"{{{_COLLADA}}}{name}"  # noqa: E731
    lib = root.find(tag("library_geometries"))
    if lib is None or len(root.findall(f".//{tag('instance_geometry')}")) < 2:
        return text
    parts: dict[str, list[str]] = {}
    for geom in list(lib.findall(tag("geometry"))):
        mesh = geom.find(tag("mesh"))
        prims = [] if mesh is None else [e for e in mesh if e.tag in {tag(p) for p in _PRIMITIVES}]
        if len(prims) < 2:
            continue
        gid = geom.get("id", "")
        parts[gid] = []
        for k, prim in enumerate(prims):
            piece = ET.Element(geom.tag, {**geom.attrib, "id": f"{gid}-part{k}", "name": f"{geom.get('name', gid)}-part{k}"})
            m = ET.SubElement(piece, tag("mesh"))
            m.extend(e for e in mesh if e.tag not in {tag(p) for p in _PRIMITIVES})  # type: ignore[union-attr]
            m.append(prim)
            lib.append(piece)
            parts[gid].append(f"#{gid}-part{k}")
        lib.remove(geom)
    if not parts:
        return text
    for parent in root.iter():
        for i, inst in reversed(list(enumerate(parent))):
            if inst.tag == tag("instance_geometry") and inst.get("url", "").lstrip("#") in parts:
                parent.remove(inst)
                for j, url in enumerate(parts[inst.get("url", "").lstrip("#")]):
                    copy = ET.fromstring(ET.tostring(inst))
                    copy.set("url", url)
                    parent.insert(i + j, copy)
    ET.register_namespace("", _COLLADA)
    return ET.tostring(root, encoding="unicode")


def set_object(path: str, obj: dict[str, Any]) -> dict[str, Any]:
    return {"type": "set_object", "path": path, "object": obj}


def set_transform(path: str, T: np.ndarray) -> dict[str, Any]:
    return {"type": "set_transform", "path": path, "matrix": column_major(T)}


def visual_objects(visuals: list[Visual], prefix: str) -> list[dict[str, Any]]:
    """``set_object`` commands for the visuals, each under ``prefix/<link>/visual<k>`` (the link's group is
    what the animation moves)."""
    grey = (0.75, 0.75, 0.78, 1.0)
    out = []
    count: dict[str, int] = {}
    for v in visuals:
        k = count[v.link] = count.get(v.link, 0) + 1
        path = f"{prefix}/{v.link}/visual{k}"
        if v.kind == "mesh":
            assert v.mesh is not None
            out.append(set_object(path, mesh_file(v.mesh, v.size, v.rgba, v.origin)))
        elif v.kind == "box":
            out.append(set_object(path, box(v.size, v.rgba or grey, v.origin)))
        elif v.kind == "cylinder":
            out.append(set_object(path, cylinder(v.size[0], v.size[1], v.rgba or grey, v.origin)))
        else:
            out.append(set_object(path, sphere(v.size[0], v.rgba or grey, v.origin)))
    return out


# ----------------------------------------------------------------------------- the contact surface

SURFACE = (0.55, 0.6, 0.65, 0.55)


def _frame_from_z(z: np.ndarray) -> np.ndarray:
    """A rotation whose third column is the unit vector ``z``."""
    z = z / np.linalg.norm(z)
    x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _lift(v: Any) -> np.ndarray:
    """A planar point or vector in 3-D (z = 0)."""
    a = np.asarray(v, dtype=float).reshape(-1)
    return np.concatenate([a, np.zeros(3 - a.size)]) if a.size < 3 else a[:3]


def surface_objects(environment: Any, centre: np.ndarray, size: float, prefix: str) -> tuple[list[dict[str, Any]], str | None]:
    """The environment's contact surface as ``set_object`` commands, sized ``size`` around ``centre`` (3-D, the
    tool's mean position); a planar environment is extruded along z. Returns (commands, note): the note says
    why nothing is drawn (an environment without a surface, e.g. a spring), else None."""
    env = environment
    if env is None:
        return [], None
    for _ in range(8):  # a wrapper (friction on a surface) draws the surface it wraps
        inner = getattr(env, "surface", None)
        if inner is None or inner is env:
            break
        env = inner
    source = getattr(env, "constraint", env)  # a rigid environment holds its constraint
    name = type(environment).__name__
    planar = int(getattr(env, "dim", getattr(env, "space", 3)) or 3) == 2 or np.asarray(
        getattr(source, "point", getattr(source, "center", np.zeros(3)))).size == 2
    thick = 0.02 * size
    if hasattr(source, "heights") and hasattr(source, "origin") and hasattr(source, "spacing"):
        H = np.asarray(source.heights, dtype=float)
        o, sp = np.asarray(source.origin, dtype=float), np.asarray(source.spacing, dtype=float)
        if H.ndim == 1:  # a profile y = h(x), extruded along z
            xs = o[0] + sp[0] * np.arange(H.size)
            verts = np.array([[x, h, z] for x, h in zip(xs, H) for z in (-0.5 * size, 0.5 * size)])
            faces = [f for i in range(H.size - 1) for f in ([2 * i, 2 * i + 2, 2 * i + 1], [2 * i + 1, 2 * i + 2, 2 * i + 3])]
        else:
            step = max(1, int(math.ceil(max(H.shape) / 160)))  # at most 160 × 160 vertices
            Hs = H[::step, ::step]
            nx, ny = Hs.shape
            X, Y = np.meshgrid(o[0] + sp[0] * step * np.arange(nx), o[1] + sp[1] * step * np.arange(ny), indexing="ij")
            verts = np.column_stack([X.ravel(), Y.ravel(), Hs.ravel()])
            faces = [f for i in range(nx - 1) for j in range(ny - 1) for a in [i * ny + j]
                     for f in ([a, a + ny, a + 1], [a + 1, a + ny, a + ny + 1])]
        return [set_object(f"{prefix}/surface", triangles(verts, faces, SURFACE))], None
    if hasattr(source, "vertices") and hasattr(source, "faces"):
        return [set_object(f"{prefix}/surface", triangles(source.vertices, source.faces, SURFACE))], None
    if hasattr(source, "radius") and hasattr(source, "axis") and hasattr(source, "point"):
        a, u = np.asarray(source.point, float), np.asarray(source.axis, float)
        c = a + float((centre - a) @ u) * u
        T = _homogeneous(_frame_from_z(u), c)
        return [set_object(f"{prefix}/surface", cylinder(source.radius, 2.0 * size, SURFACE, T))], None
    if hasattr(source, "radius") and hasattr(source, "center"):
        c = _lift(source.center)
        if planar:  # a circle of the arm's plane: a cylinder across it
            return [set_object(f"{prefix}/surface", cylinder(source.radius, size, SURFACE, _homogeneous(np.eye(3), c)))], None
        return [set_object(f"{prefix}/surface", sphere(source.radius, SURFACE, _homogeneous(np.eye(3), c)))], None
    if hasattr(source, "point") and hasattr(source, "normal"):
        p, n = _lift(source.point), _lift(source.normal)
        n = n / np.linalg.norm(n)
        c = centre - float((centre - p) @ n) * n - 0.5 * thick * n  # the slab's top face is the surface
        if planar:  # a line of the arm's plane: a wall across it
            R = np.column_stack([np.cross([0.0, 0.0, 1.0], n), n, [0.0, 0.0, 1.0]])
            return [set_object(f"{prefix}/surface", box((2.0 * size, thick, 0.5 * size), SURFACE, _homogeneous(R, c)))], None
        return [set_object(f"{prefix}/surface", box((2.0 * size, 2.0 * size, thick), SURFACE,
                                                    _homogeneous(_frame_from_z(n), c)))], None
    return [], f"the environment {name} has no surface to draw (only the force arrow shows it)"


def arrow_objects(prefix: str, radius: float) -> list[dict[str, Any]]:
    """The force arrow under ``prefix``: a unit shaft along y (``prefix/shaft``, scaled by the caller) and a
    cone (``prefix/head``, moved to the shaft's end); the group ``prefix`` turns y to the force."""
    colour = (0.84, 0.37, 0.0, 1.0)
    turn = _homogeneous(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]), (0.0, 0.0, 0.0))  # cylinder's z -> y
    return [set_object(f"{prefix}/shaft", cylinder(radius, 1.0, colour, turn)),
            set_object(f"{prefix}/head", cylinder(2.2 * radius, 5.0 * radius, colour,
                                                   _homogeneous(np.eye(3), (0.0, 2.5 * radius, 0.0)) @ turn, top=0.0))]
