"""Registration of the 6-D analysis: spatial impedance (9.36) and admittance (9.37) on linear environments.

Kept apart from ``parts_spatial`` (which :mod:`.core` imports for the 6-D robots) so that importing
:func:`.core.register_analysis` here closes no import circle.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .core import register_analysis

# ----------------------------------------------------------------------------- 6-D analysis


def _spatial_impedance_applies(parts: dict[str, Any]) -> bool:
    from ..controllers.admittance import AdmittanceController
    from ..controllers.spatial import SpatialImpedanceController
    from ..trajectories import Setpoint

    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    if not isinstance(ctl, (SpatialImpedanceController, AdmittanceController)) or not isinstance(ref, Setpoint):
        return False
    if ref.dim != 6 or not hasattr(env, "stiffness_matrix"):
        return False
    if isinstance(ctl, SpatialImpedanceController) and not getattr(ctl, "force_measurement", True):
        return False
    K = np.asarray(env.stiffness_matrix(), dtype=float)
    if K.shape != (6, 6):
        return False
    gains = (ctl.inertia, ctl.damping, ctl.stiffness)
    coupled = any(np.any(np.abs(G[:3, 3:]) > 0.0) or np.any(np.abs(G[3:, :3]) > 0.0) for G in gains)
    # translation only: the environment acts on forces (a table, a translational spring)
    return not coupled and not np.any(np.abs(K[3:, :]) > 0.0) and not np.any(np.abs(K[:, 3:]) > 0.0)


def _spatial_impedance_analysis(parts: dict[str, Any]) -> dict[str, Any]:
    """Equilibrium, ω_n and ζ of the translational part of (9.36) (impedance) or (9.37) (admittance).

    On the desired frame O_d (o_d, R_d), the impedance's closed loop (9.36) and the compliant frame
    of admittance control (9.37), with an ideal motion loop (the tip on the compliant frame), are
    ``M z̃̈ + K_D z̃̇ + K_P z̃ = h_e^d``; with a translational environment ``h_e = K (o_e − o_r)`` in
    the base frame, ``p = R_dᵀ (o_e − o_d)`` obeys ``M p̈ + K_D ṗ + (K_P + K^d) p = K^d p_r``,
    ``K^d = R_dᵀ K R_d``, ``p_r = R_dᵀ (o_r − o_d)`` — the coupled linear model of
    :func:`~forcecontrol.analysis.impedance_modes` on the 3 × 3 translational blocks (the gains
    must not couple translation and rotation; the environment must exert no moment). The
    equilibrium is reported in the base frame (``steady_x/y/z``, ``steady_fx/fy/fz``, force
    exerted on the environment), the modes along the desired frame's axes when they decouple.
    Impedance in the base frame (``frame="base"``, (9.31)): the same with R_d = I.
    """
    from ..analysis import impedance_modes
    from ..spatial import euler_xyz_to_rotation

    ctl, env, ref = parts["controller"], parts["environment"], parts["reference"]
    pose = np.asarray(ref.position, dtype=float)
    o_d, R_d = pose[:3], euler_xyz_to_rotation(pose[3:])
    if getattr(ctl, "frame", "desired") == "base":  # (9.31): the translational error in base-frame axes
        R_d = np.eye(3)
    K = np.asarray(env.stiffness_matrix(), dtype=float)[:3, :3]
    Kd = R_d.T @ K @ R_d
    Kd = 0.5 * (Kd + Kd.T)
    rest = np.asarray(env.point if hasattr(env, "point") else env.rest_position, dtype=float)[:3]
    normal = getattr(env, "normal", None)
    md = impedance_modes(
        ctl.inertia[:3, :3], ctl.damping[:3, :3], ctl.stiffness[:3, :3], Kd, np.zeros(3), R_d.T @ (rest - o_d),
        one_sided_normal=None if normal is None else R_d.T @ np.asarray(normal, dtype=float)[:3],
    )
    o_e = o_d + R_d @ md.position
    force = R_d @ md.contact_force
    out: dict[str, Any] = {}
    for i, a in enumerate("xyz"):
        out[f"steady_{a}"] = float(o_e[i])
        out[f"steady_f{a}"] = float(force[i])
    D = np.abs(md.directions)
    aligned = bool(np.all(np.abs(D.max(axis=1) - 1.0) < 1e-9)) and len(set(D.argmax(axis=1).tolist())) == 3
    for i in range(3):
        name = "xyz"[int(D[i].argmax())] if aligned else str(i + 1)
        out[f"omega_n_{name}"] = float(md.natural_frequencies[i])
        out[f"zeta_{name}"] = float(md.damping_ratios[i])
    out["in_contact"] = md.in_contact
    return out


register_analysis(_spatial_impedance_applies, _spatial_impedance_analysis)
