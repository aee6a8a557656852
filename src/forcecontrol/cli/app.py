"""The ``forcecontrol`` application and the commands ``list``, ``run``, ``show`` and ``schema``.

The other commands live in one module each in this package and register on :data:`app`
(see :mod:`forcecontrol.cli`).
"""

from __future__ import annotations

import contextvars
import functools
import json
import re
import sys
from collections.abc import Callable
from enum import Enum
from pathlib import Path
from typing import Annotated, Any, NoReturn

import typer
from rich.console import Console
from rich.table import Table

from .. import __version__
from ..core import numba_cache as _numba_cache
from ..core.paths import MAX_NAME, inside
from ..errors import ForceControlError
from ..viz import render_process
from .notices import show_library_warnings
from .overrides import SetOption, apply_sets, parse_sets
from .safe import escape, terminal_safe

#: options shared by the commands.
JsonOut = Annotated[bool, typer.Option("--json", help="print one JSON object instead of tables")]
ForceOverwrite = Annotated[bool, typer.Option("--force", help="overwrite files already in the output folder")]

app = typer.Typer(
    name="forcecontrol",
    help="Force control of robot manipulators: the chapter's schemes, simulated, analysed and checked.",
    no_args_is_help=True,
    add_completion=True,  # --install-completion / --show-completion (bash, zsh, fish, PowerShell)
    pretty_exceptions_enable=False,
    # plain help (click's formatter): with Rich markup, '[s]', '[deg]', '[N/m]' and '[k_min, k_max]' in help
    # strings were read as tags and vanished from --help; every help text is printed as written
    rich_markup_mode=None,
    # inherited by every command; help lines up to 120 columns (click's default, 80, wraps the option table early)
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 120},
)
console = Console(width=None if sys.stdout.isatty() else 132)
err_console = Console(stderr=True)


def _version_callback(value: bool) -> None:
    if value:
        sys.stdout.write(f"forcecontrol {__version__}\n")
        raise typer.Exit()


@app.callback()
def _main_options(
    ctx: typer.Context,
    version: Annotated[
        bool, typer.Option("--version", "-V", help="print the version and exit", callback=_version_callback, is_eager=True)
    ] = False,
) -> None:
    """Force control of robot manipulators: the chapter's schemes, simulated, analysed and checked."""
    ctx.call_on_close(show_library_warnings())  # the library's warnings as plain note:/warning: lines meanwhile


def compile_notice() -> None:
    """Say on stderr, once, when the compiled kernels are about to compile (a cold Numba cache)."""
    _numba_cache.install_notice()


class Engine(str, Enum):
    auto = "auto"
    python = "python"
    compiled = "compiled"
    mujoco = "mujoco"


class DataFormat(str, Enum):
    auto = "auto"
    none = "none"
    csv = "csv"
    parquet = "parquet"


def comma_numbers(option: str, text: str, what: str) -> Any:
    """The numbers of an option given as ``a,b,c`` (``;`` also separates) as a float array.

    Raises:
        ParameterError: a part that is not a number (the message names ``option`` and says ``what`` it takes).
    """
    import numpy as np

    from ..errors import ParameterError

    try:
        return np.array([float(x) for x in text.replace(";", ",").split(",") if x.strip()], dtype=np.float64)
    except ValueError:
        raise ParameterError(f"{option} must be {what} separated by commas; got {text!r}") from None


def _slug(s: str) -> str:
    """A file-name-safe form of a name: letters, digits, single dots and dashes; never '.', '..' or a path."""
    slug = re.sub(r"[^A-Za-z0-9.]+", "-", s).lower()
    slug = re.sub(r"\.{2,}", ".", slug).strip("-.")[:MAX_NAME].strip("-.")
    return slug or "case"


