"""MuJoCo as an independent plant: same models, calibrated soft contact, same controller object, both engines compared."""

from __future__ import annotations

import math

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
pytest.importorskip("pinocchio")

import forcecontrol as fc  # noqa: E402
from forcecontrol.controllers.spatial import SpatialImpedanceController  # noqa: E402
from forcecontrol.engines.mujoco import DIFFERENCES, MujocoPlant, compare_engines, simulate_mujoco  # noqa: E402
from forcecontrol.environments.spatial import ConstantWrench, Table  # noqa: E402
from forcecontrol.errors import ParameterError  # noqa: E402
from forcecontrol.robots.pinocchio import PANDA_READY, panda  # noqa: E402
from forcecontrol.spatial import rotation_to_euler_xyz  # noqa: E402

Q_CONTACT = np.array([math.pi / 3, -2 * math.pi / 3])


@pytest.fixture(scope="module")
def franka():
    return panda()


def test_mujoco_panda_has_pinocchios_inertia_and_gravity(franka):
    """MuJoCo's Panda rebuilt from the same URDF has Pinocchio's B(q) and g(q) (fingers locked) to 1e-9."""
    plant = MujocoPlant(franka, Table([0.3, 0.0, 0.0], stiffness=1e4))
    m, d = plant.model, plant.data
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = PANDA_READY + rng.normal(0, 0.3, 7)
        d.qpos[:] = q
        d.qvel[:] = 0
        mujoco.mj_forward(m, d)
        M = np.zeros((7, 7))
        mujoco.mj_fullM(m, d, M)
        assert np.allclose(M, franka.mass_matrix(q), atol=1e-9)
        assert np.allclose(d.qfrc_bias, franka.gravity(q), atol=1e-9)
        R, p = franka.frame_pose(q)
        assert np.allclose(d.xpos[plant.ee_body], p, atol=1e-12)


def test_mujoco_chapter_arm_differs_only_by_the_rotor_coupling():
    """The chapter arm in MuJoCo matches the closed form's B except b12, short by k_r2 I_m2 = 1 (documented)."""
    arm = fc.PlanarTwoLink()
    plant = MujocoPlant(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4))
    m, d = plant.model, plant.data
    q, qd = np.array([0.7, -1.3]), np.array([0.5, -0.8])
    d.qpos[:], d.qvel[:] = q, qd
    mujoco.mj_forward(m, d)
    M = np.zeros((2, 2))
    mujoco.mj_fullM(m, d, M)
    assert np.allclose(arm.mass_matrix(q) - M, [[0, 1.0], [1.0, 0]], atol=1e-9)
    # n = C q̇ + F q̇ + g: MuJoCo's bias minus its passive (joint damping) forces
    assert np.allclose(d.qfrc_bias - d.qfrc_passive, arm.nonlinear_effects(q, qd), atol=1e-9)


def test_calibrated_mujoco_contact_is_the_environment_spring_at_rest():
    """With torques balancing k δ and gravity, MuJoCo's sensed contact force is k δ at several postures (static calibration)."""
    arm = fc.PlanarTwoLink()
    plant = MujocoPlant(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4))
    m, d = plant.model, plant.data
    for target in ([1.01, 0.0], [1.02, 0.3], [1.005, -0.4]):
        q = arm.inverse_kinematics(target)
        f = 1e4 * (target[0] - 1.0)
        d.qpos[:], d.qvel[:] = q, 0.0
        mujoco.mj_forward(m, d)
        plant._reschedule()
        d.qfrc_applied[:] = arm.gravity(q) + arm.jacobian(q).T @ np.array([f, 0.0])
        mujoco.mj_forward(m, d)
        assert np.allclose(plant.contact_wrench(), [f, 0.0], rtol=1e-6)
        assert np.allclose(d.qacc, 0.0, atol=1e-6)


def test_example_9_2_on_mujoco_matches_the_builtin_simulator():
    """Example 9.2 (k = 1e4): the same ImpedanceController on MuJoCo: steady force within 2%, same peak time and overshoot."""
    arm = fc.PlanarTwoLink()
    env = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4)
    ctrl = fc.ImpedanceController(arm, 100.0, 500.0, 2500.0)
    ref = fc.Setpoint([1.1, 0.1])
    a = fc.simulate(arm, env, ctrl, ref, q0=Q_CONTACT, duration=2.0)
    b = MujocoPlant(arm, env).run(ctrl, ref, q0=Q_CONTACT, duration=2.0)
    rep = compare_engines(a, b, axis=0)
    assert rep["steady_force_difference_percent"] < 2.0
    assert abs(rep["builtin"]["steady"] - 200.0) < 2.0  # the book's 200 N
    assert abs(rep["mujoco"]["peak_time"] - rep["builtin"]["peak_time"]) <= 0.05 * rep["builtin"]["peak_time"]
    assert abs(rep["mujoco"]["overshoot_percent"] - rep["builtin"]["overshoot_percent"]) < 3.0
    assert rep["max_force_difference_over_peak_percent"] < 5.0
    assert rep["why_they_differ"] == [d for d in DIFFERENCES if not d.startswith("payload:")]  # no payload sensor here
    assert any(d.startswith("chapter arm:") for d in rep["why_they_differ"])


