"""The ``forcecontrol tune`` command (registered in :mod:`forcecontrol.cli`)."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Annotated

import typer

__all__ = ["tune_command"]


def tune_command(
    scenario: Annotated[str, typer.Argument(help="built-in name (see 'forcecontrol list') or a .toml file")],
    port: Annotated[int, typer.Option(help="port of the page (0: a free one)")] = 0,
    address: Annotated[str, typer.Option(
        help="interface to listen on (default localhost; anything beyond loopback, e.g. 0.0.0.0, needs the printed token)",
    )] = "localhost",
    token: Annotated[str | None, typer.Option(  # noqa: UP007 - typer needs Optional
        help="access token for the page (default: a random one when listening beyond loopback, none on loopback)")] = None,
    overwrite: Annotated[bool, typer.Option(
        "--overwrite", help="let Save replace an existing --save file this server did not write")] = False,
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
    from ..core.text import terminal_safe
    from ..errors import ForceControlError, ParameterError
    from ..scenarios import load_scenario
    from ..workbench import require
    from .app import _fail, _slug, compile_notice, console, err_console

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
    from ..workbench.app import free_port, page_url, serve

    path = save or Path("forcecontrol-out") / f"{_slug(scn.name)}-tuned.toml"
    shown = terminal_safe(path, newlines=False)  # a file name printed as text
    if port < 0 or port > 65535:
        _fail(ParameterError(f"--port must be in 0..65535; got {port}"))
    from ..workbench.guard import is_loopback, new_token

    local = is_loopback(address)
    if token is not None and not token.strip():
        _fail(ParameterError("--token must be a non-empty string; got an empty one"))
    token = token or (None if local else new_token())
    try:
        port = port or free_port(address)
    except OSError as exc:
        _fail(ParameterError(f"--address must be an interface of this machine; cannot listen on {address!r}: {exc}"))
    url = page_url(address, port, token)
    if not local:
        err_console.print(f"warning: listening on {address}:{port}, beyond this machine; the page needs the token in "
                          "its address (anyone with it can read the scenario and Save)", markup=False, highlight=False)
    if path.exists() and not overwrite:
        err_console.print(f"note: {shown} exists; Save will not replace it (--overwrite lets it)", markup=False,
                          highlight=False)
    console.print(f"forcecontrol tune {terminal_safe(scn.name, 200, newlines=False)}: {url}  (Save writes {shown}; "
                  "Ctrl-C stops)", markup=False, highlight=False)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="the tuning server listens on")  # said above
        serve(scn, port=port, show=not no_browser, save_path=path, address=address, token=token, overwrite=overwrite)
