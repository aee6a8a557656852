"""The compiled 6-D loop (sim/loop_tree.py; impedance, admittance) against the Python engine; the C++ baseline's skip rule."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from forcecontrol.controllers.spatial import SpatialImpedanceController  # noqa: E402
from forcecontrol.environments.spatial import ConstantWrench, SpatialSpring, Table  # noqa: E402
from forcecontrol.errors import ForceControlError, ParameterError  # noqa: E402
from forcecontrol.robots.pinocchio import PANDA_READY, panda, ur5  # noqa: E402
from forcecontrol.sim.loop_tree import run_impedance_loop  # noqa: E402
from forcecontrol.sim.simulation import simulate  # noqa: E402
from forcecontrol.spatial import rotation_to_euler_xyz  # noqa: E402
from forcecontrol.trajectories import Setpoint  # noqa: E402

MD = np.diag([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
KP = np.diag([400.0, 400.0, 400.0, 10.0, 10.0, 10.0])
KD = np.diag(2 * 0.7 * np.sqrt(np.diag(MD) * np.diag(KP)))


def _panda_table():
    robot = panda()
    R, p = robot.frame_pose(PANDA_READY)
    ref = Setpoint(np.concatenate([p - [0.0, 0.0, 0.02], rotation_to_euler_xyz(R)]))
    ctrl = SpatialImpedanceController(robot, MD, KD, KP, posture=PANDA_READY)
    return robot, Table(p, (0.0, 0.0, 1.0), 5000.0, 50.0), ctrl, ref, PANDA_READY


def test_panda_on_a_table_equals_the_python_engine():
    """Panda impedance pressing into a table: q, wrench and torque equal simulate(engine='python')'s to 1e-9 (RK4 x 2)."""
    robot, env, ctrl, ref, q0 = _panda_table()
    res = simulate(robot, env, ctrl, ref, q0=q0, duration=0.15, substeps=2, engine="python")
    out = run_impedance_loop(robot, env, ctrl, ref, q0, 0.15, 2)
    assert out["status"] == 0 and out["q"].shape == res.q.shape
    assert np.max(np.abs(out["q"] - res.q)) < 1e-9
    assert np.max(np.abs(out["qd"] - res.qd)) < 1e-7
    assert np.max(np.abs(out["wrench"] - res.wrench)) < 1e-6
    assert np.max(np.abs(out["torque"] - res.torque)) < 1e-6
    assert res.wrench[-1, 2] < -1.0  # in contact (h_e is the force the tool exerts on the table)


def test_ur5_under_a_constant_wrench_equals_the_python_engine():
    """UR5 (6 DOF, no posture) under a constant wrench with a moving-free setpoint: equal to the Python engine to 1e-9."""
    robot = ur5()
    q0 = np.array([0.3, -1.2, 1.5, -1.8, -1.5, 0.4])
    R, p = robot.frame_pose(q0)
    ref = Setpoint(np.concatenate([p + [0.01, 0.0, 0.0], rotation_to_euler_xyz(R) + [0.05, 0.0, 0.0]]))
    ctrl = SpatialImpedanceController(robot, MD, KD, KP)
    env = ConstantWrench([3.0, -2.0, 1.0, 0.1, 0.2, -0.1])
    res = simulate(robot, env, ctrl, ref, q0=q0, duration=0.1, substeps=1, engine="python")
    out = run_impedance_loop(robot, env, ctrl, ref, q0, 0.1, 1)
    assert out["status"] == 0
    assert np.max(np.abs(out["q"] - res.q)) < 1e-9


def test_panda_admittance_contact_scenario_equals_the_python_engine():
    """The built-in scenario panda-admittance-contact (admittance (9.37), table, RK4 x 2): equal to the Python engine to 1e-9."""
    from forcecontrol.scenarios import build_case, load_scenario

    parts = build_case(load_scenario("panda-admittance-contact").cases[0])
    robot, env, ctrl, ref, q0 = parts["robot"], parts["environment"], parts["controller"], parts["reference"], parts["q0"]
    res = simulate(robot, env, ctrl, ref, q0=q0, duration=0.2, substeps=parts["substeps"], engine="python")
    out = run_impedance_loop(robot, env, ctrl, ref, q0, 0.2, parts["substeps"])
    assert out["status"] == 0
    assert np.max(np.abs(out["q"] - res.q)) < 1e-9
    assert np.max(np.abs(out["wrench"] - res.wrench)) < 1e-6
    assert np.max(np.abs(out["torque"] - res.torque)) < 1e-6
    assert res.wrench[-1, 2] < -1.0


