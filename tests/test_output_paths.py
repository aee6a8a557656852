"""Outputs stay inside the folder the user named; user files and folders at a sweep's --out are never touched (issue 28)."""

from __future__ import annotations

import os
import sys
import types

import pytest
from typer.testing import CliRunner

from forcecontrol.cli import app
from forcecontrol.core.paths import inside, safe_name
from forcecontrol.errors import OutputError

runner = CliRunner()

SCENARIO = """
name = "{name}"
duration = 0.05
[robot]
model = "chapter-arm"
start_position = [1.0, 0.0]
elbow = "up"
[environment]
type = "elastic-plane"
point = [1.0, 0.0]
normal = [-1.0, 0.0]
stiffness = 1e4
[controller]
type = "inner-velocity"
inertia = [100.0, 100.0]
damping = [500.0, 500.0]
stiffness = [2500.0, 2500.0]
force_gain = [0.0024, 0.0]
[reference]
type = "setpoint"
position = [1.015, 0.1]
force = [10.0, 0.0]
[figure]
name = "{figure}"
signals = ["x", "fx"]
"""

TRAVERSAL = "../../../../escaped/x"


def _files(root):
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())


def test_safe_name_gives_one_component():
    """No separator, no '..', no control character, bounded length; plain names unchanged."""
    for text in ["../../etc/passwd", "a/b\\c", "..", ".", "x\x00y\n", "é" * 300, "a" * 500]:
        s = safe_name(text)
        assert "/" not in s and "\\" not in s and ".." not in s and s not in (".", "")
        assert all(ord(ch) >= 32 for ch in s) and len(s) <= 120
    assert safe_name("example-9.2") == "example-9.2"


def test_inside_refuses_escapes_and_symlinks(tmp_path):
    """'..' and a symlink pointing out of the folder are refused with OutputError; a plain name is accepted."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "link").symlink_to(tmp_path)
    assert inside(out, "a.png") == out / "a.png"
    for bad in ["../a.png", "link/a.png", str(tmp_path / "a.png")]:
        with pytest.raises(OutputError, match="inside the output folder"):
            inside(out, bad)


def test_run_figure_name_with_traversal_writes_inside_out(tmp_path):
    """`run` with [figure] name = '../../../../escaped/x' writes its PNG inside --out, nothing elsewhere."""
    scn = tmp_path / "scn" / "s.toml"
    scn.parent.mkdir()
    scn.write_text(SCENARIO.format(name="trav", figure=TRAVERSAL))
    out = tmp_path / "a" / "b" / "out"
    res = runner.invoke(app, ["run", str(scn), "--out", str(out)])
    assert res.exit_code == 0, res.output
    outside = [f for f in _files(tmp_path) if not f.startswith("a/b/out/") and not f.startswith("scn/")]
    assert outside == []
    pngs = [f for f in _files(out) if f.endswith(".png")]
    assert len(pngs) == 1 and pngs[0].startswith("trav/")


def test_run_animation_and_scenario_name_with_traversal_stay_inside_out(tmp_path):
    """A scenario named '../../../../escaped' with --animate: the folder and GIF are inside --out."""
    scn = tmp_path / "scn" / "s.toml"
    scn.parent.mkdir()
    scn.write_text(SCENARIO.format(name="../../../../escaped", figure="f"))
    out = tmp_path / "a" / "b" / "out"
    res = runner.invoke(app, ["run", str(scn), "--out", str(out), "--animate"])
    assert res.exit_code == 0, res.output
    assert [f for f in _files(tmp_path) if not f.startswith(("a/b/out/", "scn/"))] == []
    assert any(f.endswith(".gif") for f in _files(out)) and any(f.endswith(".png") for f in _files(out))


def test_scheme_report_figures_stay_inside_the_folder(tmp_path):
    """The analysis report's per-scheme figures, for a scenario named with '..' and '/', land in the folder given."""
    from forcecontrol.scenarios.report import plot_scheme_figures

    scn_file = tmp_path / "s.toml"
    scn_file.write_text(SCENARIO.format(name="../../../../escaped", figure="f"))
    folder = tmp_path / "a" / "b" / "out"
    paths = plot_scheme_figures(scn_file, folder)
    assert paths and all(p.resolve().is_relative_to(folder.resolve()) for p in paths)


# ----------------------------------------------------------------------------- sweep --out


def _sweep(args, out):
    return runner.invoke(app, ["sweep", "example-9.2", "--param", "environment.stiffness=1000,2000",
                               "--no-figure", "--out", str(out), *args])


def _snapshot(path):
    if path.is_dir():
        return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in path.iterdir()}, path.stat().st_mtime_ns
    return path.read_bytes(), path.stat().st_mtime_ns


@pytest.mark.parametrize("force", [False, True])
def test_sweep_out_existing_user_folder_is_refused_untouched(tmp_path, force):
    """--out naming a user's folder: refused (exit 2, OutputError naming it), even with --force; its files unchanged."""
    pytest.importorskip("pyarrow")
    folder = tmp_path / "mydata"
    folder.mkdir()
    (folder / "keep.txt").write_text("precious")
    before = _snapshot(folder)
    res = _sweep(["--force"] if force else [], folder)
    assert res.exit_code == 2 and "existing folder" in res.output
    assert _snapshot(folder) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mydata"]


def test_sweep_out_user_file_refused_without_force_replaced_with_force(tmp_path):
    """--out notes.csv (not a sweep): refused with bytes and mtime unchanged; --force replaces it, saying so in --json."""
    pytest.importorskip("pyarrow")
    notes = tmp_path / "notes.csv"
    notes.write_text("a,b\n1,2\n")
    os.utime(notes, ns=(1_000_000_000, 1_000_000_000))
    before = _snapshot(notes)
    res = _sweep([], notes)
    assert res.exit_code == 2 and "--force" in res.output and "not a sweep table" in res.output
    assert _snapshot(notes) == before
    assert not list(tmp_path.glob("notes.csv.*")) and not list(tmp_path.glob("*.corrupt-*"))
    res = _sweep(["--force", "--json"], notes)
    assert res.exit_code == 0, res.output
    import json

    doc = json.loads(res.stdout)
    assert any("--force" in n and "not a sweep table" in n for n in doc["notes"])
    from forcecontrol.sweep import read_sweep

    df, _ = read_sweep(notes)
    assert len(df) == 4  # example-9.2: 2 cases x 2 stiffnesses
    # the library's own table now: a re-run resumes it without --force
    assert _sweep([], notes).exit_code == 0


def test_stable_identities_survives_sys_modules_changing_during_iteration(monkeypatch):
    """A module imported while stable_identities scans sys.modules (here: by a key's own startswith) raises nothing."""
    pytest.importorskip("numba")
    from forcecontrol.core import numba_cache

    class ImportingKey(str):
        """A sys.modules key whose startswith imports another module, as a concurrent thread would."""

        def startswith(self, *args):
            monkeypatch.setitem(sys.modules, f"fc_test_imported_{len(sys.modules)}", types.ModuleType("x"))
            return False

    monkeypatch.setitem(sys.modules, ImportingKey("fc_test_importing_key"), types.ModuleType("y"))
    numba_cache.stable_identities()
