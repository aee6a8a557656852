"""`forcecontrol calibrate` and `calibrate-plan` on files the tests write (CSV by the csv module, Parquet by pyarrow)."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from forcecontrol.cli import app

runner = CliRunner()
G = 9.81
TRUE = {"mass": 2.3, "com": np.array([0.01, -0.02, 0.08]), "force_bias": np.array([0.5, -0.3, 1.2]),
        "torque_bias": np.array([0.05, 0.02, -0.01])}


def _readings(Rs: np.ndarray, seed: int = 7, sf: float = 0.05, st: float = 0.005):
    """Hand-written physics of a static tool on a 3-D sensor plus Gaussian noise (the sensor holds the tool up)."""
    rng = np.random.default_rng(seed)
    w = TRUE["mass"] * np.einsum("kji,j->ki", Rs, [0.0, 0.0, -G])
    F = -w + TRUE["force_bias"] + sf * rng.standard_normal(w.shape)
    T = -np.cross(TRUE["com"], w) + TRUE["torque_bias"] + st * rng.standard_normal(w.shape)
    return F, T


def _write_csv(path, header, rows):
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)


def _quaternion_csv(path, n=20, moments=True):
    rot = Rotation.random(n, random_state=3)
    F, T = _readings(rot.as_matrix())
    header = ["qx", "qy", "qz", "qw", "fx", "fy", "fz"] + (["tx", "ty", "tz"] if moments else [])
    rows = [[*rot.as_quat()[i], *F[i], *(T[i] if moments else [])] for i in range(n)]
    _write_csv(path, header, rows)
    return path


def test_calibrate_csv_json_recovers_the_simulated_sensor(tmp_path):
    """Quaternion CSV from a simulated sensor (known m, c, b): --json values within 4 σ of the truth, σ > 0, condition < 3."""
    out = runner.invoke(app, ["calibrate", str(_quaternion_csv(tmp_path / "cal.csv")), "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.stdout)
    assert rep["dim"] == 3 and rep["n_readings"] == 20 and 1.0 <= rep["condition_number"] < 3.0
    assert abs(rep["mass"] - TRUE["mass"]) <= 4 * rep["mass_std"]
    for name in ("com", "force_bias", "torque_bias"):
        est, std = np.array(rep[name]), np.array(rep[name + "_std"])
        assert np.all(std > 0) and np.all(np.abs(est - TRUE[name]) <= 4 * std), name
    assert [p["name"] for p in rep["parameters"]][:4] == ["mass", "com_x", "com_y", "com_z"]


def test_calibrate_prints_a_table_with_uncertainties(tmp_path):
    """The table lists each parameter with value, ± std and unit, then the condition number."""
    out = runner.invoke(app, ["calibrate", str(_quaternion_csv(tmp_path / "cal.csv"))])
    assert out.exit_code == 0, out.output
    for word in ("mass", "com_z", "force_bias_x", "torque_bias_z", "± std", "kg", "N m", "condition number of the poses"):
        assert word in out.stdout, word
    row = next(line for line in out.stdout.splitlines() if "mass" in line)
    assert float(row.split("│")[2]) == pytest.approx(2.3, abs=0.01)


def test_calibrate_parquet_with_rotation_matrices(tmp_path):
    """r11..r33 columns in a Parquet file written by pyarrow, forces only: mass and force bias within 4 σ; no com."""
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    Rs = Rotation.random(15, random_state=8).as_matrix()
    F, _ = _readings(Rs, seed=2)
    cols = {f"r{i + 1}{j + 1}": Rs[:, i, j] for i in range(3) for j in range(3)}
    cols.update(fx=F[:, 0], fy=F[:, 1], fz=F[:, 2])
    pq.write_table(pa.table(cols), tmp_path / "cal.parquet")
    out = runner.invoke(app, ["calibrate", str(tmp_path / "cal.parquet"), "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.stdout)
    assert abs(rep["mass"] - TRUE["mass"]) <= 4 * rep["mass_std"]
    assert np.all(np.abs(np.array(rep["force_bias"]) - TRUE["force_bias"]) <= 4 * np.array(rep["force_bias_std"]))
    assert rep["com"] is None and rep["torque_bias"] is None


def test_calibrate_planar_angle_csv(tmp_path):
    """Planar: angle, fx, fy, tz columns (12 angles): mass 1.2 kg and com (0.1, 0.03) m within 4 σ."""
    rng = np.random.default_rng(4)
    rows = []
    for a in np.linspace(-2.5, 2.5, 12):
        R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        w = 1.2 * (R.T @ [0.0, -G])
        f = -w + [0.8, -0.4] + 0.05 * rng.standard_normal(2)
        tz = -(0.10 * w[1] - 0.03 * w[0]) + 0.02 + 0.005 * rng.standard_normal()
        rows.append([a, *f, tz])
    _write_csv(tmp_path / "planar.csv", ["angle", "fx", "fy", "tz"], rows)
    rep = json.loads(runner.invoke(app, ["calibrate", str(tmp_path / "planar.csv"), "--json"]).stdout)
    assert rep["dim"] == 2 and abs(rep["mass"] - 1.2) <= 4 * rep["mass_std"]
    assert np.all(np.abs(np.array(rep["com"]) - [0.10, 0.03]) <= 4 * np.array(rep["com_std"]))


@pytest.mark.parametrize(
    "header, rows, match",
    [
        (["qx", "qy", "qz", "qw", "fx", "fy"], [[0, 0, 0, 1, 1, 2]] * 3,
         r"missing force column\(s\) \['fz'\] for a 3-D calibration"),
        (["fx", "fy", "fz"], [[1, 2, 3]] * 3, r"no orientation columns: give qx, qy, qz, qw"),
        (["angle", "fx", "fy"], [[0.0, 1, 2], [0.001, 1, 2], [0.0, 1, 2], [0.001, 1, 2]],
         r"the calibration poses are too similar: the condition number of the normalised gravity regressor is"),
        (["angle", "fx", "fy"], [[0.0, 1, 2], [0.0, 1, 2], [0.0, 1, 2]], "do not identify the tool mass"),
        (["angle", "fx", "fy"], [[0.0, 1, "x"]], "column 'fy' must hold numbers"),
    ],
)
def test_calibrate_bad_files_exit_2_with_a_clear_message(tmp_path, header, rows, match):
    """Missing columns, too-similar or identical poses, text in a number column: exit code 2 and the reason on stderr."""
    import re

    _write_csv(tmp_path / "bad.csv", header, rows)
    out = runner.invoke(app, ["calibrate", str(tmp_path / "bad.csv")])
    assert out.exit_code == 2
    assert re.search(match, " ".join(out.output.split())), out.output


def test_calibrate_refuses_missing_and_unknown_files(tmp_path):
    """A path that does not exist and a .xlsx file: exit 2 naming the file or the accepted formats."""
    out = runner.invoke(app, ["calibrate", str(tmp_path / "none.csv")])
    assert out.exit_code == 2 and "does not exist" in out.output
    (tmp_path / "x.xlsx").write_text("a")
    out = runner.invoke(app, ["calibrate", str(tmp_path / "x.xlsx")])
    assert out.exit_code == 2 and "must be a .csv or .parquet file" in out.output


def test_calibrate_plan_writes_poses_that_calibrate(tmp_path):
    """calibrate-plan chapter-arm 6 --out: 6 poses q1, q2 in a CSV; --json condition number < 2 and equal to the table's."""
    out = runner.invoke(app, ["calibrate-plan", "chapter-arm", "6", "--out", str(tmp_path / "poses.csv"), "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.stdout)
    assert rep["condition_number"] < 2.0 and len(rep["joint_positions"]) == 6
    with (tmp_path / "poses.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["q1", "q2"] and len(rows) == 7
    np.testing.assert_allclose(np.array(rows[1:], dtype=float), rep["joint_positions"], rtol=0, atol=0)
    table = runner.invoke(app, ["calibrate-plan", "chapter-arm", "6"])
    assert table.exit_code == 0 and f"{rep['condition_number']:.3g}" in table.stdout
    bad = runner.invoke(app, ["calibrate-plan", "chapter-arm", "2"])
    assert bad.exit_code == 2 and "n_poses must be an integer >= 3" in bad.output


def test_calibrate_reads_an_excel_csv_with_a_byte_order_mark_as_the_same_file(tmp_path):
    """Excel's "CSV UTF-8" starts with a byte-order mark: the same readings with and without it give the same
    calibration (its first column was read as '\\ufeffqx' and the file refused)."""
    plain = _quaternion_csv(tmp_path / "cal.csv")
    bom = tmp_path / "excel.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    reps = []
    for p in (plain, bom):
        out = runner.invoke(app, ["calibrate", str(p), "--json"])
        assert out.exit_code == 0, out.output
        reps.append(json.loads(out.stdout))
    assert reps[0]["mass"] == reps[1]["mass"] and reps[0]["com"] == reps[1]["com"]


def test_calibrate_refuses_a_reading_beyond_any_sensor(tmp_path):
    """A corrupt 1e200 N reading is refused naming the reading (it gave a tool of 5.5e197 kg ± inf, exit 0)."""
    rot = Rotation.random(12, random_state=4)
    F, T = _readings(rot.as_matrix())
    F[5, 2] = 1e200
    rows = [[*rot.as_quat()[i], *F[i], *T[i]] for i in range(12)]
    _write_csv(tmp_path / "huge.csv", ["qx", "qy", "qz", "qw", "fx", "fy", "fz", "tx", "ty", "tz"], rows)
    out = runner.invoke(app, ["calibrate", str(tmp_path / "huge.csv")])
    assert out.exit_code == 2, out.output
    assert "reading 5" in out.output and "beyond any sensor's range" in out.output
