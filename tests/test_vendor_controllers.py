"""The vendor controllers on 6-D arms (issue 30, item 3): the 1-DOF closed forms hold along an axis of the UR5 and the Panda.

Position-interface controllers run their ``command`` once per 2-ms cycle with an ideal servo (the
measured joints are the previous command, survey §1.2/§2.5); the contact is an elastic plane
along z evaluated at the measured pose. Near the start posture the arm's z axis behaves as the
1-DOF twin, so its response is compared with the 1-DOF closed forms within 1 % of the step.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol.controllers.base import Measurement, Reference
from forcecontrol.controllers.vendor import (
    FrankaCartesianImpedanceController,
    FziComplianceController,
    FziForceController,
    Ros2AdmittanceController,
    UrForceModeController,
)
from forcecontrol.errors import ParameterError

pytest.importorskip("pinocchio")

from forcecontrol.robots.pinocchio import PANDA_READY, panda, ur5  # noqa: E402
from forcecontrol.robots.servo import PositionInterfaceRobot  # noqa: E402

Q0 = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])


@pytest.fixture(scope="module")
def arm():
    return ur5()


@pytest.fixture(scope="module")
def robot(arm):
    return PositionInterfaceRobot(arm, "ur-e-series")


def _run(arm, ctl, steps, f_d=None, k_e=0.0, z_e=None, dz_target=0.0):
    """``command`` in a loop with the ideal servo; returns z − z_0 of the measured pose per cycle."""
    x0 = arm.forward_kinematics(Q0)
    xt = x0.copy()
    xt[2] += dz_target
    ref = Reference.setpoint(xt, np.zeros(6) if f_d is None else np.array([0.0, 0.0, f_d, 0.0, 0.0, 0.0]))
    ctl.reset(Measurement(Q0, np.zeros(6), np.zeros(6)), ref)
    q = Q0.copy()
    out = np.empty(steps)
    for k in range(steps):
        dz = arm.frame_pose(q)[1][2] - x0[2]
        h = np.zeros(6)
        if z_e is not None and dz < z_e:
            h[2] = -k_e * (z_e - dz)
        q = np.asarray(ctl.command(k * 0.002, Measurement(q, np.zeros(6), h), ref).q)
        out[k] = arm.frame_pose(q)[1][2] - x0[2]
    return out


def test_ros2_admittance_on_ur5_follows_the_1dof_closed_form(arm, robot):
    """A 10 N wrench reference along −z: z follows M z̈ + (D + c_j M) ż + K z = F (discrete, α = 1) within 1 % of F/K."""
    M, zeta, K, c_j, T, F = 5.5, 0.3, 214.1, 1.0, 0.002, -10.0
    ctl = Ros2AdmittanceController(robot, mass=M, damping_ratio=zeta, stiffness=K, joint_damping=c_j,
                                   filter_coefficient=1.0, kinematics_alpha=0.0)
    z = _run(arm, ctl, 1500, f_d=F)
    D = zeta * 2.0 * math.sqrt(M * K)
    A = np.array([[1.0 - T * (D / M + c_j), -T * K / M], [T * (1.0 - T * (D / M + c_j)), 1.0 - T * T * K / M]])
    b = np.array([T * F / M, T * T * F / M])
    zr, v = np.zeros(2), []
    for _ in range(1500):  # the documented recurrence (survey §1.2) on (v, p), x_k = p_{k−1}
        zr = A @ zr + b
        v.append(zr[1])
    assert np.max(np.abs(z - np.array(v))) < 0.01 * abs(F / K)
    assert z[-1] == pytest.approx(F / K, rel=0.01)


def test_fzi_compliance_on_ur5_follows_the_1dof_closed_form(arm, robot):
    """A 1 cm target step along z: (z − 1)(z − 0.9) + 0.9 g with g = s p K h²/m_v, within 1 % of the step."""
    P, s, K, m_v, dz = 0.05, 0.5, 500.0, 1.3, 0.01
    ctl = FziComplianceController(robot, stiffness=[K] * 3 + [20.0] * 3, p=[P] * 3 + [1.5] * 3, error_scale=s, virtual_mass=m_v)
    z = _run(arm, ctl, 300, dz_target=dz)
    g = s * P * K * 0.02**2 / m_v
    A = np.array([[1.0, 1.0], [-0.9 * g, 0.9]])
    e, ref = np.array([-dz, 0.0]), []
    for _ in range(300):
        e = A @ e
        ref.append(dz + e[0])
    assert np.max(np.abs(z - np.array(ref))) < 0.01 * dz


def test_fzi_force_on_ur5_settles_at_the_target_force(arm, robot):
    """The force controller pushing 10 N into a 5 kN/m plane settles at 10 N (penetration 2 mm)."""
    ctl = FziForceController(robot, p=[0.05] * 3 + [1.5] * 3, error_scale=0.5)
    z = _run(arm, ctl, 1500, f_d=-10.0, k_e=5000.0, z_e=0.0)
    assert -5000.0 * z[-1] == pytest.approx(10.0, rel=1e-3)


def test_ur_force_mode_on_ur5_against_plane_closed_form(arm, robot):
    """force_mode compliant in z with 10 N down onto a 5 kN/m plane 1 cm below: the 1-DOF recurrence within 1 %."""
    T, G, sg, d, F, k_e, z_e = 0.002, 0.05, 0.5, 0.025, -10.0, 5000.0, -0.01
    ctl = UrForceModeController(robot, selection_vector=[0, 0, 1, 0, 0, 0], wrench=[0, 0, F, 0, 0, 0],
                                limits=[0.1, 0.1, 0.5, 0.785, 0.785, 0.785], damping=d, gain_scaling=sg, gain=G)
    z = _run(arm, ctl, 2000, k_e=k_e, z_e=z_e)
    v = x = 0.0
    ref = []
    for _ in range(2000):  # v ← (1 − d) v + T G s_g (F_d − F(x_{k−1})), x ← x + T v (the inferred law, 1 DOF)
        f = -k_e * (z_e - x) if x < z_e else 0.0
        v = (1.0 - d) * v + T * G * sg * (F - f)
        x += T * v
        ref.append(x)
    assert np.max(np.abs(z - np.array(ref))) < 0.01 * abs(z_e + F / k_e)
    assert z[-1] == pytest.approx(z_e + F / k_e, rel=1e-3)


def test_ur_force_mode_refuses_frame_types_it_does_not_model(robot):
    """force_mode types 1 and 3 re-orient the task frame from the TCP: refused, naming the type."""
    with pytest.raises(ParameterError, match="frame_type must be 2.*got 3"):
        UrForceModeController(robot, frame_type=3)


def test_franka_on_panda_settles_at_the_springs_in_series():
    """The Franka law on the Panda pressing a 2 kN/m table: z settles at (K z_d + k_e z_e)/(K + k_e) within 1 %."""
    from forcecontrol.environments.spatial import Table
    from forcecontrol.sim.simulation import simulate
    from forcecontrol.trajectories.profiles import Setpoint

    arm = panda()
    x0 = arm.forward_kinematics(PANDA_READY)
    _, p = arm.frame_pose(PANDA_READY)
    env = Table(point=p - np.array([0.0, 0.0, 0.005]), stiffness=2000.0)
    xd = x0.copy()
    xd[2] -= 0.02
    ctl = FrankaCartesianImpedanceController(arm, soft_start=False, filter_coefficient=1.0)
    res = simulate(arm, env, ctl, Setpoint(xd), q0=PANDA_READY, duration=2.0)
    expected = (200.0 * -0.02 + 2000.0 * -0.005) / 2200.0
    assert res.x[-1][2] - x0[2] == pytest.approx(expected, rel=0.01)


def test_franka_soft_start_begins_the_nullspace_stiffness_at_upstreams_20_and_filters_it_to_the_target():
    """franka_ros's example starts nullspace_stiffness_ at 20 (its header) and K, D at 0 (init), then filters each towards
    its target by 0.005 per cycle: k_ns = 0.5 + 19.5 * 0.995^k after k cycles (12.3, 7.7, 2.1 at 100, 200, 500 ms)."""
    from forcecontrol.laws.vendor.layout import FRANKA_STATE

    arm = panda()
    ctl = FrankaCartesianImpedanceController(arm)  # soft start, nullspace_stiffness 0.5 (the .cfg default)
    m = Measurement(PANDA_READY.copy(), np.zeros(7), np.zeros(6))
    ref = Reference.setpoint(arm.forward_kinematics(PANDA_READY))
    ctl.reset(m, ref)
    k_ns, K = FRANKA_STATE.slice("k_ns", 6, 7), FRANKA_STATE.slice("K", 6, 7)
    assert ctl.state[k_ns][0] == 20.0 and not ctl.state[K].any()
    seen = {}
    for k in range(1, 501):
        ctl.step((k - 1) * 1e-3, m, ref)
        seen[k] = float(ctl.state[k_ns][0])
    for k, printed in ((100, 12.3), (200, 7.7), (500, 2.1)):
        assert seen[k] == pytest.approx(0.5 + 19.5 * 0.995**k, rel=1e-9)
        assert seen[k] == pytest.approx(printed, abs=0.05)
    hard = FrankaCartesianImpedanceController(arm, soft_start=False)  # without the soft start: the targets at once
    hard.reset(m, ref)
    assert hard.state[k_ns][0] == 0.5 and hard.state[K][0] == 200.0


def test_ur_force_mode_says_when_a_non_compliant_axis_exceeds_its_deviation_limit(arm, robot):
    """Program pose 5 cm above the arm, z non-compliant with a 1 cm limit: a 'force-mode-deviation' event (the
    protective stop a UR would make) is logged and warned, naming the axis, the deviation and the limit."""
    ctl = UrForceModeController(robot, selection_vector=[1, 0, 0, 0, 0, 0], wrench=[0.0] * 6,
                                limits=[0.1, 0.1, 0.01, 0.785, 0.785, 0.785])
    xt = arm.forward_kinematics(Q0).copy()
    xt[2] += 0.05
    ref = Reference.setpoint(xt)
    m = Measurement(Q0, np.zeros(6), np.zeros(6))
    ctl.reset(m, ref)
    with pytest.warns(UserWarning, match="non-compliant axis z is -0.05, beyond its limit 0.01"):
        ctl.command(0.0, m, ref)
    assert [e["event"] for e in ctl.events][0] == "force-mode-deviation"
    assert ctl.deviation_exceeded[1] == "z"
