"""The command line: run, list, show, and the --json contract."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from forcecontrol.cli import app

runner = CliRunner()


def test_run_json_contract(tmp_path):
    """`run example-9.2 --json` prints scenario and cases with label, final (t, tip_position, contact_force), peak."""
    res = runner.invoke(app, ["run", "example-9.2", "--json", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["scenario"] == "example-9.2" and len(data["cases"]) == 2
    for case in data["cases"]:
        assert set(case) >= {"label", "final", "peak_contact_force_norm"}
        assert set(case["final"]) >= {"t", "tip_position", "contact_force"}
        assert len(case["final"]["tip_position"]) == 2 and len(case["final"]["contact_force"]) == 2
    forces = sorted(c["final"]["contact_force"][0] for c in data["cases"])
    assert abs(forces[0] - 71.4) < 0.36 and abs(forces[1] - 200.0) < 1.0
    assert (tmp_path / "example-9.2" / "example-9.2.png").stat().st_size > 10_000
    assert data["all_checks_pass"] is True


def test_run_writes_a_figure_a_table_and_data_files(tmp_path):
    """The main job prints a summary table, writes the PNG, and with --data the CSV logs and metadata."""
    res = runner.invoke(app, ["run", "example-9.2", "--out", str(tmp_path), "--data", "csv", "--check"])
    assert res.exit_code == 0, res.output
    assert "Against the book" in res.stdout and "71.4" in res.stdout
    files = sorted(p.name for p in (tmp_path / "example-9.2").iterdir())
    assert "example-9.2.png" in files and sum(f.endswith(".csv") for f in files) == 2
    assert sum(f.endswith(".json") for f in files) == 2


def test_list_and_show():
    """`list` names the built-ins; `show` prints a TOML that loads back."""
    assert "example-9.1" in runner.invoke(app, ["list"]).stdout
    out = runner.invoke(app, ["show", "example-9.2"]).stdout
    assert out.startswith('name = "example-9.2"')


def test_bad_scenario_exits_2_with_message(tmp_path):
    """A bad file exits with code 2 and the loader's message on stderr."""
    p = tmp_path / "bad.toml"
    p.write_text('name = "x"\n')
    res = runner.invoke(app, ["run", str(p)])
    assert res.exit_code == 2 and "missing key 'duration'" in res.stderr


def test_schema_lists_every_registered_type():
    """`schema` documents the tables and each registered type's keys."""
    out = runner.invoke(app, ["schema"]).stdout
    assert 'type = "impedance"' in out and 'type = "elastic-plane"' in out and "start_position" in out


