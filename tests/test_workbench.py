"""The workbench without a browser: TOML writer, tuning session, the Panel app driven from Python, reports."""

from __future__ import annotations

import html
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

import forcecontrol as fc
from forcecontrol.cli import app
from forcecontrol.errors import OutputError, ParameterError
from forcecontrol.scenarios import list_scenarios, scenario_source
from forcecontrol.workbench.session import TuneSession
from forcecontrol.workbench.toml_writer import dumps_toml

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

runner = CliRunner()


# ----------------------------------------------------------------------------- TOML writer


@pytest.mark.parametrize("name", sorted(list_scenarios()))
def test_every_builtin_scenario_round_trips_through_the_writer(name):
    """tomllib (the standard library's reader) reads back exactly what it read from the built-in file."""
    with scenario_source(name).open("rb") as f:
        data = tomllib.load(f)
    assert tomllib.loads(dumps_toml(data)) == data


_scalars = st.one_of(
    st.booleans(), st.integers(-(2**63), 2**63 - 1), st.floats(allow_nan=False, allow_infinity=False),
    st.text(max_size=20),
)
_keys = st.text(min_size=1, max_size=12)
_values = st.one_of(_scalars, st.lists(st.floats(allow_nan=False, allow_infinity=False), max_size=4),
                    st.lists(st.lists(st.integers(-5, 5), min_size=1, max_size=3), max_size=3),
                    st.dictionaries(_keys, _scalars, max_size=3))


@settings(max_examples=150, deadline=None)
@example({"0\n": False})  # a bare-looking key with a trailing newline must be quoted (found by Hypothesis in CI)
@example({"0": [], "0\n": {}})
@given(st.dictionaries(_keys, st.one_of(_values, st.dictionaries(_keys, _values, max_size=4)), max_size=6))
def test_writer_round_trips_arbitrary_documents(doc):
    """Any keys (quoted when not bare), unicode strings, floats to the last bit, nested arrays and tables."""
    assert tomllib.loads(dumps_toml(doc)) == doc


@pytest.mark.parametrize("key", ["a\n", "a\r", "\na", "a b", "a.b", "é", ""])
def test_writer_quotes_keys_that_are_not_bare(key):
    """Only A-Za-z0-9_- keys are written bare; a trailing newline does not pass for bare."""
    text = dumps_toml({key: 1, "t": {key: 2}})
    assert tomllib.loads(text) == {key: 1, "t": {key: 2}}
    assert text.splitlines()[0].startswith('"')


@pytest.mark.parametrize("bad", [{"k": math.nan}, {"t": {"k": math.inf}}, {"k": object()}, {1: 2}])
def test_writer_refuses_what_toml_cannot_hold(bad):
    with pytest.raises(ParameterError, match=r"finite|cannot be written|keys must be strings"):
        dumps_toml(bad)


# ----------------------------------------------------------------------------- session


def test_knobs_of_example_9_3_are_every_gain_and_the_environment():
    s = TuneSession("example-9.3", "inner position, k_x = 1e3 N/m")
    names = [k.name for k in s.knobs]
    for gain in ("inertia", "damping", "stiffness", "force_gain", "integral_gain"):
        assert f"controller.{gain}[0]" in names and f"controller.{gain}[1]" in names
    assert "environment.stiffness" in names and "environment.damping" in names
    assert not any("integral_limit" in n for n in names)
    k = next(k for k in s.knobs if k.name == "environment.stiffness")
    assert k.value == 1000.0 and k.value in k.options
    assert min(k.options) == pytest.approx(100.0) and max(k.options) == pytest.approx(10000.0)
    zero = next(k for k in s.knobs if k.name == "controller.force_gain[1]")
    assert zero.options[0] == 0.0 and zero.value == 0.0