#: the default output folder of the commands that write files (``--out``).
DEFAULT_OUT = Path("forcecontrol-out")
#: the ``--out`` option of ``run``, ``replay`` and ``compare-trace``: ``None`` stands for :data:`DEFAULT_OUT`.
OutFolder = Annotated[Path | None, typer.Option(  # noqa: UP007 - typer needs Optional
    "--out", show_default=str(DEFAULT_OUT),
    help="folder for the files; when left at the default, a re-run never overwrites nor fails: it writes in NAME-2, "
         "NAME-3, ... (said on stderr and in --json notes), as it does while another command writes in NAME")]


def _empty(folder: Path) -> bool:
    return not folder.exists() or (folder.is_dir() and not any(folder.iterdir()))


def _next_free(out: Path, name: str) -> tuple[Path, Any, str | None]:
    """``out/name``, or the first of ``out/name-2``, ``out/name-3``, ... that is missing or an empty folder and that
    no other live command has claimed (:mod:`.claim`): the folder, its claim, and why ``out/name`` was passed over
    (``None`` when it was not). A lock file a killed command left beside a folder holding files is removed."""
    from .claim import claim, holder, lock_path

    earlier = "already holds an earlier run's files (never overwritten)"
    why = None
    for i in range(1, 10_000):
        folder = out / (name if i == 1 else f"{name}-{i}")
        if not _empty(folder):
            if lock_path(folder).exists():  # a stale claim (its command was killed) or a live one: a live one stays
                stale = claim(folder)
                if not isinstance(stale, str):
                    stale.release()
            why = why or earlier
            continue
        held = claim(folder)
        if isinstance(held, str):
            why = why or f"is being written by another forcecontrol command ({holder(held)})"
            continue
        try:
            empty = _empty(folder)  # still: a command that held it may have written its files meanwhile
        except BaseException:
            held.release()
            raise
        if empty:
            return folder, held, why
        held.release()
        why = why or earlier
    return out / name, None, why  # pragma: no cover - 10,000 earlier runs: prepare_output refuses with the usual message


def _mkdir(folder: Path, parents: bool = True) -> None:
    from ..errors import OutputError

    try:
        folder.mkdir(parents=parents, exist_ok=True)
    except OSError as exc:
        why = exc.strerror or exc
        raise OutputError(f"cannot create the output folder {str(folder)!r}: {why}; choose another --out") from exc


def prepare_output(out: Path | None, name: str, force: bool, ctx: typer.Context) -> tuple[Path, str | None]:
    """The folder for a run's files and a note when it is not ``out/<name>``.

    ``out`` given: the folder ``out/<name>``, created, writable, and not holding files unless ``force``.
    ``out`` None (the user left ``--out`` at its default): ``forcecontrol-out/<name>``, or when that
    already holds an earlier run's files (and not ``force``) the next free ``<name>-2``, ``<name>-3``, ...
    (nothing is overwritten and a re-run of the same command succeeds); the note says so.

    The folder is claimed (:mod:`.claim`) until the command ends (its context ``ctx`` closes): a folder another
    live command has claimed is passed over (default output) or refused.

    Raises:
        OutputError: the folder cannot be created or written, already holds files (``--force``), or another
            live command is writing in it.
    """
    from ..errors import OutputError
    from .claim import claim, holder

    note = None
    default = out is None
    out = DEFAULT_OUT if out is None else out
    try:
        (out / name).resolve().relative_to(out.resolve())
    except ValueError as exc:  # pragma: no cover - _slug makes this impossible; kept as the rule
        raise OutputError(f"output name {name!r} would write outside {str(out)!r}") from exc
    _mkdir(out)
    if default and not force:
        folder, held, why = _next_free(out, name)
        if folder != out / name:
            hint = "--force overwrites an earlier run's files, " if why and why.startswith("already") else ""
            note = f"{str(out / name)!r} {why}: this run writes in {str(folder)!r}; {hint}--out DIR writes elsewhere"
    else:
        folder = out / name
        held = claim(folder)
    if isinstance(held, str):
        raise OutputError(f"another forcecontrol command ({holder(held)}) is writing in {str(folder)!r}; wait for it to "
                          "end, or write elsewhere with --out DIR")
    try:
        _mkdir(folder, parents=False)
        existing = sorted(p.name for p in folder.iterdir())
        if existing and not force:
            shown = ", ".join(existing[:4]) + (", ..." if len(existing) > 4 else "")
            raise OutputError(
                f"{str(folder)!r} already holds {len(existing)} file(s) ({shown}); pass --force to overwrite them, "
                "or --out to write elsewhere"
            )
        probe = folder / ".forcecontrol-write-test"
        try:
            probe.write_bytes(b"")
            probe.unlink()
        except OSError as exc:
            raise OutputError(f"cannot write in {str(folder)!r}: {exc.strerror or exc}; choose another --out") from exc
    except BaseException:
        if held is not None:
            held.release()
        raise
    if held is not None and held.held:
        ctx.call_on_close(held.release)
    return folder, note


