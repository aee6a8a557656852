"""End-to-end journeys (issue 27) of the commands that read or write files: ``report`` of a run folder, ``design
--out`` then ``run``, ``replay``, ``compare-trace``, ``convert``, ``calibrate``, ``calibrate-plan`` (on files the
tests write, with the helpers of test_cli_replay.py, test_cli_calibrate.py and test_convert.py), and ``compare``
(MuJoCo). Each command runs as a subprocess in a temporary folder, as a user types it, with its defaults.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import forcecontrol as fc
from forcecontrol.scenarios import build_case
from journeys_helpers import assert_figure, fenced_commands, forcecontrol, number, rich_tables, shell
from rosfiles_helpers import write_mcap

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Example 9.2's first case simulated for 0.5 s by the library, written as run.csv and run.mcap (a user's log)."""
    folder = tmp_path_factory.mktemp("recorded")
    p = build_case(fc.scenario("example-9.2").cases[0])
    res = fc.simulate(p["robot"], p["environment"], p["controller"], p["reference"], q0=p["q0"], duration=0.5,
                      sensor=p["sensor"])
    res.save(folder / "run", format="csv")
    write_mcap(folder / "run.mcap", res.t, res.q, res.qd, res.torque, res.t, res.wrench_measured)
    return folder, res


def test_report_of_a_run_folder_as_the_docs_say(tmp_path):
    """docs/guides/workbench.md's lines (tune aside): `run example-9.3 --data csv` then `report forcecontrol-out/example-9.3`:
    one self-contained HTML whose traces are the six cases and whose f_x data are the CSV logs'."""
    lines = [c for c in fenced_commands((ROOT / "docs" / "guides" / "workbench.md").read_text(encoding="utf-8"))
             if not c.startswith("forcecontrol tune")]
    assert lines[-1] == "forcecontrol report forcecontrol-out/example-9.3"
    outs = [shell(tmp_path, line) for line in lines]
    html_path = tmp_path / "forcecontrol-out" / "example-9.3" / "report.html"
    assert f"report: {html_path.relative_to(tmp_path)}" in outs[-1].stdout
    html = html_path.read_text(encoding="utf-8")
    assert "<script src=" not in html and "Plotly.newPlot" in html and "plotly.js v" in html  # no network needed
    names = {json.loads(f'"{m}"') for m in re.findall(r'"name":\s*"((?:[^"\\]|\\.)*)"', html)}  # the traces' names
    logs = sorted((tmp_path / "forcecontrol-out" / "example-9.3").glob("*.csv"))
    assert len(logs) == 6
    for log in logs:
        label = json.loads(log.with_suffix(".json").read_text(encoding="utf-8"))["label"]
        assert label in names, (label, names)
        fx = pd.read_csv(log)["fx"].to_numpy()
        assert fx[-1] == pytest.approx(10.0, rel=5e-3)  # Example 9.3: f_d = 10 N
    for png in ("example-9.3-fig-9.9.png", "example-9.3-fig-9.10.png", "example-9.3-fig-9.11.png"):
        assert_figure(tmp_path / "forcecontrol-out" / "example-9.3" / png)


def _settling(t: np.ndarray, f: np.ndarray, target: float, band: float = 0.02) -> float:
    """The first time after which f stays within band * target (2 % settling), computed here from the log."""
    out = np.nonzero(np.abs(f - target) > band * abs(target))[0]
    return float(t[out[-1] + 1]) if out.size else float(t[0])


def test_design_out_then_run_gives_the_promised_behaviour(tmp_path):
    """README's `design inner-velocity ... --out designed.toml`, then `run designed.toml --data csv`: each case settles
    to f_d = 10 N, and the 2 % settling time measured on its log is the one the design printed for that stiffness."""
    readme = fenced_commands((ROOT / "README.md").read_text(encoding="utf-8"))
    line = next(c for c in readme if c.startswith("forcecontrol design"))
    design = shell(tmp_path, line)
    promised = {number(r["k [N/m]"]): number(r["settling 2 % [s]"]) for r in rich_tables(design.stdout)[-1]}
    assert sorted(promised) == [1e3, 1e4, 1e5] and "scenario: designed.toml" in design.stdout
    run = forcecontrol(tmp_path, "run", "designed.toml", "--data", "csv")
    assert_figure(tmp_path / "forcecontrol-out" / "designed" / "designed.png")
    rows = rich_tables(run.stdout)[0]
    assert len(rows) == 3
    for k, ts in promised.items():
        log = tmp_path / "forcecontrol-out" / "designed" / f"designed-k-{k:.0f}-n-m.csv"
        d = pd.read_csv(log)
        assert d["fx"].iloc[-1] == pytest.approx(10.0, rel=0.02), k  # f_d, within the 2 % band at the end
        assert _settling(d["t"].to_numpy(), d["fx"].to_numpy(), 10.0) == pytest.approx(ts, rel=0.05, abs=2e-3), k
        assert np.abs(d["fx"]).max() < 10.0 * 1.3  # a well-damped design: no large overshoot (zeta = 0.8)


