"""The Python conveniences a notebook user reaches for: plots, DataFrames, named values, scenarios as objects."""

from __future__ import annotations

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import ParameterError, ScenarioError

ARM = fc.PlanarTwoLink()


@pytest.fixture(scope="module")
def res():
    q0 = ARM.inverse_kinematics([1.0, 0.0], elbow="up")
    plane = fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e3)
    ctl = fc.ImpedanceController(ARM, 100, 500, 2500)
    return fc.simulate(ARM, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=4.0, label="k = 1e3")


def test_named_final_and_settled_values(res):
    """final_values / settled_values name every component and equal the raw arrays (Example 9.2: 71.43 N, 7.14 cm)."""
    fin = res.final_values()
    assert list(fin) == ["t", "x", "y", "vx", "vy", "fx", "fy"]
    assert fin["fx"] == res.wrench[-1, 0] and fin["t"] == res.t[-1]
    st = res.settled_values(0.1)
    np.testing.assert_allclose([st["fx"], st["fy"]], res.settled("wrench", 0.1), rtol=1e-15)
    assert st["fx"] == pytest.approx(71.43, abs=0.01) and st["x"] == pytest.approx(1.0714, abs=1e-4)


def test_plot_panels_follow_the_requested_signals(res, tmp_path):
    """plot() draws position and force by default (4 panels planar), plot('force') the force only, PNG when a path is given."""
    import matplotlib

    matplotlib.use("Agg")
    fig = res.plot()
    assert [ax.get_ylabel() for ax in fig.axes] == ["tip x [m]", "tip y [m]", "f_x [N]", "f_y [N]"]
    fig = res.plot("force")
    assert len(fig.axes) == 2
    line = fig.axes[0].lines[0]
    np.testing.assert_array_equal(line.get_ydata(), res.wrench[:, 0])
    out = res.plot("fx", "u1", path=tmp_path / "p.png")
    assert out.stat().st_size > 1000
    with pytest.raises(ParameterError, match="unknown signal 'fz'; expected a group"):
        res.plot("fz")


def test_to_pandas_has_named_columns(res):
    """to_pandas() gives the named columns (t, q1.., x, y, fx, fy, references)."""
    pytest.importorskip("pandas")
    df = res.to_pandas()
    assert {"t", "q1", "x", "fy", "ref_position_x"} <= set(df.columns)
    assert len(df) == len(res.t)


def test_scenario_object_edit_and_run():
    """fc.scenario(name).with_({...}).run(): an edited Example 9.2 with K_P doubled settles at the closed form."""
    scn = fc.scenario("example-9.2")
    stiffer = scn.with_({"controller.stiffness": [5000.0, 5000.0]}, duration=3.0)
    assert scn.cases[0].config["controller"]["stiffness"] == [2500.0, 2500.0]  # the original is untouched
    run = stiffer.run()
    k_x = 1e4
    f_hand = k_x * 5000.0 / (5000.0 + k_x) * 0.1  # (9.32) at rest: f = k k_P/(k_P + k) (x_d − x_r)
    assert run.cases[0].metrics["fx"] == pytest.approx(f_hand, rel=1e-3)
    with pytest.raises(ScenarioError, match=r"\(edited\).*stiffness"):
        scn.with_({"controller.stiffness": -1.0})
    with pytest.raises(ScenarioError, match="names no table 'controler'"):
        scn.with_({"controler.stiffness": 1.0})


def test_force_step_at_one_second_from_a_scenario():
    """[reference] force_start = 1.0 in a scenario: f_d(t) steps at 1 s, the run has no force before, settles at f_d."""
    scn = fc.scenario("example-9.3").with_({"reference.force_start": 1.0, "duration": 6.0})
    run = scn.run()
    for c in run.cases:
        r = c.result
        if not c.label.startswith("parallel"):  # the parallel scheme's x_d inside the plane pushes by itself
            assert np.abs(r.wrench[:1000, 0]).max() == 0.0
        assert r.reference_block("force")[999, 0] == 0.0 and r.reference_block("force")[1000, 0] == 10.0
    ipl = [c for c in run.cases if c.label.startswith("inner velocity")]
    assert all(abs(c.metrics["fx"] - 10.0) < 0.01 for c in ipl)
    with pytest.raises(ScenarioError, match="force_shape"):
        fc.scenario("example-9.3").with_({"reference.force_shape": "cubic"})