def say_note(note: str | None) -> None:
    """Print ``note: ...`` on stderr (a command that did something other than the plain request says so)."""
    if note:
        err_console.print(f"[bold]note:[/] {escape(note)}", highlight=False, soft_wrap=True)


#: the running command's ``--json`` and whether it printed its object yet (:func:`json_aware`, :func:`_fail`)
_JSON_STATE: contextvars.ContextVar[dict[str, bool] | None] = contextvars.ContextVar("forcecontrol_json", default=None)


def json_aware(fn: Callable[..., Any]) -> Callable[..., Any]:
    """The command ``fn`` (its signature kept for typer), recording its ``--json`` (``json_out``) while it runs, for
    :func:`_fail`; ``forcecontrol.cli`` wraps every command so."""

    @functools.wraps(fn)
    def command(*args: Any, **kwargs: Any) -> Any:
        token = _JSON_STATE.set({"json": bool(kwargs.get("json_out")), "printed": False})
        try:
            return fn(*args, **kwargs)
        finally:
            _JSON_STATE.reset(token)

    return command


def print_json(obj: Any) -> None:
    """Print one JSON object (NaN and infinity as null, NumPy values as numbers) for ``--json``."""
    from ..core.jsonsafe import json_safe

    sys.stdout.write(json.dumps(json_safe(obj), indent=2, allow_nan=False) + "\n")
    state = _JSON_STATE.get()
    if state is not None:
        state["printed"] = True


def _fail(exc: Exception) -> NoReturn:
    """Print ``error: <message>`` on stderr (the message verbatim: ``[controller]`` is text, not markup); exit 2.

    A command given ``--json`` that has not printed its object yet prints one on stdout too,
    ``{"error": {"type": <the exception's class>, "message": <the message>}, "exit_code": 2}``: a script
    that reads the object finds why there is no result instead of an empty stdout.
    """
    err_console.print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False, soft_wrap=True)
    state = _JSON_STATE.get()
    if state is not None and state["json"] and not state["printed"]:
        print_json({"error": {"type": type(exc).__name__, "message": str(exc)}, "exit_code": 2})
    raise typer.Exit(code=2)


@app.command("list")
def list_command() -> None:
    """List the built-in scenarios (the chapter's examples and problems)."""
    from ..scenarios import list_scenarios

    table = Table(title="Built-in scenarios")
    table.add_column("name", style="bold")
    table.add_column("title")
    for name, title in list_scenarios().items():
        table.add_row(name, title)
    console.print(table)


@app.command("show")
def show_command(scenario: Annotated[str, typer.Argument(help="built-in scenario name")]) -> None:
    """Print a built-in scenario's TOML (a template for your own scenario files)."""
    from ..scenarios import scenario_source

    try:
        sys.stdout.write(scenario_source(scenario).read_text())
    except ForceControlError as exc:
        _fail(exc)


