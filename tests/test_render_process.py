"""The figure process (forcecontrol.viz.render_process): same PNG bytes as drawing in the calling process,
and every way it can fail ends with the figure drawn here or the figure's own error."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from forcecontrol.scenarios import load_scenario, run_scenario
from forcecontrol.viz import plotting, render_process


@pytest.fixture(scope="module")
def run():
    return run_scenario(load_scenario("example-9.2"))


@pytest.fixture(autouse=True)
def _pyplot_not_loaded(monkeypatch):
    """This worker has loaded pyplot (other tests drew): the tests of the second process pretend it has not, as in a
    new `forcecontrol run` (test_no_process_once_pyplot_is_loaded_here checks the rule in a new interpreter)."""
    monkeypatch.setattr(render_process, "drawing_loaded", lambda: False)


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
    monkeypatch.setattr(render_process, "command", lambda: [sys.executable, "-c", "import sys; sys.exit(3)"])
    fp = render_process.start(min_cores=1)
    assert fp.started
    paths = fp.render(plotting.figure_jobs(run, tmp_path, "fig"))
    assert len(paths) == 1 and paths[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_process_that_cannot_start_leaves_the_drawing_to_the_caller(run, tmp_path, monkeypatch):
    monkeypatch.setattr(render_process, "command", lambda: [str(tmp_path / "no-such-python")])
    fp = render_process.start(min_cores=1)
    assert not fp.started
    assert fp.render(plotting.figure_jobs(run, tmp_path, "fig"))[0].exists()


def test_a_process_answering_nonsense_leaves_the_drawing_to_the_caller(run, tmp_path, monkeypatch):
    jobs = plotting.figure_jobs(run, tmp_path, "fig")
    mark = render_process.ANSWER_MARK.decode()
    modules = json.dumps(render_process._module_files())
    for reply in ("[1, 2]", '{"paths": [1]}', '{"paths": []}', '{"paths": ["a.png", "b.png"]}', '{"error": "x"}',
                  '{"paths": ["a.png"], "modules": {"forcecontrol": "elsewhere", "matplotlib": null}}'):
        code = f"import sys; sys.stdin.buffer.read(); sys.stdout.write({mark + reply!r})"
        monkeypatch.setattr(render_process, "command", lambda code=code: [sys.executable, "-c", code])
        fp = render_process.start(min_cores=1)
        proc = fp._proc
        paths = fp.render(jobs)
        assert paths == [tmp_path / "fig.png"] and paths[0].exists(), reply
        assert proc.returncode is not None  # reaped
    # and a well-formed answer is taken as it is (the process's word for the path)
    reply = '{"paths": ["drawn-there.png"], "modules": ' + modules + "}"
    code = f"import sys; sys.stdin.buffer.read(); print('noise'); sys.stdout.write({mark + reply!r})"
    monkeypatch.setattr(render_process, "command", lambda: [sys.executable, "-c", code])
    assert render_process.start(min_cores=1).render(jobs) == [Path("drawn-there.png")]


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
    done = subprocess.run(render_process.command(), stdin=subprocess.DEVNULL, capture_output=True, timeout=60)
    assert done.returncode == 0 and done.stdout == b""


def test_the_process_reports_a_figures_error(run, tmp_path):
    args, kwargs = plotting.figure_jobs(run, tmp_path, "fig")[0]
    data = pickle.dumps([((args[0], ["no_such_signal"]), kwargs)])
    done = subprocess.run(render_process.command(), input=data, capture_output=True, timeout=120)
    answer = json.loads(done.stdout.rsplit(render_process.ANSWER_MARK, 1)[1])
    assert answer["error"].startswith("KeyError")


@pytest.mark.parametrize("why", ["no executable", "frozen", "warnings raise", "one core"])
def test_no_process_when_it_could_not_draw_as_the_caller_would(why, monkeypatch):
    if why == "no executable":
        monkeypatch.setattr(sys, "executable", "")
    elif why == "frozen":
        monkeypatch.setattr(sys, "frozen", True, raising=False)
    elif why == "warnings raise":
        monkeypatch.setattr(warnings, "filters", [("error", None, Warning, None, 0), *warnings.filters])
    else:
        monkeypatch.setattr(render_process, "usable_cores", lambda: 1)
    assert not render_process.start().started


def test_no_process_once_pyplot_is_loaded_here():
    """A new interpreter starts the figure process; once it has loaded pyplot itself, with no backend chosen yet or on
    Agg, it draws here (the second process would only load matplotlib again); on a backend of its own (a notebook's)
    the second process draws, so that the program's backend is not switched. In a new interpreter, without any patch."""
    code = (
        "from forcecontrol.viz import render_process\n"
        "first = render_process.start(min_cores=1)\n"
        "print(first.started)\n"
        "first.close()\n"
        "import matplotlib\n"
        "import matplotlib.pyplot\n"
        "print(render_process.drawing_loaded(), render_process.start(min_cores=1).started)\n"
        "matplotlib.use('svg')\n"  # a backend of the program's own (a notebook's): left alone, drawn elsewhere
        "other = render_process.start(min_cores=1)\n"
        "print(render_process.drawing_loaded(), other.started)\n"
        "other.close()\n"
        "matplotlib.use('Agg')\n"
        "print(render_process.drawing_loaded(), render_process.start(min_cores=1).started)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "True", "False", "False", "True", "True", "False"]


def test_usable_cores_is_a_positive_count_within_the_affinity():
    n = render_process.usable_cores()
    assert 1 <= n <= (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count())


def test_run_command_draws_in_the_process_and_stops_it_when_the_run_fails(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    started = []
    real_start = render_process.start

    def recording_start(*a, **k):
        fp = real_start(min_cores=1)
        started.append(fp._proc)
        return fp

    monkeypatch.setattr(render_process, "start", recording_start)
    ok = CliRunner().invoke(app, ["run", "no-such-scenario", "--out", str(tmp_path)])
    assert ok.exit_code != 0
    assert started and started[0] is not None and started[0].returncode is not None  # stopped
    _no_local_drawing(monkeypatch)
    res = CliRunner().invoke(app, ["run", "example-9.2", "--json", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "example-9.2" / "example-9.2.png").exists()
    assert started[-1].returncode == 0


def test_the_process_loads_neither_numba_nor_scipy(run, tmp_path):
    """What the second process imports to draw (plotting, and result to unpickle the logs of a real
    run) stays light, so it is ready before the simulation ends."""
    (tmp_path / "jobs.pkl").write_bytes(pickle.dumps(plotting.figure_jobs(run, tmp_path, "fig")))
    code = (
        "import sys, pickle, forcecontrol.viz.render_process, forcecontrol.viz.plotting\n"
        f"pickle.loads(open({str(tmp_path / 'jobs.pkl')!r}, 'rb').read())\n"
        "print(sorted(m for m in ('numba', 'scipy', 'forcecontrol.controllers') if m in sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_what_the_process_warns_reaches_the_callers_stderr(tmp_path, monkeypatch, capsys):
    reply = render_process.ANSWER_MARK.decode() + json.dumps({"paths": [], "modules": render_process._module_files()})
    warn = "sys.stderr.write('UserWarning: a glyph is missing\\n')"
    code = f"import sys; sys.stdin.buffer.read(); {warn}; sys.stdout.write({reply!r})"
    monkeypatch.setattr(render_process, "command", lambda: [sys.executable, "-c", code])
    assert render_process.start(min_cores=1).render([]) == []
    assert "a glyph is missing" in capsys.readouterr().err