def test_tuned_evaluation_is_the_scenario_runner_with_the_same_edit():
    """A knob change gives the run that Scenario.with_ + run gives (the library's own path), to round-off."""
    s = TuneSession("example-9.2", 0)
    s.set("controller.stiffness[0]", 4000.0)
    ev = s.evaluate()
    ref = fc.scenario("example-9.2").with_({"controller.stiffness": [4000.0, 2500.0]}).run().cases[0].result
    np.testing.assert_allclose(ev.result.wrench, ref.wrench, rtol=1e-12, atol=1e-9)
    # the analysis' settled force: k_P,x k (x_d − x_r) / (k_P,x + k) (9.32 at rest), by hand
    assert ev.analysis["steady_fx"] == pytest.approx(4000.0 * 1e4 * 0.1 / (4000.0 + 1e4), rel=1e-9)


def test_impedance_poles_are_the_closed_form_roots():
    """Per axis m s² + k_D s + (k_P + k) = 0 (Example 9.2, x in contact with k = 1e4; y free)."""
    s = TuneSession("example-9.2", 0)
    s.set("controller.damping[0]", 800.0)
    ev = s.evaluate()
    np.testing.assert_allclose(np.sort_complex(ev.poles["x"]), np.sort_complex(np.roots([100.0, 800.0, 2500.0 + 1e4])),
                               rtol=1e-9)
    np.testing.assert_allclose(np.sort_complex(ev.poles["y"]), np.sort_complex(np.roots([100.0, 500.0, 2500.0])), rtol=1e-9)
    assert ev.stability is None and any("no sampled-loop stability analysis" in n for n in ev.notes)


def test_force_scheme_poles_and_stability_curve():
    """Inner velocity loop (Example 9.3): poles of 100 s² + 500 s + 2500·0.0024·k; ρ(k) < 1 exactly below the limit."""
    s = TuneSession("example-9.3", "inner velocity, k_x = 1e3 N/m")
    ev = s.evaluate()
    np.testing.assert_allclose(np.sort_complex(ev.poles["x"]), np.sort_complex(np.roots([100.0, 500.0, 2500 * 0.0024 * 1e3])),
                               rtol=1e-9)
    st_ = ev.stability
    assert st_.axis == "x" and st_.current[0] == 1e3 and st_.current[1] < 1.0
    assert math.isfinite(st_.limit)
    below, above = st_.stiffness < st_.limit * (1 - 1e-3), st_.stiffness > st_.limit * (1 + 1e-3)
    assert np.all(st_.radius[below] < 1.0) and np.all(st_.radius[above] >= 1.0) and above.any()


def test_set_refuses_unknown_knobs_and_bad_values():
    s = TuneSession("example-9.2", 0)
    with pytest.raises(ParameterError, match="knob must be one of"):
        s.set("controller.nonsense", 1.0)
    for bad in (-1.0, math.nan, math.inf, "1"):
        with pytest.raises(ParameterError, match="must be a finite number >= 0"):
            s.set("controller.stiffness[0]", bad)


def test_a_case_the_scenario_rejects_is_reported_not_raised():
    s = TuneSession("example-9.2", 0)
    s.set("controller.inertia[0]", 0.0)  # M_d must be positive definite
    ev = s.evaluate()
    assert ev.result is None and "inertia" in ev.error


def test_saved_scenario_loads_and_reproduces_the_tuned_run(tmp_path):
    s = TuneSession("example-9.3", "parallel, k_x = 1e3 N/m")
    s.set("controller.force_gain[0]", 0.001)
    s.set("environment.stiffness", 2000.0)
    path = s.save(tmp_path / "out" / "tuned.toml")
    scn = fc.scenario(path)
    assert scn.name == "example-9.3-tuned" and [c.label for c in scn.cases] == ["parallel, k_x = 1e3 N/m (tuned)"]
    cfg = scn.cases[0].config
    assert cfg["controller"]["type"] == "parallel" and cfg["controller"]["force_gain"] == [0.001, 0.0]
    assert cfg["environment"]["stiffness"] == 2000.0 and cfg["controller"]["integral_gain"] == [0.0016, 0.0]
    run = scn.run().cases[0].result
    np.testing.assert_allclose(run.wrench, s.evaluate().result.wrench, rtol=1e-12, atol=1e-9)
    assert "force_gain[0] 0.00064 -> 0.001" in scn.description
    assert sorted(p.name for p in path.parent.iterdir()) == ["tuned.toml"]  # no temporary file left beside it