def test_replay_and_compare_trace_of_a_recorded_log_run_twice(tmp_path, recorded):
    """`replay example-9.2 run.csv` gives back the recorded torques (table, CSV, PNG) and `compare-trace example-9.2
    run.mcap` finds zero shift and tiny errors; both re-run with the default --out into NAME-2, saying so."""
    folder, res = recorded
    for name in ("run.csv", "run.json", "run.mcap"):
        (tmp_path / name).write_bytes((folder / name).read_bytes())
    for n, suffix in ((1, ""), (2, "-2")):
        rep = forcecontrol(tmp_path, "replay", "example-9.2", "run.csv")
        metrics = {r["quantity"]: r["value"] for r in rich_tables(rep.stdout)[0]}
        assert number(metrics["torque_difference_max"]) < 1e-6 * np.abs(res.torque).max()
        out = tmp_path / "forcecontrol-out" / f"example-9.2-replay{suffix}"
        table = pd.read_csv(out / "k-x-1e4-n-m.csv")
        np.testing.assert_allclose(table["u1"], res.torque[:, 0], atol=1e-6 * np.abs(res.torque).max())
        assert_figure(out / "k-x-1e4-n-m.png")
        cmp = forcecontrol(tmp_path, "compare-trace", "example-9.2", "run.mcap")
        m = {r["metric"]: r["value"].split()[0] for r in rich_tables(cmp.stdout)[0]}
        assert number(m["shift"]) == 0.0 and number(m["position_error_max"]) < 1e-9 and number(m["force_error_max"]) < 1e-6
        assert_figure(tmp_path / "forcecontrol-out" / f"example-9.2-compare-trace{suffix}" / "compare-trace.png")
        assert (n == 1) == ("note:" not in rep.stderr + cmp.stderr)


def test_convert_a_franka_recording_with_its_defaults(tmp_path):
    """`convert in.csv --from franka-K --to library` (default output in.csv -> here): the tool pointing down
    (qx qy qz qw = 1 0 0 0) turns K_F_ext_hat_K = (0, 0, +10) into h_e = (0, 0, -10) in the base frame, libfranka's sign."""
    from test_convert import _table

    n = 30
    src = _table(tmp_path, np.tile([0.0, 0.0, 10.0, 0.0, 0.0, 0.0], (n, 1)), quat=[1.0, 0.0, 0.0, 0.0], n=n)
    out = forcecontrol(tmp_path, "convert", src.name, "--from", "franka-K", "--to", "library")
    written = sorted(p.name for p in tmp_path.iterdir() if p.name != src.name)
    assert any(p.endswith(".csv") for p in written), (written, out.stdout)
    result = pd.read_csv(tmp_path / next(p for p in written if p.endswith(".csv")))
    np.testing.assert_allclose(result[["fx", "fy", "fz"]].to_numpy(), np.tile([0.0, 0.0, -10.0], (n, 1)), atol=1e-12)
    assert {"qx", "qw"} <= set(result.columns)


def test_calibrate_json_and_calibrate_plan_on_the_chapter_arm(tmp_path):
    """`calibrate cal.csv --json`: the simulated sensor's mass, centre of mass and biases within 4 sigma;
    `calibrate-plan chapter-arm 6 --out poses.csv`: six poses, condition number below 2."""
    from test_cli_calibrate import TRUE, _quaternion_csv

    _quaternion_csv(tmp_path / "cal.csv")
    rep = json.loads(forcecontrol(tmp_path, "calibrate", "cal.csv", "--json").stdout)
    assert abs(rep["mass"] - TRUE["mass"]) <= 4 * rep["mass_std"]
    for name in ("com", "force_bias", "torque_bias"):
        assert np.all(np.abs(np.array(rep[name]) - TRUE[name]) <= 4 * np.array(rep[name + "_std"])), name
    plan = forcecontrol(tmp_path, "calibrate-plan", "chapter-arm", "6", "--out", "poses.csv")
    rows = (tmp_path / "poses.csv").read_text().strip().splitlines()
    assert rows[0] == "q1,q2" and len(rows) == 7
    cond = float(re.search(r"condition number[^0-9]*([0-9.]+)", plan.stdout).group(1))
    assert cond < 2.0


def test_compare_builtin_and_mujoco_on_example_9_2(tmp_path):
    """`compare example-9.2`: both engines settle to the book's 200 N and 71.4 N, and the reasons they differ are printed."""
    out = forcecontrol(tmp_path, "compare", "example-9.2")
    rows = rich_tables(out.stdout)[0]
    steady = {(r["case"], r["engine"]): number(r["steady [N]"]) for r in rows if r["engine"] != "difference"}
    assert [r["steady [N]"] for r in rows if r["engine"] == "difference"] == ["0.000 %", "0.000 %"]
    for (case, engine), f in steady.items():
        assert f == pytest.approx(200.0 if "1e4" in case else 71.4, rel=5e-3), (case, engine)
    assert {e for _, e in steady} == {"compiled", "mujoco"} and len(steady) == 4
    assert "Where the engines differ, and why" in out.stdout
