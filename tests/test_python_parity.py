"""ScenarioRun in Python gives what `forcecontrol run` gives: the figure, the summary (HTML), one data frame, short reprs."""

from __future__ import annotations

import dataclasses
import html
import re

import numpy as np
import pytest
from typer.testing import CliRunner

import forcecontrol as fc
from forcecontrol.cli import app
from forcecontrol.errors import ParameterError
from journeys_helpers import rich_tables

runner = CliRunner()

#: Example 9.2's closed-form equilibrium (9.22)-(9.23): f_x = k K_P / (k + K_P) (x_d - x_r), K_P = 2500, x_d - x_r = 0.1 m
CLOSED_FORM_FX = {"k_x = 1e4 N/m": 1e4 * 2500 / 12500 * 0.1, "k_x = 1e3 N/m": 1e3 * 2500 / 3500 * 0.1}


@pytest.fixture(scope="module")
def run():
    return fc.scenario("example-9.2").run()


def _cells(table_html: str) -> list[list[str]]:
    rows = re.findall(r"<tr>(.*?)</tr>", table_html)
    return [[html.unescape(c) for c in re.findall(r"<t[dh]>(.*?)</t[dh]>", r)] for r in rows]


def test_plot_is_the_figure_the_cli_writes(run, tmp_path):
    """run.plot(path=...) writes the same PNG, pixel for pixel, as `forcecontrol run example-9.2` writes, and returns a Figure."""
    import matplotlib.image as mpimg
    from matplotlib.figure import Figure

    res = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path / "cli")])
    assert res.exit_code == 0, res.output
    fig = run.plot(path=tmp_path / "py" / "example-9.2.png")
    assert isinstance(fig, Figure)
    cli = mpimg.imread(tmp_path / "cli" / "example-9.2" / "example-9.2.png")
    py = mpimg.imread(tmp_path / "py" / "example-9.2.png")
    assert cli.shape == py.shape
    np.testing.assert_array_equal(cli, py)


def test_plot_without_path_draws_the_scenario_signals(run):
    """run.plot() returns a Figure with one panel per [figure] signal (x, f_x), a curve per case; no file is written."""
    fig = run.plot()
    panels = [ax for ax in fig.axes if ax.get_ylabel()]
    assert len(panels) >= 2
    data = {tuple(np.round(line.get_ydata()[-1:], 6)) for ax in panels for line in ax.get_lines() if len(line.get_xdata()) > 100}
    fx_end = {round(float(c.result.wrench[-1, 0]), 6) for c in run.cases}
    assert fx_end <= {v[0] for v in data if v}


@pytest.mark.parametrize(("figure", "match"), [(3, r"figure must be an index in \[0, 0\].*got 3"),
                                                ("nope", r"figure must be the name of one of the scenario's figures.*'nope'"),
                                                (True, r"figure must be an index.*got True")])
def test_plot_refuses_an_unknown_figure(run, figure, match):
    """run.plot(figure=...) with an index out of range, an unknown name or a bool is a ParameterError naming what was given."""
    with pytest.raises(ParameterError, match=match):
        run.plot(figure)


def test_to_pandas_is_one_frame_with_case_labels_and_units(run):
    """to_pandas(): every case's log stacked with a 'case' column, columns equal to the logs, SI units in df.attrs['units']."""
    df = run.to_pandas()
    assert list(df.columns[:2]) == ["case", "t"]
    assert len(df) == sum(c.result.t.shape[0] for c in run.cases)
    assert list(dict.fromkeys(df["case"])) == [c.label for c in run.cases]
    for c in run.cases:
        part = df[df["case"] == c.label]
        np.testing.assert_array_equal(part["t"].to_numpy(), c.result.t)
        np.testing.assert_array_equal(part["fx"].to_numpy(), c.result.wrench[:, 0])
        np.testing.assert_array_equal(part["q2"].to_numpy(), c.result.q[:, 1])
    units = df.attrs["units"]
    assert df.attrs["scenario"] == "example-9.2"
    expected = {"t": "s", "x": "m", "vx": "m/s", "fx": "N", "fx_measured": "N", "q1": "rad", "qd1": "rad/s",
                "u1": "N m", "ref_position_x": "m", "ref_velocity_y": "m/s", "ref_acceleration_x": "m/s^2",
                "ref_force_x": "N", "ref_force_rate_x": "N/s", "case": ""}
    assert {k: units[k] for k in expected} == expected
    assert all(units[c] for c in df.columns if c != "case")  # every signal of this scenario has its unit


