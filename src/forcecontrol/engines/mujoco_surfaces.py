"""Curved surfaces in the MuJoCo engine: an :class:`~forcecontrol.environments.surfaces.ElasticSphere` or
:class:`~forcecontrol.environments.surfaces.ElasticCylinder` as MuJoCo's sphere or cylinder geom, a closed convex
:class:`~forcecontrol.environments.mesh.ElasticMesh` as MuJoCo's mesh geom.

The geom's radius is the surface's less the end-effector sphere's (``contact_radius``), so that the
penetration MuJoCo sees between the two spheres (or the sphere and the cylinder) is the surface's δ
at the controlled frame's origin; the contact force acts along the line of centres, the surface's
normal. The stiffness and damping are calibrated like the plane's (:meth:`MujocoPlant._calibrate`).

A mesh: MuJoCo collides with a mesh's convex hull (GJK/EPA, one contact), so only a closed convex mesh is
taken (a non-convex one is refused: its hull would be a different surface). The geom is the mesh eroded by
``contact_radius`` (each face's plane moved inwards by it: the half-spaces' intersection), so that the
penetration MuJoCo sees is the mesh's δ wherever the closest point is inside a face (near an edge the
eroded solid's rounded offset differs from the polyhedron by at most r (1 − cos(θ/2)), θ the dihedral).

Not modelled, refused by name: MuJoCo's height field. Its collision treats the field as a union of
triangular prisms and returns one contact per prism the tool's sphere overlaps (measured at 1 mm depth
with a 1 cm sphere: 2 contacts on a 2-cm grid, 7 on a 1-cm grid, 16 on a 5-mm grid, some through the
prisms' side walls), each of which MuJoCo's soft contact turns into a full surface spring: the force is a
multiple of k δ, not an independent check of the built-in field.

Friction (a :class:`~forcecontrol.environments.friction.FrictionalContact`, :func:`add_friction`): MuJoCo's Coulomb
friction on the same contact (condim 3, the *elliptic* cone: the friction force is projected onto
|f_t| <= μ f_n, so while sliding it is μ f_n exactly, in the sliding direction), μ = the kinetic coefficient
μ_k. MuJoCo's friction is a soft constraint too: its rows get the contact's solref damping (at least
:data:`FRICTION_MIN_DAMPING`) and a regulariser :data:`FRICTION_IMPRATIO` times smaller than the normal
row's, so that while sliding it saturates at μ_k f_n (measured: the ratio 0.3 to 1e-12 at 0.125 m/s); it is not
the built-in stick/slip state: MuJoCo has no static coefficient (μ_s is not modelled: a tool pulled with more than
μ_k f_n slides), and the bristle (stick_stiffness, stick_damping, stick_speed)
and the viscous coefficient b are not modelled either. The elliptic cone's projection also raises the
normal force a little while sliding (measured 0.06 % with 1 N s/m). :class:`MujocoFrictionNote` says so
on stderr and in the run's ``--json`` warnings.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError

#: MuJoCo's impratio with friction: the friction rows' regulariser this many times smaller than the normal row's.
FRICTION_IMPRATIO = 1e4
#: the least solref damping with friction [N s/m] (MuJoCo's friction rows resist the sliding speed through it).
FRICTION_MIN_DAMPING = 1.0


class MujocoFrictionNote(UserWarning):
    """MuJoCo's friction differs from the built-in stick/slip model (no static coefficient, no bristle)."""

__all__ = ["add_surface_geom", "add_friction", "quat_z_to", "MujocoFrictionNote", "FRICTION_IMPRATIO", "FRICTION_MIN_DAMPING"]


def quat_z_to(direction: np.ndarray) -> list[float]:
    """MuJoCo's quaternion (w, x, y, z) of the shortest rotation taking the local z axis onto ``direction`` (unit)."""
    z = np.array([0.0, 0.0, 1.0])
    ax = np.cross(z, direction)
    s, c = float(np.linalg.norm(ax)), float(z @ direction)
    if s < 1e-12:
        return [1.0, 0.0, 0.0, 0.0] if c > 0 else [0.0, 1.0, 0.0, 0.0]
    ang = math.atan2(s, c)
    return [math.cos(ang / 2), *(math.sin(ang / 2) * ax / s)]


def _eroded_convex(env: Any, r: float) -> np.ndarray:
    """The vertices of the closed convex mesh ``env`` eroded by r [m] (its face planes moved inwards by r)."""
    from scipy.spatial import ConvexHull, HalfspaceIntersection

    V, F = env.vertices, env.faces
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0
    hull = ConvexHull(V) if env.closed else None
    if hull is None or volume < hull.volume * (1.0 - 1e-6):
        why = "not closed" if hull is None else f"not convex (volume {volume:.6g} m^3, its convex hull's {hull.volume:.6g} m^3)"
        raise ParameterError(
            f"the MuJoCo engine collides with a mesh's convex hull: the mesh must be closed and convex; this one is {why}; "
            "run the built-in engine"
        )
    n = env.face_normals
    offs = np.einsum("ij,ij->i", n, a) - r  # n·x <= b − r
    inner = V.mean(axis=0)
    margin = float(np.min(offs - n @ inner))
    if not margin > 1e-9:
        raise ParameterError(f"the mesh is thinner than twice contact_radius = {r} m (its centroid lies {margin + r:.3g} m "
                             "inside the nearest face): MuJoCo cannot hold it")
    pts = HalfspaceIntersection(np.hstack([n, -offs[:, None]]), inner).intersections
    return pts[ConvexHull(pts).vertices]