def test_save_appears_whole_or_not_at_all(tmp_path, monkeypatch):
    """The tuned file is written beside its target, checked, then moved into place: a reader never sees it half
    written (a browser test read it as soon as it existed: an empty table). A file that does not load never appears;
    overwrite=False refuses an existing file and leaves it as it was."""
    import forcecontrol.scenarios as scenarios
    from forcecontrol.errors import ScenarioError

    s = TuneSession("example-9.2")
    target = tmp_path / "tuned.toml"
    seen = []
    real = scenarios.load_scenario

    def check(path, *a, **k):  # called on the written file before it is moved into place
        seen.append(target.exists())
        return real(path, *a, **k)

    monkeypatch.setattr(scenarios, "load_scenario", check)
    s.save(target)
    assert seen == [False] and fc.scenario(target).name == "example-9.2-tuned"

    def broken(path, *a, **k):
        raise ScenarioError(f"{path}: broken")

    monkeypatch.setattr(scenarios, "load_scenario", broken)
    with pytest.raises(ScenarioError):
        s.save(tmp_path / "other.toml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tuned.toml"]
    monkeypatch.setattr(scenarios, "load_scenario", real)
    before = target.read_bytes()
    with pytest.raises(OutputError, match="exists and this server did not write it"):
        s.save(target, overwrite=False)
    assert target.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["tuned.toml"]


# ----------------------------------------------------------------------------- the app, from Python


def test_app_slider_change_updates_the_plotted_data_and_saves(tmp_path):
    from forcecontrol.workbench.app import TuneApp

    a = TuneApp("example-9.2", tmp_path / "t.toml")
    before = np.array(a.sources["fx"][0].data["v"], dtype=float)
    slider = a.sliders["environment.stiffness"]
    slider.value = slider.values[-1]  # 1e5 N/m
    after = np.array(a.sources["fx"][0].data["v"], dtype=float)
    ref = fc.scenario("example-9.2").with_({"environment.stiffness": 1e5}).run().cases[0].result
    np.testing.assert_allclose(after, ref.wrench[:, 0], rtol=1e-12, atol=1e-9)
    assert not np.allclose(before, after)
    assert a.sources["fx"][1].data["v"][0] == pytest.approx(2500.0 * 1e5 * 0.1 / (2500.0 + 1e5), rel=1e-9)
    assert len(a.latencies) == 2 and "updated in" in a.status.object
    a.save_button.clicks += 1
    assert fc.scenario(tmp_path / "t.toml").cases[0].config["environment"]["stiffness"] == 1e5
    assert "saved" in a.save_message.object
    a.case_select.value = a.case_select.options[1]
    assert a.session.case.label == "k_x = 1e3 N/m" and a.sliders["environment.stiffness"].value == 1000.0


def test_workbench_is_not_imported_by_forcecontrol():
    import subprocess

    code = ("import sys, forcecontrol; bad = [m for m in sys.modules if m.split('.')[0] in ('panel', 'bokeh', 'plotly') "
            "or m.startswith('forcecontrol.workbench')]; print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# ----------------------------------------------------------------------------- reports


def _plot_data(html: str, i: int = 0) -> list[dict]:
    """The traces of the i-th plot of a report, as plotly.js receives them."""
    start = html.index(f'"plot-{i}",', html.index("Plotly.newPlot(")) + len(f'"plot-{i}",')
    while html[start].isspace():
        start += 1
    return json.JSONDecoder().raw_decode(html, start)[0]


def _assert_self_contained(html: str) -> None:
    assert "<script src=" not in html and "cdn.plot.ly" not in html.split("Plotly.newPlot")[0][-500:]
    assert "Plotly.newPlot" in html and "plotly.js v" in html  # the library itself is inline


def test_report_of_a_run_folder(tmp_path):
    res = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path), "--data", "csv", "--no-figure"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["report", str(tmp_path)])
    assert res.exit_code == 0, res.output
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    _assert_self_contained(html)
    data = _plot_data(html)
    names = {tr["name"] for tr in data}
    assert names == {"k_x = 1e4 N/m", "k_x = 1e3 N/m"}
    saved = np.loadtxt(next(tmp_path.glob("*/*1e4*.csv")), delimiter=",", skiprows=1)
    fx = next(tr for tr in data if tr["name"] == "k_x = 1e4 N/m" and tr["yaxis"] == "y3")
    assert len(fx["x"]["bdata"] if isinstance(fx["x"], dict) else fx["x"]) > 0 and saved.shape[0] == 4001
    again = runner.invoke(app, ["report", str(tmp_path)])
    assert again.exit_code == 2 and "--force" in again.output


