"""The ``forcecontrol sweep`` command (registered in :mod:`forcecontrol.cli`)."""

from __future__ import annotations

import signal
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer

from .app import JsonOut, print_json
from .overrides import SetOption, apply_sets, parse_sets

__all__ = ["sweep_command"]


class Design(str, Enum):
    grid = "grid"
    random = "random"


def sweep_command(
    scenario: Annotated[str, typer.Argument(help="built-in name or .toml file (may hold a [sweep] table)")],
    param: Annotated[list[str] | None, typer.Option(  # noqa: UP007 - typer needs Optional
        "--param", "-p",
        help="PATH=VALUES, e.g. environment.stiffness=logspace(3,6,40), controller.force_gain[0]=0.001,0.002, "
             "sensor.seed=range(0,100); random design: uniform(a,b), loguniform(a,b), normal(m,s), randint(a,b)",
    )] = None,
    design: Annotated[Design, typer.Option(help="grid (full factorial) or random (Monte Carlo)")] = Design.grid,
    samples: Annotated[int, typer.Option(min=0, help="number of random draws (design random)")] = 0,
    seed: Annotated[int, typer.Option(help="seed of the random design")] = 0,
    case: Annotated[list[str] | None, typer.Option(  # noqa: UP007
        "--case", help="scenario case label or 1-based index to sweep (repeatable; default: all)")] = None,
    out: Annotated[Path | None, typer.Option(  # noqa: UP007
        help="Parquet table (default forcecontrol-out/NAME-sweep.parquet)")] = None,
    scheduler: Annotated[str | None, typer.Option(  # noqa: UP007
        help="Dask scheduler address (tcp://host:8786); default: this machine, all cores")] = None,
    workers: Annotated[int | None, typer.Option(  # noqa: UP007
        min=1, max=4096, help="local workers, 1 to 4096 (default: all cores): threads for the planar batch kernel, "
                              "processes (at most one per core) for the cases simulate() runs (6-D arms)")] = None,
    block_size: Annotated[int | None, typer.Option(  # noqa: UP007
        min=1, help="cases per stored block, >= 1 (default: automatic)")] = None,
    figure: Annotated[bool, typer.Option(help="write the metric maps over the first two parameters (PNG)")] = True,
    x: Annotated[str | None, typer.Option(help="figure x axis (a swept parameter)")] = None,  # noqa: UP007
    y: Annotated[str | None, typer.Option(help="figure y axis (a swept parameter)")] = None,  # noqa: UP007
    overwrite: Annotated[bool, typer.Option("--overwrite", "--force", help="replace a different sweep stored at --out, or "
                                            "a file there (table, figure) forcecontrol did not write (never a folder)")] = False,
    json_out: JsonOut = False,
    set_: SetOption = None,
) -> None:
    """Sweep scenario parameters (grid or Monte Carlo), locally or on a Dask cluster; resumable.

    Each case's settling time, overshoot, steady-state force error, peak force, stability and
    contact loss go to a Parquet table (the sweep definition is in its metadata). Finished
    blocks are stored as they end: after Ctrl-C or a crash, the same command resumes.
    """
    from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn
    from rich.text import Text

    from ..errors import ForceControlError
    from ..scenarios.units import SWEEP_METRIC_UNITS
    from ..sweep.run import load_sweep_scenario, prepare_sweep, run_sweep
    from ..sweep.spec import SweepDefinition, SweepWarning
    from .app import _fail, _slug, compile_notice, console, err_console
    from .safe import escape

    compile_notice()

    class Rate(ProgressColumn):
        def render(self, task) -> Text:  # type: ignore[override]
            s = task.finished_speed or task.speed
            return Text(f"{s:,.0f} cases/s" if s else "- cases/s")

    notes: list[str] = []  # what the sweep does other than asked: stderr now, "notes" in --json

    def note(text: str) -> None:
        notes.append(text)
        err_console.print(f"[yellow]note:[/] {escape(text)}", highlight=False, soft_wrap=True)

    @contextmanager
    def noting() -> Iterator[None]:
        """SweepWarnings (a check-only key swept, a part set aside, a lock taken over, a block resubmitted) as notes."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SweepWarning)
            try:
                yield
            finally:
                for w in caught:
                    if issubclass(w.category, SweepWarning):
                        note(str(w.message))
                    else:
                        warnings.showwarning(w.message, w.category, w.filename, w.lineno)

    try:
        scn, file_def = load_sweep_scenario(scenario)
        sets = parse_sets(set_)
        scn, set_notes = apply_sets(scn, sets)
        for text in set_notes:
            note(text)
        if param:
            definition = SweepDefinition.from_options(
                param, design=design.value, samples=samples, seed=seed, cases=case or []
            )
            if file_def is not None:
                note(f"the [sweep] table of {scn.source} is replaced by the --param options")
            if design is Design.grid and seed != 0:
                note(f"--seed {seed} is ignored: only the random design draws values")
        elif file_def is not None:
            definition = file_def
            given = [o for o, v, d in (("--design", design.value, "grid"), ("--samples", samples, 0), ("--seed", seed, 0))
                     if v != d]
            if given:
                note(f"{', '.join(given)} ignored: the sweep is the [sweep] table of {scn.source} "
                     "(give --param to define it on the command line)")
            if case:
                from dataclasses import replace

                definition = replace(definition, cases=tuple(case))
        else:
            definition = None
        if definition is not None:
            _check_figure_axes(definition, figure, x, y, note)
            swept = {p.path for p in definition.parameters}
            both = sorted(k for k in sets if k in swept)
            if both:  # --set would be overridden case by case by the swept values
                from ..sweep.spec import SweepError

                raise SweepError(f"--set {', '.join(both)}: the sweep varies {'it' if len(both) == 1 else 'them'} "
                                 "(--param or the [sweep] table); give each key either to --set or to the sweep")
        if scheduler is not None and workers is not None:
            note(f"--workers {workers} is ignored: the Dask cluster at {scheduler} runs the blocks on its own workers")
        with Progress(TextColumn("[bold]checking and building cases"), BarColumn(),
                      TextColumn("{task.completed}/{task.total}"), console=err_console, transient=True,
                      disable=json_out or not err_console.is_terminal) as checking, noting():
            job = checking.add_task("build", total=None)
            prep = prepare_sweep(scn, definition, progress=lambda d, n: checking.update(job, completed=d, total=n))
    except KeyboardInterrupt:
        err_console.print("[yellow]interrupted[/] while checking and building the cases: nothing was run or written")
        raise typer.Exit(code=130) from None
    except ForceControlError as exc:
        _fail(exc)
        return
    unforced = sum(1 for j in prep.jobs if j.f_ref == 0.0)
    if unforced:  # y_final − d·f_d with f_d = 0: the column holds the settled force, which a reader takes for an error
        which = "no case asks a" if unforced == len(prep.jobs) else f"{unforced} of {len(prep.jobs)} cases ask no"
        note(f"{which} contact force (f_d = 0 at the end of the run): their steady_state_force_error is y_final − d·f_d "
             "with f_d = 0, the settled force itself (as settled_force), not a distance from a force asked")
    path = out or Path("forcecontrol-out") / f"{_slug(scn.name)}-sweep.parquet"
    if Path(path).suffix.lower() not in (".parquet", ".pq"):
        note(f"--out {str(path)!r}: the table is written in Parquet whatever its suffix (read it with "
             "pandas.read_parquet; name it .parquet to say so)")
    bar = Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total} cases"),
        Rate(), TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(), console=err_console,
        disable=json_out or not err_console.is_terminal,  # on a file or pipe: its last frame, wrapped at 80 columns
    )
    task = bar.add_task(f"sweep {scn.name}", total=prep.n_cases)
    try:
        with bar, noting(), _terminate_as_interrupt():
            result = run_sweep(
                prep, path, scheduler=scheduler, workers=workers, block_size=block_size, overwrite=overwrite,
                progress=lambda done, total: bar.update(task, completed=done),
            )
    except KeyboardInterrupt as exc:
        what = "terminated (SIGTERM)" if isinstance(exc, _Terminated) else "interrupted"
        err_console.print(f"[yellow]{what}[/]: finished cases are stored in {path}.parts; run the same command "
                          "again to resume")
        raise typer.Exit(code=143 if isinstance(exc, _Terminated) else 130) from None
    except ForceControlError as exc:
        _fail(exc)
        return
    files = {"table": str(result.path)}
    if figure:
        from ..sweep.figures import plot_sweep

        figure_path = path.with_suffix(".png")
        if figure_path == path:  # --out x.png: the figure must not be drawn over the table it was drawn from
            figure_path = path.with_name(f"{path.stem}-figure.png")
            note(f"--out {str(path)!r} ends in .png: the table is Parquet there, its figure is {str(figure_path)!r}")
        try:
            fig_path, fig_notes = plot_sweep(result, figure_path, x, y, overwrite=overwrite)
            files["figure"] = str(fig_path)
            for text in fig_notes:
                note(text)
        except (ForceControlError, ImportError) as exc:  # the table is written: say what is missing, exit 0
            note(f"no figure drawn: {exc}")
    df = result.table
    summary = {
        "scenario": scn.name,
        "cases": int(len(df)),
        "ran": result.ran,
        "resumed": result.resumed,
        "seconds": round(result.seconds, 3),
        "arm_steps_per_second": round(result.steps / result.seconds) if result.seconds > 0 else None,
        "scheduler": result.scheduler,
        "stable": int(df["stable"].sum()),
        "contact_lost": int(df["contact_lost"].sum()),
        "files": files,
        "notes": notes,
        "set": sets,
        "units": {"seconds": "s", "arm_steps_per_second": "1/s", **SWEEP_METRIC_UNITS},  # the table's metric columns too
    }
    if json_out:
        print_json(summary)
        return
    from rich.table import Table

    for key, value in sets.items():
        console.print(f"set: {escape(key)} = {escape(repr(value))}", highlight=False)
    t = Table(title=f"{scn.name}: {len(df)} cases ({result.ran} run now, {result.resumed} stored before)",
              title_justify="left")
    for col in ("case", "cases", "stable", "contact lost", "median settling [s]", "max overshoot [%]",
                "max |ss error| [N]"):
        t.add_column(escape(col), justify="left" if col == "case" else "right")  # '[s]' is a unit, not rich markup
    for label, g in df.groupby("case", sort=False):
        t.add_row(
            escape(str(label)), str(len(g)), str(int(g["stable"].sum())), str(int(g["contact_lost"].sum())),
            f"{g['settling_time'].median():.3g}", f"{g['overshoot'].max():.3g}",
            f"{g['steady_state_force_error'].abs().max():.3g}",
        )
    console.print(t)
    if result.seconds > 0:
        console.print(f"{result.steps:,} arm-steps in {result.seconds:.2f} s "
                      f"({summary['arm_steps_per_second']:,} per second, {result.scheduler})")
    for k, v in files.items():
        console.print(f"{k}: {v}")


class _Terminated(KeyboardInterrupt):
    """SIGTERM during a sweep: handled as Ctrl-C (running blocks stored, workers stopped), said as what it was."""


@contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """While the sweep runs, SIGTERM (``kill``, a job scheduler's stop) stops it as Ctrl-C does: the finished and
    running blocks are stored and the worker processes end; before, it ended the command at once, printed nothing and
    left the workers running. Only in the main thread (where Python runs signal handlers)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum: int, frame: Any) -> None:
        raise _Terminated()

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _check_figure_axes(definition: Any, figure: bool, x: str | None, y: str | None, note: Any) -> None:
    """--x/--y name swept parameters (checked before anything runs, also with --no-figure, where they are then
    ignored, said)."""
    from ..sweep.spec import SweepError

    given = [(o, v) for o, v in (("--x", x), ("--y", y)) if v is not None]
    paths = [p.path for p in definition.parameters]
    for o, v in given:  # a name that is not swept is a mistake, figure or not
        if v not in paths:
            raise SweepError(f"{o} '{v}' is not a swept parameter; expected one of {', '.join(paths)}")
    if not figure:
        if given:
            note(f"{' and '.join(o for o, _ in given)} ignored: --no-figure draws no figure")
        return
    if x is not None and x == y:
        raise SweepError(f"--x and --y must be two different swept parameters; got '{x}' for both")
    if y is not None and len(paths) < 2:
        raise SweepError(f"--y '{y}' needs a second swept parameter for the x axis; the sweep has only '{paths[0]}'")
