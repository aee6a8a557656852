"""Franka's cartesian_impedance_example_controller: the sampled contact loop's stability limit (issue 30).

References from outside the analysis: the 1-DOF loop's characteristic polynomial in closed form (Jury's
conditions), the controller itself (finite differences of its torque), and the simulator (bisection bracket).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from forcecontrol.analysis.vendor_franka import (
    franka_contact_modes,
    franka_loop_matrix,
    franka_spectral_radius,
    franka_stability_limit,
    nyquist_stiffness,
    point_mass_loop,
)


def _closed_form_coefficients(m: float, K: float, D: float, T: float, k_e: float) -> tuple[float, float]:
    """(trace, det) of the 1-DOF loop: the spring k_e in the continuous plant, the PD held over T (derived by hand)."""
    w = math.sqrt(k_e / m)
    c, s = math.cos(w * T), math.sin(w * T)
    g1, g2 = (1.0 - c) / (m * w * w), s / (m * w)
    trace = 2.0 * c - g1 * K - g2 * D
    det = 1.0 - c * (g2 * D + g1 * K) + (s / w) * g2 * K - w * s * g1 * D
    return trace, det


def _jury_stable(trace: float, det: float) -> bool:
    """z² − trace z + det has both roots inside the unit circle (Jury): |det| < 1, 1 ∓ trace + det > 0."""
    return abs(det) < 1.0 and 1.0 - trace + det > 0.0 and 1.0 + trace + det > 0.0


def test_point_mass_poles_are_the_closed_form_roots():
    """1-DOF point mass under the sampled PD against a spring: the loop's poles are the roots of z² − tr z + det (closed form)."""
    m, K, D, T = 2.0, 200.0, 2.0 * math.sqrt(200.0), 1e-3
    for k_e in (1e3, 1e6, 5e7):
        tr, det = _closed_form_coefficients(m, K, D, T, k_e)
        got = np.sort_complex(np.linalg.eigvals(franka_loop_matrix(point_mass_loop(m, K, D, T), k_e)))
        want = np.sort_complex(np.roots([1.0, -tr, det]).astype(complex))
        assert np.allclose(got, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("m, K, D, T", [(2.0, 200.0, 2.0 * math.sqrt(200.0), 1e-3), (4.0, 50.0, 300.0, 5e-4),
                                        (1.0, 1000.0, 20.0, 2e-3)])
def test_point_mass_limit_is_jurys_bound(m, K, D, T):
    """The bisected k_e limit is where Jury's conditions on the closed-form polynomial first fail (within 1e-4)."""
    limit = franka_stability_limit(point_mass_loop(m, K, D, T))
    assert _jury_stable(*_closed_form_coefficients(m, K, D, T, 0.999 * limit))
    assert not _jury_stable(*_closed_form_coefficients(m, K, D, T, 1.0001 * limit))
    k = np.geomspace(1.0, 0.999 * limit, 400)  # and stable all the way below it
    assert all(_jury_stable(*_closed_form_coefficients(m, K, D, T, ki)) for ki in k)


def test_free_point_mass_damping_bound_dt_below_2m():
    """In free space (k_e = 0) the sampled PD on a mass is stable iff D T < 2m (and K T < 2D): Jury's bound, at ±1 %."""
    m, K, T = 2.0, 200.0, 1e-3
    assert franka_spectral_radius(point_mass_loop(m, K, 0.99 * 2 * m / T, T), 0.0) < 1.0
    assert franka_spectral_radius(point_mass_loop(m, K, 1.01 * 2 * m / T, T), 0.0) > 1.0
    assert franka_stability_limit(point_mass_loop(m, K, 1.01 * 2 * m / T, T)) == 0.0


def test_soft_gains_limit_is_near_the_nyquist_stiffness():
    """With soft gains the contact mode sqrt(k_e/m) turns unstable close to the Nyquist frequency: limit ≈ m (π/T)² (2 %)."""
    loop = point_mass_loop(2.0, 200.0, 2.0 * math.sqrt(200.0), 1e-3)
    assert franka_stability_limit(loop) == pytest.approx(nyquist_stiffness(loop), rel=0.02)
    assert nyquist_stiffness(loop) == pytest.approx(2.0 * (math.pi / 1e-3) ** 2, rel=1e-12)


def test_one_cycle_delay_applies_the_previous_torque():
    """delay = 1: one cycle of the loop is x⁺ = Φ x + Γ u_{k−1}, u_k = −(K x + D ẋ), with Φ, Γ the spring-mass's closed-form
    zero-order hold (cos, sin of ω T); without delay Φ − Γ [K D]."""
    m, K, D, T, k_e = 2.0, 200.0, 28.0, 1e-3, 1e6
    w = math.sqrt(k_e / m)
    c, s = math.cos(w * T), math.sin(w * T)
    Phi = np.array([[c, s / w], [-w * s, c]])
    Gam = np.array([(1.0 - c) / (m * w * w), s / (m * w)])
    z = np.array([1e-3, -2e-2, 0.5])
    A = franka_loop_matrix(point_mass_loop(m, K, D, T, delay=1), k_e)
    assert np.allclose(A @ z, [*(Phi @ z[:2] + Gam * z[2]), -(K * z[0] + D * z[1])], rtol=1e-12, atol=1e-15)
    A0 = franka_loop_matrix(point_mass_loop(m, K, D, T), k_e)
    assert np.allclose(A0, Phi - np.outer(Gam, [K, D]), rtol=1e-12, atol=1e-12)


pytest.importorskip("pinocchio")

Q0 = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])


