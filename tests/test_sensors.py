"""Sensor realism: the rich F/T sensor, tool gravity identification, joint encoders, noisy settling."""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import DimensionError, ParameterError
from forcecontrol.sensors import (
    RealisticForceSensor,
    ToolGravity,
    identify_tool_gravity,
    planar_sensor_rotation,
)
from forcecontrol.sim.encoders import EncoderFeedback, JointEncoder

ARM = fc.CHAPTER_ARM
Q0 = ARM.inverse_kinematics([1.0, 0.0])
TS = 1e-3


def _example_93(scheme: str, k: float):
    """Example 9.3's plane, controller and reference (book gains) for one scheme."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], k)
    if scheme == "inner position":
        ctl = fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0])
    elif scheme == "inner velocity":
        ctl = fc.InnerVelocityForceController(ARM, 100, 500, 2500, [0.0024, 0.0])
    else:
        ctl = fc.ParallelForcePositionController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0])
    return env, ctl, fc.Setpoint([1.015, 0.1], [10.0, 0.0])


def _feed(sensor: RealisticForceSensor, forces, q=None, dim=2):
    """Run the sensor over a sequence of true forces (one per sample); returns the outputs."""
    forces = np.asarray(forces, dtype=float)
    out = [sensor.start(len(forces), dim, TS, forces[0], q)]
    for k in range(1, len(forces)):
        out.append(sensor.measure(k, k * TS, forces[k], q))
    return np.array(out)


# ----------------------------------------------------------------------------- engine choice


def test_simple_sensor_is_compiled_ok_and_rich_sensor_runs_in_python():
    """ForceSensor keeps the compiled loop; a RealisticForceSensor makes 'auto' pick the Python loop."""
    assert fc.ForceSensor(noise_std=0.5, cutoff=50.0).compiled_ok
    rich = RealisticForceSensor(noise_std=0.5, cutoff=50.0)
    assert not rich.compiled_ok
    env, ctl, ref = _example_93("inner velocity", 1e4)
    r = fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=0.05, sensor=rich)
    assert r.metadata["engine"] == "python" and r.metadata["sensor"]["kind"] == "realistic"


def test_compiled_engine_refuses_a_rich_sensor():
    """engine='compiled' with a stateful sensor is a clear error naming the sensor."""
    env, ctl, ref = _example_93("inner velocity", 1e4)
    with pytest.raises(ParameterError, match=r"simple ForceSensor.*RealisticForceSensor"):
        fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=0.05, sensor=RealisticForceSensor(), engine="compiled")


def test_rich_sensor_with_simple_settings_reproduces_the_compiled_loop():
    """Second implementation: the rich sensor (bias, noise, first-order) in Python = ForceSensor compiled, to round-off."""
    env, _, ref = _example_93("inner position", 1e4)
    kw = dict(noise_std=0.5, bias=[0.3, -0.2], cutoff=80.0, seed=4)
    ctl = lambda: fc.InnerPositionForceController(ARM, 100, 500, 2500, [0.00064, 0.0], [0.0016, 0.0])  # noqa: E731
    a = fc.simulate(ARM, env, ctl(), ref, q0=Q0, duration=0.4, sensor=fc.ForceSensor(**kw))
    b = fc.simulate(ARM, env, ctl(), ref, q0=Q0, duration=0.4, sensor=RealisticForceSensor(**kw))
    assert a.metadata["engine"] == "compiled" and b.metadata["engine"] == "python"
    for name in ("wrench_measured", "torque", "q"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-9, atol=1e-9, err_msg=name)


# ----------------------------------------------------------------------------- signal chain by hand


def test_quantisation_rounds_to_the_resolution():
    """Δ = 0.1 N: 3.14159 → 3.1, −2.71828 → −2.7, 0.05001 → 0.1 (hand-rounded)."""
    s = RealisticForceSensor(resolution=0.1)
    out = _feed(s, [[3.14159, -2.71828], [0.05001, 0.0]])
    np.testing.assert_allclose(out, [[3.1, -2.7], [0.1, 0.0]], atol=1e-12)


def test_drift_grows_linearly_with_time():
    """Drift ḃ = [0.5, −0.25] N/s adds exactly ḃ t to a constant force."""
    s = RealisticForceSensor(drift=[0.5, -0.25])
    out = _feed(s, np.tile([10.0, 0.0], (2001, 1)))
    np.testing.assert_allclose(out[2000], [11.0, -0.5], atol=1e-12)
    np.testing.assert_allclose(out[:, 0] - 10.0, 0.5 * TS * np.arange(2001), atol=1e-12)


def test_delay_shifts_a_step_by_whole_samples():
    """With d = 3 a force step at sample 5 appears at sample 8, unchanged."""
    f = np.zeros((12, 2))
    f[5:, 0] = 7.0
    out = _feed(RealisticForceSensor(delay_samples=3), f)
    np.testing.assert_array_equal(out[:, 0], np.r_[np.zeros(8), 7.0 * np.ones(4)])


def test_first_order_filter_step_response_is_analytic():
    """Unit step after sample 0: y_k = 1 − (1 − α)^k with α = 1 − exp(−2π f_c Ts)."""
    f = np.zeros((50, 2))
    f[1:, 0] = 1.0
    out = _feed(RealisticForceSensor(cutoff=20.0), f)
    alpha = 1 - math.exp(-2 * math.pi * 20.0 * TS)
    np.testing.assert_allclose(out[:, 0], 1 - (1 - alpha) ** np.arange(50), atol=1e-12)


def test_butterworth_coefficients_match_scipy_and_halve_power_at_cutoff():
    """Second-order Butterworth (scipy.signal.butter): the coefficients of the pre-warped bilinear transform
    written out (K = tan(π f_c Ts)); a sine at f_c comes out at 1/√2 amplitude."""
    s = RealisticForceSensor(cutoff=50.0, filter="butterworth")
    b, a = s.filter_coefficients(TS)
    K = math.tan(math.pi * 50.0 * TS)
    norm = 1.0 / (1.0 + math.sqrt(2.0) * K + K * K)
    b_ref = np.array([1.0, 2.0, 1.0]) * K * K * norm
    a_ref = np.array([1.0, 2.0 * (K * K - 1.0) * norm, (1.0 - math.sqrt(2.0) * K + K * K) * norm])
    np.testing.assert_allclose(b, b_ref, rtol=1e-12)
    np.testing.assert_allclose(a, a_ref, rtol=1e-12)
    t = np.arange(4000) * TS
    out = _feed(s, np.column_stack([np.sin(2 * np.pi * 50.0 * t), np.zeros_like(t)]))
    assert np.abs(out[2000:, 0]).max() == pytest.approx(1 / math.sqrt(2), rel=2e-3)


def test_zeroing_estimates_the_bias_within_its_standard_error():
    """Zeroing over n = 400 samples at rest: |b̂ − b| < 4 σ/√n, and the zeroed reading at rest averages 0."""
    s = RealisticForceSensor(noise_std=0.5, bias=[2.0, -1.0], zeroing_samples=400, seed=7)
    out = _feed(s, np.zeros((2000, 2)))
    assert np.all(np.abs(s.bias_estimate - [2.0, -1.0]) < 4 * 0.5 / 20)
    assert np.all(np.abs(out.mean(axis=0)) < 4 * 0.5 / 20 + 4 * 0.5 / math.sqrt(2000))


def test_tool_weight_is_measured_in_the_rotating_sensor_frame_and_compensated():
    """Raw = h − m g (free body of the tool: sensor force + m g − h_e = 0); compensated: h exactly (no noise).

    Pressing [10, 3] N with a 1.5 kg tool (gravity −y): the sensor also holds the tool up, so it
    reads [10, 3 + 1.5 · 9.81] N.
    """
    tool = ToolGravity(1.5, force_bias=[0.0, 0.0])
    q = np.array([0.4, -1.1])
    h = np.array([10.0, 3.0])
    raw = _feed(RealisticForceSensor(tool=tool), [h, h], q)
    np.testing.assert_allclose(raw[1], [10.0, 3.0 + 1.5 * 9.81], atol=1e-12)
    comp = _feed(RealisticForceSensor(bias=[1.0, 2.0], tool=tool, tool_estimate=tool, zeroing_samples=10),
                 [np.zeros(2), h], q)
    np.testing.assert_allclose(comp[1], h, atol=1e-12)


def test_hanging_tool_reading_is_the_holding_force():
    """A 2 kg tool hanging from a sensor aligned with the base reads +2 · 9.81 N up (it is held up), and
    its centre of mass 0.1 m along x_S gives the moment −c × w = −(0.1 · (−19.62)) = +1.962 N m."""
    f, tau = ToolGravity(2.0, com=[0.1, 0.0]).reading(np.eye(2))
    np.testing.assert_allclose(f, [0.0, 2.0 * 9.81], atol=1e-12)
    np.testing.assert_allclose(tau, [0.1 * 2.0 * 9.81], atol=1e-12)


def test_sensor_frame_bias_rotates_with_the_tool():
    """A bias fixed in the sensor frame appears in the base frame as R_S b (hand-built rotation)."""
    q = np.array([0.3, 0.5])
    s = RealisticForceSensor(bias=[1.0, 0.0], tool=ToolGravity(0.0))
    out = _feed(s, [np.zeros(2)], q)
    np.testing.assert_allclose(out[0], [math.cos(0.8), math.sin(0.8)], atol=1e-12)
    np.testing.assert_allclose(planar_sensor_rotation(q), [[math.cos(0.8), -math.sin(0.8)], [math.sin(0.8), math.cos(0.8)]])


# ----------------------------------------------------------------------------- tool identification


def _rot3(rng) -> np.ndarray:
    Q, R = np.linalg.qr(rng.standard_normal((3, 3)))
    return Q * np.sign(np.diag(R)) * (1 if np.linalg.det(Q * np.sign(np.diag(R))) > 0 else -1)


def test_identify_tool_in_3d_recovers_mass_com_and_biases_exactly():
    """Six random poses, no noise: m, c, b_f, b_τ recovered to 1e-9 (synthetic ground truth)."""
    rng = np.random.default_rng(0)
    true = ToolGravity(2.3, [0.01, -0.02, 0.08], [0.5, -0.3, 1.2], [0.05, 0.02, -0.01], dim=3)
    Rs = np.array([_rot3(rng) for _ in range(6)])
    assert np.allclose([np.linalg.det(R) for R in Rs], 1.0)
    F, T = zip(*(true.reading(R) for R in Rs))
    est = identify_tool_gravity(Rs, np.array(F), np.array(T))
    assert est.mass == pytest.approx(2.3, abs=1e-9)
    np.testing.assert_allclose(est.com, true.com, atol=1e-9)
    np.testing.assert_allclose(est.force_bias, true.force_bias, atol=1e-9)
    np.testing.assert_allclose(est.torque_bias, true.torque_bias, atol=1e-9)


def test_identify_planar_tool_from_noisy_poses():
    """Planar, 8 poses, 0.05 N noise: mass within 1 %, com within 5 mm, bias within 0.05 N."""
    rng = np.random.default_rng(1)
    true = ToolGravity(1.2, [0.10, 0.03], [0.8, -0.4], [0.02])
    Rs = np.array([planar_sensor_rotation([a, 0.0]) for a in np.linspace(-1.5, 1.5, 8)])
    F, T = zip(*(true.reading(R) for R in Rs))
    F = np.array(F) + 0.05 * rng.standard_normal((8, 2))
    T = np.array(T).ravel() + 0.005 * rng.standard_normal(8)
    est = identify_tool_gravity(Rs, F, T)
    assert est.mass == pytest.approx(1.2, rel=0.01)
    np.testing.assert_allclose(est.com, true.com, atol=5e-3)
    np.testing.assert_allclose(est.force_bias, true.force_bias, atol=0.05)


def test_identified_tool_compensates_the_weight_during_motion():
    """An arm swinging in free space with a 2 kg tool reads ≈ 0 N after identification and zeroing."""
    tool = ToolGravity(2.0, [0.05, 0.0], [0.6, -0.3])
    Rs = np.array([planar_sensor_rotation([a, 0.0]) for a in (-1.0, 0.0, 1.0)])
    est = identify_tool_gravity(Rs, np.array([tool.reading(R)[0] for R in Rs]))
    s = RealisticForceSensor(bias=[0.6, -0.3], tool=ToolGravity(2.0), tool_estimate=est, zeroing_samples=5)
    s.start(100, 2, TS, np.zeros(2), [0.0, 0.0])
    for k, a in enumerate(np.linspace(0.0, 2.0, 99), start=1):
        np.testing.assert_allclose(s.measure(k, k * TS, np.zeros(2), [a, 0.3]), 0.0, atol=1e-9)


# ----------------------------------------------------------------------------- acceptance: noisy settling


@pytest.mark.parametrize("k", [1e4, 1e3])
def test_example_93_schemes_settle_within_2_percent_with_half_newton_noise(k):
    """0.5 N RMS noise: each scheme's force over the last 2 s is within 2 % of f_d = 10 N, and so is the average."""
    errs = []
    for scheme in ("inner position", "inner velocity", "parallel"):
        env, ctl, ref = _example_93(scheme, k)
        r = fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=10.0, sensor=fc.ForceSensor(noise_std=0.5, seed=11))
        errs.append(abs(r.wrench[r.t >= 8.0, 0].mean() - 10.0) / 10.0)
        assert np.std(r.wrench_measured[:, 0] - r.wrench[:, 0]) == pytest.approx(0.5, rel=0.05)
    assert max(errs) < 0.02 and np.mean(errs) < 0.02


