"""The ``forcecontrol`` command line: one module per command, the only importer of typer and rich.

``forcecontrol.cli.app`` is the typer application (the console script); each command module
registers its command on it when imported here.
"""

from __future__ import annotations

from ..core.threads import one_blas_thread

one_blas_thread()  # before any command module loads NumPy: core.threads says why

from . import analyze, cache, calibrate, compare, compare_trace, config, convert, design, replay, report, sweep, task, tune  # noqa: E402
from .app import app, json_aware, main  # noqa: E402

# each module's ``*_command`` functions, in the order of ``forcecontrol --help``:
# ``calibrate_plan_command`` is the command ``calibrate-plan``
for _module in (analyze, task, sweep, compare, calibrate, replay, compare_trace, convert, config, design, tune, report, cache):
    for _name, _fn in vars(_module).items():
        if _name.endswith("_command") and getattr(_fn, "__module__", None) == _module.__name__:
            app.command(_name.removesuffix("_command").replace("_", "-"))(_fn)
# every command records its --json while it runs: an error (app._fail) is then a JSON object on stdout too
for _info in app.registered_commands:
    _info.callback = json_aware(_info.callback)

__all__ = ["app", "main"]
