"""The sampled-data simulator: engines agree, integration is accurate, divergence stops clearly."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import DimensionError, ParameterError, SimulationDivergedError

ARM = fc.PlanarTwoLink()
Q0 = ARM.inverse_kinematics([1.0, 0.0])


def _impedance_case(k=1e4, **kw):
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], k)
    ctl = fc.ImpedanceController(ARM, 100, 500, 2500)
    return env, ctl, fc.Setpoint([1.1, 0.1])


@pytest.mark.parametrize(
    "controller",
    [
        lambda: fc.ImpedanceController(ARM, 100, 500, 2500),
        lambda: fc.ImpedanceController(ARM, 100, 500, 2500, force_measurement=False),
        lambda: fc.OperationalSpacePD(ARM, [2500, 2500], [1200, 1000]),
        lambda: fc.JointSpacePD(ARM, [5000, 3000], [600, 400], ARM.inverse_kinematics([1.1, 0.1])),
    ],
)
def test_compiled_and_python_loops_agree(controller):
    """The compiled loop and the plain-Python loop give the same log to round-off (second implementation)."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4, damping=20.0)
    sensor = fc.ForceSensor(noise_std=0.5, bias=[0.2, -0.1], cutoff=100.0, seed=3)
    ref = fc.LinearPath([1.0, 0.0], [1.05, 0.1], 0.5, force=[10.0, 0.0])
    a = fc.simulate(ARM, env, controller(), ref, q0=Q0, duration=0.6, sensor=sensor, engine="compiled")
    b = fc.simulate(ARM, env, controller(), ref, q0=Q0, duration=0.6, sensor=sensor, engine="python")
    assert a.metadata["engine"] == "compiled" and b.metadata["engine"] == "python"
    for name in ("q", "qd", "wrench", "wrench_measured", "torque"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-9, atol=1e-9, err_msg=name)


def test_halving_the_integration_step_changes_no_force_by_more_than_0_1_percent():
    """Plant integration accuracy: default substeps versus twice as many, stiff plane, whole transient."""
    env, ctl, ref = _impedance_case(1e4)
    a = fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=2.5)
    b = fc.simulate(ARM, env, fc.ImpedanceController(ARM, 100, 500, 2500), ref, q0=Q0, duration=2.5,
                    substeps=2 * a.metadata["substeps"])
    scale = np.abs(a.wrench[:, 0]).max()
    assert np.abs(a.wrench[:, 0] - b.wrench[:, 0]).max() <= 1e-3 * scale


def test_substeps_grow_with_environment_stiffness():
    """A stiffer plane gets more substeps, each resolving ω² = k νᵀ J B⁻¹ Jᵀ ν with ω h <= 0.05."""
    nu = np.array([-1.0, 0.0])
    inv_mass = nu @ ARM.jacobian(Q0) @ np.linalg.solve(ARM.mass_matrix(Q0), ARM.jacobian(Q0).T) @ nu
    counts = []
    for k in (1e3, 1e5, 1e7, 1e8):
        n = fc.sim.simulation.choose_substeps(ARM, fc.ElasticPlane([1, 0], [-1, 0], k), Q0, 1e-3)
        assert 1e-3 / n * math.sqrt(k * inv_mass) <= 0.05
        counts.append(n)
    assert counts[0] == 1 and counts == sorted(counts) and counts[-1] > counts[1]


def test_divergence_stops_with_time_and_cause():
    """An unstable loop (huge gains, stiff plane) stops with SimulationDivergedError saying when."""
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e6)
    ctl = fc.ImpedanceController(ARM, 1.0, 1.0, 1e5)
    with pytest.raises(SimulationDivergedError, match=r"diverged at t = \d+\.\d+ s \(sample \d+\): runaway") as ei:
        fc.simulate(ARM, env, ctl, fc.Setpoint([1.1, 0.1]), q0=Q0, duration=2.0)
    err = ei.value
    assert err.cause == "runaway" and 0 < err.time < 2.0
    assert err.partial.t[-1] == pytest.approx(err.time)


def test_singularity_during_simulation_stops_clearly():
    """Starting at the stretched-out singularity stops the run with cause 'singular jacobian'."""
    env = fc.ElasticPlane([3.0, 0.0], [-1.0, 0.0], 1e3)
    ctl = fc.ImpedanceController(ARM, 100, 500, 2500)
    for engine in ("compiled", "python"):
        with pytest.raises(SimulationDivergedError, match="singular jacobian") as ei:
            fc.simulate(ARM, env, ctl, fc.Setpoint([1.5, 0.0]), q0=[0.0, 0.0], duration=0.1, engine=engine)
        assert ei.value.step == 0