def _panda_loop(Ts: float):
    from forcecontrol.analysis.vendor_franka import franka_contact_loop
    from forcecontrol.controllers.vendor import FrankaCartesianImpedanceController
    from forcecontrol.robots.pinocchio import panda

    arm = panda()
    return arm, franka_contact_loop(arm, Q0, FrankaCartesianImpedanceController(arm, sample_time=Ts))


def test_linear_feedback_is_the_controllers_own_torque_by_finite_differences():
    """K_q, D_q of the model equal −∂τ/∂q, −∂τ/∂q̇ of the controller's step at the equilibrium (central differences, 1e-5 rel)
    (this checks the halved rotational stiffness of the quaternion error and the damped null-space projector)."""
    from forcecontrol.controllers.signals import Measurement, Reference
    from forcecontrol.controllers.vendor import FrankaCartesianImpedanceController

    arm, loop = _panda_loop(1e-3)
    ctl = FrankaCartesianImpedanceController(arm, soft_start=False, delta_tau_max=1e9)
    x0 = np.asarray(arm.forward_kinematics(Q0), dtype=np.float64)
    z6 = np.zeros(6)
    ctl.reset(Measurement(Q0, np.zeros(7), z6), Reference.setpoint(x0))
    saved = ctl.state.copy()
    clock = iter(range(1000))

    def tau(q, qd):
        ctl.state[:] = saved  # the same controller state for every evaluation (the step filters it)
        return ctl.step(1e-3 * next(clock), Measurement(q, qd, z6), Reference.setpoint(x0)) - np.asarray(arm.gravity(q)) - (
            np.asarray(arm.nonlinear_effects(q, qd)) - np.asarray(arm.gravity(q)) - np.asarray(arm.friction) @ qd)

    h = 1e-6
    E = np.eye(7)
    dq = np.column_stack([(tau(Q0 + h * E[i], np.zeros(7)) - tau(Q0 - h * E[i], np.zeros(7))) / (2 * h) for i in range(7)])
    dqd = np.column_stack([(tau(Q0, h * E[i]) - tau(Q0, -h * E[i])) / (2 * h) for i in range(7)])
    Kq, Dq = loop.feedback()
    assert np.allclose(-dq, Kq, rtol=1e-5, atol=1e-5 * np.abs(Kq).max())
    assert np.allclose(-dqd, Dq, rtol=1e-5, atol=1e-5 * np.abs(Dq).max())


def _contact_force(Ts: float, k_e: float, duration: float = 0.3) -> np.ndarray:
    """The Panda (q = the project's start pose) with the example's default gains at rate 1/Ts (soft start off: the loop
    at its target gains from the first cycle), the equilibrium pose 2 cm into a table at the tool: f_z (N + 1,)."""
    from forcecontrol.controllers.vendor import FrankaCartesianImpedanceController
    from forcecontrol.environments.spatial import Table
    from forcecontrol.robots.pinocchio import panda
    from forcecontrol.sim.simulation import simulate
    from forcecontrol.trajectories.profiles import Setpoint

    arm = panda()
    _, p = arm.frame_pose(Q0)
    ctl = FrankaCartesianImpedanceController(arm, soft_start=False, sample_time=Ts)
    target = np.asarray(arm.forward_kinematics(Q0)) + np.array([0.0, 0.0, -0.02, 0.0, 0.0, 0.0])
    res = simulate(arm, Table(p, stiffness=k_e), ctl, Setpoint(target, [0.0] * 6), q0=Q0, duration=duration)
    return np.asarray(res.wrench)[:, 2]


