"""The analysis of Franka's ``cartesian_impedance_example_controller`` against a plane (issue 30).

For a case whose controller is :class:`~forcecontrol.controllers.vendor.FrankaCartesianImpedanceController`
on a torque robot (the Panda) against a plane (or a spring stiff along one direction), ``forcecontrol
analyze`` reports the sampled loop of :mod:`forcecontrol.analysis.vendor_franka`, linearised at the
case's q0 with the controller's target gains (after the soft start) and its sample time: the spectral
radius at the environment's stiffness, the stability limit in environment stiffness [N/m], the margin
(limit / k_e), the verdict (``settles``; ``bounces`` beyond the limit; ``unstable in free space`` when
the loop is unstable without contact) and the equilibrium contact force. The names are those of the
other vendor controllers' analysis (:mod:`.parts_vendor_analysis`), so their units and consumers are
shared. Registered by the package's ``parts*`` loader (``scenarios/__init__.py``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["franka_quantities"]

_CLASS = "FrankaCartesianImpedanceController"


def franka_quantities(loop: Any, k_e: float) -> dict[str, Any]:
    """Spectral radius, limit, margin and verdict of a :class:`~forcecontrol.analysis.vendor_franka.FrankaContactLoop`
    at the environment stiffness ``k_e`` [N/m]."""
    from ..analysis.vendor_franka import franka_spectral_radius, franka_stability_limit

    rho = franka_spectral_radius(loop, k_e)
    limit = franka_stability_limit(loop)
    if rho < 1.0:
        verdict = "settles"
    else:
        verdict = "unstable in free space" if limit == 0.0 else "bounces"
    return {"environment_stiffness": float(k_e), "vendor_loop_spectral_radius": rho, "vendor_loop_stability_limit": limit,
            "vendor_loop_margin": limit / k_e if k_e > 0 else math.inf, "vendor_loop_verdict": verdict}


def _summary(loop: Any, ctl: Any) -> str:
    from ..analysis.vendor_franka import nyquist_stiffness

    return (f"franka_ros cartesian_impedance_example_controller (translational {ctl.translational_stiffness:g} N/m, "
            f"rotational {ctl.rotational_stiffness:g} N m/rad, nullspace {ctl.nullspace_stiffness:g}, D = 2 sqrt(K)) on the "
            f"torque interface at {1.0 / loop.sample_time:g} Hz (zero-order hold, no delay), the arm's M(q0) and J(q0), the "
            f"contact a spring along the normal; the contact mode meets the Nyquist frequency at Λ_n (π/T_s)² = "
            f"{nyquist_stiffness(loop):.4g} N/m. Linear: the soft start, the pose filter and the torque-rate clamp "
            f"(±{ctl.delta_tau_max:g} N m per cycle) are not in the model")


def _advice(loop: Any, k_e: float, verdict: str) -> str:
    """Which stiffness (translational or rotational, D = 2 sqrt(K) with it) makes the loop stable at ``k_e``, or why none does."""
    from ..analysis.vendor_franka import franka_design_stiffness
    from ..errors import ParameterError

    target = 0.0 if verdict == "unstable in free space" else k_e
    where = "without contact" if target == 0.0 else f"at k_e = {k_e:g} N/m"
    hints = []
    for axes, unit in (("rotational", "N m/rad"), ("translational", "N/m")):
        try:
            k = franka_design_stiffness(loop, target, margin=1.0, axes=axes)
        except ParameterError:
            continue
        hints.append(f"{axes}_stiffness <= {k:.4g} {unit}")
    rate = f"{1.0 / loop.sample_time:g} Hz"
    if not hints:
        return (f"no stiffness alone makes the loop stable {where} at {rate}: the contact mode is past the Nyquist "
                "frequency (a softer contact, a compliant tool or a higher rate is needed)")
    return f"stable {where} at {rate} with " + " or ".join(hints) + " (the other gains as they are)"


def _applies(parts: dict[str, Any]) -> bool:
    from ..robots.servo import PositionInterfaceRobot
    from .parts_servo import _normal_stiffness

    return (type(parts["controller"]).__name__ == _CLASS and not isinstance(parts["robot"], PositionInterfaceRobot)
            and _normal_stiffness(parts["environment"]) is not None)


def _analysis(parts: dict[str, Any]) -> dict[str, Any]:
    from ..analysis.vendor_franka import franka_contact_loop
    from ..core.axes import axis_names
    from .parts_servo import _normal_stiffness

    ctl, robot, env = parts["controller"], parts["robot"], parts["environment"]
    nu, k_e = _normal_stiffness(env)  # type: ignore[misc]
    nu = np.asarray(nu, dtype=float)[:3]
    loop = franka_contact_loop(robot, np.asarray(parts["q0"], dtype=float), ctl, nu,
                               contact_damping=float(getattr(env, "damping", 0.0) or 0.0))
    out: dict[str, Any] = {"vendor_loop": _summary(loop, ctl), **franka_quantities(loop, k_e)}
    if out["vendor_loop_verdict"] != "settles":
        out["vendor_loop_advice"] = _advice(loop, k_e, out["vendor_loop_verdict"])
    # at rest: the law's spring K (translational, along ν) in series with the surface, the target δ_t below it
    ref = parts["reference"].at(float(parts["duration"]))
    point = np.asarray(getattr(env, "point", getattr(env, "rest_position", np.zeros(3))), dtype=float)[:3]
    depth = float(nu @ (point - np.asarray(ref.position, dtype=float)[:3]))
    K = float(ctl.translational_stiffness)
    h = min(-k_e * K * depth / (K + k_e), 0.0)
    names = axis_names(int(robot.task_dim))[2]
    out.update({f"steady_{names[i]}": float(nu[i] * h) + 0.0 for i in range(3)})
    return out


def _register_analyses() -> None:
    from .checks import register_once

    register_once(_applies, _analysis)
