"""Units in every table and JSON of run, analyze, design and sweep; `--set KEY=VALUE` on run, analyze and sweep."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from forcecontrol.cli import app
from forcecontrol.scenarios.report import analyze_scenario
from forcecontrol.scenarios.units import unit
from journeys_helpers import rich_tables

runner = CliRunner()

#: units by dimensional analysis of the chapter's quantities (not from the code under test)
BY_HAND = {
    "stability_limit_x": "N/m", "omega_n_x": "rad/s", "zeta_x": "-", "pole_re_x": "1/s", "pole_im_x": "rad/s",
    "steady_x": "m", "steady_fx": "N", "spectral_radius_x": "-", "zero_x": "1/s", "real_pole_x": "1/s",
}
#: Example 9.2 with K_P = 5000 I: the closed-form equilibrium f_x = k K_P / (k + K_P) (x_d - x_r), x_d - x_r = 0.1 m
FX_STIFF = {"k_x = 1e4 N/m": 1e4 * 5000 / 15000 * 0.1, "k_x = 1e3 N/m": 1e3 * 5000 / 6000 * 0.1}


def _json(*args: str) -> dict:
    res = runner.invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_analyze_table_shows_each_quantity_with_its_unit():
    """`analyze example-9.3` prints 'stability_limit_x [N/m]', 'omega_n_x [rad/s]', ... (the units worked out by hand)."""
    res = runner.invoke(app, ["analyze", "example-9.3"])
    assert res.exit_code == 0, res.output
    quantities = {r["quantity"] for table in rich_tables(res.stdout) for r in table if "quantity" in r}
    for name, u in BY_HAND.items():
        assert f"{name} [{u}]" in quantities, name


@pytest.mark.parametrize("name", ["example-9.1", "example-9.2", "example-9.3", "example-9.4", "hybrid-rigid-plane",
                                  "problem-9.3", "problem-9.10", "variable-stiffness", "servo-admittance"])
def test_analyze_json_units_cover_every_number(name):
    """`analyze NAME --json` has a units map naming the unit of every numeric analysis quantity of every case."""
    doc = _json("analyze", name)
    for case in doc["cases"]:
        for key, value in case["analysis"].items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                assert doc["units"].get(key), (name, key)
    for key, u in BY_HAND.items():
        assert doc["units"].get(key, u) == u


def test_run_json_units_and_table_headers():
    """`run --json` carries units for its settled metrics and final fields; the table headers carry [s], [m], [N]."""
    doc = _json("run", "example-9.2", "--no-figure")
    units = doc["units"]
    assert (units["t"], units["fx"], units["x"], units["penetration"]) == ("s", "N", "m", "m")
    assert units["peak_contact_force_norm"] == "N"
    assert units["tip_position"] == ["m", "m"] and units["contact_force"] == ["N", "N"]
    assert all(units.get(k) for k in doc["cases"][0]["settled"] if k != "contact_losses")
    header = list(rich_tables(runner.invoke(app, ["run", "example-9.2", "--no-figure"]).stdout)[1][0])
    assert header[:3] == ["case", "quantity", "simulated"]
    rows = rich_tables(runner.invoke(app, ["run", "example-9.2", "--no-figure"]).stdout)[1]
    assert {r["quantity"] for r in rows} >= {"fx [N]", "penetration [m]", "analysis.omega_n_x [rad/s]", "analysis.zeta_x [-]"}


def test_design_table_and_json_carry_gain_units():
    """`design` prints each gain with its unit (damping [N s/m], force_gain [m/N]) and --json has the same in 'units'."""
    res = runner.invoke(app, ["design", "inner-position", "--k-min", "1000", "--k-max", "10000"])
    assert res.exit_code == 0, res.output
    gains = {r["gain"] for r in rich_tables(res.stdout)[0]}
    assert {"inertia [kg]", "damping [N s/m]", "stiffness [N/m]", "force_gain [m/N]", "integral_gain [m/(N s)]"} <= gains
    header = list(rich_tables(res.stdout)[1][0])
    assert header[:3] == ["k [N/m]", "phase margin [deg]", "gain margin [dB]"]
    doc = _json("design", "inner-position", "--k-min", "1000", "--k-max", "10000")
    assert doc["units"]["gains.force_gain"] == "m/N" and doc["units"]["gains.damping"] == "N s/m"
    assert (doc["units"]["k"], doc["units"]["phase_margin_deg"], doc["units"]["settling_time"]) == ("N/m", "deg", "s")


def test_sweep_table_keeps_its_units_and_json_has_them(tmp_path):
    """The sweep summary's headers show 'median settling [s]' (rich read '[s]' as strike-through markup and dropped it)."""
    args = ["sweep", "example-9.2", "-p", "environment.stiffness=1000,2000", "--case", "1", "--no-figure",
            "--out", str(tmp_path / "s.parquet")]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    header = list(rich_tables(res.stdout)[0][0])
    assert header[-3:] == ["median settling [s]", "max overshoot [%]", "max |ss error| [N]"]
    doc = _json(*args)
    assert doc["units"]["settling_time"] == "s" and doc["units"]["overshoot"] == "%" and doc["units"]["seconds"] == "s"
    assert doc["units"]["diverged_at"] == "s"  # the table's column of the time a case diverged


