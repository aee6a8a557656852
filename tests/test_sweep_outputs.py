"""The sweep's figure follows the table's rule: a file forcecontrol did not write is replaced only with --force (issue 28)."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from forcecontrol.cli import app
from forcecontrol.errors import OutputError
from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_sweep

pytest.importorskip("pyarrow.parquet")
pytest.importorskip("matplotlib")

ARGS = ["sweep", "example-9.2", "--param", "environment.stiffness=1000,2000", "--workers", "1", "--json"]
USER_PNG = b"\x89PNG\r\n\x1a\n a user's own picture"


def _sweep(out, *extra):
    res = CliRunner().invoke(app, [*ARGS, "--out", str(out), *extra])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_users_png_beside_out_is_left_untouched_and_the_refusal_is_said(tmp_path):
    """A user's s.png beside --out s.parquet: the table is written, the PNG kept byte for byte, a note says why and how."""
    png = tmp_path / "s.png"
    png.write_bytes(USER_PNG)
    doc = _sweep(tmp_path / "s.parquet")
    assert png.read_bytes() == USER_PNG
    assert "figure" not in doc["files"] and (tmp_path / "s.parquet").exists()
    assert any("no figure drawn" in n and "did not write" in n and "--force" in n for n in doc["notes"])


def test_force_replaces_a_users_png_saying_so_and_a_later_run_replaces_its_own(tmp_path):
    """--force replaces the user's PNG with a note; a second run (no --force) replaces the library's own figure silently."""
    png = tmp_path / "s.png"
    png.write_bytes(USER_PNG)
    doc = _sweep(tmp_path / "s.parquet", "--force")
    assert doc["files"]["figure"] == str(png) and png.read_bytes()[:8] == USER_PNG[:8] and png.read_bytes() != USER_PNG
    assert any(n.startswith("--force: ") and "was not written by forcecontrol" in n for n in doc["notes"])
    mark = json.loads((tmp_path / ".s.png.forcecontrol-sweep.json").read_text())
    assert mark["file"] == "s.png"
    png.write_bytes(png.read_bytes() + b"\0")  # still the library's (its mark names it)
    doc = _sweep(tmp_path / "s.parquet")
    assert doc["files"]["figure"] == str(png) and not any("figure" in n or "--force" in n for n in doc["notes"])


def test_plot_sweep_map_refuses_a_users_file_and_a_folder(tmp_path):
    """plot_sweep_map (the API) refuses a user's file at out (OutputError naming it and --force) and a folder."""
    from forcecontrol.sweep.figures import plot_sweep_map

    d = SweepDefinition.from_options({"environment.stiffness": [1000.0, 2000.0], "controller.damping": [400.0, 600.0]})
    res = run_sweep(prepare_sweep("example-9.2", d), tmp_path / "m.parquet", workers=1)
    user = tmp_path / "m.png"
    user.write_bytes(USER_PNG)
    with pytest.raises(OutputError, match=r"m\.png' is an existing file that forcecontrol did not write.*--force"):
        plot_sweep_map(res, "environment.stiffness", "controller.damping", user, resolution=4)
    assert user.read_bytes() == USER_PNG
    (tmp_path / "dir.png").mkdir()
    with pytest.raises(OutputError, match="existing folder"):
        plot_sweep_map(res, "environment.stiffness", "controller.damping", tmp_path / "dir.png", resolution=4)


def test_a_stable_two_parameter_map_draws_without_a_warning(tmp_path):
    """A 2-D map whose cases are all stable and have no analytic boundary has nothing to explain: no legend, and no
    matplotlib 'No artists with labels' warning (it reached the user's stderr on every such sweep)."""
    import warnings

    from forcecontrol.sweep.figures import plot_sweep_map

    d = SweepDefinition.from_options({"environment.stiffness": [1000.0, 2000.0], "controller.damping[0]": [100.0, 200.0]})
    res = run_sweep(prepare_sweep("example-9.2", d), tmp_path / "m.parquet", workers=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plot_sweep_map(res, "environment.stiffness", "controller.damping[0]", tmp_path / "m.png", resolution=4)
    assert (tmp_path / "m.png").stat().st_size > 5_000