def _oscillation_growth(f: np.ndarray) -> float:
    """RMS of the force's second difference (the contact mode near the Nyquist frequency; the slow preload ramp has none)
    over the second half, over that of the second sixth to the half: < 1 decays, > 1 grows."""
    d2 = f[2:] - 2.0 * f[1:-1] + f[:-2]
    n = len(d2)
    return float(np.sqrt(np.mean(d2[n // 2 :] ** 2)) / np.sqrt(np.mean(d2[n // 6 : n // 2] ** 2)))


@pytest.mark.parametrize("rate", [1000.0, 2000.0])
def test_predicted_limit_brackets_the_simulated_one_within_5_percent(rate):
    """The example's default gains on the Panda at 1 and 2 kHz: at 0.95 × the predicted k_e limit the contact holds and the
    force's oscillation decays; at 1.05 × it grows (the contact mode's pair near z = −1 leaves the unit circle)."""
    _, loop = _panda_loop(1.0 / rate)
    limit = franka_stability_limit(loop)
    assert limit == pytest.approx(nyquist_stiffness(loop), rel=0.03)  # the contact mode at the Nyquist frequency
    assert np.abs(franka_contact_modes(loop, 0.95 * limit)).max() < 1.0 < np.abs(franka_contact_modes(loop, 1.05 * limit)).max()
    below, above = _contact_force(1.0 / rate, 0.95 * limit), _contact_force(1.0 / rate, 1.05 * limit)
    n = len(below)
    assert np.all(below[n // 2 :] < 0.0) and _oscillation_growth(below) < 0.95
    assert _oscillation_growth(above) > 1.03


def test_simulated_growth_per_cycle_is_the_contact_modes_radius():
    """Just above the limit (1.01 ×, 1 kHz) the contact pole is real, z ≈ −1.0155: from cycle 200 (the other pole's part
    gone) to 300 the simulated force's oscillation grows by |z| per cycle within 1e-4 (the rate clamp not yet acting)."""
    _, loop = _panda_loop(1e-3)
    limit = franka_stability_limit(loop)
    z = franka_contact_modes(loop, 1.01 * limit)
    assert abs(z[0].imag) < 1e-12 and z[0].real < -1.01
    f = _contact_force(1e-3, 1.01 * limit, duration=0.302)
    d2 = np.abs(f[2:] - 2.0 * f[1:-1] + f[:-2])
    assert (d2[300] / d2[200]) ** (1.0 / 100) == pytest.approx(abs(z[0]), rel=1e-4)


def _imported_scenario(tmp_path, name: str, *, stiffness: float = 5000.0, sample_time: float = 0.001):
    """The scenario `forcecontrol import-config` writes for the shipped Franka example YAML, with the table's stiffness
    and the sample time replaced."""
    from importlib import resources
    from pathlib import Path

    from journeys_helpers import forcecontrol

    yaml = Path(str(resources.files("forcecontrol.scenarios"))) / "configs" / "franka_cartesian_impedance.yaml"
    text = forcecontrol(tmp_path, "import-config", yaml).stdout
    assert "stiffness = 5000.0" in text and "sample_time = 0.001" in text
    path = tmp_path / name
    path.write_text(text.replace("stiffness = 5000.0", f"stiffness = {stiffness!r}")
                    .replace("sample_time = 0.001", f"sample_time = {sample_time!r}"), encoding="utf-8")
    return path


@pytest.mark.parametrize("stiffness, sample_time, verdict", [(5000.0, 1e-3, "settles"), (5e7, 1e-3, "bounces"),
                                                              (5000.0, 2e-3, "unstable in free space")])
def test_analyze_reports_the_franka_loop_limit_margin_and_verdict(tmp_path, stiffness, sample_time, verdict):
    """analyze --json on the imported Franka example: the limit equals franka_stability_limit of the loop built here from
    the Panda at q0 (1e-9), margin = limit / k_e, the verdict (5e7 N/m is beyond the 1 kHz limit 3.84e7; at 500 Hz the
    default gains are unstable without contact), f_z at rest −K k_e δ/(K + k_e) with δ = 15 mm; units named; the advice
    when it does not settle (the designed rotational stiffness at 500 Hz; none at 5e7 N/m)."""
    import json

    pytest.importorskip("ruamel.yaml")
    from journeys_helpers import forcecontrol

    arm, loop = _panda_loop(sample_time)
    limit = franka_stability_limit(loop)
    path = _imported_scenario(tmp_path, "franka.toml", stiffness=stiffness, sample_time=sample_time)
    proc = forcecontrol(tmp_path, "analyze", path, "--json")
    doc = json.loads(proc.stdout)
    a = doc["cases"][0]["analysis"]
    assert a["vendor_loop_stability_limit"] == pytest.approx(limit, rel=1e-9)
    assert a["vendor_loop_margin"] == pytest.approx(limit / stiffness, rel=1e-9)
    assert a["vendor_loop_spectral_radius"] == pytest.approx(franka_spectral_radius(loop, stiffness), rel=1e-9)
    assert a["vendor_loop_verdict"] == verdict and a["environment_stiffness"] == stiffness
    assert a["steady_fz"] == pytest.approx(-200.0 * stiffness * 0.015 / (200.0 + stiffness), rel=1e-9)
    assert "cartesian_impedance_example_controller" in a["vendor_loop"] and "torque-rate clamp" in a["vendor_loop"]
    assert doc["units"]["vendor_loop_stability_limit"] == "N/m" and doc["units"]["steady_fz"] == "N"
    assert all(c.get("analysis_skipped") is None for c in doc["cases"])
    if verdict == "unstable in free space":  # the way out: franka_design_stiffness without contact
        from forcecontrol.analysis.vendor_franka import franka_design_stiffness

        assert f"rotational_stiffness <= {franka_design_stiffness(loop, 0.0, margin=1.0):.4g} N m/rad" in a["vendor_loop_advice"]
    elif verdict == "bounces":  # no gain moves the contact mode below the Nyquist frequency
        assert "no stiffness alone" in a["vendor_loop_advice"] and "Nyquist" in a["vendor_loop_advice"]
    else:
        assert "vendor_loop_advice" not in a
        table = forcecontrol(tmp_path, "analyze", path).stdout
        assert "vendor_loop_stability_limit [N/m]" in table and "no analysis applies" not in table


def _free_space_wrist_speed(Ts: float, rotational_stiffness: float) -> np.ndarray:
    """The Panda in free space (the table 0.5 m below), the target its start pose, joint 7 started at 0.1 rad/s: q̇_7."""
    from forcecontrol.controllers.vendor import FrankaCartesianImpedanceController
    from forcecontrol.environments.spatial import Table
    from forcecontrol.robots.pinocchio import panda
    from forcecontrol.sim.simulation import simulate
    from forcecontrol.trajectories.profiles import Setpoint

    arm = panda()
    _, p = arm.frame_pose(Q0)
    ctl = FrankaCartesianImpedanceController(arm, soft_start=False, rotational_stiffness=rotational_stiffness, sample_time=Ts)
    res = simulate(arm, Table(p - np.array([0.0, 0.0, 0.5]), stiffness=1e4), ctl, Setpoint(arm.forward_kinematics(Q0), [0.0] * 6),
                   q0=Q0, qd0=np.array([0.0] * 6 + [0.1]), duration=0.5)
    return np.asarray(res.qd)[:, 6]


def test_designed_rotational_stiffness_brackets_the_free_space_limit_at_500_hz():
    """At 500 Hz the default rotational stiffness (10 N m/rad, D = 2 sqrt(10)) is unstable without contact (the wrist's
    small inertia against the sampled damping); franka_design_stiffness gives the largest stable one (~9.66): at 0.95 × it
    the wrist's oscillation dies out in simulation, at 1.05 × it grows (to the torque-rate clamp's limit cycle)."""
    from forcecontrol.analysis.vendor_franka import franka_design_stiffness, with_stiffness

    _, loop = _panda_loop(2e-3)
    assert franka_stability_limit(loop) == 0.0 and franka_spectral_radius(loop, 0.0) > 1.0
    k = franka_design_stiffness(loop, 0.0)
    assert 9.0 < k < 10.0
    rho = [franka_spectral_radius(with_stiffness(loop, f * k), 0.0) for f in (1.0, 1.001)]
    assert rho[0] < 1.0 < rho[1]
    below, above = _free_space_wrist_speed(2e-3, 0.95 * k), _free_space_wrist_speed(2e-3, 1.05 * k)
    n = len(below)

    def rms(x, i):
        return float(np.sqrt(np.mean(x[i * n // 5 : (i + 1) * n // 5] ** 2)))

    assert rms(below, 4) < 0.05 * rms(below, 0)
    assert rms(above, 4) > 2.0 * rms(above, 0)


def test_designed_stiffness_meets_the_margin_and_no_more():
    """franka_design_stiffness with a contact: at the returned rotational stiffness the k_e limit is >= 2 k_e; 1 % above it,
    it is below (500 Hz, k_e = 4.5e6 N/m)."""
    from forcecontrol.analysis.vendor_franka import franka_design_stiffness, with_stiffness

    _, loop = _panda_loop(2e-3)
    k = franka_design_stiffness(loop, 4.5e6)
    assert franka_stability_limit(with_stiffness(loop, k)) >= 9e6
    assert franka_stability_limit(with_stiffness(loop, 1.01 * k)) < 9e6
