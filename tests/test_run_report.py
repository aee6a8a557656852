"""A plain `forcecontrol run` folder is enough for `forcecontrol report`; long steps of `run` show progress."""

from __future__ import annotations

import io

import numpy as np
import pytest
from rich.console import Console
from typer.testing import CliRunner

from forcecontrol.cli import app
from journeys_helpers import shell

runner = CliRunner()


def test_readme_run_then_report_of_its_folder(tmp_path):
    """`forcecontrol run example-9.2` then `forcecontrol report forcecontrol-out/example-9.2`, verbatim: the report is
    written from the run's own folder (both cases' logs), no --data needed."""
    pytest.importorskip("plotly")
    shell(tmp_path, "forcecontrol run example-9.2")
    folder = tmp_path / "forcecontrol-out" / "example-9.2"
    logs = sorted(p.name for p in folder.glob("*.csv"))
    assert logs == ["example-9.2-k-x-1e3-n-m.csv", "example-9.2-k-x-1e4-n-m.csv"]
    rep = shell(tmp_path, "forcecontrol report forcecontrol-out/example-9.2")
    page = (folder / "report.html").read_text(encoding="utf-8")
    assert "report: forcecontrol-out/example-9.2/report.html" in rep.stdout
    assert '"name":"k_x = 1e4 N\\u002fm"' in page and '"name":"k_x = 1e3 N\\u002fm"' in page  # plotly's JSON of the labels
    assert "Run of example-9.2: 2 case(s)" in page


def test_run_logs_equal_the_python_run(tmp_path):
    """The CSV a plain run keeps holds the same log as fc.scenario(...).run() (10 significant digits)."""
    import pandas as pd

    import forcecontrol as fc

    res = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path), "--no-figure", "--data", "csv"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path / "plain")])
    assert res.exit_code == 0, res.output
    run = fc.scenario("example-9.2").run()
    table = pd.read_csv(tmp_path / "plain" / "example-9.2" / "example-9.2-k-x-1e4-n-m.csv")
    np.testing.assert_allclose(table["fx"].to_numpy(), run.cases[0].result.wrench[:, 0], rtol=1e-9, atol=1e-9)


def test_run_without_figure_writes_no_folder(tmp_path, monkeypatch):
    """`run --no-figure` (data left at auto) writes nothing: no folder appears in the working directory."""
    monkeypatch.chdir(tmp_path)
    res = runner.invoke(app, ["run", "example-9.2", "--no-figure", "--set", "duration=0.2"])
    assert res.exit_code == 0, res.output
    assert list(tmp_path.iterdir()) == []