@pytest.mark.parametrize("scheme", ["inner position", "inner velocity", "parallel"])
def test_example_93_settles_through_a_realistic_sensor_and_encoders(scheme):
    """Quantised, delayed, filtered, zeroed sensor with a compensated tool, 2^20-count encoders: within 2 % (k = 1e4)."""
    tool = ToolGravity(1.5)
    sensor = RealisticForceSensor(
        noise_std=0.5, bias=[2.0, -1.0], cutoff=50.0, seed=3, drift=[0.0, 0.0], resolution=0.05,
        delay_samples=1, tool=tool, tool_estimate=tool, zeroing_samples=200,
    )
    env, ctl, ref = _example_93(scheme, 1e4)
    wrapped = EncoderFeedback(ctl, JointEncoder(2**20, TS, velocity_cutoff=100.0))
    # the arm starts touching the plane with zero force: zeroing sees free-space conditions
    r = fc.simulate(ARM, env, wrapped, ref, q0=Q0, duration=4.0, sensor=sensor)
    assert r.metadata["engine"] == "python"
    assert abs(r.wrench[r.t >= 3.0, 0].mean() - 10.0) < 0.2


def test_uncompensated_drift_shifts_the_true_force_by_drift_times_time():
    """Drift ḃ = 0.05 N/s, no re-zeroing: the PI loop holds the measured force at f_d, so the true one is f_d − ḃ t (±0.05 N)."""
    env, ctl, ref = _example_93("inner position", 1e4)
    r = fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=5.0, sensor=RealisticForceSensor(drift=[0.05, 0.0]))
    sel = r.t >= 4.0
    assert abs(r.wrench[sel, 0].mean() - (10.0 - 0.05 * r.t[sel].mean())) < 0.05
    assert abs(r.wrench_measured[sel, 0].mean() - 10.0) < 0.05