def test_panda_pressing_a_table_on_mujoco_matches_the_builtin_simulator(franka):
    """Panda, 6-D impedance pushing 5 cm into a table: steady force (9.22) within 2% on both engines, same transient."""
    R, p = franka.frame_pose(PANDA_READY)
    x0 = np.concatenate([p, rotation_to_euler_xyz(R)])
    Md = np.diag([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
    KP = np.diag([400.0] * 3 + [10.0] * 3)
    KD = np.diag(2 * 0.7 * np.sqrt(np.diag(Md) * np.diag(KP)))
    table = Table(p, [0, 0, 1], stiffness=1e4, damping=20.0)
    ref = fc.Setpoint(x0 - np.array([0, 0, 0.05, 0, 0, 0]))
    ctrl = SpatialImpedanceController(franka, Md, KD, KP, posture=PANDA_READY)
    a = fc.simulate(franka, table, ctrl, ref, q0=PANDA_READY, duration=0.6, substeps=2)
    b = MujocoPlant(franka, table).run(ctrl, ref, q0=PANDA_READY, duration=0.6)
    rep = compare_engines(a, b)
    assert rep["axis"] == 2
    f_expected = 400.0 * 1e4 / (400.0 + 1e4) * 0.05  # (9.22) along z
    for eng in ("builtin", "mujoco"):
        assert abs(-rep[eng]["steady"] - f_expected) <= 0.02 * f_expected
    assert rep["steady_force_difference_percent"] < 2.0
    assert abs(rep["mujoco"]["peak_time"] - rep["builtin"]["peak_time"]) <= 0.05 * rep["builtin"]["peak_time"]
    assert rep["max_force_difference_over_peak_percent"] < 5.0


def test_unsupported_environment_and_robot_are_errors(franka):
    """A constant-wrench environment or a robot without a URDF cannot be rebuilt in MuJoCo: ParameterError."""
    with pytest.raises(ParameterError, match="supports ElasticPlane, Table and LinearSpring"):
        MujocoPlant(franka, ConstantWrench(np.zeros(6)))
    with pytest.raises(ParameterError, match="a LinearSpring in MuJoCo acts on the position"):
        MujocoPlant(franka, fc.LinearSpring(np.eye(6), np.zeros(6)))
    bare = type(franka)(franka.model, franka.frame)
    with pytest.raises(ParameterError, match="needs the built-in arm or a PinocchioRobot loaded from a URDF"):
        MujocoPlant(bare, Table([0.3, 0, 0]))


def test_cli_run_with_mujoco_engine_and_compare_command(tmp_path):
    """`forcecontrol run NAME --engine mujoco --json` and `forcecontrol compare NAME --json` report both engines."""
    import json

    from typer.testing import CliRunner

    from forcecontrol.cli import app

    runner = CliRunner()
    res = runner.invoke(app, ["run", "panda-table-line", "--engine", "mujoco", "--json", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert out["cases"][0]["engine"] == "mujoco" and out["all_checks_pass"]
    res = runner.invoke(app, ["compare", "panda-table-line", "--json"])
    assert res.exit_code == 0, res.output
    rep = json.loads(res.stdout)["cases"][0]
    assert rep["engines"][1] == "mujoco" and rep["axis"] == 2
    assert rep["steady_force_difference_percent"] < 2.0
    assert rep["why_they_differ"]
    res = runner.invoke(app, ["compare", "panda-table-line"])
    assert res.exit_code == 0 and "why" in res.stdout


def test_a_coupled_linear_spring_in_mujoco_agrees_with_the_built_in_engine():
    """A LinearSpring with coupled K and D (a passive force MuJoCo evaluates at every RK4 stage): impedance
    control settles at the same contact force as the built-in engine (and (9.32)'s closed form) within 0.05 %,
    and the transient agrees within 1 % of the peak (the arms differ by the rotor coupling of b12 only)."""
    arm = fc.PlanarTwoLink()
    K = np.array([[3000.0, 1200.0], [1200.0, 2000.0]])
    x_r, x_d = np.array([1.0, 0.0]), np.array([1.1, 0.1])
    env = fc.LinearSpring(K, x_r, np.diag([20.0, 10.0]))
    q0 = arm.inverse_kinematics(x_r, elbow="up")
    runs = [engine(arm, env, fc.ImpedanceController(arm, 100.0, 500.0, 2500.0), fc.Setpoint(x_d), q0=q0, duration=3.0)
            for engine in (fc.simulate, simulate_mujoco)]
    f_hand = K @ (np.linalg.solve(2500.0 * np.eye(2) + K, 2500.0 * x_d + K @ x_r) - x_r)
    for r in runs:
        np.testing.assert_allclose(r.wrench[-1], f_hand, rtol=5e-4)
    peak = np.max(np.linalg.norm(runs[0].wrench, axis=1))
    assert np.max(np.linalg.norm(runs[0].wrench - runs[1].wrench, axis=1)) < 0.01 * peak
    assert mujoco.get_mjcb_passive() is None  # the global callback is restored after the run


def test_compare_on_a_scenario_mujoco_cannot_build_is_a_clear_error():
    """A scenario whose environment MuJoCo cannot model (a 6-D spring) exits with code 2 and says why."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    res = CliRunner().invoke(app, ["compare", "panda-peg-in-hole"])
    assert res.exit_code == 2
    assert "supports ElasticPlane, Table and LinearSpring" in res.output


def test_mujoco_refuses_an_arm_it_would_not_model():
    """A planar arm with other link data cannot be silently swapped for the chapter's URDF arm."""
    arm = fc.PlanarTwoLink(fc.PlanarTwoLinkParameters(m_l2=20.0, a1=0.8))
    with pytest.raises(ParameterError, match=r"parameters a1, m_l2 must keep the chapter's values; got a1 = 0.8, m_l2 = 20.0"):
        simulate_mujoco(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3), fc.ImpedanceController(arm, 100, 500, 2500),
                        fc.Setpoint([1.1, 0.1]), q0=[1.0, -2.0], duration=0.01)


def test_logged_mujoco_twist_is_the_tip_velocity():
    """The MuJoCo log's ẋ is J(q) q̇ of the closed-form arm at the tip (not at a body's inertial frame)."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0])
    res = simulate_mujoco(arm, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3), fc.ImpedanceController(arm, 100, 500, 2500),
                          fc.Setpoint([1.1, 0.1]), q0=q0, duration=0.3)
    for k in (50, 150, 300):
        np.testing.assert_allclose(res.xd[k], arm.jacobian(res.q[k]) @ res.qd[k], atol=1e-9)
        np.testing.assert_allclose(res.x[k], arm.forward_kinematics(res.q[k]), atol=1e-9)


def test_the_reasons_the_engines_differ_are_those_of_the_run():
    """The chapter arm's rotor coupling is named for the chapter's arm only, the payload sensor's reading with a payload
    sensor only (`compare` listed both for every scenario)."""
    from types import SimpleNamespace

    from forcecontrol.engines.compare import differences

    def names(robot, sensor):
        return {d.split(":")[0] for d in differences(SimpleNamespace(metadata={"robot": robot, "sensor": sensor}))}

    assert {"chapter arm", "payload"} <= names("PlanarTwoLink", {"kind": "payload"})
    assert not {"chapter arm", "payload"} & names("PinocchioRobot", {"type": "ForceSensor"})
    assert "integration" in names("PinocchioRobot", None)


def test_mujoco_runs_keep_the_controllers_signals_as_the_builtin_engine_does(tmp_path):
    """The variable-stiffness tank case on MuJoCo: its tank energy, stiffness scale and storage are logged (they were
    dropped: `run --engine mujoco` stopped on a KeyError drawing the tank, and its tank_energy_min check read NaN); the
    tank energy follows the built-in engine's to the engines' difference, and `run --engine mujoco` draws and checks."""
    from forcecontrol.scenarios.build import build_case
    from journeys_helpers import forcecontrol as cli

    runs = {}
    for engine in ("mujoco", "python"):
        p = build_case(fc.scenario("variable-stiffness").with_({"duration": 0.5}).cases[1])
        runs[engine] = (simulate_mujoco if engine == "mujoco" else fc.simulate)(
            p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=0.5,
            **({} if engine == "mujoco" else {"engine": "python"}))
    mj, py = runs["mujoco"].signals, runs["python"].signals
    assert sorted(mj) == sorted(py) and {"tank_energy", "stiffness_scale", "storage"} <= set(mj)
    assert np.all(np.isfinite(mj["tank_energy"]))
    gap = np.abs(mj["tank_energy"] - py["tank_energy"])  # a schedule switch a sample apart moves one sample's T
    assert np.median(gap) < 1e-3 and abs(mj["tank_energy"].min() - py["tank_energy"].min()) < 0.01
    out = cli(tmp_path, "run", "variable-stiffness", "--engine", "mujoco", "--set", "duration=0.5")
    assert "Traceback" not in out.stderr and (tmp_path / "forcecontrol-out" / "variable-stiffness").is_dir()
