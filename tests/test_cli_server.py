"""The command server of the suite's command-line tests (tests/cli_server.py): a command forked from it gives what the
same command gives in a new process, exit code, stdout and stderr alike, and it is refused what it cannot run alike."""

from __future__ import annotations

import json
import os
import subprocess

import pytest

import cli_server


def _both(args: list[str], tmp_path, module: bool = False, env: dict[str, str] | None = None):
    """The command forked from the server, then in a new process, each in a folder of its own (same relative paths)."""
    out = []
    for name, new in (("forked", False), ("new", True)):
        folder = tmp_path / name
        folder.mkdir(parents=True)
        old = os.environ.get("FORCECONTROL_TEST_NEW_PROCESSES")
        os.environ["FORCECONTROL_TEST_NEW_PROCESSES"] = "1" if new else "0"
        try:
            proc = cli_server.run(args, cwd=folder, module=module, env=env)
        finally:
            if old is None:
                del os.environ["FORCECONTROL_TEST_NEW_PROCESSES"]
            else:
                os.environ["FORCECONTROL_TEST_NEW_PROCESSES"] = old
        assert proc.forked is not new, (name, cli_server.refused(env))
        out.append((proc, folder))
    return out


@pytest.fixture(scope="module", autouse=True)
def _kernels_compiled():
    """The kernels of the commands below are in the cache before they are compared: on a cold cache the first of the
    two runs would compile them and say so on stderr, and the second would not (what a first run says is tested in
    tests/test_coldstart.py)."""
    from forcecontrol.scenarios import load_scenario, run_scenario

    run_scenario(load_scenario("example-9.2"))


@pytest.mark.parametrize("args, module", [
    (["run", "example-9.2", "--json"], False),  # figures on, as users run it
    (["run", "example-9.2"], True),
    (["analyze", "example-9.3", "--json"], True),
    (["show", "example-9.4"], False),
    (["run", "no-such-scenario"], False),  # an error: exit 2, the message on stderr
    (["run", "example-9.2", "--no-such-option"], True),
    (["--help"], False),
])
def test_a_forked_command_gives_what_a_new_process_gives(args, module, tmp_path):
    (forked, f_dir), (new, n_dir) = _both(args, tmp_path, module=module)
    assert forked.returncode == new.returncode, (forked.stderr, new.stderr)
    assert forked.stderr.replace(str(f_dir), "<dir>") == new.stderr.replace(str(n_dir), "<dir>")
    if "--json" in args and forked.returncode == 0:
        a, b = json.loads(forked.stdout), json.loads(new.stdout)
        assert json.dumps(a).replace(str(f_dir), "<dir>") == json.dumps(b).replace(str(n_dir), "<dir>")
    else:
        assert forked.stdout.replace(str(f_dir), "<dir>") == new.stdout.replace(str(n_dir), "<dir>")
    files = sorted(p.relative_to(f_dir).as_posix() for p in f_dir.rglob("*"))
    assert files == sorted(p.relative_to(n_dir).as_posix() for p in n_dir.rglob("*"))
    for rel in files:  # the figures and tables written, byte for byte
        if (f_dir / rel).is_file() and not rel.endswith(".json"):
            assert (f_dir / rel).read_bytes() == (n_dir / rel).read_bytes(), rel


def test_the_command_reads_a_relative_path_in_its_folder_as_a_new_process_does(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "mine.toml").write_text(cli_server.run(["show", "example-9.2"], cwd=tmp_path).stdout,
                                                encoding="utf-8")
    env = {**cli_server.base_environment(), "COLUMNS": "200"}  # a variable a forked command may be given
    (forked, _), (new, _) = _both(["analyze", "../src/mine.toml"], tmp_path, env=env)
    assert forked.returncode == new.returncode == 0, (forked.stderr, new.stderr)
    assert forked.stdout == new.stdout and "Example 9.2" in forked.stdout


def test_an_environment_the_imports_read_runs_a_new_process(tmp_path):
    """A variable read while Python starts or imports (Numba's cache folder, BLAS threads) cannot be given to a
    forked command: that command runs in a new process."""
    base = cli_server.base_environment()
    assert cli_server.servable({**base, "COLUMNS": "99", "PYTHONIOENCODING": "utf-8"}, base)
    for k, v in (("NUMBA_CACHE_DIR", str(tmp_path)), ("OPENBLAS_NUM_THREADS", "7"), ("PYTHONWARNINGS", "error"),
                 ("MPLBACKEND", "pdf")):
        assert not cli_server.servable({**base, k: v}, base), k
    proc = cli_server.run(["--help"], cwd=tmp_path, env={**base, "PYTHONWARNINGS": "default"})
    assert proc.returncode == 0 and not proc.forked


def test_a_command_over_its_time_is_killed_and_the_next_one_runs(tmp_path):
    with pytest.raises(subprocess.TimeoutExpired):
        cli_server.run(["run", "panda-wipe-heightfield"], cwd=tmp_path, timeout=0.2)
    proc = cli_server.run(["--version"], cwd=tmp_path)
    assert proc.returncode == 0 and proc.forked and proc.stdout.strip(), proc.stderr


def test_what_one_command_changes_in_its_process_is_gone_for_the_next(tmp_path):
    """Each command starts from the server's state: a scenario registered, a module imported or a variable set by one
    command is not seen by the next (as between two new processes)."""
    (tmp_path / "a.toml").write_text("not toml [", encoding="utf-8")
    first = cli_server.run(["run", "a.toml"], cwd=tmp_path)
    second = cli_server.run(["run", "a.toml"], cwd=tmp_path)
    assert first.forked and second.forked, cli_server.refused()
    assert first.returncode == second.returncode == 2
    assert first.stderr == second.stderr


def test_what_a_library_writes_in_the_environment_is_gone_after_the_test():
    """tests/conftest.py restores the environment after each test: first, a library writes a variable (here, as Dask's
    LocalCluster and pyviz_comms do, by hand)."""
    os.environ["_FORCECONTROL_TEST_LEAK"] = "1"


def test_what_a_library_wrote_in_the_environment_before_is_gone():
    """... and the next test (on the same worker: this module is one of conftest's ONE_WORKER) no longer sees it, and
    its commands are forked from the server again."""
    assert "_FORCECONTROL_TEST_LEAK" not in os.environ
    proc = cli_server.run(["--version"])
    assert proc.forked, cli_server.refused()
