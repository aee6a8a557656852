"""Poses, XYZ Euler angles, the operational-space error on the desired frame, frame-tagged wrenches.

The chapter's 6-D quantities (Sect. 9.2.2, 9.3):

* the displacement of the end-effector frame from the desired frame (9.8)
  ``T_e^d = T_d⁻¹ T_e``, ``R_e^d = R_dᵀ R_e``, ``o_{d,e}^d = R_dᵀ (o_e − o_d)``;
* the error (9.9) ``x̃ = −[o_{d,e}^d; φ_{d,e}]`` with φ_{d,e} the XYZ Euler angles of ``R_e^d``;
* ``ω = T(φ) φ̇`` (3.64) for XYZ angles, ``T_A = blockdiag(I, T)``, ``T(0) = I`` (Problem 3.13);
* the analytical Jacobian on the desired frame (9.14) ``J_Ad = T_A⁻¹(φ_{d,e}) blockdiag(R_dᵀ, R_dᵀ) J``;
* ``x̃̇ = −J_Ad q̇ + b`` (9.33), with b in its corrected form (the chapter misprints the first
  block): ``b = [R_dᵀ ȯ_d + S(ω_d^d) o_{d,e}^d; T⁻¹(φ_{d,e}) ω_d^d]``.

XYZ angles have a representation singularity at ``cos φ₂ = 0`` (``det T = cos φ₂``).
:func:`rotation_vector` and :func:`rotvec_T` give the axis-angle alternative (singular only at a
rotation of 2π), used by the 6-D controllers with ``orientation="rotvec"``.

Naming follows the frames: ``R_d`` is the desired frame's rotation in the base frame, ``h_e_d``
a wrench expressed in the desired frame.

The package: :mod:`.rotations` (XYZ Euler angles, rotation vectors via SciPy's ``Rotation``; the
T maps), :mod:`.closed_form` (the same conversions in closed form, for per-sample code),
:mod:`.error` (the error on the desired frame, (9.8)–(9.33)) and :mod:`.frames` (Transform,
Wrench, Twist).
"""

from __future__ import annotations

from . import error, frames, rotations
from .error import *  # noqa: F403
from .frames import *  # noqa: F403
from .rotations import *  # noqa: F403

#: the public names of the submodules (each keeps its own list).
__all__ = [*rotations.__all__, *error.__all__, *frames.__all__]
