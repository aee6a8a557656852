"""Who may talk to the tuning server: the Host (and Origin) check and the access token.

Bokeh checks a websocket's Origin against ``websocket_origin`` but never the Host header, so a page
on a DNS-rebinding domain (``evil.example`` resolving to 127.0.0.1) whose Host and Origin are both
``evil.example:<port>`` passes. :class:`RequestGuard` runs before Tornado picks any handler (page,
static file or websocket) and answers HTTP 403 unless

* the Host names this machine: a loopback name (``localhost``, ``127.x.y.z``, ``::1``) with the
  server's port, and, when the server listens beyond loopback, also an IP literal or this
  machine's host name;
* a request that carries an Origin comes from the same host and port as its Host;
* when a token is set (always when listening beyond loopback, as Jupyter does): the request
  carries it as ``?token=...``, as the cookie set by the first such request, or as an
  ``Authorization: token ...`` header. A page request with a good ``?token=`` gets the cookie and
  a redirect to the same address without the token, so the websocket (which cannot carry the
  query) and the static files are let in by the cookie.
"""

from __future__ import annotations

import ipaddress
import secrets
import socket
from typing import Any
from urllib.parse import parse_qsl, urlencode, urlsplit

__all__ = ["RequestGuard", "is_loopback", "new_token"]

_LOOPBACK_NAMES = {"localhost", "localhost.localdomain", "ip6-localhost"}


def new_token() -> str:
    """A random access token (``secrets.token_urlsafe``, 32 bytes)."""
    return secrets.token_urlsafe(32)


def _ip(host: str) -> Any:
    try:
        return ipaddress.ip_address(host.strip("[]"))
    except ValueError:
        return None


def is_loopback(address: str) -> bool:
    """True when ``address`` (a name or IP) is reachable only from this machine."""
    ip = _ip(address)
    return address.lower() in _LOOPBACK_NAMES if ip is None else ip.is_loopback


def _split_host(netloc: str) -> tuple[str, int | None] | None:
    try:
        parts = urlsplit("//" + netloc)
        return (parts.hostname or "").lower(), parts.port
    except ValueError:
        return None


class RequestGuard:
    """The Host/Origin/token policy of one tuning server (see the module docstring).

    Args:
        address: the address the server listens on; port: its port.
        token: the access token (None: none needed; only allowed on loopback).
    """

    def __init__(self, address: str, port: int, token: str | None = None) -> None:
        self.address, self.port, self.token = address, int(port), token
        self.loopback = is_loopback(address)
        if token is None and not self.loopback:
            from ..errors import ParameterError

            raise ParameterError(f"token: a server listening on {address!r} (beyond loopback) needs a token; got none")
        self.cookie = f"forcecontrol-tune-token-{self.port}"
        names = set(_LOOPBACK_NAMES)
        if not self.loopback:
            names |= {address.lower(), socket.gethostname().lower(), socket.getfqdn().lower()}
        self._names = names

    def host_allowed(self, netloc: str) -> bool:
        """True for a Host header (``name:port``) that names this server."""
        split = _split_host(netloc)
        if split is None or split[1] != self.port:
            return False
        host, ip = split[0], _ip(split[0])
        if host in self._names:
            return True
        if ip is None:
            return False
        return ip.is_loopback or not self.loopback  # beyond loopback: any IP literal (a rebinding page has a name)

    def _token_given(self, request: Any) -> tuple[bool, bool]:
        """(the request carries the token, it came in the query)."""
        if self.token is None:
            return True, False
        query = dict(parse_qsl(urlsplit(request.uri).query))
        if secrets.compare_digest(query.get("token", ""), self.token):
            return True, True
        auth = request.headers.get("Authorization", "")
        if auth.lower().startswith("token ") and secrets.compare_digest(auth[6:].strip(), self.token):
            return True, False
        morsel = request.cookies.get(self.cookie) if hasattr(request, "cookies") else None
        return bool(morsel is not None and secrets.compare_digest(morsel.value, self.token)), False

    def verdict(self, request: Any) -> tuple[str, str] | None:
        """None to let the request through; else (``"refuse"``, reason) or (``"login"``, redirect target)."""
        host = request.headers.get("Host", "")
        if not self.host_allowed(host):
            return "refuse", f"refused: the Host header {host!r} does not name this server (port {self.port})"
        origin = request.headers.get("Origin")
        if origin is not None:
            o = urlsplit(origin)
            if _split_host(o.netloc) != _split_host(host):
                return "refuse", f"refused: the Origin {origin!r} is not this server ({host!r})"
        ok, in_query = self._token_given(request)
        if not ok:
            return "refuse", "refused: this server needs its access token (open the address with ?token=... it printed)"
        if in_query and request.method == "GET" and request.headers.get("Upgrade", "").lower() != "websocket":
            parts = urlsplit(request.uri)
            query = urlencode([(k, v) for k, v in parse_qsl(parts.query, keep_blank_values=True) if k != "token"])
            return "login", parts.path + (f"?{query}" if query else "")
        return None

    def install(self, application: Any) -> None:
        """Run :meth:`verdict` before the Tornado ``application`` routes any request."""
        from tornado.web import RequestHandler

        guard = self

        class _Refuse(RequestHandler):
            def initialize(self, reason: str) -> None:
                self.reason = reason

            def prepare(self) -> None:
                self.set_status(403)
                self.set_header("Content-Type", "text/plain; charset=utf-8")
                self.finish(self.reason + "\n")

        class _Login(RequestHandler):
            def initialize(self, target: str) -> None:
                self.target = target

            def prepare(self) -> None:
                self.set_cookie(guard.cookie, guard.token or "", httponly=True, samesite="Strict")
                self.redirect(self.target)

        find = application.find_handler

        def find_handler(request: Any, **kwargs: Any) -> Any:
            v = guard.verdict(request)
            if v is None:
                return find(request, **kwargs)
            if v[0] == "login":
                return application.get_handler_delegate(request, _Login, {"target": v[1]})
            return application.get_handler_delegate(request, _Refuse, {"reason": v[1]})

        application.find_handler = find_handler
