"""Sweeps on every path (issue 27): resumed tables in case order, the default figures of one- and
two-parameter sweeps, and the notes a sweep prints when it does something other than asked."""

from __future__ import annotations

import json
import struct

import pandas as pd
import pytest
from typer.testing import CliRunner

from forcecontrol.cli import app
from forcecontrol.sweep import SweepDefinition, SweepError, prepare_sweep, read_sweep, run_sweep
from forcecontrol.sweep.figures import plot_sweep

#: Example 9.3's inner velocity loop (chapter arm on the plane x = 1, f_d = 10 N), short runs.
PLANAR = {
    "name": "paths-test",
    "duration": 0.3,
    "robot": {"model": "chapter-arm", "start_position": [1.0, 0.0], "elbow": "up"},
    "environment": {"type": "elastic-plane", "point": [1.0, 0.0], "normal": [-1.0, 0.0], "stiffness": 1e4},
    "controller": {"type": "inner-velocity", "inertia": [100.0, 100.0], "damping": [500.0, 500.0],
                   "stiffness": [2500.0, 2500.0], "force_gain": [0.0024, 0.0]},
    "reference": {"type": "setpoint", "position": [1.015, 0.1], "force": [10.0, 0.0]},
}


def _png_size(path) -> tuple[int, int]:
    """Width and height from a PNG's IHDR chunk (the file's own header, read without matplotlib)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


# ----------------------------------------------------------------------------- resume


def test_resumed_sweep_with_scattered_missing_parts_is_sorted_by_case_id(tmp_path):
    """Parts 2-3 and 6-7 recomputed in one block (stored after 4-5 by name): the table is in case-id order
    and equals the uninterrupted one."""
    d = SweepDefinition.from_options({"environment.stiffness": [5e3, 1e4, 2e4, 4e4, 8e4, 1.6e5, 3.2e5, 6.4e5]})
    whole = run_sweep(prepare_sweep(PLANAR, d), tmp_path / "whole.parquet", workers=1, block_size=2)
    out = tmp_path / "cut.parquet"
    parts = tmp_path / "cut.parquet.parts"

    def stop_at_the_end(done: int, total: int) -> None:
        if done == total:  # every part is stored, the table not yet assembled
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(prepare_sweep(PLANAR, d), out, workers=1, block_size=2, progress=stop_at_the_end)
    names = sorted(p.name for p in parts.glob("part-*.parquet"))
    assert [n.split("-")[1:3] for n in names] == [["00000000", "00000001"], ["00000002", "00000003"],
                                                  ["00000004", "00000005"], ["00000006", "00000007"]]
    for n in (names[1], names[3]):
        (parts / n).unlink()
    resumed = run_sweep(prepare_sweep(PLANAR, d), out, workers=1, block_size=4)
    assert (resumed.ran, resumed.resumed) == (4, 4)
    assert resumed.table["case_id"].tolist() == list(range(8))
    pd.testing.assert_frame_equal(resumed.table, whole.table, check_exact=True)
    on_disk, _ = read_sweep(out)
    assert on_disk["case_id"].tolist() == list(range(8))


# ----------------------------------------------------------------------------- figures


def test_one_parameter_sweep_draws_curves_with_the_sampled_loop_limit(tmp_path):
    """A one-parameter sweep's default figure is a valid PNG; a sweep variable held at one value is no axis."""
    d = SweepDefinition.from_options({"environment.stiffness": [5e3, 2e4, 8e4], "duration": [0.3]})
    res = run_sweep(prepare_sweep(PLANAR, d), tmp_path / "one.parquet", workers=1)
    png, notes = plot_sweep(res, tmp_path / "one.png")
    w, h = _png_size(png)
    assert w > 800 and 200 < h < w and png.stat().st_size > 20_000
    assert notes == []  # the only other parameter takes one value: every case is drawn


def test_map_over_two_of_three_parameters_says_which_cases_it_shows(tmp_path):
    """A grid over three parameters: the map is drawn over the first two and a note names the held value."""
    d = SweepDefinition.from_options({"environment.stiffness": [5e3, 2e4], "controller.damping[0]": [400.0, 600.0],
                                      "controller.stiffness[0]": [2000.0, 3000.0]})
    res = run_sweep(prepare_sweep(PLANAR, d), tmp_path / "three.parquet", workers=1)
    png, notes = plot_sweep(res, tmp_path / "three.png")
    assert _png_size(png)[0] > 800
    assert len(notes) == 1 and "shows 4 of 8 cases" in notes[0] and "controller.stiffness[0] = 2000.0" in notes[0]
    with pytest.raises(SweepError, match=r"figure axis 'duration' is not a swept parameter; expected one of"):
        plot_sweep(res, tmp_path / "bad.png", x="duration")