# ----------------------------------------------------------------------------- encoders


def test_encoder_quantises_to_counts_by_hand():
    """4096 counts/turn: Δ = 2π/4096; q = 0.1 rad reads 65 Δ (0.1/Δ = 65.19), q = −0.2 reads −130 Δ."""
    enc = JointEncoder(4096, TS)
    d = 2 * math.pi / 4096
    np.testing.assert_allclose(enc.quantise([0.1, -0.2]), [65 * d, -130 * d], atol=1e-15)


def test_encoder_velocity_is_the_backward_difference():
    """Exact positions on a ramp: q̇_m = v; quantised: (q_m,k − q_m,k−1)/Ts by hand."""
    enc = JointEncoder(None, TS)
    enc.reset([0.0, 0.0])
    for k in range(1, 5):
        _, v = enc.read([0.3 * k * TS, -1.0 * k * TS])
    np.testing.assert_allclose(v, [0.3, -1.0], rtol=1e-9)
    enc = JointEncoder(1000, TS)  # Δ = 6.283e-3 rad: a 1 rad/s ramp moves 1e-3 rad per sample
    enc.reset([0.0])
    d = 2 * math.pi / 1000
    vs = [enc.read([k * TS])[1][0] for k in range(1, 12)]
    expected = [(round(k * TS / d) - round((k - 1) * TS / d)) * d / TS for k in range(1, 12)]
    np.testing.assert_allclose(vs, expected, atol=1e-12)
    assert max(vs) == pytest.approx(d / TS)  # the difference jumps by whole counts


