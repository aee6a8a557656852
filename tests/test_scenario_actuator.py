"""Scenario files: the ``[actuator]`` table (joint friction, actuation delay, torque quantisation)."""

from __future__ import annotations

import numpy as np
import pytest
import tomllib

from forcecontrol.errors import ScenarioError
from forcecontrol.scenarios import load_scenario, run_scenario
from forcecontrol.scenarios.core import scenario_source


def _config(**extra):
    """Example 9.2 shortened to one 0.1 s case, plus the given top-level tables."""
    cfg = tomllib.loads(scenario_source("example-9.2").read_text())
    for key in ("case", "figure"):
        cfg.pop(key, None)
    cfg.update(duration=0.1, name="actuator-test", **extra)
    return cfg


def test_actuator_delay_shows_exactly_in_the_torque_log():
    """delay_samples = 3: the torque applied at sample k is the one commanded at k − 3; before, the start torque.

    Reference outside the code under test: the run without [actuator] commands, at sample 0, the same torque
    (same initial state), and that is what the delayed arm applies at sample 3.
    """
    plain = run_scenario(load_scenario(_config()), engine="python").cases[0].result
    delayed = run_scenario(load_scenario(_config(actuator={"delay_samples": 3})), engine="python").cases[0].result
    u_cmd, u = delayed.torque_commanded, delayed.torque
    assert u_cmd is not None and plain.torque_commanded is None
    np.testing.assert_array_equal(u[3:], u_cmd[:-3])
    np.testing.assert_array_equal(u[3], plain.torque[0])
    assert not np.allclose(u[:3], plain.torque[0])  # the first 3 samples hold the start torque, not the command
    np.testing.assert_array_equal(u[0], u[2])


def test_actuator_quantisation_and_friction_reach_the_simulation():
    """resolution = 0.5 N m: every applied torque is a multiple of 0.5; friction changes the motion."""
    res = run_scenario(load_scenario(_config(actuator={"resolution": 0.5, "coulomb": [1.0, 0.5], "viscous": 2.0})),
                       engine="python").cases[0].result
    np.testing.assert_allclose(res.torque / 0.5, np.round(res.torque / 0.5), atol=1e-9)
    plain = run_scenario(load_scenario(_config()), engine="python").cases[0].result
    assert np.max(np.abs(res.q - plain.q)) > 1e-6


@pytest.mark.parametrize(
    "table, match",
    [
        ({"delay_samples": -1}, r"\[actuator\]: key 'delay_samples' must be a whole number of samples >= 0; got -1"),
        ({"delay_samples": 1.5}, r"\[actuator\]: key 'delay_samples' must be an integer"),
        ({"coulomb": -0.1}, r"\[actuator\]: coulomb must be non-negative"),
        ({"viscous": [1.0, 2.0, 3.0]}, r"\[actuator\]: key 'viscous' must be a number or a list of 2 numbers"),
        ({"coulomb_band": 0.0}, r"\[actuator\]: coulomb_band must be positive"),
        ({"delay": 2}, r"\[actuator\].*delay"),
    ],
)
def test_bad_actuator_values_name_the_table_and_key(table, match):
    """Each bad value is refused when the scenario is loaded, with [actuator] and the key in the message."""
    with pytest.raises(ScenarioError, match=match):
        load_scenario(_config(actuator=table))


def test_actuator_needs_the_python_engine_and_is_in_the_schema():
    """MuJoCo is refused with a message; `forcecontrol schema` lists the [actuator] keys."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    with pytest.raises(ScenarioError, match=r"\[actuator\] needs the python engine"):
        run_scenario(load_scenario(_config(actuator={"delay_samples": 1})), engine="mujoco")
    out = CliRunner().invoke(app, ["schema"], env={"COLUMNS": "200"})
    assert out.exit_code == 0, out.output
    assert "[actuator]" in out.output
    for key in ("coulomb", "viscous", "coulomb_band", "delay_samples", "resolution"):
        assert key in out.output
    assert "[whole samples]" in out.output and "[rad/s]" in out.output  # units survive rich's markup


def test_a_sweep_of_a_scenario_with_an_actuator_simulates_the_actuator(tmp_path):
    """The sweep runs such cases through simulate() with the actuator (not the compiled kernel without it)."""
    import textwrap

    from forcecontrol.sweep import prepare_sweep, run_sweep

    def scenario(actuator: str) -> str:
        return textwrap.dedent(f"""
            name = "sweep-actuator"
            duration = 0.3
            [robot]
            start_position = [1.0, 0.0]
            [environment]
            type = "elastic-plane"
            point = [1.0, 0.0]
            normal = [-1.0, 0.0]
            stiffness = 10000.0
            [controller]
            type = "inner-velocity"
            inertia = 100.0
            damping = 500.0
            stiffness = 2500.0
            force_gain = [0.0024, 0.0]
            [reference]
            type = "setpoint"
            position = [1.0, 0.0]
            force = [10.0, 0.0]
            {actuator}
            [sweep]
            design = "grid"
            [sweep.parameters]
            "environment.stiffness" = [5000.0, 10000.0]
        """)

    tables = {}
    for name, act in (("plain", ""), ("delayed", "[actuator]\ndelay_samples = 20")):
        path = tmp_path / f"{name}.toml"
        path.write_text(scenario(act))
        tables[name] = run_sweep(prepare_sweep(str(path)), tmp_path / f"{name}.parquet", workers=1).table
    # a 20 ms actuation delay changes the transient: the peak force differs in every case
    assert (tables["plain"]["peak_force"] != tables["delayed"]["peak_force"]).all()