def test_example_9_3_writes_one_figure_per_scheme(tmp_path):
    """`run example-9.3` writes Figs. 9.9, 9.10 and 9.11 as three files, each with its scheme's cases."""
    res = runner.invoke(app, ["run", "example-9.3", "--json", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    files = json.loads(res.stdout)["files"]
    names = sorted(v.rsplit("/", 1)[1] for k, v in files.items() if k.startswith("figure"))
    assert names == ["example-9.3-fig-9.10.png", "example-9.3-fig-9.11.png", "example-9.3-fig-9.9.png"]


def test_version_prints_the_package_version():
    """`--version` (and `-V`) print `forcecontrol <__version__>` and exit 0."""
    import forcecontrol

    for flag in ("--version", "-V"):
        res = runner.invoke(app, [flag])
        assert res.exit_code == 0 and res.stdout.strip() == f"forcecontrol {forcecontrol.__version__}"


def test_short_help_on_every_command():
    """`-h` works like `--help` on the application and on every registered command."""
    names = [c.name or c.callback.__name__ for c in app.registered_commands]
    assert {"run", "list", "show", "schema", "analyze", "task", "sweep", "compare"} <= set(names)
    for args in ([], *([n] for n in names)):
        short, long = runner.invoke(app, [*args, "-h"]), runner.invoke(app, [*args, "--help"])
        assert short.exit_code == 0 and "Usage:" in short.stdout, (args, short.output)
        assert short.stdout == long.stdout


def test_shell_completion_is_offered():
    """The help lists typer's --install-completion/--show-completion; the bash script and a completion work.

    Driven through the environment variables that the installed completion script itself sets
    (``_FORCECONTROL_COMPLETE``), so the test does not depend on which shell launched pytest
    (``--show-completion`` detects the parent shell, which fails under a background job).
    """
    out = runner.invoke(app, ["--help"]).stdout
    assert "--install-completion" in out and "--show-completion" in out
    import os
    import subprocess
    import sys

    def run(**env):
        return subprocess.run(
            [sys.executable, "-m", "forcecontrol"], capture_output=True, text=True, env={**os.environ, **env}, timeout=120
        )

    script = run(_FORCECONTROL_COMPLETE="source_bash")
    assert script.returncode == 0 and "complete " in script.stdout and "_forcecontrol_completion" in script.stdout, script.stderr
    done = run(_FORCECONTROL_COMPLETE="complete_bash", COMP_WORDS="forcecontrol ru", COMP_CWORD="1")
    assert done.returncode == 0 and done.stdout.split() == ["run"], (done.stdout, done.stderr)


def test_error_messages_keep_bracketed_table_names(tmp_path):
    """A scenario error naming `[controller]` reaches stderr verbatim (Rich markup escaped; issue 13)."""
    src = runner.invoke(app, ["show", "example-9.2"]).stdout
    p = tmp_path / "bad.toml"
    p.write_text(src.replace("inertia = [100.0, 100.0]", 'inertia = "big"'))
    res = runner.invoke(app, ["run", str(p), "--no-figure"])
    assert res.exit_code == 2
    assert "[controller]" in res.stderr and "'inertia'" in res.stderr, res.stderr


def test_fail_prints_markup_like_text_verbatim(capsys):
    """`_fail` prints an error text holding `[bold]`/`[/]`-like brackets unchanged, on one line."""
    import pytest
    import typer

    from forcecontrol.cli.app import _fail
    from forcecontrol.errors import ScenarioError

    msg = "[controller] stiffness: expected a 2x2 matrix, got [[1, 2]] [/] [red]x"
    with pytest.raises(typer.Exit) as info:
        _fail(ScenarioError(msg))
    assert info.value.exit_code == 2
    err = capsys.readouterr().err
    assert msg in err


def test_cold_cache_compile_notice(tmp_path):
    """With an empty cache folder the first compile of a forcecontrol kernel prints one notice; a warm cache prints none."""
    import os
    import subprocess
    import sys

    (tmp_path / "probe_kernels.py").write_text(
        "import numba\n"
        "@numba.njit(cache=True)\n"
        "def f(x):\n    return x + 1\n"
        "@numba.njit(cache=True)\n"
        "def g(x):\n    return x + 2\n"
    )
    probe = tmp_path / "probe.py"
    probe.write_text(  # the probe's module stands in for forcecontrol's kernels (a real cold compile takes ~40 s)
        "from forcecontrol.core import numba_cache as _numba_cache\n"
        "_numba_cache.WATCHED = ('probe_kernels',)\n"
        "_numba_cache.install_notice()\n"
        "import probe_kernels\n"
        "print(probe_kernels.f(1) + probe_kernels.g(1))\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), env.get("PYTHONPATH", "")])

    def run() -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, str(probe)], capture_output=True, text=True, env=env, timeout=300)

    cold, warm = run(), run()
    assert cold.returncode == 0 and cold.stdout.strip() == "5", cold.stderr
    notices = [line for line in cold.stderr.splitlines() if "compiling kernels" in line]
    assert len(notices) == 1 and "first run" in notices[0], cold.stderr
    assert warm.returncode == 0 and "compiling" not in warm.stderr, warm.stderr


def _python(code: str, timeout: float = 300) -> list[str]:
    """``python -c code`` in a fresh interpreter (what a user's new process sees): its output lines,
    after checking that it exited with 0 (else its stderr is the failure's message)."""
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout)
    assert res.returncode == 0, res.stderr
    return res.stdout.splitlines()