def test_report_of_a_sweep_has_a_map_per_metric_and_the_analytic_boundary(tmp_path):
    from forcecontrol.sweep import prepare_sweep, run_sweep
    from forcecontrol.sweep.spec import SweepDefinition
    from forcecontrol.workbench.report import write_report

    scn = fc.scenario("example-9.3").with_(duration=1.0)
    definition = SweepDefinition.from_options(
        ["environment.stiffness=logspace(3,6,4)", "controller.force_gain[0]=0.0012,0.0024"], cases=["4"],
    )
    table = tmp_path / "sw" / "s.parquet"
    run_sweep(prepare_sweep(scn, definition), table, workers=1)
    out = write_report(table.parent)
    assert out == table.parent / "report.html"
    html = out.read_text(encoding="utf-8")
    _assert_self_contained(html)
    data = _plot_data(html)
    kinds = [tr["type"] for tr in data if tr.get("name") != "unstable"]  # the grey layer of unstable cells aside
    assert kinds.count("heatmap") == 4 and kinds.count("contour") == 4


def test_report_refuses_a_folder_without_runs(tmp_path):
    res = runner.invoke(app, ["report", str(tmp_path)])
    assert res.exit_code == 2 and "holds no saved runs" in res.output
    from forcecontrol.workbench.report import write_report

    with pytest.raises(OutputError, match="does not exist"):
        write_report(Path(tmp_path / "missing"))


def test_tune_command_refuses_an_unknown_scenario():
    res = runner.invoke(app, ["tune", "no-such-scenario", "--no-browser"])
    assert res.exit_code == 2 and "unknown scenario" in res.output


def test_nested_controllers_give_their_gains_and_a_change_reaches_the_run():
    """impact-safety: safety layer -> contact supervisor -> impedance (approach) and inner velocity (contact)."""
    short = fc.scenario("impact-safety").with_(duration=0.3)
    s = TuneSession(short, 0)
    names = [k.name for k in s.knobs]
    assert "controller.wrapped.contact.force_gain[0]" in names and "controller.wrapped.approach.stiffness[1]" in names
    assert not any(n.startswith("controller.max_") for n in names)  # limits are not gains
    s.set("controller.wrapped.contact.force_gain[0]", 0.0012)
    cfg = s.config()
    assert cfg["controller"]["wrapped"]["contact"]["force_gain"] == [0.0012, 0.0]
    assert fc.scenario("impact-safety").cases[0].config["controller"]["wrapped"]["contact"]["force_gain"] == [0.0024, 0.0]
    ev = s.evaluate()
    ref = short.with_({"controller.wrapped.contact.force_gain": [0.0012, 0.0]}).run().cases[0].result
    np.testing.assert_allclose(ev.result.wrench, ref.wrench, rtol=1e-12, atol=1e-9)


# ----------------------------------------------------------------------------- the server's guard and Save policy


def test_guard_accepts_only_hosts_naming_this_server():
    """Loopback server: localhost/127.x/[::1] with its port pass; a rebinding name, another port or garbage do not."""
    from forcecontrol.workbench.guard import RequestGuard

    g = RequestGuard("localhost", 5006)
    assert all(g.host_allowed(h) for h in ("localhost:5006", "127.0.0.1:5006", "127.0.0.2:5006", "[::1]:5006"))
    assert not any(g.host_allowed(h) for h in ("evil.example:5006", "localhost:5007", "localhost", "10.0.0.5:5006",
                                               "", "[zz:5006"))
    lan = RequestGuard("0.0.0.0", 5006, token="t")
    assert lan.host_allowed("10.0.0.5:5006") and not lan.host_allowed("evil.example:5006")


