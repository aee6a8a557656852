"""The chapter's control laws, each written once, compiled, generic in the task dimension.

Every law is one Numba function with the same signature::

    ok = law(t, dt, q, qd, x, xd, J, Jdq, B, nv, g, h, ref, p, s, ws, u)

* ``q, qd`` (n,): joint state; ``x, xd`` (m,): end-effector position and velocity (J q̇);
  ``J`` (m, n), ``Jdq`` = J̇ q̇ (m,), ``B`` (n, n), ``nv`` = C q̇ + F q̇ + g (n,), ``g`` (n,);
* ``h`` (m,): the measured end-effector force (base frame);
* ``ref`` (6 m,): the reference row ``[x_d, ẋ_d, ẍ_d, f_d, ḟ_d, f̈_d]``
  (:data:`forcecontrol.laws.layout.REFERENCE`, one block per
  :data:`forcecontrol.controllers.base.REFERENCE_FIELDS` entry);
* ``p``: the controller's packed parameters; ``s``: its state (integrators), advanced in place by
  one sample ``dt``. Each law's layouts are declared once in :mod:`forcecontrol.laws.layout`
  (``IMPEDANCE``, ``FORCE``, ``FORCE_STATE``, ...): the controller class packs through the
  declaration, and the law reads every block by name (``p[impedance_K_P(m) + i * m + j]``);
* ``ws``: scratch of at least :func:`workspace_size` (m, n) floats; ``u`` (n,): the torques,
  written in place. Nothing is allocated.

``on_arm(law)`` is the law on the chapter's arm in one compiled call, for ``Controller.step``
(the checks and terms of :mod:`forcecontrol.laws.arm`, then the law). The inverse-dynamics
schemes are written as their acceleration (``*_acceleration``, the chapter's equation) and
composed with the inner loop (9.30) once, by :func:`inverse_dynamics_law`.

It returns False when the law cannot be applied (a singular Jacobian in the inner loop (9.30));
``u`` is then NaN.

The same function runs everywhere: ``Controller.step`` in a user's loop (through one fused
compiled call on the chapter's arm, or on the robot's terms for any other robot), the compiled
single-run loop (:mod:`forcecontrol.sim.loop`) and the sweeps' batch kernel
(:mod:`forcecontrol.sim.batch`), both of which take the law as a compiled function argument and so
are specialised per law. Inverse-dynamics laws also expose their acceleration part
(``*_acceleration``), so that a redundant or near-singular arm runs the same law through the
damped inner loop of :mod:`forcecontrol.controllers.redundant`.
"""

from __future__ import annotations

from .arm import on_arm
from .compliance import joint_pd, os_pd
from .force import (
    inner_position,
    inner_position_acceleration,
    inner_velocity,
    inner_velocity_acceleration,
    parallel,
    parallel_acceleration,
)
from .hybrid import (
    hybrid_compliant,
    hybrid_compliant_acceleration,
    hybrid_rigid,
    hybrid_rigid_acceleration,
)
from .impedance import impedance, impedance_acceleration, impedance_core
from .inner import inverse_dynamics, inverse_dynamics_law
from .spatial import spatial_impedance_torque

__all__ = [
    "workspace_size",
    "inverse_dynamics",
    "inverse_dynamics_law",
    "on_arm",
    "os_pd",
    "joint_pd",
    "impedance",
    "impedance_acceleration",
    "impedance_core",
    "spatial_impedance_torque",
    "inner_position",
    "inner_position_acceleration",
    "inner_velocity",
    "inner_velocity_acceleration",
    "parallel",
    "parallel_acceleration",
    "hybrid_compliant",
    "hybrid_compliant_acceleration",
    "hybrid_rigid",
    "hybrid_rigid_acceleration",
]


def workspace_size(m: int, n: int) -> int:
    """Scratch floats every law needs for task dimension m and n joints."""
    return 2 * m * m + 12 * m + 2 * n + 8
