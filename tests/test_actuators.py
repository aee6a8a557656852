"""Actuation realism: joint friction in the plant, delay and quantisation on the command."""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.controllers.base import Controller
from forcecontrol.environments.base import Environment
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.robots.base import RobotTerms
from forcecontrol.sim.actuators import Actuator

J_ROTOR = 0.5  # [kg m²]


class Rotor:
    """A single free joint of inertia J (no gravity, no friction of its own): q̈ = (u − τ_f) / J."""

    nq = 1
    task_dim = 1

    def forward_kinematics(self, q):
        return np.array(q, dtype=float)

    def jacobian(self, q):
        return np.eye(1)

    def jdot_qdot(self, q, qd):
        return np.zeros(1)

    def mass_matrix(self, q):
        return np.array([[J_ROTOR]])

    def nonlinear_effects(self, q, qd):
        return np.zeros(1)

    def gravity(self, q):
        return np.zeros(1)

    def terms(self, q, qd):
        return RobotTerms(np.array(q, float), np.array(qd, float), np.eye(1), np.zeros(1), np.array([[J_ROTOR]]),
                          np.zeros(1), np.zeros(1))


class FreeSpace(Environment):
    """Nothing to touch (1-D)."""

    dim = 1

    def wrench(self, x, xd):
        return np.zeros(1)

    def max_stiffness(self):
        return 0.0


class ConstantTorque(Controller):
    """Commands the same torque at every sample."""

    uses_force = False

    def __init__(self, robot, torque, sample_time=1e-3):
        super().__init__(robot, sample_time)
        self.torque = np.atleast_1d(np.asarray(torque, dtype=float))

    def step(self, t, measurement, reference):
        return self.torque.copy()


def _run(actuator, torque=0.0, qd0=1.0, duration=1.0):
    rotor = Rotor()
    return fc.simulate(rotor, FreeSpace(), ConstantTorque(rotor, torque), fc.Setpoint([0.0]), q0=[0.0], qd0=[qd0],
                       duration=duration, actuator=actuator, substeps=4)


def test_viscous_friction_decays_exponentially():
    """A free joint with viscous friction F_v and no torque: q̇(t) = q̇₀ exp(−F_v t / J) (closed form)."""
    Fv = 1.5
    res = _run(Actuator(viscous=Fv))
    expected = np.exp(-Fv * res.t / J_ROTOR)
    assert np.max(np.abs(res.qd[:, 0] - expected)) < 1e-9
    # and the position is its integral q̇₀ J / F_v (1 − exp(−F_v t / J))
    assert abs(res.q[-1, 0] - J_ROTOR / Fv * (1 - math.exp(-Fv * res.t[-1] / J_ROTOR))) < 1e-9


def test_coulomb_friction_steady_speed_matches_closed_form():
    """A constant torque u < τ_c against smooth Coulomb friction: q̇ settles at v_s artanh(u / τ_c)."""
    tau_c, vs, u = 2.0, 0.05, 1.2
    res = _run(Actuator(coulomb=tau_c, coulomb_band=vs), torque=u, qd0=0.0, duration=2.0)
    assert abs(res.qd[-1, 0] - vs * math.atanh(u / tau_c)) < 1e-6


def test_without_friction_the_rotor_keeps_its_speed():
    """The same rotor with a friction-free actuator keeps q̇₀ (the decay above is the actuator's)."""
    res = _run(Actuator(delay=0))
    assert np.allclose(res.qd[:, 0], 1.0, atol=1e-12)


def test_delay_shifts_the_applied_torque_by_exactly_d_samples():
    """With delay d the applied torque at sample k is the commanded one at k − d; before that, the held torque."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500, force_measurement=True)
    d = 7
    res = fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=0.2, actuator=Actuator(delay=d))
    assert res.metadata["engine"] == "python"
    np.testing.assert_array_equal(res.torque[d:], res.torque_commanded[:-d])
    np.testing.assert_array_equal(res.torque[:d], np.tile(arm.gravity(q0), (d, 1)))
    assert "uc1" in res.columns() and "uc1" not in fc.simulate(
        arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=0.01).columns()


def test_quantisation_error_is_at_most_half_a_step():
    """Quantised torques are multiples of Δ and differ from the command by at most Δ/2."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500, force_measurement=True)
    step = 0.25
    res = fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=0.3, actuator=Actuator(resolution=step))
    err = res.torque[1:] - res.torque_commanded[1:]
    assert np.max(np.abs(err)) <= step / 2 + 1e-12 and np.max(np.abs(err)) > 0.01
    assert np.allclose(res.torque[1:] / step, np.round(res.torque[1:] / step), atol=1e-9)


def test_compiled_engine_is_refused_with_an_actuator_and_auto_picks_python():
    """engine='compiled' with an actuator is a clear error; 'auto' runs the Python loop."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500)
    with pytest.raises(ParameterError, match="engine='compiled' does not model an actuator"):
        fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=0.01, engine="compiled",
                    actuator=Actuator(viscous=1.0))
    res = fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=0.01, actuator=Actuator(viscous=1.0))
    assert res.metadata["engine"] == "python" and res.metadata["actuator"]["viscous"] == [1.0]


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"coulomb": -1.0}, ParameterError, "coulomb must be non-negative"),
        ({"viscous": [1.0, -2.0]}, ParameterError, "viscous must be non-negative"),
        ({"coulomb_band": 0.0}, ParameterError, "coulomb_band must be positive"),
        ({"delay": 1.5}, ParameterError, "delay must be a whole number"),
        ({"delay": -1}, ParameterError, "delay must be a whole number"),
        ({"resolution": float("nan")}, ParameterError, "resolution must be finite"),
    ],
)
def test_bad_actuator_parameters_are_refused(kwargs, error, match):
    """Every impossible actuator parameter is refused, naming it."""
    with pytest.raises(error, match=match):
        Actuator(**kwargs)


def test_per_joint_vectors_must_fit_the_arm():
    """A 3-entry friction vector on the 2-joint arm is a DimensionError before anything runs."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500)
    with pytest.raises(DimensionError, match=r"coulomb must be a scalar or have shape \(2,\)"):
        fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=0.01, actuator=Actuator(coulomb=[1, 2, 3]))


def test_stiff_friction_gets_enough_substeps():
    """A narrow Coulomb band (steep tanh) raises the automatic RK4 substeps so the run stays accurate."""
    tau_c, vs, u = 2.0, 1e-3, 1.0
    rotor = Rotor()
    res = fc.simulate(rotor, FreeSpace(), ConstantTorque(rotor, u), fc.Setpoint([0.0]), q0=[0.0], qd0=[0.0],
                      duration=0.5, actuator=Actuator(coulomb=tau_c, coulomb_band=vs))
    assert res.metadata["substeps"] >= math.ceil(tau_c / vs / J_ROTOR * 1e-3 / 0.05)
    assert abs(res.qd[-1, 0] - vs * math.atanh(u / tau_c)) < 1e-7


def test_a_non_actuator_is_refused():
    """actuator= must be an Actuator."""
    rotor = Rotor()
    with pytest.raises(ParameterError, match="actuator must be a forcecontrol Actuator; got dict"):
        fc.simulate(rotor, FreeSpace(), ConstantTorque(rotor, 0.0), fc.Setpoint([0.0]), q0=[0.0], duration=0.01,
                    actuator={"coulomb": 1.0})