_LOGS = ("q", "qd", "x", "xd", "wrench", "wrench_measured", "torque")


def test_simulate_engine_compiled_runs_the_admittance_scenario_like_the_python_engine():
    """simulate(engine='compiled') on panda-admittance-contact: each log within 1e-9 (forces 1e-6) of the Python engine's."""
    from forcecontrol.scenarios import build_case, load_scenario

    parts = build_case(load_scenario("panda-admittance-contact").cases[0])
    robot, env, ctrl, ref, q0 = parts["robot"], parts["environment"], parts["controller"], parts["reference"], parts["q0"]
    kw = dict(q0=q0, duration=0.2, substeps=parts["substeps"])
    py = simulate(robot, env, ctrl, ref, engine="python", **kw)
    state_py, lam_py = ctrl.state.copy(), ctrl.last_damping
    co = simulate(robot, env, ctrl, ref, engine="compiled", **kw)
    assert py.metadata["engine"] == "python" and co.metadata["engine"] == "compiled"
    for name in _LOGS:
        tol = 1e-9 if name in ("q", "qd", "x") else 1e-6
        assert np.max(np.abs(getattr(co, name) - getattr(py, name))) < tol, name
    assert np.max(np.abs(ctrl.state - state_py)) < 1e-9 and abs(ctrl.last_damping - lam_py) < 1e-12
    auto = simulate(robot, env, ctrl, ref, engine="auto", **kw)
    assert auto.metadata["engine"] == "python"  # 6-D arms stay on the Python engine unless asked


def test_simulate_engine_compiled_with_a_noisy_filtered_sensor():
    """Impedance on a table with sensor bias, noise and a low-pass: engine='compiled' equals engine='python' (1e-9 in q)."""
    from forcecontrol.sensors import ForceSensor

    robot, env, ctrl, ref, q0 = _panda_table()
    sensor = ForceSensor(noise_std=0.5, bias=[0.2, -0.1, 0.3, 0.0, 0.01, 0.0], cutoff=50.0, seed=4)
    py = simulate(robot, env, ctrl, ref, q0=q0, duration=0.1, substeps=2, sensor=sensor, engine="python")
    co = simulate(robot, env, ctrl, ref, q0=q0, duration=0.1, substeps=2, sensor=sensor, engine="compiled")
    assert np.max(np.abs(co.q - py.q)) < 1e-9
    assert np.max(np.abs(co.wrench_measured - py.wrench_measured)) < 1e-6
    assert np.ptp(py.wrench_measured[:, 0]) > 0.1  # the noise reached the law


def test_simulate_engine_compiled_names_what_a_6d_case_lacks():
    """engine='compiled' with a spatial spring: a ParameterError that names the 6-D reason (the Python engine still runs it)."""
    robot, _env, ctrl, ref, q0 = _panda_table()
    spring = SpatialSpring(np.eye(6) * 100.0, rest_position=np.zeros(3))
    with pytest.raises(ParameterError, match="for a 6-D arm: the environment is a SpatialSpring"):
        simulate(robot, spring, ctrl, ref, q0=q0, duration=0.01, substeps=1, engine="compiled")


def test_unsupported_parts_are_refused():
    """Another environment is refused with a library error naming what the compiled loop supports."""
    robot, _env, ctrl, ref, q0 = _panda_table()
    spring = SpatialSpring(np.eye(6) * 100.0, rest_position=np.zeros(3))
    with pytest.raises(ParameterError, match="SpatialSpring.*Table or ConstantWrench") as exc:
        run_impedance_loop(robot, spring, ctrl, ref, q0, 0.01, 1)
    assert isinstance(exc.value, ForceControlError)