def test_encoder_velocity_filter_step_response_is_analytic():
    """A velocity step through the first-order filter: v_k = v (1 − (1 − α)^k)."""
    enc = JointEncoder(None, TS, velocity_cutoff=10.0)
    enc.reset([0.0])
    alpha = 1 - math.exp(-2 * math.pi * 10.0 * TS)
    vs = [enc.read([0.5 * k * TS])[1][0] for k in range(1, 30)]
    np.testing.assert_allclose(vs, 0.5 * (1 - (1 - alpha) ** np.arange(1, 30)), rtol=1e-9)


# ----------------------------------------------------------------------------- bad configuration


@pytest.mark.parametrize(
    "make, exc, match",
    [
        (lambda: ToolGravity(-0.5), ParameterError, r"tool mass must be a non-negative number \[kg\]; got -0.5"),
        (lambda: ToolGravity("heavy"), ParameterError, "tool mass must be a non-negative number"),
        (lambda: ToolGravity(1.0, dim=4), ParameterError, "dim must be 2 \\(planar\\) or 3"),
        (lambda: ToolGravity(1.0, com=[0.0, 0.0, 0.0]), DimensionError, "com must have 2 entries"),
        (lambda: ToolGravity(1.0, com=[np.nan, 0.0]), ParameterError, "com must be finite"),
        (lambda: RealisticForceSensor(resolution=-0.01), ParameterError, "resolution must be a non-negative number"),
        (lambda: RealisticForceSensor(resolution="fine"), ParameterError, "resolution must be a non-negative number"),
        (lambda: RealisticForceSensor(delay_samples=-1), ParameterError, "delay_samples must be a non-negative integer"),
        (lambda: RealisticForceSensor(delay_samples=1.5), ParameterError, "delay_samples must be a non-negative integer"),
        (lambda: RealisticForceSensor(zeroing_samples=-3), ParameterError, "zeroing_samples must be a non-negative integer"),
        (lambda: RealisticForceSensor(cutoff=50.0, filter="kalman"), ParameterError, "filter must be one of 'none'"),
        (lambda: RealisticForceSensor(filter="butterworth"), ParameterError, "filter 'butterworth' needs a cutoff"),
        (lambda: RealisticForceSensor(cutoff=50.0, filter="none"), ParameterError, "filter 'none' takes no cutoff"),
        (lambda: RealisticForceSensor(drift=[[1.0]]), DimensionError, "drift must be a scalar or a vector"),
        (lambda: RealisticForceSensor(drift=np.inf), ParameterError, "drift must be finite"),
        (lambda: RealisticForceSensor(tool=1.5), ParameterError, "tool must be a ToolGravity or None"),
        (lambda: RealisticForceSensor(tool_estimate="x"), ParameterError, "tool_estimate must be a ToolGravity or None"),
        (lambda: RealisticForceSensor(orientation=3), ParameterError, "orientation must be a callable"),
        (lambda: RealisticForceSensor(cutoff=600.0, filter="butterworth").filter_coefficients(TS), ParameterError,
         r"cutoff must be below the Nyquist frequency 500 Hz"),
        (lambda: JointEncoder(0, TS), ParameterError, "counts_per_turn must be a positive number"),
        (lambda: JointEncoder(4096, TS, velocity_cutoff=500.0), ParameterError,
         r"velocity_cutoff must be below the Nyquist frequency 500 Hz"),
        (lambda: EncoderFeedback(fc.ImpedanceController(ARM, 100, 500, 2500), JointEncoder(4096, 2e-3)),
         ParameterError, "encoder.sample_time must equal the controller's"),
        (lambda: EncoderFeedback("pd", JointEncoder(4096, TS)), ParameterError, "controller must be a forcecontrol Controller"),
        (lambda: EncoderFeedback(fc.ImpedanceController(ARM, 100, 500, 2500), 4096), ParameterError,
         "encoder must be a JointEncoder"),
    ],
)
def test_bad_sensor_configuration_is_refused(make, exc, match):
    """Each impossible setting is refused with a message naming it and what was given."""
    with pytest.raises(exc, match=match):
        make()