def test_guard_needs_a_token_beyond_loopback():
    """A server on 0.0.0.0 without a token is refused by construction (ParameterError names the parameter)."""
    from forcecontrol.errors import ParameterError
    from forcecontrol.workbench.guard import RequestGuard, is_loopback

    with pytest.raises(ParameterError, match="token"):
        RequestGuard("0.0.0.0", 5006)
    assert is_loopback("127.0.0.2") and is_loopback("::1") and not is_loopback("0.0.0.0") and not is_loopback("10.1.2.3")


def test_save_refuses_a_foreign_file_rewrites_its_own_and_overwrite_replaces(tmp_path):
    """Save never replaces a file it did not create; its own it rewrites; overwrite=True replaces a foreign one."""
    from forcecontrol.workbench.app import TuneApp

    foreign = tmp_path / "notes.toml"
    foreign.write_text("# mine\n")
    a = TuneApp("example-9.2", foreign)
    assert a._on_save() is None and foreign.read_text() == "# mine\n" and "not saved" in a.save_message.object
    own = tmp_path / "new.toml"
    b = TuneApp("example-9.2", own)
    assert b._on_save() == own and b._on_save() == own  # created by this server: the second Save rewrites it
    c = TuneApp("example-9.2", foreign, overwrite=True)
    assert c._on_save() == foreign and fc.scenario(foreign).cases[0].config["environment"]["stiffness"] == 1e4


def test_tune_command_beyond_loopback_warns_and_prints_a_token_address(tmp_path):
    """'tune --address 0.0.0.0' warns on stderr, prints an address with ?token=, and answers 403 without the token."""
    import http.client
    import os
    import signal
    import socket
    import subprocess
    import time

    with socket.socket() as s:
        s.bind(("0.0.0.0", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "forcecontrol", "tune", "example-9.2", "--address", "0.0.0.0", "--port",
                             str(port), "--no-browser", "--save", str(tmp_path / "t.toml")], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ, COLUMNS="300"))
    try:
        line = proc.stdout.readline()
        assert f"http://localhost:{port}/?token=" in line, line
        token = line.split("?token=", 1)[1].split()[0]
        deadline = time.time() + 120
        while time.time() < deadline:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.2)

        def status(path: str) -> int:
            conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
            conn.request("GET", path)
            code = conn.getresponse().status
            conn.close()
            return code

        assert status("/") == 403 and status(f"/?token={token}") == 302
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            _, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
    assert "warning: listening on 0.0.0.0" in err


def test_page_margins_are_those_of_the_loop_the_stability_plot_shows():
    """The table's margins come from a loop with the same spectral radius as ForceLoopAxis's, and vanish at its limit k_e."""
    from forcecontrol.analysis.design import loop_model
    from forcecontrol.workbench.metrics import loop_margins, page_metrics
    from forcecontrol.workbench.session import TuneSession

    s = TuneSession("example-9.3")
    ev = s.evaluate()
    ax, mx, Ts = ev.loop
    gains = {"inertia": ax.inertia, "damping": ax.damping, "stiffness": ax.stiffness, "force_gain": ax.force_gain,
             "integral_gain": ax.integral_gain}
    for k in (1e3, 1e4, 1e5):
        assert loop_model(ax.scheme, gains, k, Ts, arm_inertia=mx).spectral_radius() == pytest.approx(
            ax.with_environment_stiffness(k).spectral_radius(Ts, mx), rel=1e-12)
    rows = {r.key: r.value for r in page_metrics(s, ev)}
    gm, pm = loop_margins(ev.loop)
    assert rows["gain_margin_db"] == gm > 6.0 and rows["phase_margin_deg"] == pm > 10.0
    at_limit = loop_margins((ax.with_environment_stiffness(ev.stability.limit), mx, Ts))
    assert abs(at_limit[0]) < 0.05 and abs(at_limit[1]) < 0.05  # dB, deg: no margin left at the stability limit