@app.command("schema")
def schema_command(
    json_out: Annotated[bool, typer.Option("--json", help="print the JSON schema (generated from the pydantic models)")] = False,
) -> None:
    """Print the scenario file schema: every table, type and key (generated from the scenario's pydantic models)."""
    from ..scenarios.model import scenario_json_schema

    schema = scenario_json_schema()
    if json_out:
        print(json.dumps(schema, indent=2))
        return
    defs = schema.get("$defs", {})

    def kind(p: dict[str, Any]) -> str:
        if "$ref" in p:
            return p["$ref"].rsplit("/", 1)[-1]
        if "anyOf" in p:
            return " | ".join(kind(q) for q in p["anyOf"])
        if "enum" in p:  # a str key with choices: the choices ('ur-e-series' | 'kuka-rsi' | ...)
            return " | ".join(repr(e) for e in p["enum"])
        if p.get("type") == "array":
            return f"list[{kind(p.get('items', {}))}]"
        return str(p.get("type", p.get("const", p.get("enum", "any"))))

    def dump(title: str, model: dict[str, Any]) -> None:
        t = Table(title=escape(title), title_justify="left")
        for col in ("key", "kind", "required", "default", "meaning"):  # keys never wrap (they are looked up)
            t.add_column(col, style="bold" if col == "key" else None, no_wrap=col == "key")
        required = set(model.get("required", ()))
        for k, p in model.get("properties", {}).items():
            if k == "type":
                continue
            default = "" if "default" not in p or p["default"] is None else escape(repr(p["default"]))
            t.add_row(k, escape(kind(p)), "yes" if k in required else "", default, escape(p.get("description", "")))
        console.print(t)

    top = {"properties": {k: v for k, v in schema["properties"].items() if "$ref" not in v and "discriminator" not in v},
           "required": schema.get("required", [])}
    dump("top level", top)
    def nested(p: dict[str, Any]) -> str | None:  # the definition of a nested table (e.g. [robot.servo]), if any
        refs = [q["$ref"] for q in (p, *p.get("anyOf", ())) if "$ref" in q]
        return refs[0].rsplit("/", 1)[-1] if refs else None

    for table in ("robot", "sensor", "actuator", "figure"):
        if table in defs:
            dump(f"[{table}]", defs[table])
            for key, p in defs[table].get("properties", {}).items():
                if nested(p) in defs:
                    dump(f"[{table}.{key}]", defs[nested(p)])
    for name, model in sorted(defs.items()):
        label, _, _ = name.partition("_")
        const = model.get("properties", {}).get("type", {}).get("const")
        if const is not None:
            dump(f'[{label}] type = "{const}"', model)


