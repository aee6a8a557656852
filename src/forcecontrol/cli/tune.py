"""The ``forcecontrol tune`` command (registered in :mod:`forcecontrol.cli`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

__all__ = ["tune_command"]


def tune_command(
    scenario: Annotated[str, typer.Argument(help="built-in name (see 'forcecontrol list') or a .toml file")],
    port: Annotated[int, typer.Option(help="local port of the page (0: a free one)")] = 0,
    no_browser: Annotated[bool, typer.Option("--no-browser", help="do not open a browser; print the address")] = False,
    save: Annotated[Path | None, typer.Option(  # noqa: UP007 - typer needs Optional
        help="where the Save button writes the tuned scenario (default forcecontrol-out/NAME-tuned.toml)")] = None,
) -> None:
    """Tune a scenario in the browser: sliders for every gain and the environment's stiffness and damping.

    Each change re-simulates the case and redraws the force and position responses over the book's,
    the closed-loop poles and (direct force schemes) the sampled-loop stability limit against the
    environment stiffness; a button writes the tuned scenario as TOML. Stop with Ctrl-C.
    Needs the 'workbench' extra (panel).
    """
    from ..errors import ForceControlError
    from ..scenarios import load_scenario
    from ..workbench import require
    from .app import _fail, _slug, compile_notice, console

    try:
        require("panel")
    except ImportError as exc:
        _fail(exc)
    compile_notice()
    try:
        scn = load_scenario(scenario)
    except ForceControlError as exc:
        _fail(exc)
        return
    from ..workbench.app import free_port, serve

    path = save or Path("forcecontrol-out") / f"{_slug(scn.name)}-tuned.toml"
    if port < 0 or port > 65535:
        _fail(ValueError(f"--port must be in 0..65535; got {port}"))
    port = port or free_port()
    console.print(f"forcecontrol tune {scn.name}: http://localhost:{port}/  (Save writes {path}; Ctrl-C stops)",
                  markup=False, highlight=False)
    serve(scn, port=port, show=not no_browser, save_path=path)
