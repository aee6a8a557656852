"""A contact that the integrator cannot follow is refused or stopped, never silent (issue 27).

References: RK4's stability interval (2√2 on the imaginary axis, 2.785 on the real one); the contact
mode ω = √(k νᵀ J B⁻¹ Jᵀ ν) computed here from the arm's Jacobian and inertia (NumPy), not by
the simulator's own helper.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import ParameterError, SimulationDivergedError
from forcecontrol.sim.limits import RK4_STABILITY


def _normal_mode(robot, q, normal, k):
    """ω [rad/s] of a spring k along the unit normal, from the arm's own B(q) and J(q)."""
    J, B = np.asarray(robot.jacobian(q)), np.asarray(robot.mass_matrix(q))
    nu = np.zeros(J.shape[0])
    nu[: len(normal)] = normal
    return math.sqrt(k * float(nu @ J @ np.linalg.solve(B, J.T) @ nu))


def test_rk4_bound_is_its_stability_interval():
    """RK4_STABILITY lies inside RK4's stability interval on both axes: |R(z)| <= 1 at z = ±i·b and z = −b."""
    def amp(z):
        return abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)
    assert amp(1j * RK4_STABILITY) <= 1.0 and amp(-RK4_STABILITY) <= 1.0
    assert amp(1j * 2.9) > 1.0 and amp(-2.8) > 1.0  # and close to its edge


def test_planar_arm_explicit_substeps_that_miss_the_contact_are_refused():
    """ElasticPlane(1e12) with substeps = 2: refused before running, naming substeps, the number needed and k."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    need = math.ceil(_normal_mode(arm, q0, [1.0, 0.0], 1e12) * 1e-3 / RK4_STABILITY)
    ctl = fc.InnerVelocityForceController(arm, 100.0, 500.0, 2500.0, [0.0024, 0.0])
    with pytest.raises(ParameterError, match=rf"substeps = 2 does not resolve the contact.*1e\+12 N/m.*at least {need:,}"):
        fc.simulate(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e12), ctl, fc.Setpoint([1.015, 0.1], [10.0, 0.0]),
                    q0=q0, duration=0.5, substeps=2)
    # an explicit substeps that RK4 can follow still runs (1e6 N/m: ω h ≈ 0.04)
    res = fc.simulate(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e6), ctl, fc.Setpoint([1.015, 0.1], [10.0, 0.0]),
                      q0=q0, duration=0.05, substeps=2)
    assert res.metadata["substeps"] == 2


def test_panda_on_a_1e12_table_with_substeps_2_is_refused():
    """The Panda on a 10¹² N/m table with substeps = 2 (it ran and reported 0 N): refused before running."""
    pytest.importorskip("pinocchio")
    scn = fc.scenario("panda-table-line").with_({"environment.stiffness": 1e12, "substeps": 2})
    with pytest.raises(ParameterError, match=r"substeps = 2 does not resolve the contact.*1e\+12 N/m.*at least"):
        scn.run()


@pytest.mark.parametrize("engine", ["python", "compiled"])
def test_contact_met_later_in_a_stiffer_configuration_stops_the_run(engine):
    """Resolved at q0 (stretched arm) but not where the tip meets the plane: stopped there, cause named."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.95, 0.0], elbow="up")
    k, h = 1.5e10, 1e-3
    assert _normal_mode(arm, q0, [1.0, 0.0], k) * h < RK4_STABILITY  # the check before the run passes
    q_touch = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    assert _normal_mode(arm, q_touch, [1.0, 0.0], k) * h > 2 * RK4_STABILITY  # not where the contact happens
    with pytest.raises(SimulationDivergedError, match="unresolved contact") as err:
        fc.simulate(arm, fc.ElasticPlane([1.0, 0.0], [1.0, 0.0], k), fc.ImpedanceController(arm, 10.0, 200.0, 1000.0),
                    fc.Setpoint([0.9, 0.0], [0.0, 0.0]), q0=q0, duration=1.0, substeps=1, engine=engine)
    e = err.value
    assert e.cause == "unresolved contact" and "RK4's stability bound" in str(e) and "substeps" in str(e)
    x = e.partial.x[-1]
    assert abs(x[0] - 1.0) < 5e-3 and e.step == e.partial.t.shape[0] - 1  # where the tip meets the plane


def test_panda_contact_entered_and_left_within_a_sample_is_caught_in_the_loop():
    """The Python loop's guard: a contact seen only inside the RK4 stages (0 N at every sample) stops at sample 0."""
    pytest.importorskip("pinocchio")
    from forcecontrol.controllers.base import Measurement
    from forcecontrol.scenarios.build import build_case
    from forcecontrol.sim.simulation import _python_loop, pre_start_wrench

    scn = fc.scenario("panda-table-line").with_({"environment.stiffness": 1e12})
    p = build_case(scn.cases[0])
    robot, env, ctl, ref = p["robot"], p["environment"], p["controller"], p["reference"]
    q0, qd0 = np.asarray(p["q0"], dtype=float), np.zeros(robot.nq)
    N, m, n, Ts = 50, robot.task_dim, robot.nq, ctl.sample_time
    refs = np.ascontiguousarray(ref.sample(np.arange(N + 1) * Ts))
    ctl.reset(Measurement(q0, qd0, pre_start_wrench(robot, env, q0, qd0)), ref.at(0.0))
    logs = {name: np.full((N + 1, n if name in ("q", "qd", "torque") else m), np.nan)
            for name in ("q", "qd", "x", "xd", "wrench", "wrench_measured", "torque")}
    status, k = _python_loop(robot, env, ctl, refs, np.zeros(m), np.zeros((N + 1, m)), 1.0, q0, qd0, Ts, 2, 50.0, logs)
    assert (status, k) == (5, 0)
    assert not np.any(logs["wrench"][0])  # nothing at the sample itself: the contact came and went inside it


def test_a_sweep_with_explicit_substeps_that_miss_the_contact_is_refused():
    """A sweep of Example 9.2 at 1e12 N/m with substeps = 2 is refused before running, as simulate() refuses it."""
    from forcecontrol.sweep import SweepDefinition, SweepError, prepare_sweep

    d = SweepDefinition.from_options({"environment.stiffness": [1e12], "substeps": [2]})
    with pytest.raises(SweepError, match=r"substeps = 2 does not resolve the contact"):
        prepare_sweep("example-9.2", d)
