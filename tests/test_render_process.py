"""The figure process (forcecontrol.render_process): same PNG bytes as drawing in the calling process,
and every way it can fail ends with the figure drawn here or the figure's own error."""

from __future__ import annotations

import subprocess
import sys

import pytest

from forcecontrol import plotting, render_process
from forcecontrol.scenarios import load_scenario, run_scenario


@pytest.fixture(scope="module")
def run():
    return run_scenario(load_scenario("example-9.2"))


def _no_local_drawing(monkeypatch):
    """Drawing in this process fails the test: the figures must come from the second process."""
    def refuse(*args, **kwargs):
        raise AssertionError("drew in the calling process")

    monkeypatch.setattr(plotting, "plot_results", refuse)


def test_png_drawn_by_the_process_is_byte_for_byte_the_local_one(run, tmp_path, monkeypatch):
    local = plotting.plot_run_figures(run, tmp_path / "local", "fig")
    fp = render_process.start(min_cores=1)
    assert fp.started
    _no_local_drawing(monkeypatch)
    remote = fp.render(plotting.figure_jobs(run, tmp_path / "remote", "fig"))
    assert [p.name for p in remote] == [p.name for p in local]
    assert all(p.parent == tmp_path / "remote" for p in remote)
    for a, b in zip(local, remote):
        assert a.read_bytes() == b.read_bytes()


def test_a_process_that_dies_leaves_the_drawing_to_the_caller(run, tmp_path, monkeypatch):
    monkeypatch.setattr(render_process, "COMMAND", [sys.executable, "-c", "import sys; sys.exit(3)"])
    fp = render_process.start(min_cores=1)
    assert fp.started
    paths = fp.render(plotting.figure_jobs(run, tmp_path, "fig"))
    assert len(paths) == 1 and paths[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_process_that_cannot_start_leaves_the_drawing_to_the_caller(run, tmp_path, monkeypatch):
    monkeypatch.setattr(render_process, "COMMAND", [str(tmp_path / "no-such-python")])
    fp = render_process.start(min_cores=1)
    assert not fp.started
    assert fp.render(plotting.figure_jobs(run, tmp_path, "fig"))[0].exists()


def test_a_process_answering_nonsense_leaves_the_drawing_to_the_caller(run, tmp_path, monkeypatch):
    code = "import sys; sys.stdin.buffer.read(); print('[1, 2]')"
    monkeypatch.setattr(render_process, "COMMAND", [sys.executable, "-c", code])
    fp = render_process.start(min_cores=1)
    assert fp.render(plotting.figure_jobs(run, tmp_path, "fig"))[0].exists()


def test_one_core_draws_in_the_calling_process(monkeypatch):
    monkeypatch.setattr(render_process, "usable_cores", lambda: 1)
    assert not render_process.start().started


def test_the_figures_own_error_reaches_the_caller(run, tmp_path):
    args, kwargs = plotting.figure_jobs(run, tmp_path, "fig")[0]
    bad = ((args[0], ["no_such_signal"]), kwargs)
    with pytest.raises(KeyError, match="no_such_signal"):
        plotting.plot_results(*bad[0], **bad[1])  # what drawing here raises ...
    fp = render_process.start(min_cores=1)
    with pytest.raises(KeyError, match="no_such_signal"):  # ... is what the caller gets
        fp.render([bad])


def test_results_that_cannot_be_pickled_are_drawn_here(run, tmp_path):
    args, kwargs = plotting.figure_jobs(run, tmp_path, "fig")[0]
    result = args[0][0]
    result.metadata["callback"] = lambda: None  # not picklable
    try:
        fp = render_process.start(min_cores=1)
        assert fp.render([(args, kwargs)])[0].exists()
    finally:
        del result.metadata["callback"]


def test_close_stops_the_process_and_render_then_draws_here(run, tmp_path):
    fp = render_process.start(min_cores=1)
    proc = fp._proc
    with fp:
        pass
    assert proc is not None and proc.returncode is not None
    assert not fp.started
    assert fp.render(plotting.figure_jobs(run, tmp_path, "fig"))[0].exists()


def test_the_process_exits_quietly_when_its_caller_sends_nothing():
    done = subprocess.run(render_process.COMMAND, stdin=subprocess.DEVNULL, capture_output=True, timeout=60)
    assert done.returncode == 0 and done.stdout == b""


def test_the_process_loads_neither_numba_nor_scipy():
    """What the second process imports to draw (plotting, and result to unpickle the logs) stays
    light, so it is ready before the simulation ends."""
    code = (
        "import sys, forcecontrol.render_process, forcecontrol.plotting, forcecontrol.result\n"
        "print(sorted(m for m in ('numba', 'scipy', 'forcecontrol.controllers') if m in sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_what_the_process_warns_reaches_the_callers_stderr(tmp_path, monkeypatch, capsys):
    code = "import sys; sys.stdin.buffer.read(); sys.stderr.write('UserWarning: a glyph is missing\\n'); print('{\"paths\": []}')"
    monkeypatch.setattr(render_process, "COMMAND", [sys.executable, "-c", code])
    assert render_process.start(min_cores=1).render([]) == []
    assert "a glyph is missing" in capsys.readouterr().err