def test_page_metrics_are_runs_checks_and_the_library_step_metrics():
    """Book rows equal `run`'s checks; overshoot/settling/peak equal sim.metrics.step_metrics on the run's force."""
    from forcecontrol.sim.metrics import step_metrics
    from forcecontrol.workbench.metrics import page_metrics
    from forcecontrol.workbench.session import TuneSession

    s = TuneSession("example-9.2")
    rows = {r.key: r for r in page_metrics(s, s.evaluate())}
    case = fc.scenario("example-9.2").run().cases[0]
    for ch in case.checks:
        r = rows[ch["metric"]]
        assert (r.value, r.book, r.tolerance, r.ok) == pytest.approx((ch["value"], ch["expected"], ch["tolerance"], ch["ok"]))
    sm = step_metrics(case.result.t, case.result.wrench[:, 0], window=0.1)
    assert rows["overshoot"].value == pytest.approx(sm.overshoot_percent, rel=1e-12)
    assert rows["settling_time"].value == pytest.approx(sm.settling_time, rel=1e-12)
    assert rows["peak_force"].value == pytest.approx(case.result.peak_contact_force_norm(), rel=1e-12)
    assert math.isnan(rows["steady_state_force_error"].value)  # impedance control: no force reference


def test_knobs_are_labelled_with_the_chapters_symbols_and_unused_axes_hidden():
    """Example 9.3: K_P,x [N/m]-style labels; k_F,y = k_I,y = 0 hidden with the reason; Example 9.4's hybrid gains K_Pλ [1/s²]."""
    from forcecontrol.workbench.labels import knob_label, split_knobs
    from forcecontrol.workbench.session import TuneSession

    s = TuneSession("example-9.3")
    shown, hidden = split_knobs(s.knobs, s.case.config)
    assert [knob_label(k, s.case.config) for k in shown] == [
        "M_d,x [kg]", "M_d,y [kg]", "K_D,x [N s/m]", "K_D,y [N s/m]", "K_P,x [N/m]", "K_P,y [N/m]", "K_F,x [m/N]",
        "K_I,x [m/(N s)]", "k_e [N/m]", "d_e [N s/m]"]
    assert [k.name for k, _ in hidden] == ["controller.force_gain[1]", "controller.integral_gain[1]"]
    assert all("along y" in why for _, why in hidden)
    h = TuneSession("example-9.4")
    assert [knob_label(k, h.case.config) for k in h.knobs][:4] == ["K_Pν [1/s]", "K_Iν [1/s²]", "K_Pλ [1/s²]", "K_Dλ [1/s]"]


def test_app_undo_goes_back_twenty_settings_reset_restores_the_book_and_bad_entries_are_refused(tmp_path):
    """25 typed settings, 20 undos land on the 5th (its run, as `run` gives it); Reset is the book's run; text and
    negative values show an error by the field and change nothing."""
    from forcecontrol.workbench.app import UNDO_DEPTH, TuneApp

    assert UNDO_DEPTH >= 20
    a = TuneApp("example-9.2", tmp_path / "t.toml")
    book = np.array(a.sources["fx"][0].data["v"], dtype=float)
    values = [1000.0 + 100.0 * i for i in range(25)]
    for v in values:
        a.entries["controller.stiffness[0]"].value = f"{v:g}"
    for _ in range(20):
        a.undo_button.clicks += 1
    assert a.session.values["controller.stiffness[0]"] == values[4]
    assert a.sliders["controller.stiffness[0]"].value == values[4] and a.entries["controller.stiffness[0]"].value == "1400"
    want = fc.scenario("example-9.2").with_({"controller.stiffness": [values[4], 2500.0]}).run().cases[0].result
    np.testing.assert_allclose(np.array(a.sources["fx"][0].data["v"], dtype=float), want.wrench[:, 0], rtol=1e-12, atol=1e-9)
    a.reset_button.clicks += 1
    np.testing.assert_allclose(np.array(a.sources["fx"][0].data["v"], dtype=float), book, rtol=0, atol=0)
    n = len(a.latencies)
    for bad, says in (("abc", "expected a number >= 0"), ("-5", "expected a finite number >= 0"), ("nan", "finite")):
        a.entries["controller.stiffness[0]"].value = bad
        err = a.entry_errors["controller.stiffness[0]"]
        assert err.visible and says in html.unescape(err.object) and "K_P,x [N/m]" in err.object
    assert len(a.latencies) == n and a.session.values["controller.stiffness[0]"] == 2500.0
    a.entries["controller.stiffness[0]"].value = "2600"
    assert not a.entry_errors["controller.stiffness[0]"].visible and a.session.values["controller.stiffness[0]"] == 2600.0