def test_import_is_lazy():
    """`import forcecontrol` loads neither Numba, SciPy, matplotlib, python-control nor typer; names resolve on access."""
    code = (
        "import sys, forcecontrol as fc\n"
        "heavy = [m for m in ('numba', 'scipy', 'matplotlib', 'control', 'typer', 'rich', 'pandas') if m in sys.modules]\n"
        "print(','.join(heavy) or 'none')\n"
        "print(fc.ImpedanceController.__module__, fc.Task.__name__, fc.simulate.__name__,"
        " sorted(set(fc.__all__) - set(dir(fc))))\n"
    )
    lines = _python(code)
    assert lines[0] == "none"
    assert lines[1] == "forcecontrol.controllers.impedance Task simulate []"


@pytest.mark.parametrize("name", ["example-9.2", "example-9.3"])
def test_run_does_not_import_python_control(name):
    """`run` of an impedance (9.2) and a force-control (9.3) example never loads python-control (about 1 s):
    their checks need no transfer function. 9.3's force analysis module holds the lazy placeholder, which
    the compiled loop's identity pass touched (``isinstance`` on it loaded control, 1.3 s of every such run).
    The placeholder's type is read without touching it (``hasattr`` would load the module)."""
    code = (
        "import sys\n"
        "from typer.testing import CliRunner\n"
        "from forcecontrol.cli import app\n"
        f"r = CliRunner().invoke(app, ['run', '{name}', '--json', '--no-figure'])\n"
        "assert r.exit_code == 0, r.output\n"
        "print(type(sys.modules.get('control')).__name__, 'scipy.signal' in sys.modules)\n"
    )
    assert _python(code, timeout=600)[-1] in ("NoneType False", "_LazyModule False")


def test_the_command_line_starts_without_numpy_or_numba():
    """Importing the command line loads neither NumPy nor Numba (`forcecontrol --help` 0.30 -> 0.13 s: `sweep`'s
    module imported the scenarios at its top, and with them the simulator); `--help` itself exits 0 without them."""
    code = (
        "import sys\n"
        "from typer.testing import CliRunner\n"
        "from forcecontrol.cli import app\n"
        "print(sorted(m for m in ('numpy', 'numba', 'scipy', 'matplotlib', 'forcecontrol.scenarios') if m in sys.modules))\n"
        "r = CliRunner().invoke(app, ['--help'])\n"
        "print(r.exit_code, sorted(m for m in ('numpy', 'numba') if m in sys.modules))\n"
    )
    assert _python(code) == ["[]", "0 []"]


def test_console_script_main_tunes_the_collector_for_the_command_and_restores_it():
    """``forcecontrol.cli:main`` (the console script and ``python -m forcecontrol``): the command runs
    with COMMAND_GC_THRESHOLDS, the thresholds are back to Python's after it, the heap is not frozen
    while the calling program goes on, and it is frozen at the interpreter's exit (before the
    shutdown's collections); the command's output and exit code are typer's."""
    import subprocess
    import sys

    code = (
        "import atexit, gc\n"
        "from forcecontrol.cli import main\n"
        "from forcecontrol.cli.app import COMMAND_GC_THRESHOLDS, app\n"
        "before = gc.get_threshold()\n"
        "seen = []\n"
        "app.command('probe-gc')(lambda: seen.append(gc.get_threshold()))\n"
        "atexit.register(lambda: print('at exit', gc.get_freeze_count() > 1000))\n"
        "try:\n"
        "    main(['probe-gc'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "print('gc', seen == [COMMAND_GC_THRESHOLDS], gc.get_threshold() == before, gc.get_freeze_count() == 0)\n"
    )
    assert _python(code, timeout=120)[-2:] == ["gc True True True", "at exit True"]
    res = subprocess.run([sys.executable, "-m", "forcecontrol", "--version"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and "forcecontrol" in res.stdout