def test_repr_html_is_the_cli_summary_with_the_book_values(run):
    """_repr_html_ holds the CLI's tables cell for cell; f_x is the closed form's, the book's 200 N / 71.4 N are expected."""
    page = run._repr_html_()
    tables = re.findall(r"<table>.*?</table>", page)
    assert len(tables) == 2
    settled, checks = _cells(tables[0]), _cells(tables[1])
    assert settled[0] == ["case", "t_end [s]", "x [m]", "y [m]", "f_x [N]", "f_y [N]", "peak |f| [N]", "engine"]
    for row in settled[1:]:
        assert float(row[4]) == pytest.approx(CLOSED_FORM_FX[row[0]], abs=0.05)
    book = {(r[0], r[1]): r[3] for r in checks[1:]}
    assert book[("k_x = 1e4 N/m", "fx [N]")] == "200" and book[("k_x = 1e3 N/m", "fx [N]")] == "71.4"
    assert all(r[-1] == "ok" for r in checks[1:]) and all("%" in r[5] for r in checks[1:])  # relative errors shown
    cli = rich_tables(runner.invoke(app, ["run", "example-9.2", "--no-figure"]).stdout)
    for table, rows in ((cli[0], settled), (cli[1], checks)):
        assert [list(r.values()) for r in table] == [r for r in rows[1:]]


def test_repr_html_escapes_labels_and_titles(run):
    """A case label holding HTML is shown as text in _repr_html_ (escaped), never as markup."""
    hostile = "<script>alert(1)</script>&"
    cases = [dataclasses.replace(run.cases[0], label=hostile), *run.cases[1:]]
    page = dataclasses.replace(run, cases=cases)._repr_html_()
    assert "<script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt;&amp;" in page


def test_reprs_are_short_and_say_shape_duration_status(run):
    """repr of a run, a case and a log: no arrays, one line each, with samples, duration and check status."""
    for obj in (run, run.cases[0], run.cases[0].result):
        text = repr(obj)
        assert "array(" not in text and "\n" not in text and len(text) < 300, text
    assert repr(run) == ("ScenarioRun('example-9.2', 2 case(s): 'k_x = 1e4 N/m', 'k_x = 1e3 N/m'; 4 s; all checks pass; "
                         "0 file(s))")
    assert "4001 samples" in repr(run.cases[0]) and "checks 7/7 ok" in repr(run.cases[0])
    assert "4001 samples" in repr(run.cases[0].result) and "0..4 s" in repr(run.cases[0].result)


def _spatial_run():
    """A 6-D run (the Panda's table scenario) whose log is a hand-made constant: z = 0.3 m, f_z = -20 N."""
    from forcecontrol.scenarios.model import CaseResult, ScenarioRun
    from forcecontrol.sim.result import SimulationResult

    scn = fc.scenario("panda-table-line")
    n, t = 7, np.linspace(0.0, 1.0, 11)
    pose = np.tile([0.4, 0.1, 0.3, 3.14, 0.0, 0.0], (t.size, 1))
    wrench = np.tile([0.5, -0.25, -20.0, 0.0, 0.0, 0.0], (t.size, 1))
    res = SimulationResult(t, np.zeros((t.size, n)), np.zeros((t.size, n)), pose, np.zeros_like(pose), wrench, wrench,
                           np.zeros((t.size, n)), np.zeros((t.size, 36)), label="case 1", metadata={"engine": "python"})
    metrics = {k: v for k, v in res.settled_values(0.1).items()}
    return ScenarioRun(scn, [CaseResult("case 1", res, metrics, {}, [])])


def test_a_6d_summary_shows_z_and_f_z():
    """A 6-D run's summary (HTML, like the CLI's) has z [m] and f_z [N] columns with the task's values (0.3 m, -20 N)."""
    settled = _cells(re.findall(r"<table>.*?</table>", _spatial_run()._repr_html_())[0])
    row = dict(zip(settled[0], settled[1]))
    assert float(row["z [m]"]) == pytest.approx(0.3) and float(row["f_z [N]"]) == pytest.approx(-20.0)
    assert float(row["f_x [N]"]) == pytest.approx(0.5) and float(row["f_y [N]"]) == pytest.approx(-0.25)


def test_a_6d_frame_has_rotational_units():
    """to_pandas() of a 6-D run gives the orientation in rad, moments in N m, angular velocity in rad/s."""
    units = _spatial_run().to_pandas().attrs["units"]
    assert (units["rx"], units["mz"], units["wy"], units["fz"], units["ref_force_rz"]) == ("rad", "N m", "rad/s", "N", "N m")


def test_to_pandas_without_pandas_names_the_extra(run, monkeypatch):
    """Without pandas, to_pandas() raises ImportError naming the 'data' extra to install."""
    import sys

    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match=r"to_pandas needs pandas: pip install 'forcecontrol\[data\]'"):
        run.to_pandas()
