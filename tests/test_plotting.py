"""Report-ready figures (issue 16 part 6): layout, line styles, labels with units, expected marks, captions."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import ParameterError, ScenarioError
from forcecontrol.viz.plotting import CASE_STYLES, SIGNAL_LABELS, case_style, panel_grid, plot_results


@pytest.fixture(scope="module")
def two_runs():
    """Example 9.2's two planes, 1 s each (compiled engine)."""
    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    out = []
    for k in (1e3, 1e4):
        plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=k)
        ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500)
        out.append(fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=1.0, label=f"k={k:g}"))
    return out


@pytest.mark.parametrize(("n", "grid"), [(1, (1, 1)), (2, (1, 2)), (3, (1, 3)), (4, (2, 2)), (5, (2, 3)), (7, (3, 3))])
def test_panel_grid(n, grid):
    """Up to three panels in a row, 2 x 2 for four (the squashed 1 x 4 of issue 16), rows of three beyond."""
    assert panel_grid(n) == grid


@pytest.mark.parametrize("bad", [0, -1, 2.5, True])
def test_panel_grid_rejects(bad):
    """A panel count that is not a positive integer is refused, naming what was given."""
    with pytest.raises(ParameterError, match="positive integer; got"):
        panel_grid(bad)


def test_case_styles_distinct():
    """Every case of the largest built-in figure (impact: 5 cases) gets its own colour and dash pattern."""
    styles = [(s["color"], str(s["linestyle"])) for s in (case_style(i) for i in range(len(CASE_STYLES)))]
    assert len(set(styles)) == len(CASE_STYLES) >= 5
    assert len({c for c, _ in styles}) == len(CASE_STYLES)


def test_figure_layout_labels_and_styles(two_runs):
    """Four panels: 2 x 2, figure size grows with the rows, y labels carry units, each case keeps its style."""
    fig = plot_results(two_runs, ["x", "y", "fx", "fy"], title="t")
    axes = [ax for ax in fig.axes if ax.get_visible() and ax.get_xlabel()]
    assert len(axes) == 4
    assert fig.get_size_inches()[0] < 10 and fig.get_size_inches()[1] > 6
    for ax, sig in zip(axes, ["x", "y", "fx", "fy"]):
        assert ax.get_ylabel() == SIGNAL_LABELS[sig] and "[" in ax.get_ylabel()
        assert ax.get_xlabel() == "t [s]"
        cases = [ln for ln in ax.get_lines() if ln.get_label().startswith("k=")]
        assert [ln.get_color() for ln in cases] == [CASE_STYLES[0][0], CASE_STYLES[1][0]]
    fig1 = plot_results(two_runs, ["fx"])
    assert fig1.get_size_inches()[0] < fig.get_size_inches()[0]
    import matplotlib.pyplot as plt

    plt.close("all")


def test_reference_and_expected_marks(two_runs):
    """The desired position x_d = 1.1 m is drawn once (same for both cases); expected values as dotted lines."""
    fig = plot_results(two_runs, ["x", "fx"], expected={"fx": [(71.4, "book 71.4"), (200.0, "book 200")]})
    ax_x, ax_f = [ax for ax in fig.axes if ax.get_xlabel()]
    refs = [ln for ln in ax_x.get_lines() if ln.get_label() == "desired (reference)"]
    assert len(refs) == 1 and np.allclose(refs[0].get_ydata(), 1.1)
    assert not [ln for ln in ax_f.get_lines() if ln.get_label() == "desired (reference)"]  # f_d = 0: not drawn
    marks = sorted(float(ln.get_ydata()[0]) for ln in ax_f.get_lines() if ln.get_linestyle() == ":")
    assert marks == [71.4, 200.0]
    lo, hi = ax_f.get_ylim()
    assert lo < 0 and hi > max(r.wrench[:, 0].max() for r in two_runs)
    import matplotlib.pyplot as plt

    plt.close("all")


def test_no_desired_position_is_drawn_for_a_loop_that_never_reads_it():
    """Example 9.3's Figs. 9.9 and 9.10 (inner position and velocity loops: x_F replaces x_d) drew the scenario's
    x_d = 1.015 m as "desired", a position those schemes never track; the parallel scheme (Fig. 9.11) tracks it."""
    import matplotlib.pyplot as plt

    runs = fc.scenario("example-9.3").with_(duration=0.05).run(engine="python")
    for case in runs.cases:
        fig = plot_results([case.result], ["x", "fx"])
        ax_x, ax_f = [ax for ax in fig.axes if ax.get_xlabel()]
        drawn = [ln for ln in ax_x.get_lines() if ln.get_label() == "desired (reference)"]
        assert bool(drawn) == case.label.startswith("parallel"), case.label
        assert [ln for ln in ax_f.get_lines() if ln.get_label() == "desired (reference)"]  # f_d is drawn for all
        plt.close("all")

@pytest.mark.parametrize("zoom", ["-0.01", "0.0"])
def test_scenario_figure_zoom_must_be_positive(tmp_path, zoom):
    """A figure's zoom (inset length) that is not a positive time is refused when the scenario loads."""
    from forcecontrol.scenarios import load_scenario, scenario_source

    text = scenario_source("example-9.2").read_text(encoding="utf-8").replace("[figure]\n", f"[figure]\nzoom = {zoom}\n", 1)
    path = tmp_path / "zoomed.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ScenarioError, match="'zoom' must be a positive time"):
        load_scenario(path)


def test_rigid_hybrid_start_spike_is_the_sampled_pole():
    """The ±53 N spikes of the rigid hybrid figure are what its caption says: the proportional law (9.93)
    commands 1.5 λ_d on the first sample, then the error is multiplied by −K_Pλ = −0.5 each sample."""
    scn = fc.scenario("hybrid-rigid-plane").with_({"duration": 0.02})
    run = scn.run()
    prop = next(c for c in run.cases if "(9.93)" in c.label)
    f = prop.result.wrench
    lam = 50.0 / math.sqrt(2.0)  # 50 N along the π/4 normal, per axis
    assert f[0] == pytest.approx([0.0, 0.0], abs=1e-9)  # before the first torque acts
    assert f[1] == pytest.approx([1.5 * lam, -1.5 * lam], rel=2e-3)  # the 53 N spike
    err = f[1:6, 0] - lam  # the first samples (later the motion along the plane adds its own transient)
    assert np.allclose(err[1:] / err[:-1], -0.5, atol=0.025)
    fig = scn.figure
    assert fig["zoom"] > 0 and "−K_Pλ = −0.5" in fig["note"]