def _bench():
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_6d_vs_cpp.py"
    spec = importlib.util.spec_from_file_location("bench_6d_vs_cpp", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["bench_6d_vs_cpp"] = mod
    spec.loader.exec_module(mod)
    return mod


def test_benchmark_skips_the_cpp_baseline_when_the_build_fails(tmp_path, monkeypatch, capsys):
    """Without a compiler the benchmark's build returns None and says why on stderr (never raises)."""
    bench = _bench()
    monkeypatch.setattr(bench, "BINARY", tmp_path / "missing")
    monkeypatch.setenv("PATH", str(tmp_path))  # no g++, no python on PATH
    assert bench.build() is None
    assert "C++ baseline skipped" in capsys.readouterr().err


ONE_VERSION = r'''
import numpy as np
from forcecontrol.controllers.spatial import SpatialImpedanceController
from forcecontrol.environments.spatial import ConstantWrench, Table
from forcecontrol.laws.spatial import spatial_impedance_torque
from forcecontrol.robots.pinocchio import PANDA_READY, panda, ur5
from forcecontrol.scenarios import build_case, load_scenario
from forcecontrol.sim.loop_tree import impedance_loop, run_impedance_loop
from forcecontrol.sim.metrics import case_metrics, step_metrics
from forcecontrol.sim.simulation import simulate
from forcecontrol.spatial import rotation_to_euler_xyz
from forcecontrol.trajectories import Setpoint

MD = np.diag([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
KP = np.diag([400.0, 400.0, 400.0, 10.0, 10.0, 10.0])
KD = np.diag(2 * 0.7 * np.sqrt(np.diag(MD) * np.diag(KP)))
robot = panda()
R, p = robot.frame_pose(PANDA_READY)
ref = Setpoint(np.concatenate([p - [0.0, 0.0, 0.02], rotation_to_euler_xyz(R)]))
ctrl = SpatialImpedanceController(robot, MD, KD, KP, posture=PANDA_READY)
table = Table(p, (0.0, 0.0, 1.0), 5000.0, 50.0)
run_impedance_loop(robot, table, ctrl, ref, PANDA_READY, 0.01, 2)                       # impedance on a table
simulate(robot, table, ctrl, ref, q0=PANDA_READY, duration=0.01, engine="python")       # the law called from Python
arm = ur5()
q0 = np.array([0.3, -1.2, 1.5, -1.8, -1.5, 0.4])
R, p = arm.frame_pose(q0)
run_impedance_loop(arm, ConstantWrench([3.0, -2.0, 1.0, 0.1, 0.2, -0.1]), SpatialImpedanceController(arm, MD, KD, KP),
                   Setpoint(np.concatenate([p, rotation_to_euler_xyz(R)])), q0, 0.01, 1)  # a frozen wrench
parts = build_case(load_scenario("panda-admittance-contact").cases[0])                   # admittance: frozen gains
run_impedance_loop(parts["robot"], parts["environment"], parts["controller"], parts["reference"], parts["q0"], 0.01, 1)
res = simulate(robot, table, ctrl, ref, q0=PANDA_READY, duration=0.05, engine="python")
step_metrics(res.t, res.wrench[:, 2], reference=-10.0)                                   # a column of a log
print({f.py_func.__name__: [str(s) for s in f.signatures]
       for f in (impedance_loop, spatial_impedance_torque, case_metrics)})
'''


def test_every_path_into_the_6d_loop_and_its_callees_uses_one_compiled_version():
    """The 6-D loop on a table, under a frozen constant wrench and with the admittance scenario's frozen gains, the
    law called from the Python engine and the metrics of a log's column: one compiled version each of the loop, the
    law and case_metrics (fails before: Numba compiles again for a read-only or a strided array; the loop had three
    versions, 8 s each on a cold cache). The loop's callees given literal flags: test_kernel_cache.py."""
    import ast
    import subprocess

    out = subprocess.run([sys.executable, "-c", ONE_VERSION], capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    versions = ast.literal_eval(out.stdout.strip().splitlines()[-1])
    assert {name: len(sigs) for name, sigs in versions.items()} == {
        "impedance_loop": 1, "spatial_impedance_torque": 1, "case_metrics": 1}, versions