@pytest.mark.parametrize(
    "run, exc, match",
    [
        (lambda: _feed(RealisticForceSensor(drift=[1.0, 2.0, 3.0]), np.zeros((2, 2))), DimensionError,
         r"drift must be a scalar or have shape \(2,\)"),
        (lambda: _feed(RealisticForceSensor(orientation=lambda q: np.eye(3)), np.zeros((2, 2)), [0.0, 0.0]),
         DimensionError, r"orientation\(q\) must return a \(2, 2\) rotation"),
        (lambda: (lambda s: (s.start(5, 2, TS, np.zeros(2)), s.measure(3, 0.003, np.zeros(2))))(RealisticForceSensor()),
         ParameterError, "measure must be called for samples 0, 1, 2, ... in order; got 3 after 0"),
        (lambda: identify_tool_gravity(np.tile(np.eye(2), (4, 1, 1)), np.zeros((4, 2))), ParameterError,
         "poses do not excite the tool mass"),
        (lambda: identify_tool_gravity(np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3))), ParameterError,
         "poses do not excite the tool mass"),
        (lambda: identify_tool_gravity(
            np.array([planar_sensor_rotation([a, 0]) for a in (0.0, 1.0)]),
            np.array([ToolGravity(1.0).reading(planar_sensor_rotation([a, 0]))[0] for a in (0.0, 1.0)]) * -1),
         ParameterError, "identified tool mass is negative"),
        (lambda: identify_tool_gravity(np.array([np.eye(3), _rot3(np.random.default_rng(2))]),
                                       np.array([ToolGravity(1.0, dim=3).reading(R)[0]
                                                 for R in (np.eye(3), _rot3(np.random.default_rng(2)))]),
                                       np.zeros((2, 3))), ParameterError,
         "poses do not excite the centre of mass: give at least three"),
        (lambda: identify_tool_gravity(np.zeros((3, 2, 3)), np.zeros((3, 2))), DimensionError,
         r"rotations must have shape \(k, 2, 2\) or \(k, 3, 3\)"),
        (lambda: identify_tool_gravity(np.tile(np.eye(2), (3, 1, 1)), np.zeros((2, 2))), DimensionError,
         r"forces must have shape \(3, 2\)"),
        (lambda: identify_tool_gravity(np.array([planar_sensor_rotation([a, 0]) for a in (0.0, 1.0)]),
                                       np.ones((2, 2)), np.zeros((2, 3))), DimensionError,
         r"torques must have shape \(2,\) \(planar\) or \(2, 3\)"),
    ],
)
def test_bad_sensor_use_is_refused(run, exc, match):
    """Misuse at run time (shapes, order of samples, poses that identify nothing) gives a clear error."""
    with pytest.raises(exc, match=match):
        run()