def test_sensor_bias_noise_and_low_pass():
    """Measured = true + bias + noise through α = 1 − exp(−2π f_c Ts); noise has the asked std."""
    env, ctl, ref = _impedance_case(1e3)
    sensor = fc.ForceSensor(noise_std=0.5, bias=[1.0, 0.0], seed=1)
    r = fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=1.0, sensor=sensor)
    err = r.wrench_measured - r.wrench
    assert abs(err[:, 0].mean() - 1.0) < 0.1 and abs(err[:, 0].std() - 0.5) < 0.05
    # low-pass on a constant true force starting from another value: first-order response
    s = fc.ForceSensor(cutoff=10.0)
    a = s.alpha(1e-3)
    assert a == pytest.approx(1 - math.exp(-2 * math.pi * 10 * 1e-3))


def test_sensor_cutoff_above_nyquist_is_refused():
    """A filter cut-off at or above Nyquist is a clear error."""
    with pytest.raises(ParameterError, match=r"cutoff must be below the Nyquist frequency 500 Hz"):
        fc.ForceSensor(cutoff=600.0).alpha(1e-3)


def test_noise_is_reproducible_from_its_seed():
    """Same seed, same run; another seed, another run."""
    env, _, ref = _impedance_case(1e3)
    runs = [
        fc.simulate(ARM, env, fc.ImpedanceController(ARM, 100, 500, 2500), ref, q0=Q0, duration=0.2,
                    sensor=fc.ForceSensor(noise_std=1.0, seed=s))
        for s in (5, 5, 6)
    ]
    np.testing.assert_array_equal(runs[0].wrench_measured, runs[1].wrench_measured)
    assert not np.array_equal(runs[0].wrench_measured, runs[2].wrench_measured)


def test_results_save_to_csv_and_parquet_that_pandas_opens(tmp_path):
    """CSV and Parquet logs open in pandas; the JSON beside them holds gains and versions."""
    pd = pytest.importorskip("pandas")
    env, ctl, ref = _impedance_case(1e3)
    r = fc.simulate(ARM, env, ctl, ref, q0=Q0, duration=0.05, label="demo")
    for fmt in ("csv", "parquet"):
        data, meta = r.save(tmp_path / "run", format=fmt)
        df = pd.read_csv(data) if fmt == "csv" else pd.read_parquet(data)
        assert len(df) == 51 and {"t", "x", "fx", "q1", "u2", "ref_position_x"} <= set(df.columns)
        np.testing.assert_allclose(df["fx"].to_numpy(), r.wrench[:, 0], rtol=1e-9)
        m = json.loads(meta.read_text())
        assert m["controller"]["stiffness"] == [[2500.0, 0.0], [0.0, 2500.0]]
        assert m["label"] == "demo" and "numpy" in m["versions"]


@pytest.mark.parametrize(
    "kw, exc, match",
    [
        ({"duration": 0.0}, ParameterError, "duration must be a positive number"),
        ({"duration": 1e-5}, ParameterError, "duration must be at least one sample time"),
        ({"q0": [1.0]}, DimensionError, r"q0 must have shape \(2,\)"),
        ({"q0": [np.nan, 0.0]}, ParameterError, "q0 must be finite"),
        ({"substeps": 0}, ParameterError, "substeps must be a positive integer"),
        ({"engine": "gpu"}, ParameterError, "engine must be 'auto', 'python' or 'compiled'"),
    ],
)
def test_bad_simulation_arguments(kw, exc, match):
    """Bad durations, start states, substeps and engines are refused before simulating."""
    env, ctl, ref = _impedance_case()
    args = {"q0": Q0, "duration": 1.0, **kw}
    with pytest.raises(exc, match=match):
        fc.simulate(ARM, env, ctl, ref, **args)


def test_dimension_mismatch_is_refused():
    """A 3-D plane with the planar arm is a DimensionError."""
    env = fc.ElasticPlane([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], 1e3)
    with pytest.raises(DimensionError, match="environment must be 2-dimensional"):
        fc.simulate(ARM, env, fc.ImpedanceController(ARM, 1, 1, 1), fc.Setpoint([1, 0]), q0=Q0, duration=0.1)


def test_substeps_resolve_the_contact_mode_of_a_redundant_arm():
    """Panda (7 joints, 6×7 J) on a table: h·ω <= 0.05 with ω² = k νᵀ J B⁻¹ Jᵀ ν (effective mass along ν)."""
    pytest.importorskip("pinocchio")
    from forcecontrol.environments.spatial import Table
    from forcecontrol.robots.pinocchio import panda

    robot = panda()
    q = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])
    k, c = 5e4, 50.0
    table = Table(robot.forward_kinematics(q)[:3], (0.0, 0.0, 1.0), stiffness=k, damping=c)
    J, B = robot.jacobian(q), robot.mass_matrix(q)
    nu = np.zeros(6)
    nu[2] = 1.0
    inv_mass = nu @ J @ np.linalg.solve(B, J.T) @ nu  # 1 / m_eff along the normal
    omega = math.sqrt(k * inv_mass)
    nsub = fc.sim.simulation.choose_substeps(robot, table, q, 1e-3)
    assert 1e-3 / nsub * max(omega, c * inv_mass) <= 0.05
    assert 1e-3 / (nsub - 1 if nsub > 1 else 0.5) * max(omega, c * inv_mass) > 0.05  # and not more than needed