@app.command("run")
def run_command(
    ctx: typer.Context,
    scenario: Annotated[str, typer.Argument(help="built-in name (see 'forcecontrol list') or a .toml file")],
    json_out: JsonOut = False,
    out: OutFolder = None,
    figure: Annotated[bool, typer.Option(help="write the figure (PNG)")] = True,
    data: Annotated[DataFormat, typer.Option(
        help="each case's log (+ JSON metadata), what 'forcecontrol report FOLDER' reads; auto: csv when the run "
             "writes its folder (a figure or an animation), none with --no-figure")] = DataFormat.auto,
    engine: Annotated[Engine, typer.Option(help="simulator engine")] = Engine.auto,
    check: Annotated[bool, typer.Option(help="exit with code 1 if an expected value is missed")] = False,
    force: ForceOverwrite = False,
    animate: Annotated[
        bool, typer.Option("--animate", help="also write an animation (GIF) of each case: the arm, the environment, the force")
    ] = False,
    view3d: Annotated[bool, typer.Option("--view3d", help="also write view3d.html (view3d-CASE.html per case when there "
                                         "are several): a scrubbable 3-D view (the robot's meshes, the contact surface, "
                                         "the force arrow; 'view3d' extra)")] = False,
    set_: SetOption = None,
) -> None:
    """Simulate a scenario: summary table, figure like the chapter's, optional data files, animations, 3-D views."""
    # first: the figure process loads matplotlib on another core while this one loads the simulator;
    # leaving the block by any error stops it
    with render_process.start() if figure else render_process.FigureProcess(None) as figures:
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        from ..scenarios import load_scenario, run_scenario

        compile_notice()
        if data is DataFormat.auto:  # the run's folder keeps what 'report' reads; no folder, no files
            data = DataFormat.csv if figure or animate or view3d else DataFormat.none
        try:
            if view3d:  # the extra before the simulation: a clear error first
                from ..viz.view3d import meshcat_bundle

                meshcat_bundle()
            sets = parse_sets(set_)
            scn, set_notes = apply_sets(load_scenario(scenario), sets)
            for text in set_notes:
                say_note(text)
            writes = figure or animate or view3d or data is not DataFormat.none
            folder, note = prepare_output(out, _slug(scn.name), force, ctx) if writes else (Path(), None)
            say_note(note)
            if json_out:
                run = run_scenario(scn, engine=engine.value)
            else:
                with Progress(
                    TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total} cases"),
                    TimeElapsedColumn(), console=err_console, transient=True, disable=not err_console.is_terminal,
                ) as bar:  # transient: on a file or pipe it would leave only an empty line
                    task = bar.add_task(f"simulating {scn.name}", total=len(scn.cases))
                    run = run_scenario(scn, engine=engine.value, progress=lambda d, n, lab: bar.update(task, completed=d))
        except (ForceControlError, ImportError) as exc:
            _fail(exc)
            return
        if figure:
            from ..viz.plotting import figure_jobs

            paths = figures.render(figure_jobs(run, folder, _slug(scn.name)))
            run.files["figure"] = str(paths[0])
            for p in paths[1:]:
                run.files[f"figure:{p.stem}"] = str(p)
    if animate:
        try:
            for label, p in _animate_cases(run, folder, _slug(scn.name), quiet=json_out):
                run.files[f"animation:{label}"] = str(p)
        except ForceControlError as exc:
            _fail(exc)
    view_notes = _view3d_cases(run, folder) if view3d else []
    if data is not DataFormat.none:
        for c in run.cases:
            d, m = c.result.save(folder / f"{_slug(scn.name)}-{_slug(c.label)}", format=data.value)
            run.files[f"data:{c.label}"] = str(d)
            run.files[f"metadata:{c.label}"] = str(m)
    if json_out:
        doc = run.to_json()
        doc["set"] = sets  # the keys --set changed (in every case), {} when none
        more = [*set_notes, *([note] if note else []), *view_notes]
        if more:
            doc["notes"] = [*doc.get("notes", []), *more]
        print_json(doc)
    else:
        _print_summary(run, sets)
    if check and not run.all_checks_pass:
        raise typer.Exit(code=1)


