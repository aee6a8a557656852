"""A progress line on stderr for the steps of a command that has no count to show (reading a log, replaying it, compiling).

``with busy("reading the log", quiet=json_out) as step: ...; step("replaying 120000 samples")``
shows a spinner, the current step and the time elapsed (transient: gone when the command prints
its result). The first call of a compiled kernel (a cold cache) happens inside a step, so the
seconds it takes are seen counting, not a frozen terminal.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["busy"]


@contextmanager
def busy(description: str, *, quiet: bool = False) -> Iterator[Callable[[str], None]]:
    """A spinner with ``description`` and the elapsed time on stderr; yields ``step(text)`` to change the text."""
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from .app import err_console
    from .safe import escape

    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=err_console,
                  transient=True, disable=quiet or not err_console.is_terminal, redirect_stdout=False,
                  redirect_stderr=False) as bar:  # transient: on a file or pipe it would leave only an empty line
        task = bar.add_task(escape(description), total=None)
        yield lambda text: bar.update(task, description=escape(text))