def test_a_non_numeric_parameter_is_no_default_axis_and_refused_by_name(tmp_path):
    """A sweep over the elbow (a word) and stiffness: the default figure is over the stiffness (a note names the
    elbow it holds); asking for the elbow as an axis is a SweepError naming the parameter and its values."""
    d = SweepDefinition.from_options({"robot.elbow": ["up", "down"], "environment.stiffness": [5e3, 2e4]})
    res = run_sweep(prepare_sweep(PLANAR, d), tmp_path / "types.parquet", workers=1)
    png, notes = plot_sweep(res, tmp_path / "t.png")
    assert _png_size(png)[0] > 800
    assert notes == ["the figure over environment.stiffness shows 2 of 4 cases, those with robot.elbow = 'up' "
                     "(pick other axes with --x/--y)"]
    with pytest.raises(SweepError, match=r"figure axis 'robot.elbow' is not a number \(values up, down\)"):
        plot_sweep(res, tmp_path / "t.png", x="robot.elbow")


def test_cli_sweep_with_default_figure_writes_the_map_and_notes_a_non_numeric_axis(tmp_path):
    """`sweep` with figures on (the default): exit 0 and a PNG for numbers; for a string axis exit 0, the table,
    no figure, and a note on stderr and in --json."""
    scn = tmp_path / "p.toml"
    scn.write_text(_toml(PLANAR))
    out = tmp_path / "two.parquet"
    r = CliRunner().invoke(app, ["sweep", str(scn), "-p", "environment.stiffness=5000,20000",
                                 "-p", "controller.damping[0]=400,600", "--out", str(out), "--json"])
    assert r.exit_code == 0, r.output
    summary = json.loads(r.stdout)
    assert summary["files"]["figure"] == str(out.with_suffix(".png")) and summary["notes"] == []
    assert _png_size(out.with_suffix(".png"))[0] > 800
    out2 = tmp_path / "types.parquet"
    r = CliRunner().invoke(app, ["sweep", str(scn), "-p", "robot.elbow=up,down",
                                 "--out", str(out2), "--json"])
    assert r.exit_code == 0, r.output
    summary = json.loads(r.stdout)
    assert "figure" not in summary["files"] and out2.exists() and not out2.with_suffix(".png").exists()
    assert any("no figure drawn" in n and "robot.elbow" in n for n in summary["notes"])
    assert "no figure drawn" in r.stderr


def test_cli_checks_figure_axes_before_running_and_notes_ignored_options(tmp_path):
    """--y that is not swept fails before any case runs (exit 2, no table); --x with --no-figure and --seed
    with a grid are ignored with a note."""
    scn = tmp_path / "p.toml"
    scn.write_text(_toml(PLANAR))
    out = tmp_path / "s.parquet"
    r = CliRunner().invoke(app, ["sweep", str(scn), "-p", "environment.stiffness=5000,20000", "--y", "duration",
                                 "--out", str(out)])
    assert r.exit_code == 2 and "--y 'duration' is not a swept parameter" in r.stderr and not out.exists()
    r = CliRunner().invoke(app, ["sweep", str(scn), "-p", "environment.stiffness=5000", "--x", "environment.stiffness",
                                 "--no-figure", "--seed", "3", "--out", str(out), "--json"])
    assert r.exit_code == 0, r.output
    notes = json.loads(r.stdout)["notes"]
    assert any("--x ignored" in n for n in notes) and any("--seed 3 is ignored" in n for n in notes)
    r = CliRunner().invoke(app, ["sweep", str(scn), "-p", "environment.stiffness=5000", "--x", "environment.stifness",
                                 "--no-figure", "--out", str(tmp_path / "t.parquet")])  # a typo is refused, figure or not
    assert r.exit_code == 2 and "--x 'environment.stifness' is not a swept parameter" in r.stderr
    assert not (tmp_path / "t.parquet").exists()


def _toml(d: dict) -> str:
    """A flat scenario dict as TOML (tables of numbers, strings and lists)."""
    lines = []
    for k, v in d.items():
        if not isinstance(v, dict):
            lines.append(f"{k} = {json.dumps(v)}")
    for k, v in d.items():
        if isinstance(v, dict):
            lines.append(f"[{k}]")
            lines += [f"{kk} = {json.dumps(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


def test_a_case_stopped_by_an_unresolved_contact_says_so_in_its_row(monkeypatch):
    """simulate()'s newer divergence cause 'unresolved contact' reaches the table as such (it read
    'non-finite state' when the sweep did not know the cause), with the time it stopped at."""
    import forcecontrol.sim.simulation as simulation
    from forcecontrol.errors import SimulationDivergedError
    from forcecontrol.sweep.run import run_block

    d = SweepDefinition.from_options({"sensor.delay_samples": [2]})  # a realistic sensor: simulate() runs it
    job = prepare_sweep(PLANAR, d).jobs[0]
    real = simulation.simulate

    def stopped(*args, **kwargs):
        res = real(*args, **kwargs)
        k = 120
        err = SimulationDivergedError("unresolved contact", time=k * 1e-3, step=k, cause="unresolved contact",
                                      q=res.q[k])
        err.partial = type(res)(**{f: getattr(res, f)[: k + 1] for f in ("t", "q", "qd", "x", "xd", "wrench",
                                                                         "wrench_measured", "torque", "reference")})
        raise err

    monkeypatch.setattr(simulation, "simulate", stopped)
    row = run_block([job], 0.02, 0.05)[0]
    assert row["engine"] == "simulate" and row["status"] == "unresolved contact"
    assert row["diverged_at"] == pytest.approx(0.12)
