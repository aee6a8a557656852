"""Points on a curved environment's surface for drawing (issue 31, item 4): a sphere, a cylinder, a height field.

Any environment with the curved surfaces' ``geometry(p) -> (φ, p_c, ν)``
(:class:`~forcecontrol.environments.surfaces.ElasticSurface`, also inside a
:class:`~forcecontrol.environments.friction.FrictionalContact`) is drawn the same way: a grid on the plane
tangent to the surface at the point nearest the tool's path (a segment in 2-D), each grid point replaced by
its closest point of the surface, ``p_c``. So every drawn point lies on the surface (φ(p_c) = 0), whatever the
shape, and the patch covers the part of the surface the tool visits. No environment class is imported
(duck typing on ``geometry``): the drawing stays below the models in the layers.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["curved_surface", "surface_patch"]


def curved_surface(environment: Any) -> Any:
    """The environment's curved surface (an object with ``geometry`` and ``space``), or None (planes and the rest)."""
    if environment is None:
        return None
    surface = getattr(environment, "surface", environment)  # FrictionalContact holds the surface
    if not callable(getattr(surface, "geometry", None)) or getattr(surface, "space", None) not in (2, 3):
        return None
    return surface


def surface_patch(environment: Any, tips: Any, half: float, samples: int = 25) -> np.ndarray | None:
    """Points on the environment's surface around the tool's path, or None when it has no curved surface.

    Args:
        environment: the run's environment.
        tips: tool positions (N, d), d >= the surface's dimension [m]; the patch is centred at their mean's
            closest surface point.
        half: the patch's half-width on the tangent plane [m], > 0.
        samples: grid points per side.

    Returns:
        3-D: (samples, samples, 3) points (a grid for ``plot_surface``); 2-D: (samples, 2) points (a curve).
    """
    surface = curved_surface(environment)
    if surface is None:
        return None
    d = int(surface.space)
    tips = np.asarray(tips, dtype=np.float64)[:, :d]
    _phi, c, n = surface.geometry(tips.mean(axis=0))
    s = np.linspace(-half, half, int(samples))
    if d == 2:
        t = np.array([-n[1], n[0]])
        return np.array([surface.geometry(c + si * t)[1] for si in s])
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    return np.array([[surface.geometry(c + a * u + b * v)[1] for b in s] for a in s])