def test_animate_shows_a_frame_progress_bar(tmp_path, monkeypatch):
    """`run --animate` shows a progress bar per case on stderr ('animating <case> ... frames') and writes each GIF."""
    import importlib

    app_module = importlib.import_module("forcecontrol.cli.app")  # the module (the package's 'app' is the Typer app)

    buffer = io.StringIO()
    monkeypatch.setattr(app_module, "err_console", Console(file=buffer, force_terminal=True, width=120))
    res = runner.invoke(app, ["run", "example-9.2", "--animate", "--no-figure", "--data", "none", "--set", "duration=0.3",
                              "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    shown = buffer.getvalue()
    assert "animating k_x = 1e4 N/m (1/2)" in shown and "animating k_x = 1e3 N/m (2/2)" in shown and "frames" in shown
    assert len(list((tmp_path / "example-9.2").glob("*.gif"))) == 2


def test_animate_run_reports_every_frame(tmp_path):
    """animate_run(progress=...) is called once per frame, 1..n of n, n the frames frame_indices chooses."""
    import forcecontrol as fc
    from forcecontrol.scenarios import build_case
    from forcecontrol.viz.animation import animate_run, frame_indices

    scn = fc.scenario("example-9.2").with_(duration=0.3)
    run = scn.run()
    parts = build_case(scn.cases[0])
    calls: list[tuple[int, int]] = []
    animate_run(run.cases[0].result, parts["robot"], parts["environment"], tmp_path / "a.gif",
                progress=lambda i, n: calls.append((i, n)))
    n = len(frame_indices(run.cases[0].result.t, 20.0))
    assert calls == [(i, n) for i in range(1, n + 1)]


def _recording_busy(seen):
    from contextlib import contextmanager

    @contextmanager
    def fake(description, *, quiet=False):
        seen.append((description, quiet))
        yield lambda text: seen.append((text, quiet))

    return fake


def test_replay_shows_each_long_step(tmp_path, monkeypatch):
    """`replay` names each step on its progress line (reading the log, replaying N samples, writing); --json hides it."""
    import importlib

    replay_module = importlib.import_module("forcecontrol.cli.replay")
    res = runner.invoke(app, ["run", "example-9.2", "--no-figure", "--data", "csv", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    log = tmp_path / "example-9.2" / "example-9.2-k-x-1e4-n-m.csv"
    for json_out in (False, True):
        seen: list[tuple[str, bool]] = []
        monkeypatch.setattr(replay_module, "busy", _recording_busy(seen))
        args = ["replay", "example-9.2", str(log), "--out", str(tmp_path / f"r{json_out}")] + (["--json"] if json_out else [])
        res = runner.invoke(app, args)
        assert res.exit_code == 0, res.output
        texts = [t for t, _ in seen]
        assert texts[0] == "loading example-9.2" and texts[1] == f"reading {log}"
        assert texts[2].startswith("replaying 4001 samples") and texts[3].startswith("writing the table")
        assert all(quiet is json_out for _, quiet in seen)


def test_analyze_verify_shows_a_progress_line(monkeypatch):
    """`analyze --verify` (it simulates every case) runs under a progress line naming the cases; plain analyze is quiet."""
    import importlib

    analyze_module = importlib.import_module("forcecontrol.cli.analyze")
    for verify, quiet in ((True, False), (False, True)):
        seen: list[tuple[str, bool]] = []
        monkeypatch.setattr(analyze_module, "busy", _recording_busy(seen))
        res = runner.invoke(app, ["analyze", "example-9.2", *(["--verify"] if verify else [])])
        assert res.exit_code == 0, res.output
        assert seen[0][1] is quiet
        assert ("simulating its 2 case(s) to verify" in seen[0][0]) is verify


def test_busy_draws_its_steps_on_a_terminal(monkeypatch):
    """busy() draws a spinner line with the current step on a terminal's stderr, and nothing when quiet."""
    import importlib
    import time

    from forcecontrol.cli.busy import busy

    app_module = importlib.import_module("forcecontrol.cli.app")
    for quiet in (False, True):
        buffer = io.StringIO()
        monkeypatch.setattr(app_module, "err_console", Console(file=buffer, force_terminal=True, width=100))
        with busy("reading the log", quiet=quiet) as step:
            time.sleep(0.3)  # the line refreshes 10 times a second
            step("replaying 9 samples")
            time.sleep(0.3)
        shown = buffer.getvalue()
        assert ("reading the log" in shown and "replaying 9 samples" in shown) is not quiet, shown


def test_report_shows_a_progress_line(tmp_path, monkeypatch):
    """`report FOLDER` writes its page under a progress line naming the folder (seconds for long runs)."""
    import forcecontrol.cli.busy as busy_module

    pytest.importorskip("plotly")
    res = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path), "--no-figure", "--data", "csv",
                              "--set", "duration=0.2"])
    assert res.exit_code == 0, res.output
    seen: list[tuple[str, bool]] = []
    monkeypatch.setattr(busy_module, "busy", _recording_busy(seen))
    res = runner.invoke(app, ["report", str(tmp_path / "example-9.2")])
    assert res.exit_code == 0, res.output
    assert seen == [(f"writing the report of {tmp_path / 'example-9.2'} (plotly, every sample of every case)", False)]
    assert (tmp_path / "example-9.2" / "report.html").exists()