@pytest.mark.parametrize("params", [["environment.stiffness=1000,2000"],
                                    ["environment.stiffness=1000,2000", "controller.damping=500,800"]])
def test_sweep_figures_show_the_metrics_units(tmp_path, monkeypatch, params):
    """The sweep's curves and maps name each metric with its unit, as the tables do (settled_force [N], settling_time
    [s]); before, the panels' titles and the colour bars had none."""
    from forcecontrol.sweep import figures

    texts: list[str] = []
    real = figures._save

    def reading(fig, plt, out, sweep_id=None):
        texts.extend(t.get_text() for t in fig.findobj(lambda o: hasattr(o, "get_text")))
        return real(fig, plt, out, sweep_id)

    monkeypatch.setattr(figures, "_save", reading)
    args = ["sweep", "example-9.2", "--case", "1", "--set", "duration=0.3", "--out", str(tmp_path / "s.parquet")]
    for p in params:
        args += ["-p", p]
    res = runner.invoke(app, args)
    assert res.exit_code == 0 and (tmp_path / "s.png").is_file(), res.output
    import re

    from forcecontrol.scenarios.units import SWEEP_METRIC_UNITS

    shown = " ".join(texts)
    drawn = [m for m in SWEEP_METRIC_UNITS if re.search(rf"\b{m}\b", shown)]
    assert len(drawn) >= 2, shown[:400]
    for metric in drawn:  # every time a metric is named, its unit follows
        assert len(re.findall(rf"\b{metric}\b", shown)) == shown.count(f"{metric} [{SWEEP_METRIC_UNITS[metric]}]"), (
            metric, shown[:600])


def test_units_of_reference_and_rotational_columns():
    """unit() gives a reference block the rate of its axis' unit and rotational axes rad / N m (worked out by hand)."""
    cases = {"ref_acceleration_rz": "rad/s^2", "ref_force_accel_y": "N/s^2", "stability_limit_rx": "N m/rad",
             "steady_mz": "N m", "motion_omega_n_2": "rad/s", "analysis.zeta_y": "-", "label": "", "in_contact": ""}
    assert {k: unit(k) for k in cases} == cases


# ----------------------------------------------------------------------------- --set


def test_run_set_changes_every_case_and_says_so():
    """`run example-9.2 --set controller.stiffness=[5000,5000]` settles at the closed form (K_P = 5000); JSON, table say so."""
    doc = _json("run", "example-9.2", "--no-figure", "--set", "controller.stiffness=[5000,5000]")
    assert doc["set"] == {"controller.stiffness": [5000, 5000]}
    for case in doc["cases"]:
        assert case["settled"]["fx"] == pytest.approx(FX_STIFF[case["label"]], rel=2e-3)
    res = runner.invoke(app, ["run", "example-9.2", "--no-figure", "--set", "controller.stiffness=[5000,5000]"])
    assert "set: controller.stiffness = [5000, 5000]" in res.stdout


def test_analyze_set_changes_the_prediction():
    """`analyze --set controller.stiffness=[5000,5000]` predicts the closed-form f_x for K_P = 5000 (1e-9)."""
    doc = _json("analyze", "example-9.2", "--set", "controller.stiffness=[5000,5000]")
    assert doc["set"] == {"controller.stiffness": [5000, 5000]}
    for case in doc["cases"]:
        assert case["analysis"]["steady_fx"] == pytest.approx(FX_STIFF[case["label"]], rel=1e-9)
    plain = analyze_scenario("example-9.2")["cases"][0]["analysis"]["steady_fx"]
    assert plain == pytest.approx(200.0, rel=1e-9)  # the file itself is unchanged


