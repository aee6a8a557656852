"""Commands that write a run folder claim it (forcecontrol.cli.claim): two at once never write into one folder.

Found in session 24: two ``forcecontrol run example-9.2`` started together both chose
``forcecontrol-out/example-9.2`` (each saw it missing) and wrote their files over each other's. The
claim is tested the way users meet it: real processes, the README's command with its defaults.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from forcecontrol.cli.claim import claim, lock_path

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="no flock on Windows: folders are used unclaimed there")

RUN_FILES = {"example-9.2.png", "example-9.2-k-x-1e3-n-m.csv", "example-9.2-k-x-1e3-n-m.json",
             "example-9.2-k-x-1e4-n-m.csv", "example-9.2-k-x-1e4-n-m.json"}


def _start(cwd: Path, *args: str) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONIOENCODING": "utf-8", "COLUMNS": "200"}
    return subprocess.Popen([sys.executable, "-m", "forcecontrol", *args], cwd=cwd, env=env, text=True,
                            encoding="utf-8", stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _finish(proc: subprocess.Popen[str]) -> tuple[int, str, str]:
    out, err = proc.communicate(timeout=600)
    return proc.returncode, out, err


def _figure_line(stdout: str) -> str:
    return next(line for line in stdout.splitlines() if line.startswith("figure: "))


def test_two_runs_started_together_write_two_whole_folders(tmp_path: Path) -> None:
    """`forcecontrol run example-9.2` twice at once: one writes forcecontrol-out/example-9.2, the other
    example-9.2-2 and says why; each folder holds one run's five files, and no lock file is left."""
    a, b = _start(tmp_path, "run", "example-9.2"), _start(tmp_path, "run", "example-9.2")
    (ra, oa, ea), (rb, ob, eb) = _finish(a), _finish(b)
    assert ra == 0 and rb == 0, ea + eb
    figures = sorted([_figure_line(oa), _figure_line(ob)])
    assert figures == ["figure: forcecontrol-out/example-9.2-2/example-9.2.png",
                       "figure: forcecontrol-out/example-9.2/example-9.2.png"]
    out = tmp_path / "forcecontrol-out"
    assert sorted(p.name for p in out.iterdir()) == ["example-9.2", "example-9.2-2"]  # no lock file left beside them
    for folder in ("example-9.2", "example-9.2-2"):
        assert {p.name for p in (out / folder).iterdir()} == RUN_FILES
    moved = ea if "example-9.2-2" in oa else eb
    assert "this run writes in 'forcecontrol-out/example-9.2-2'" in " ".join(moved.split())


def test_a_claimed_folder_is_passed_over_by_default_and_refused_with_out(tmp_path: Path) -> None:
    """While another process holds forcecontrol-out/example-9.2 (claimed here): the default output moves on to
    example-9.2-2 and names the holder; --out refuses (also with --force), naming it; released, --out writes there."""
    out = tmp_path / "forcecontrol-out"
    out.mkdir()
    held = claim(out / "example-9.2")
    assert not isinstance(held, str) and held.held
    try:
        code, stdout, stderr = _finish(_start(tmp_path, "run", "example-9.2", "--json"))
        assert code == 0, stderr
        assert not (out / "example-9.2").exists() and {p.name for p in (out / "example-9.2-2").iterdir()} == RUN_FILES
        said = " ".join(stderr.split())
        busy = f"'forcecontrol-out/example-9.2' is being written by another forcecontrol command (process {os.getpid()})"
        assert busy in said and "--force" not in said  # --force would be refused too: not offered
        assert any(busy in n for n in json.loads(stdout)["notes"])  # and in --json
        for extra in ((), ("--force",)):
            code, _, stderr = _finish(_start(tmp_path, "run", "example-9.2", "--out", "forcecontrol-out", *extra))
            assert code == 2, stderr
            assert (f"another forcecontrol command (process {os.getpid()}) is writing in "
                    f"'forcecontrol-out/example-9.2'") in " ".join(stderr.split())
            assert not (out / "example-9.2").exists()
    finally:
        held.release()
    assert not lock_path(out / "example-9.2").exists()
    code, _, stderr = _finish(_start(tmp_path, "run", "example-9.2", "--out", "forcecontrol-out"))
    assert code == 0, stderr
    assert {p.name for p in (out / "example-9.2").iterdir()} == RUN_FILES


def test_a_claim_left_by_a_killed_command_is_taken_over(tmp_path: Path) -> None:
    """A lock file whose process is gone (written, never locked, like a killed command's): the next run uses the
    folder (no refusal) and removes the file when it ends."""
    out = tmp_path / "forcecontrol-out"
    out.mkdir()
    stale = lock_path(out / "example-9.2")
    stale.write_text("999999999\n")
    code, stdout, stderr = _finish(_start(tmp_path, "run", "example-9.2"))
    assert code == 0, stderr
    assert _figure_line(stdout) == "figure: forcecontrol-out/example-9.2/example-9.2.png"
    assert not stale.exists()
    stale.write_text("999999999\n")  # killed after writing its files: the next run goes on to -2 and removes the file
    code, stdout, stderr = _finish(_start(tmp_path, "run", "example-9.2"))
    assert code == 0, stderr
    assert _figure_line(stdout) == "figure: forcecontrol-out/example-9.2-2/example-9.2.png"
    assert not stale.exists() and sorted(p.name for p in out.iterdir()) == ["example-9.2", "example-9.2-2"]


def test_a_command_run_twice_in_one_process_releases_its_claim(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """In-process (typer's runner, as a notebook or a test calls the CLI): each command's claim ends with it, so the
    same --out --force runs again in the same process, and no lock file is left."""
    from typer.testing import CliRunner

    from forcecontrol.cli.app import app

    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    for _ in range(2):
        res = runner.invoke(app, ["run", "example-9.2", "--out", "mine", "--force", "--no-figure", "--data", "csv"])
        assert res.exit_code == 0, res.output
        assert sorted(p.name for p in (tmp_path / "mine").iterdir()) == ["example-9.2"]
