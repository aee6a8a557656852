"""The tuning server: one page (:class:`~forcecontrol.workbench.app.TuneApp`) per browser session, behind the guard.

Start-up order (the page answers before the kernels are loaded): the scenario is loaded and
checked, the simulator's kernels are loaded (or compiled) in a background thread while the
server starts, and each page is served with its layout at once; its first simulation runs when
the browser's websocket is connected (``pn.state.onload``) and the page shows "computing…" until then.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

__all__ = ["serve", "free_port", "page_url"]


def free_port(address: str = "localhost") -> int:
    """A TCP port nobody listens on at ``address`` now (the OS picks it)."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((address, 0))
        return int(s.getsockname()[1])


def serve(scenario: Any, *, app_class: Any, port: int = 0, show: bool = True, save_path: str | Path = "tuned.toml",
          threaded: bool = False, address: str = "localhost", token: str | None = None,
          overwrite: bool = False) -> Any:
    """Serve the tuning page at ``http://address:port/`` (one ``app_class`` per browser session).

    Every request (page, static file, websocket) must name this server in its Host header (and
    Origin, when it has one) and, when a token is set, carry it (:mod:`.guard`). Listening beyond
    loopback (``address="0.0.0.0"``, a LAN address) always needs a token: without one a random
    token is made, and a :class:`UserWarning` gives the address with it.

    Args:
        scenario: a loaded scenario, a built-in name or a TOML path (loaded once, checked here).
        app_class: the page (:class:`~forcecontrol.workbench.app.TuneApp`; :func:`forcecontrol.workbench.app.serve`
            passes it, so that this module does not import the page's).
        port: the port (0: a free one); show: open the browser; threaded: run the server in a
            background thread and return it (``.stop()`` ends it) instead of blocking.
        address: the interface to listen on; token: the access token (``?token=...``).
        overwrite: Save may replace an existing ``save_path`` this server did not write.

    Returns:
        The Panel server (threaded; its ``url`` attribute is the address with the token) or
        nothing once the blocking server stops.
    """
    import uuid
    import warnings
    import webbrowser

    from panel.io.server import get_server
    from tornado.ioloop import IOLoop

    from ..scenarios import Scenario, load_scenario
    from .guard import RequestGuard, is_loopback, new_token

    scn = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    if port == 0:
        port = free_port(address)
    local = is_loopback(address)
    if token is None and not local:
        token = new_token()
    url = page_url(address, port, token)
    if not local:
        warnings.warn(f"the tuning server listens on {address}:{port}, beyond this machine: anyone who can reach it "
                      f"and has the token can read the scenario and write {save_path}; open {url}", UserWarning,
                      stacklevel=3)
    guard = RequestGuard(address, port, token)
    warm = threading.Thread(target=_warm, args=(scn,), name="forcecontrol-tune-warm-up", daemon=True)
    warm.start()  # load (or compile) the simulator's kernels while the server starts
    created: set[Path] = set()

    def page() -> Any:
        import panel as pn

        app = app_class(scn, save_path, overwrite=overwrite, created=created, deferred=True)

        def load() -> None:
            warm.join()
            app.load()

        pn.state.onload(load)
        return app.panel()

    origins = [f"localhost:{port}", f"127.0.0.1:{port}", f"{address}:{port}"] if local else [f"*:{port}"]  # + the guard

    def run(**kwargs: Any) -> Any:
        server = get_server({"/": page}, **kwargs)
        guard.install(server._tornado)  # the Host/Origin/token check before any handler
        if show:
            server.io_loop.add_callback(webbrowser.open, url)
        server.start()
        try:
            server.io_loop.start()
        except RuntimeError:
            pass
        return server

    kwargs = {"port": port, "address": address, "show": False, "start": False, "title": f"forcecontrol tune: {scn.name}",
              "websocket_origin": origins, "verbose": False}
    if not threaded:
        run(**kwargs)
        return None
    from panel.io.state import state
    from panel.io.threads import StoppableThread

    kwargs["loop"] = IOLoop(make_current=False)
    kwargs["server_id"] = uuid.uuid4().hex
    thread = StoppableThread(target=run, io_loop=kwargs["loop"], kwargs=kwargs, owns_loop=True)
    state._threads[kwargs["server_id"]] = thread
    thread.url = url  # type: ignore[attr-defined]
    thread.start()
    return thread


def page_url(address: str, port: int, token: str | None = None) -> str:
    """The address to open: a loopback name when listening on every interface, with ``?token=`` if set."""
    host = "localhost" if address in ("0.0.0.0", "::", "") else (f"[{address}]" if ":" in address else address)
    return f"http://{host}:{port}/" + (f"?token={token}" if token else "")


def _warm(scn: Any) -> None:
    """One evaluation of the first case: the kernels are loaded (or compiled) once per process."""
    from ..errors import ForceControlError
    from .session import TuneSession

    try:
        TuneSession(scn).evaluate()
    except ForceControlError:  # the page reports it
        pass