def add_surface_geom(plant: Any, spec: Any, env: Any) -> bool:
    """Add the environment geom for ``env`` to ``spec``: a sphere (for the planar arm, the circle is the sphere's cut
    by the arm's plane z = 0), a cylinder, their radius less the end-effector sphere's, or a closed convex mesh eroded
    by it. Returns True (a contact)."""
    from ..environments.mesh import ElasticMesh
    from ..environments.surfaces import ElasticCylinder, ElasticSphere

    mujoco = plant._mujoco
    if env.dim != plant.robot.task_dim:
        raise ParameterError(f"the environment is {env.dim}-dimensional, the robot's task {plant.robot.task_dim}-dimensional")
    if not isinstance(env, (ElasticSphere, ElasticCylinder, ElasticMesh)):
        reason = (" (MuJoCo's height-field collision gives one soft contact per prism the tool overlaps: a multiple of "
                  "the surface's force; see engines/mujoco_surfaces.py)") if type(env).__name__ == "HeightField" else ""
        raise ParameterError(
            f"the MuJoCo engine models ElasticSphere and ElasticCylinder surfaces; got {type(env).__name__}{reason} "
            "(it also models a closed convex ElasticMesh); run the built-in engine"
        )
    g = spec.worldbody.add_geom()
    g.name = "environment"
    plant._k_env, plant._c_env = float(env.stiffness), float(env.damping)
    if isinstance(env, ElasticMesh):
        pts = _eroded_convex(env, plant.radius)
        mesh = spec.add_mesh()
        mesh.name = "environment_mesh"
        mesh.uservert = pts.ravel().tolist()
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = "environment_mesh"
        plant._probe_depth = 0.0  # calibration: the probe sits inside the solid (any contact row gives the ratios)
    else:
        if env.radius <= plant.radius:
            raise ParameterError(f"the surface's radius must exceed contact_radius = {plant.radius} m; got {env.radius} m")
        if isinstance(env, ElasticSphere):
            g.type = mujoco.mjtGeom.mjGEOM_SPHERE
            g.pos = np.pad(env.center, (0, 3 - env.space))
            g.size = [env.radius - plant.radius, 0.0, 0.0]
        else:  # ElasticCylinder
            g.type = mujoco.mjtGeom.mjGEOM_CYLINDER
            g.pos = env.point
            g.size = [env.radius - plant.radius, 5.0, 0.0]  # 10 m long: infinite for the tool
            g.quat = quat_z_to(env.axis)
        plant._probe_depth = env.radius - plant.radius  # calibration: the probe touches the geom's side (its local x)
    g.condim = 1
    g.solimp = [plant.impedance, plant.impedance, 1e-6, 0.5, 2.0]
    g.solref = [-1.0, -1.0]  # set by _calibrate
    return True


def friction_note(env: Any, damping_raised: bool) -> str:
    """What MuJoCo does differently from the built-in FrictionalContact ``env`` (one sentence per difference)."""
    parts = [f"MuJoCo's friction is Coulomb with μ = kinetic = {env.mu_k:g} (elliptic cone, soft): no static coefficient "
             f"(static = {env.mu_s:g} not modelled: a pull between μ_k f_n and μ_s f_n slides instead of sticking), "
             "no stick/slip state"]
    if env.viscous > 0:
        parts.append(f"viscous = {env.viscous:g} N s/m not modelled")
    if damping_raised:
        parts.append(f"the contact damping raised to {FRICTION_MIN_DAMPING:g} N s/m (MuJoCo's friction acts through it)")
    return "; ".join(parts)


def add_friction(plant: Any, spec: Any, env: Any, add_surface: Any) -> bool:
    """Add a FrictionalContact ``env``: its surface through ``add_surface(spec)`` (the plant's own builder, with
    ``plant.environment`` the surface meanwhile), then MuJoCo's friction on it (see the module's text). The note
    goes to stderr (:class:`MujocoFrictionNote`) and to ``plant.notes``. All coefficients zero: the frictionless
    contact (condim 1), no note."""
    import warnings

    mujoco = plant._mujoco
    plant.environment = env.surface
    try:
        contact = add_surface(spec)
    finally:
        plant.environment = env
    if env.mu_s == 0.0 and env.mu_k == 0.0 and env.viscous == 0.0:  # no friction at all: the frictionless contact
        return contact
    raised = plant._c_env < FRICTION_MIN_DAMPING
    plant._c_env = max(plant._c_env, FRICTION_MIN_DAMPING)
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = FRICTION_IMPRATIO
    for g in spec.geoms:
        if g.name in ("environment", "ee_contact"):
            g.condim = 3
            g.friction = [env.mu_k, 0.0, 0.0]
    plant._contact_row = int(mujoco.mjtConstraint.mjCNSTR_CONTACT_ELLIPTIC)  # the normal row of an elliptic contact
    note = friction_note(env, raised)
    plant.notes = [*getattr(plant, "notes", []), note]
    warnings.warn(note, MujocoFrictionNote, stacklevel=4)
    return contact
