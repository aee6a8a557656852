"""Admittance control (9.37): the compliant frame, its exact integration, tracking on the Panda, bandwidth warning, contact."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from forcecontrol.controllers.base import Measurement, Reference
from forcecontrol.errors import BandwidthWarning, ParameterError
from forcecontrol.spatial import euler_xyz_T, euler_xyz_to_rotation, pose_error, rotation_to_euler_xyz

pin = pytest.importorskip("pinocchio")

from forcecontrol.controllers.admittance import AdmittanceController, compliant_frame  # noqa: E402
from forcecontrol.environments.spatial import ConstantWrench, Table  # noqa: E402
from forcecontrol.robots.pinocchio import PANDA_READY, panda  # noqa: E402
from forcecontrol.sim.simulation import simulate  # noqa: E402
from forcecontrol.trajectories import Setpoint  # noqa: E402

MT = np.diag([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
KPT = np.diag([300.0, 300.0, 300.0, 8.0, 8.0, 8.0])
KDT = np.diag(2 * 0.8 * np.sqrt(np.diag(MT) * np.diag(KPT)))


@pytest.fixture(scope="module")
def franka():
    return panda()


def _x0(robot, q):
    R, p = robot.frame_pose(q)
    return np.concatenate([p, rotation_to_euler_xyz(R)])


def test_compliant_frame_kinematics_against_finite_differences():
    """The compliant frame's twist and acceleration are the derivatives of its pose for a moving desired frame."""
    def desired(t):
        phi = np.array([0.1 + 0.2 * t, 0.3 - 0.1 * t, -0.2 + 0.3 * t])
        phid = np.array([0.2, -0.1, 0.3])
        o = np.array([0.3 + 0.2 * t, -0.1 * t, 0.4 + 0.1 * t])
        return Reference(np.concatenate([o, phi]), np.concatenate([[0.2, -0.1, 0.1], euler_xyz_T(phi) @ phid]),
                         np.concatenate([np.zeros(3), _Tdot_phid(phi, phid)]), np.zeros(6), np.zeros(6), np.zeros(6))

    def _z(t):
        a = np.array([0.01, -0.02, 0.015, 0.05, -0.04, 0.03])
        return a * math.sin(3 * t), 3 * a * math.cos(3 * t), -9 * a * math.sin(3 * t)

    def ref(t):
        return compliant_frame(desired(t), *_z(t))

    t0, h = 0.4, 1e-5
    r0, rp, rm = ref(t0), ref(t0 + h), ref(t0 - h)
    assert np.allclose((rp.position[:3] - rm.position[:3]) / (2 * h), r0.velocity[:3], atol=1e-8)
    Rp, Rm, R0 = (euler_xyz_to_rotation(r.position[3:]) for r in (rp, rm, r0))
    W = (Rp - Rm) / (2 * h) @ R0.T
    assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], r0.velocity[3:], atol=1e-8)
    assert np.allclose((rp.velocity - rm.velocity) / (2 * h), r0.acceleration, atol=1e-6)
    # and z̃ is indeed the error (9.9) of the compliant frame from the desired frame
    d = desired(t0)
    assert np.allclose(
        pose_error(d.position[:3], euler_xyz_to_rotation(d.position[3:]), r0.position[:3], R0), _z(t0)[0], atol=1e-12
    )


def _Tdot_phid(phi, phid):
    from forcecontrol.spatial import euler_xyz_T_dot

    return euler_xyz_T_dot(phi, phid) @ phid


def test_compliant_frame_integration_is_the_exact_second_order_step(franka):
    """With a constant wrench the integrated z̃ equals the analytic step response of (9.37) at every sample."""
    c = AdmittanceController(franka, MT, KDT, KPT)
    x0 = _x0(franka, PANDA_READY)
    h = np.array([3.0, -2.0, 4.0, 0.1, 0.2, -0.1])
    ref = Reference.setpoint(x0)
    R_d = euler_xyz_to_rotation(x0[3:])
    h_d = np.concatenate([R_d.T @ h[:3], R_d.T @ h[3:]])
    c.reset()
    zs = [c.state[:6].copy()]
    for k in range(300):
        c.step(k * 1e-3, Measurement(PANDA_READY, np.zeros(7), h), ref)
        zs.append(c.state[:6].copy())
    zs = np.array(zs)
    t = np.arange(301) * 1e-3
    for i in range(6):
        _, y = signal.step(signal.lti([1.0], [MT[i, i], KDT[i, i], KPT[i, i]]), T=t)
        assert np.allclose(zs[:, i], h_d[i] * y, atol=1e-9 * max(1.0, abs(h_d[i]))), i


