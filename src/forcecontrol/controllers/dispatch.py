"""The compiled dispatcher: one branch per controller kind.

The compiled simulation loop calls :func:`controller_step` each sample; each branch calls the
same law function the controller's Python ``step`` uses, through its packed adapter (the
parameter layout is documented next to each adapter). Adding a controller to the compiled path
means adding its adapter here with the ``kind`` of its class.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .compliance import joint_pd_packed, os_pd_packed
from .force import inner_position_packed, inner_velocity_packed, parallel_packed
from .hybrid import hybrid_compliant_packed, hybrid_rigid_packed
from .impedance import impedance_packed

__all__ = ["controller_step", "COMPILED_KINDS"]

#: controller kinds the compiled loop knows.
COMPILED_KINDS = frozenset({1, 2, 3, 4, 5, 6, 7, 8})


@njit(cache=True)
def controller_step(kind, t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s):  # pragma: no cover
    """Torques of controller ``kind`` with packed parameters ``p`` and state ``s``."""
    if kind == 1:
        return os_pd_packed(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
    if kind == 2:
        return joint_pd_packed(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
    if kind == 3:
        return impedance_packed(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
    if kind == 4:
        return inner_position_packed(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
    if kind == 5:
        return inner_velocity_packed(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
    if kind == 6:
        return parallel_packed(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
    if kind == 7:
        return hybrid_compliant_packed(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
    if kind == 8:
        return hybrid_rigid_packed(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s)
    u = np.empty(q.shape[0])
    u[:] = np.nan
    return u