# ----------------------------------------------------------------------------- scenario [sensor] table


def _scenario_with_sensor(sensor: dict) -> dict:
    """Example 9.3's base case (inner position, k = 1e3) with the given [sensor] table."""
    import copy

    from forcecontrol.scenarios import load_scenario

    data = copy.deepcopy(load_scenario("example-9.3").raw)
    data["sensor"] = sensor
    data["duration"] = 0.05
    data["controller"]["integral_gain"] = [0.0016, 0.0]
    return data


def test_scenario_sensor_table_builds_the_realistic_sensor_when_asked():
    """[sensor] with resolution/delay/tool keys gives a RealisticForceSensor; without them the simple one."""
    from forcecontrol.scenarios import build_case, load_scenario

    rich = load_scenario(_scenario_with_sensor({"noise_std": 0.5, "cutoff": 50.0, "filter": "butterworth",
                                                "resolution": 0.05, "delay_samples": 2, "tool_mass": 1.2,
                                                "zeroing_samples": 100}))
    s = build_case(rich.cases[0])["sensor"]
    assert isinstance(s, RealisticForceSensor) and s.filter == "butterworth" and s.delay_samples == 2
    assert s.tool.mass == 1.2 and s.tool_estimate.mass == 1.2 and s.resolution == 0.05
    simple = load_scenario(_scenario_with_sensor({"noise_std": 0.5, "cutoff": 50.0}))
    assert build_case(simple.cases[0])["sensor"].compiled_ok