def _plotly_array(v) -> np.ndarray:
    """A plotly.js array as written in the page: a typed array (``bdata``) or nested lists with nulls."""
    import base64

    if isinstance(v, dict) and "bdata" in v:
        a = np.frombuffer(base64.b64decode(v["bdata"]), dtype=np.dtype(v["dtype"])).astype(float)
        return a.reshape([int(n) for n in str(v["shape"]).split(",")]) if "shape" in v else a
    return np.array([[np.nan if x is None else x for x in row] for row in v], dtype=float)


def test_sweep_maps_keep_unstable_cases_out_of_the_colour_scale(tmp_path, monkeypatch):
    """Report and PNG maps: the colour scale spans the stable cases' metric only; unstable cells are a grey layer
    (report) or grey hatched cells (PNG) with a legend entry "unstable"."""
    import matplotlib.collections
    import matplotlib.figure

    from forcecontrol.sweep import prepare_sweep, run_sweep
    from forcecontrol.sweep.figures import plot_sweep_map
    from forcecontrol.sweep.run import read_sweep
    from forcecontrol.sweep.spec import SweepDefinition
    from forcecontrol.workbench.report import write_report

    scn = fc.scenario("example-9.3").with_(duration=1.0)
    definition = SweepDefinition.from_options(
        ["environment.stiffness=logspace(3,6,4)", "controller.force_gain[0]=0.0012,0.0024"], cases=["4"])
    table = tmp_path / "sw" / "s.parquet"
    run_sweep(prepare_sweep(scn, definition), table, workers=1)
    df, _ = read_sweep(table)
    bad = ~df["stable"].to_numpy(dtype=bool)
    assert bad.any() and (~bad).any()  # the sweep has both kinds of case
    metric = "peak_force"
    stable_max = float(np.nanmax(df[metric].to_numpy(dtype=float)[~bad]))
    assert float(np.nanmax(df[metric].to_numpy(dtype=float))) > 2 * stable_max  # unstable cases would swamp the scale

    data = _plot_data(write_report(table.parent).read_text(encoding="utf-8"))
    maps = [tr for tr in data if tr["type"] == "heatmap" and tr.get("name") == metric]
    grey = [tr for tr in data if tr["type"] == "heatmap" and tr.get("name") == "unstable"]
    assert len(maps) == 1 and len(grey) == 4
    z = _plotly_array(maps[0]["z"])
    assert np.nanmax(z) == pytest.approx(stable_max, rel=1e-12)
    u = _plotly_array(grey[0]["z"])
    assert int(np.nansum(u)) == int(bad.sum()) and np.all(np.isnan(z[u == 1.0]))
    assert any("unstable" in str(tr.get("name")) and tr.get("showlegend") for tr in data if tr["type"] == "scatter")

    figs = []
    real = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", lambda self, *a, **k: (figs.append(self), real(self, *a, **k)))
    plot_sweep_map(table, "environment.stiffness", "controller.force_gain[0]", tmp_path / "m.png", metrics=(metric,),
                   resolution=6)
    ax = figs[0].axes[0]
    colour = [c for c in ax.collections if isinstance(c, matplotlib.collections.QuadMesh)]
    assert len(colour) == 1 and colour[0].get_clim()[1] == pytest.approx(stable_max, rel=1e-12)
    hatched = [c for c in ax.collections if c.get_hatch() == "///"]
    assert len(hatched) == 1 and int(np.ma.count(hatched[0].get_array())) == int(bad.sum())
    assert any(t.get_text().startswith("unstable") for t in ax.get_legend().get_texts())
