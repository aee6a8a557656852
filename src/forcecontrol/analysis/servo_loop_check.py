"""The predicted stability limit of admittance control on a position-interface arm, checked by simulation.

:func:`simulated_stability_limit` bisects on the environment stiffness k_e in the full
simulation (the arm's dynamics, the servo at its step, the law at the interface rate) against a
bilateral spring ``h = k_e ν νᵀ (x − x_r)`` (so that the loop stays linear: a one-sided plane
would bounce off and hide the growth). A run is *stable* when the contact force's deviation from
its equilibrium is smaller over the last quarter of the run than over the third quarter (the
start's slow transient has died out by then), *unstable* when it is not or when the run diverges.

``python -m forcecontrol.analysis.servo_loop_check`` prints the predicted-vs-simulated table for
the chapter's arm at 500, 250 and 125 Hz (the issue asks for two rates).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import SimulationDivergedError

__all__ = ["simulated_stability_limit", "stable_in_simulation", "chapter_arm_case"]


def stable_in_simulation(controller: Any, q0: Any, x_d: Any, rest: Any, normal: Any, k_e: float, *,
                         duration: float = 3.0) -> bool:
    """Whether the simulated loop settles against the spring of stiffness k_e (see the module docstring)."""
    from ..environments.elastic import LinearSpring
    from ..sim.simulation import simulate
    from ..trajectories import Setpoint

    robot = controller.robot
    m = int(robot.task_dim)
    nu = np.zeros(m)
    nn = np.asarray(normal, dtype=np.float64)
    nu[: nn.size] = nn / np.linalg.norm(nn)
    env = LinearSpring(k_e * np.outer(nu, nu), rest)
    try:
        r = simulate(robot, env, controller, Setpoint(x_d), q0=q0, duration=duration)
    except SimulationDivergedError:
        return False
    f = r.wrench @ nu
    n = f.size
    late = f[3 * n // 4 :]
    third = f[n // 2 : 3 * n // 4]
    centre = float(np.mean(late))
    a3 = float(np.max(np.abs(third - centre)))
    a4 = float(np.max(np.abs(late - centre)))
    return bool(np.all(np.isfinite(f))) and a4 < a3


def simulated_stability_limit(controller: Any, q0: Any, x_d: Any, rest: Any, normal: Any, k_low: float, k_high: float, *,
                              iterations: int = 6, duration: float = 3.0) -> tuple[float, float]:
    """Bracket [k_stable, k_unstable] of the stability limit by bisection in simulation.

    ``k_low`` must be stable and ``k_high`` unstable in simulation (checked; a ValueError-type
    :class:`~forcecontrol.errors.ParameterError` otherwise).
    """
    from ..errors import ParameterError

    if not stable_in_simulation(controller, q0, x_d, rest, normal, k_low, duration=duration):
        raise ParameterError(f"k_low = {k_low:g} N/m is not stable in simulation: lower it")
    if stable_in_simulation(controller, q0, x_d, rest, normal, k_high, duration=duration):
        raise ParameterError(f"k_high = {k_high:g} N/m is stable in simulation: raise it")
    lo, hi = k_low, k_high
    for _ in range(iterations):
        mid = math.sqrt(lo * hi)
        if stable_in_simulation(controller, q0, x_d, rest, normal, mid, duration=duration):
            lo = mid
        else:
            hi = mid
    return lo, hi


def chapter_arm_case(rate: float, *, bandwidth: float = 44.7, damping: float = 0.67, delay: int = 1,
                     sample_time: float = 5e-4) -> dict[str, Any]:
    """The issue's reference case: the chapter's arm, tip on the plane x = 1 (elbow up), x_d 1 cm inside,
    M_t = 10 kg, K_Dt = 200 N s/m, K_Pt = 1000 N/m, a UR-like servo (servoj gain 2000, lookahead
    0.03 s: ω = 44.7 rad/s, ζ = 0.67) with one cycle of delay, at ``rate``."""
    from ..controllers.admittance_position import PositionAdmittanceController
    from ..robots.planar_2r import PlanarTwoLink
    from ..robots.servo import JointServo, PositionInterfaceRobot

    arm = PlanarTwoLink()
    servo = JointServo(nq=2, rate=rate, bandwidth=bandwidth, damping=damping, delay=delay, name="ur-like")
    pir = PositionInterfaceRobot(arm, servo)
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    ctl = PositionAdmittanceController(pir, 10.0, 200.0, 1000.0, sample_time=sample_time)
    return {"controller": ctl, "q0": q0, "x_d": np.array([1.01, 0.0]), "rest": np.array([1.0, 0.0]),
            "normal": np.array([-1.0, 0.0])}


def _table() -> None:  # pragma: no cover - the report's measurement
    from .servo_loop import admittance_servo_loop

    print("rate [Hz] | predicted k_e limit [N/m] | simulated bracket [N/m] | predicted / simulated midpoint")
    for rate in (500.0, 250.0, 125.0):
        c = chapter_arm_case(rate)
        loop = admittance_servo_loop(c["controller"], c["q0"], c["normal"])
        k = loop.stability_limit()
        lo, hi = simulated_stability_limit(c["controller"], c["q0"], c["x_d"], c["rest"], c["normal"], 0.8 * k, 1.25 * k)
        mid = math.sqrt(lo * hi)
        print(f"{rate:9.0f} | {k:25.1f} | [{lo:8.1f}, {hi:8.1f}]    | {k / mid:.4f}")


if __name__ == "__main__":  # pragma: no cover
    _table()