@pytest.mark.parametrize(
    "sensor, match",
    [
        ({"tool_mass": -1.0}, r"\[sensor\]: tool mass must be a non-negative number \[kg\]; got -1.0"),
        ({"cutoff": 700.0, "filter": "butterworth"}, r"\[sensor\]: cutoff must be below the Nyquist frequency 500 Hz"),
        ({"resolution": -0.1}, r"\[sensor\]: resolution must be a non-negative number"),
        ({"delay_samples": -2}, r"\[sensor\]: delay_samples must be a non-negative integer"),
        ({"filter": "median"}, r"key 'filter' must be one of 'none', 'first-order', 'butterworth'"),
    ],
)
def test_scenario_sensor_table_refuses_bad_values(sensor, match):
    """Bad [sensor] values in a scenario are ScenarioErrors naming the table and the key."""
    from forcecontrol.errors import ScenarioError
    from forcecontrol.scenarios import load_scenario

    with pytest.raises(ScenarioError, match=match):
        load_scenario(_scenario_with_sensor(sensor))


def test_measuring_beyond_the_prepared_samples_is_refused():
    """start(n) prepares n samples of noise; asking for sample n is a clear error, not an IndexError."""
    s = RealisticForceSensor(noise_std=0.1)
    s.start(2, 2, TS, np.zeros(2))
    s.measure(1, TS, np.zeros(2))
    with pytest.raises(ParameterError, match=r"measure: sample 2 is beyond the 2 samples prepared by start\(\)"):
        s.measure(2, 2 * TS, np.zeros(2))


def test_exact_only_without_any_imperfection():
    """RealisticForceSensor() is exact; any one imperfection (resolution, delay, drift, tool) makes it inexact."""
    assert RealisticForceSensor().exact
    for kw in ({"resolution": 0.01}, {"delay_samples": 1}, {"drift": 0.1}, {"tool": ToolGravity(1.0)}):
        assert not RealisticForceSensor(**kw).exact