def test_panda_tracks_the_compliant_frame_under_a_wrench_step(franka):
    """Closed loop: the end-effector's error on the desired frame follows (9.37)'s step response within 3%."""
    q0 = PANDA_READY
    x0 = _x0(franka, q0)
    h = np.array([5.0, -3.0, 4.0, 0.2, -0.15, 0.1])
    c = AdmittanceController(franka, MT, KDT, KPT, motion_stiffness=3600.0, motion_damping=120.0, posture=q0)
    res = simulate(franka, ConstantWrench(h), c, Setpoint(x0), q0=q0, duration=0.8, substeps=1)
    R_d = euler_xyz_to_rotation(x0[3:])
    h_d = np.concatenate([R_d.T @ h[:3], R_d.T @ h[3:]])
    xt = np.array([pose_error(x0[:3], R_d, x[:3], euler_xyz_to_rotation(x[3:])) for x in res.x])
    for i in range(6):
        _, y = signal.step(signal.lti([1.0], [MT[i, i], KDT[i, i], KPT[i, i]]), T=res.t)
        y = h_d[i] * y
        assert np.max(np.abs(xt[:, i] - y)) <= 0.03 * np.max(np.abs(y)), i
        assert abs(xt[-1, i] - h_d[i] / KPT[i, i]) <= 0.02 * abs(h_d[i] / KPT[i, i]), i


def test_admittance_contact_with_a_table_reaches_series_spring_force(franka):
    """Pressing a table with the desired frame 2 cm below it: f = k K_Pt/(k + K_Pt) d at equilibrium ((9.22), one axis)."""
    q0 = PANDA_READY
    x0 = _x0(franka, q0)
    k_env = 5000.0
    table = Table(x0[:3], [0, 0, 1], stiffness=k_env, damping=50.0)
    d = 0.02
    ref = Setpoint(x0 - np.array([0, 0, d, 0, 0, 0]))
    Kpt = np.diag([1000.0, 1000.0, 1000.0, 20.0, 20.0, 20.0])
    Mt = np.diag([4.0, 4.0, 4.0, 0.1, 0.1, 0.1])
    Kdt = np.diag(2 * np.sqrt(np.diag(Mt) * (np.diag(Kpt) + [0, 0, k_env, 0, 0, 0])))
    c = AdmittanceController(franka, Mt, Kdt, Kpt, motion_stiffness=14400.0, motion_damping=240.0, posture=q0,
                             environment_stiffness=np.diag([0, 0, k_env, 0, 0, 0]))
    res = simulate(franka, table, c, ref, q0=q0, duration=1.5, substeps=2)
    f_expected = k_env * Kpt[2, 2] / (k_env + Kpt[2, 2]) * d
    assert abs(-res.wrench[-1, 2] - f_expected) <= 0.02 * f_expected
    # the table pushes along z only: the tip holds its lateral position and orientation meanwhile
    assert np.abs(res.x[-1, :2] - x0[:2]).max() < 1e-3
    dphi = np.angle(np.exp(1j * (res.x[-1, 3:] - x0[3:])))  # Euler angles compared modulo 2π (φ₁ = ±π here)
    assert np.abs(dphi).max() < 1e-2


def test_slow_motion_loop_warns_about_bandwidth(franka):
    """A motion loop slower than the impedance loop (ratio below 3) raises BandwidthWarning with both frequencies."""
    with pytest.warns(BandwidthWarning, match=r"motion loop \(ω = 10 rad/s\) must be faster than the impedance loop"):
        AdmittanceController(franka, MT, KDT, KPT, motion_stiffness=100.0, motion_damping=20.0)


def test_environment_stiffness_enters_the_bandwidth_check(franka):
    """A stiff expected environment raises the impedance loop's frequency: the same gains then warn."""
    c = AdmittanceController(franka, MT, KDT, KPT, motion_stiffness=3600.0)
    assert c.bandwidths["ratio"] > 3
    with pytest.warns(BandwidthWarning):
        AdmittanceController(franka, MT, KDT, KPT, motion_stiffness=3600.0, environment_stiffness=np.diag([2e5, 0, 0, 0, 0, 0]))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"motion_stiffness": -1.0}, "motion_stiffness must be a symmetric positive definite"),
        ({"bandwidth_ratio": 0.0}, "bandwidth_ratio must be a positive number"),
        ({"environment_stiffness": -np.eye(6)}, "environment_stiffness must be a symmetric positive semi-definite"),
    ],
)
def test_bad_admittance_inputs(franka, kwargs, match):
    """Bad motion gains, ratio or environment stiffness raise ParameterError naming the parameter."""
    with pytest.raises(ParameterError, match=match):
        AdmittanceController(franka, MT, KDT, KPT, **kwargs)