def _animate_cases(run, folder: Path, stem: str, quiet: bool = False) -> list[tuple[str, Path]]:
    """One GIF per case, ``folder/stem-<case>.gif`` (the robot and environment rebuilt from the scenario), with a
    progress bar of the frames on stderr (an animation takes seconds to a minute per case); ``quiet``: no bar."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from ..scenarios import build_case
    from ..viz.animation import animate_run

    out = []
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("frames"),
                  TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(), console=err_console, transient=True,
                  disable=quiet or not err_console.is_terminal, redirect_stdout=False, redirect_stderr=False) as bar:
        for i, (spec, c) in enumerate(zip(run.scenario.cases, run.cases)):
            parts = build_case(spec, where=f"{run.scenario.source}: [[case]] #{i + 1}")
            name = f"{stem}-{_slug(c.label)}" if len(run.cases) > 1 else stem
            task = bar.add_task(escape(f"animating {c.label} ({i + 1}/{len(run.cases)})"), total=None)
            path = animate_run(c.result, parts["robot"], parts["environment"], inside(folder, f"{name}.gif"),
                               title=f"{run.scenario.name}: {c.label}",
                               progress=lambda done, total, task=task: bar.update(task, completed=done, total=total))
            out.append((c.label, path))
    return out


def _view3d_cases(run, folder: Path) -> list[str]:
    """Each case's 3-D view in the run folder (:func:`forcecontrol.viz.view3d.view3d_name`), recorded in
    ``run.files``; what is not drawn is said on stderr and returned (for ``--json``'s notes)."""
    from ..scenarios import build_case
    from ..viz.view3d import view3d_name, write_view3d

    labels = [c.label for c in run.cases]
    notes = []
    with err_console.status(escape(f"writing the 3-D view of {len(labels)} case(s)")):
        try:
            for i, (spec, c) in enumerate(zip(run.scenario.cases, run.cases)):
                parts = build_case(spec, where=f"{run.scenario.source}: [[case]] #{i + 1}")
                path, said = write_view3d(c.result, parts["robot"], parts["environment"],
                                          inside(folder, view3d_name(labels, i)), title=f"{run.scenario.name}: {c.label}")
                run.files[f"view3d:{c.label}"] = str(path)
                notes += [f"view3d {c.label}: {n}" for n in said]
        except (ForceControlError, ImportError) as exc:
            _fail(exc)
    for n in notes:
        say_note(n)
    return notes


def _print_summary(run, sets: dict[str, Any] | None = None) -> None:
    """The run's tables (:mod:`forcecontrol.scenarios.summary`, the rows a notebook shows too): settled values
    on every translational task axis (x y z, f_x f_y f_z of a 6-D case), contact warnings, the book's values."""
    from ..scenarios.summary import checks_table, contact_warnings, settled_table

    scn = run.scenario
    console.print(f"[bold]{escape(scn.title or scn.name)}[/]")
    for key, value in (sets or {}).items():
        console.print(f"set: {escape(key)} = {escape(json.dumps(value))}", highlight=False)
    cols, rows = settled_table(run)
    t = Table(title="Settled values (mean of the last samples) and peak contact force", title_justify="left")
    for col in cols:  # escaped: '[m]' and '[s]' are units, not rich markup
        t.add_column(escape(col), justify="right" if col != "case" else "left")
    for row in rows:
        t.add_row(*(escape(v) for v in row))
    console.print(t)
    for line in contact_warnings(run):
        console.print(f"[yellow]warning:[/] {escape(line)}", highlight=False)
    cols, rows = checks_table(run)
    if rows:
        ct = Table(title="Against the book (or the closed form)", title_justify="left")
        for col in cols:
            ct.add_column(col, justify="left" if col in ("case", "quantity") else "right")
        for row in rows:
            ok = "[green]ok[/]" if row[-1] == "ok" else "[red]MISSED[/]"
            ct.add_row(*(escape(v) for v in row[:-1]), ok)
        console.print(ct)
    for k, v in run.files.items():
        console.print(terminal_safe(f"{k}: {v}"), markup=False, highlight=False)


#: the collector's thresholds while a command runs (Python's defaults: 700, 10, 10). Start-up
#: imports NumPy, Numba, pydantic and matplotlib: about a million long-lived objects, which the
#: default gen-0 threshold collects hundreds of times over (0.1–0.2 s of a 1 s command).
COMMAND_GC_THRESHOLDS = (50_000, 20, 20)


def main(argv: list[str] | None = None) -> None:
    """The console script ``forcecontrol``: the typer app, with the collector tuned for a command.

    While the command runs, the cyclic garbage collector runs less often
    (:data:`COMMAND_GC_THRESHOLDS`; cycles are still collected); the thresholds are restored after.
    When the interpreter exits, before its shutdown collections, the heap is frozen
    (``gc.freeze``, an exit hook): the shutdown then does not traverse it again (0.2–0.3 s after a
    run that loaded the compiled kernels). A program that calls ``main`` and goes on running keeps
    its collector as it was.
    """
    import atexit
    import gc

    atexit.unregister(gc.freeze)  # once, however many times main runs
    atexit.register(gc.freeze)  # the last registered runs first: before the other exit hooks
    old = gc.get_threshold()
    gc.set_threshold(*COMMAND_GC_THRESHOLDS)
    try:
        app(args=argv, prog_name="forcecontrol")
    finally:
        gc.set_threshold(*old)