def test_set_a_key_the_cases_set_is_noted():
    """--set environment.stiffness replaces what each [[case]] sets: said on stderr and in --json notes."""
    res = runner.invoke(app, ["run", "example-9.2", "--no-figure", "--json", "--set", "environment.stiffness=2000"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert any("--set environment.stiffness replaces" in n for n in doc["notes"])
    assert "replaces the value the [[case]] table" in " ".join(res.stderr.split())


@pytest.mark.parametrize(("option", "match"), [
    ("controller.stifness=[5000,5000]", r"--set controller\.stifness=\[5000, 5000\]: .*unknown key 'stifness'"),
    ("controller.stiffness=abc", r"--set controller\.stiffness='abc': .*key 'stiffness' must be a number"),
    ("controller.stiffness=[5000,", r"--set controller\.stiffness: VALUE must be a TOML value.*got '\[5000,'"),
    ("controler.stiffness=1", r"override 'controler\.stiffness' names no table 'controler'"),
    ("stiffness", r"--set must be KEY=VALUE .*got 'stiffness'"),
    ("a..b=1", r"--set key must be a dotted name .*got 'a\.\.b'"),
])
def test_set_errors_name_the_key_and_value(option, match):
    """A bad --set exits 2 with an error naming the key, what was expected and what was given; nothing runs."""
    import re

    for command in ("run", "analyze"):
        res = runner.invoke(app, [command, "example-9.2", "--no-figure", "--set", option] if command == "run"
                            else [command, "example-9.2", "--set", option])
        assert res.exit_code == 2, res.output
        assert re.search(match, " ".join(res.stderr.split())), res.stderr


def test_set_twice_is_refused():
    """The same --set key given twice is an error naming both values."""
    res = runner.invoke(app, ["run", "example-9.2", "--no-figure", "--set", "duration=2", "--set", "duration=3"])
    assert res.exit_code == 2 and "--set duration is given twice (2 and '3')" in " ".join(res.stderr.split())


def test_set_reads_a_bare_word_as_a_string():
    """--set robot.elbow=down (not TOML) is read as the string 'down', as a file's "down"; the JSON shows it."""
    doc = _json("analyze", "example-9.2", "--set", "robot.elbow=down")
    assert doc["set"] == {"robot.elbow": "down"}


def test_replay_and_compare_trace_json_and_table_carry_units(tmp_path):
    """`replay` and `compare-trace` over a run's log: every metric of the JSON has its unit; replay's table has a unit column."""
    res = runner.invoke(app, ["run", "example-9.2", "--no-figure", "--data", "csv", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    log = str(tmp_path / "example-9.2" / "example-9.2-k-x-1e4-n-m.csv")
    doc = _json("replay", "example-9.2", log, "--out", str(tmp_path / "r"))
    assert set(doc["metrics"]) <= set(doc["units"]) and doc["units"]["torque_difference_max"] == "N m"
    assert doc["units"]["period"] == "s" and doc["units"]["force_error_rms"] == "N"
    rows = rich_tables(runner.invoke(app, ["replay", "example-9.2", log, "--out", str(tmp_path / "r2")]).stdout)[0]
    assert {r["quantity"]: r["unit"] for r in rows}["torque_difference_rms"] == "N m"
    doc = _json("compare-trace", "example-9.2", log, "--out", str(tmp_path / "c"))
    assert set(doc["metrics"]) == set(doc["units"]) and doc["units"]["shift"] == "s"


def test_compare_json_units_cover_each_engine_metric():
    """`compare example-9.2 --json` (built-in vs MuJoCo) names the unit of every number of each engine's metrics."""
    pytest.importorskip("mujoco")
    doc = _json("compare", "example-9.2")
    for case in doc["cases"]:
        for key in ("builtin", "mujoco"):
            assert set(case[key]) <= set(doc["units"]), set(case[key]) - set(doc["units"])
        assert doc["units"]["steady_force_difference_percent"] == "%"


def test_replay_set_changes_the_replayed_controller(tmp_path):
    """`replay --set controller.stiffness=[5000,5000]` replays other gains: the recorded torques are no longer reproduced."""
    res = runner.invoke(app, ["run", "example-9.2", "--no-figure", "--data", "csv", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    log = str(tmp_path / "example-9.2" / "example-9.2-k-x-1e4-n-m.csv")
    same = _json("replay", "example-9.2", log, "--out", str(tmp_path / "a"))
    other = _json("replay", "example-9.2", log, "--out", str(tmp_path / "b"), "--set", "controller.stiffness=[5000,5000]")
    assert same["set"] == {} and other["set"] == {"controller.stiffness": [5000, 5000]}
    assert same["metrics"]["torque_difference_max"] < 1e-3 < other["metrics"]["torque_difference_max"]


def test_design_json_units_cover_every_requirement_of_every_scheme():
    """`design SCHEME --json`: every numeric requirement and check field has its unit, for each scheme (servo ones too)."""
    for scheme in ("impedance", "inner-velocity", "hybrid", "admittance-position"):
        doc = _json("design", scheme, "--k-min", "1000", "--k-max", "5000")
        numbers = [k for k, v in doc["requirements"].items() if isinstance(v, (int, float)) and not isinstance(v, bool)]
        numbers += [k for c in doc["checks"] for k in c]
        assert not [k for k in numbers if k not in doc["units"]], (scheme, doc["units"])
        assert all(f"gains.{g}" in doc["units"] for g in doc["gains"]), scheme
