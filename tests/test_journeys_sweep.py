"""End-to-end journeys of sweeps (issue 27): the `forcecontrol` command run as a user types it (the README's
commands, figures on by default), each checked for exit 0, no traceback and what matters: the table's rows
and numbers (against `forcecontrol run` of the same case and the book's or closed-form values), valid PNGs,
the HTML report."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

import cli_server

FORCECONTROL = str(Path(sys.executable).with_name("forcecontrol"))


@pytest.fixture(scope="session")
def folder(tmp_path_factory) -> Path:
    """One folder for every journey (a user's working directory)."""
    return tmp_path_factory.mktemp("journeys-sweep")


def _cli(folder: Path, *args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    r = cli_server.run(list(args), cwd=folder, timeout=timeout)
    assert r.returncode == 0, f"forcecontrol {' '.join(args)}: exit {r.returncode}\n{r.stderr[-3000:]}"
    assert "Traceback" not in r.stderr and "Traceback" not in r.stdout, r.stderr[-3000:]
    return r


def _png(path: Path) -> tuple[int, int]:
    """A valid PNG of a sensible size: its signature, its IHDR width and height, its IEND."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR" and data[-8:-4] == b"IEND"
    w, h = struct.unpack(">II", data[16:24])
    assert 600 <= w <= 4000 and 200 <= h <= 4000 and len(data) > 20_000
    return w, h


@pytest.fixture(scope="session")
def run_92(folder) -> dict:
    """`forcecontrol run example-9.2 --json` (figures on)."""
    return json.loads(_cli(folder, "run", "example-9.2", "--json").stdout)


@pytest.fixture(scope="session")
def sweep_92(folder) -> subprocess.CompletedProcess:
    """The issue's command: a two-parameter sweep of Example 9.2 with its default figure."""
    return _cli(folder, "sweep", "example-9.2", "-p", "environment.stiffness=1000,5000",
                "-p", "controller.damping[0]=300,500", "--out", "d/t.parquet")


def test_two_parameter_sweep_writes_its_table_and_map(folder, sweep_92):
    """Two parameters, figures on: exit 0, 'table:' and 'figure:' printed, a valid PNG, 2 cases x 4 rows sorted."""
    assert "table: d/t.parquet" in sweep_92.stdout and "figure: d/t.png" in sweep_92.stdout
    w, h = _png(folder / "d" / "t.png")
    assert w > h  # a row per scenario case, four metric columns
    df = pd.read_parquet(folder / "d" / "t.parquet")
    assert df["case_id"].tolist() == list(range(8))
    assert sorted(zip(df["environment.stiffness"], df["controller.damping[0]"])) == sorted(
        [(k, c) for k in (1000.0, 5000.0) for c in (300.0, 500.0)] * 2)
    assert (df["status"] == "ok").all() and df["stable"].all()


def test_a_sweep_whose_cases_ask_no_force_says_what_its_force_error_column_holds(folder, sweep_92):
    """Example 9.2 (impedance, f_d = 0): the 'ss error' column is y_final − d·f_d = the settled force, which a reader
    takes for an error: said in a note on stderr; Example 9.3 (f_d = 10 N) gets no such note and a small error."""
    assert "no case asks a contact force (f_d = 0 at the end of the run)" in " ".join(sweep_92.stderr.split())
    df = pd.read_parquet(folder / "d" / "t.parquet")
    assert (df["steady_state_force_error"] == df["settled_force"]).all() and (df["settled_force"] > 50).all()
    doc = json.loads(_cli(folder, "sweep", "example-9.3", "--case", "1", "-p", "environment.stiffness=1000,2000",
                          "--no-figure", "--json", "--out", "d/f.parquet").stdout)
    assert not [n for n in doc["notes"] if "contact force" in n], doc["notes"]
    forced = pd.read_parquet(folder / "d" / "f.parquet")
    assert (forced["steady_state_force_error"].abs() < 0.5).all(), forced["steady_state_force_error"].tolist()


def test_the_sweep_row_of_the_scenarios_own_values_equals_forcecontrol_run(folder, sweep_92, run_92):
    """The row k = 1e3 N/m, damping 500 (the scenario's own case 2) has the settled force and peak of
    `forcecontrol run` of that case, and the book's f_x = 71.4 N (Example 9.2)."""
    df = pd.read_parquet(folder / "d" / "t.parquet")
    case = next(c for c in run_92["cases"] if c["label"] == "k_x = 1e3 N/m")
    rows = df[(df["environment.stiffness"] == 1000.0) & (df["controller.damping[0]"] == 500.0)]
    assert len(rows) == 2  # both scenario cases, made equal by the swept stiffness
    for _, row in rows.iterrows():
        # the sweep's batch kernel and run's compiled loop: the same law and plant, summed in another order
        assert row["settled_force"] == pytest.approx(case["settled"]["fx"], rel=1e-6)
        assert row["peak_force"] == pytest.approx(case["peak_contact_force_norm"], rel=1e-6)
        assert row["settled_force"] == pytest.approx(71.4, rel=0.005)


def test_report_of_a_sweep_is_one_html_file_with_its_parameters(folder, sweep_92):
    """`forcecontrol report d/t.parquet`: exit 0, d/t.html beside the table, self-contained, naming the axes."""
    r = _cli(folder, "report", "d/t.parquet")
    html = (folder / "d" / "t.html").read_text(encoding="utf-8")
    assert "report: d/t.html" in r.stdout and len(html) > 100_000
    assert "environment.stiffness" in html and "controller.damping[0]" in html and "plotly" in html.lower()


def test_one_parameter_sweep_of_one_case_on_two_workers_draws_its_curves(folder):
    """`sweep example-9.3 -p environment.stiffness=... --case 2 --workers 2`: exit 0, one figure of curves, the
    chosen case only (its label marked: the sweep replaces the stiffness it sets), the integral action's zero
    steady-state force error at every stiffness."""
    r = _cli(folder, "sweep", "example-9.3", "-p", "environment.stiffness=5000,20000,40000", "--case", "2",
             "--workers", "2", "--out", "one/s.parquet", "--json")
    summary = json.loads(r.stdout)
    assert summary["files"] == {"table": "one/s.parquet", "figure": "one/s.png"} and summary["notes"] == []
    _png(folder / "one" / "s.png")
    df = pd.read_parquet(folder / "one" / "s.parquet")
    assert df["case"].tolist() == ["inner position, k_x = 1e3 N/m [environment.stiffness swept]"] * 3
    assert df["case_id"].tolist() == [0, 1, 2] and df["environment.stiffness"].tolist() == [5000.0, 20000.0, 40000.0]
    assert (df["steady_state_force_error"].abs() < 1e-3 * df["settled_force"]).all()


def test_6d_admittance_sweep_runs_with_its_figure_and_matches_the_closed_form(folder):
    """`sweep panda-admittance-contact -p environment.stiffness=2000,5000` (6-D, figures on): exit 0, a PNG, the
    settled forces k K/(k + K) 0.02 of two springs in series (9.22): the scenario's own k = 5000 gives its book
    value 16.67 N, and a stiffer table is penetrated less."""
    _cli(folder, "sweep", "panda-admittance-contact", "-p", "environment.stiffness=2000,5000", "--out", "adm/s.parquet")
    _png(folder / "adm" / "s.png")
    df = pd.read_parquet(folder / "adm" / "s.parquet")
    assert list(df["engine"]) == ["simulate"] * 2 and list(df["status"]) == ["ok"] * 2
    for k, f in zip((2000.0, 5000.0), df["settled_force"]):
        assert f == pytest.approx(k * 1000.0 / (k + 1000.0) * 0.02, rel=1e-4)
    assert (df["settled_force"] / df["environment.stiffness"]).is_monotonic_decreasing  # stiffer: less penetration


def test_sweep_on_a_dask_cluster_of_two_workers_equals_the_local_one(folder):
    """`--scheduler ADDRESS` (a LocalCluster of 2 worker processes): the table equals the local sweep's; --workers,
    meaningless there, is noted on stderr and in --json."""
    distributed = pytest.importorskip("dask.distributed")
    args = ["sweep", "example-9.3", "-p", "environment.stiffness=5000,20000", "-p", "duration=0.5", "--case", "2"]
    local = json.loads(_cli(folder, *args, "--workers", "2", "--out", "dask/local.parquet", "--json").stdout)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        r = _cli(folder, *args, "--scheduler", c.scheduler_address, "--workers", "2", "--out", "dask/remote.parquet",
                 "--json")
    remote = json.loads(r.stdout)
    assert remote["scheduler"] == c.scheduler_address and local["scheduler"] == "local"
    assert any("--workers 2 is ignored" in n for n in remote["notes"]) and "--workers 2 is ignored" in r.stderr
    _png(folder / "dask" / "remote.png")
    pd.testing.assert_frame_equal(pd.read_parquet(folder / "dask" / "local.parquet"),
                                  pd.read_parquet(folder / "dask" / "remote.parquet"), check_exact=True)
