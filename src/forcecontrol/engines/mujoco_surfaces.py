"""Curved surfaces in the MuJoCo engine: an :class:`~forcecontrol.environments.surfaces.ElasticSphere` or
:class:`~forcecontrol.environments.surfaces.ElasticCylinder` as MuJoCo's sphere or cylinder geom.

The geom's radius is the surface's less the end-effector sphere's (``contact_radius``), so that the
penetration MuJoCo sees between the two spheres (or the sphere and the cylinder) is the surface's δ
at the controlled frame's origin; the contact force acts along the line of centres, the surface's
normal. The stiffness and damping are calibrated like the plane's (:meth:`MujocoPlant._calibrate`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError

__all__ = ["add_surface_geom", "quat_z_to"]


def quat_z_to(direction: np.ndarray) -> list[float]:
    """MuJoCo's quaternion (w, x, y, z) of the shortest rotation taking the local z axis onto ``direction`` (unit)."""
    z = np.array([0.0, 0.0, 1.0])
    ax = np.cross(z, direction)
    s, c = float(np.linalg.norm(ax)), float(z @ direction)
    if s < 1e-12:
        return [1.0, 0.0, 0.0, 0.0] if c > 0 else [0.0, 1.0, 0.0, 0.0]
    ang = math.atan2(s, c)
    return [math.cos(ang / 2), *(math.sin(ang / 2) * ax / s)]


def add_surface_geom(plant: Any, spec: Any, env: Any) -> bool:
    """Add the environment geom for ``env`` to ``spec``: a sphere (for the planar arm, the circle is the sphere's cut
    by the arm's plane z = 0) or a cylinder, its radius less the end-effector sphere's. Returns True (a contact)."""
    from ..environments.surfaces import ElasticCylinder, ElasticSphere

    mujoco = plant._mujoco
    if env.dim != plant.robot.task_dim:
        raise ParameterError(f"the environment is {env.dim}-dimensional, the robot's task {plant.robot.task_dim}-dimensional")
    if not isinstance(env, (ElasticSphere, ElasticCylinder)):
        raise ParameterError(
            f"the MuJoCo engine models ElasticSphere and ElasticCylinder surfaces; got {type(env).__name__}"
        )
    if env.radius <= plant.radius:
        raise ParameterError(f"the surface's radius must exceed contact_radius = {plant.radius} m; got {env.radius} m")
    g = spec.worldbody.add_geom()
    g.name = "environment"
    if isinstance(env, ElasticSphere):
        g.type = mujoco.mjtGeom.mjGEOM_SPHERE
        g.pos = np.pad(env.center, (0, 3 - env.space))
        g.size = [env.radius - plant.radius, 0.0, 0.0]
    else:  # ElasticCylinder
        g.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        g.pos = env.point
        g.size = [env.radius - plant.radius, 5.0, 0.0]  # 10 m long: infinite for the tool
        g.quat = quat_z_to(env.axis)
    plant._k_env, plant._c_env = float(env.stiffness), float(env.damping)
    plant._probe_depth = env.radius - plant.radius  # calibration: the probe touches the geom's side (its local x)
    g.condim = 1
    g.solimp = [plant.impedance, plant.impedance, 1e-6, 0.5, 2.0]
    g.solref = [-1.0, -1.0]  # set by _calibrate
    return True
