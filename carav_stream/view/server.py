"""The live view's web server: a Bokeh server on its own thread and event loop, serving one page at `/`.

Bokeh's server keeps a document per browser tab in sync with Python over a websocket: the page module changes
plot data in Python and Bokeh sends only the change (a `stream` sends the new points alone). It runs on a thread
of the live_view node's process, never in the radar chain's processes; a browser tab takes an update only once it
has shown the last one (view.sync), so a slow browser gets fewer updates rather than a growing queue of writes,
and the node's taps skip frames rather than wait for it.

Who may open the page: the page can swap the run's attacker, so it is not open to every local process.
- The page's address carries a per-run token (`?token=...`, 24 random bytes from `secrets`): a request for the
  page, its metadata or its autoload script without it is refused with 403 before Bokeh sees it.
- The websocket is refused (403, before the upgrade) unless its `Origin` header names the page's own host and
  port: a client that sends none (any local script) or another web page's (a browser tab on another site) is
  refused; tornado alone would accept a missing `Origin`.
- Bokeh's sessions are signed with a per-run secret key: a websocket must present the session token the page was
  served with, so only a client that loaded the page with the run's token gets one.
The token costs one constant-time comparison per HTTP request, nothing per websocket message.
"""
from __future__ import annotations

import asyncio
import hmac
import secrets
import socket
import threading
from collections.abc import Callable
from typing import Any


def free_port(host: str) -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def new_token() -> str:
    """A per-run access token for the page's address (24 bytes from `secrets`)."""
    return secrets.token_urlsafe(24)


def page_url(host: str, port: int, token: str) -> str:
    return f"http://{host}:{port}/?token={token}"


def page_origins(host: str, port: int) -> set[str]:
    """The `host:port` forms a browser sends as the `Origin` of the page served on host:port (loopback is reached
    as localhost or 127.0.0.1)."""
    hosts = {host, "localhost", "127.0.0.1"} if host in ("127.0.0.1", "localhost") else {host}
    return {f"{h}:{port}" for h in hosts}


def _auth_provider(token: str, origins: set[str]) -> Any:
    """A Bokeh AuthProvider that refuses (tornado HTTPError 403, before any Bokeh handler runs) a websocket whose
    Origin is missing or foreign and any other request of the page without the run's token."""
    from urllib.parse import urlparse

    from bokeh.server.auth_provider import AuthProvider
    from tornado.web import HTTPError
    from tornado.websocket import WebSocketHandler

    async def user(handler: Any) -> str:
        if isinstance(handler, WebSocketHandler):
            origin = handler.request.headers.get("Origin")
            if origin is None or urlparse(origin).netloc.lower() not in origins:
                raise HTTPError(403, reason="websocket from another origin than the page's")
        elif not hmac.compare_digest(handler.get_argument("token", ""), token):
            raise HTTPError(403, reason="the live view's address needs the run's token")
        return "viewer"

    class Provider(AuthProvider):
        @property
        def get_user_async(self) -> Any:
            return user

        @property
        def login_url(self) -> str:
            return "/"   # never reached: a refused request ends in 403, never in a redirect

    return Provider()


class ViewServer:
    """serve(make_document, host, port, token) on a daemon thread; `url` (with the token) once started; stop().
    An empty token draws a new one."""

    def __init__(self, make_document: Callable[[Any], None], host: str, port: int, token: str = "") -> None:
        self.make_document, self.host = make_document, host
        self.port = port or free_port(host)
        self.token = token or new_token()
        self.url = page_url(host, self.port, self.token)
        self.started = threading.Event()
        self.error: BaseException | None = None
        self.loop: asyncio.AbstractEventLoop | None = None
        self.server: Any = None
        self.thread = threading.Thread(target=self._run, name="live-view-server", daemon=True)

    def start(self, timeout_s: float = 20.0) -> None:
        self.thread.start()
        if not self.started.wait(timeout_s):
            raise RuntimeError(f"live view: the web server did not start within {timeout_s:.0f} s")
        if self.error is not None:
            raise RuntimeError(f"live view: cannot serve on {self.host}:{self.port}: {self.error}") from self.error

    def _run(self) -> None:
        from bokeh.application import Application
        from bokeh.application.handlers.function import FunctionHandler
        from bokeh.server.server import Server
        from tornado.ioloop import IOLoop
        self.loop = asyncio.new_event_loop()
        asyncio.set_event_loop(self.loop)
        try:
            origins = page_origins(self.host, self.port)
            self.server = Server({"/": Application(FunctionHandler(self.make_document))}, io_loop=IOLoop.current(),
                                 address=self.host, port=self.port, allow_websocket_origin=sorted(origins),
                                 auth_provider=_auth_provider(self.token, origins), sign_sessions=True,
                                 secret_key=secrets.token_urlsafe(32).encode(), generate_session_ids=True)
            self.server.start()
        except BaseException as exc:       # reported by start() in the block's thread
            self.error = exc
            self.started.set()
            return
        self.started.set()
        self.loop.run_forever()

    def stop(self) -> None:
        if self.loop is None or self.server is None:
            return
        done = threading.Event()

        def shut() -> None:
            try:
                self.server.stop()
            finally:
                self.loop.stop()
                done.set()
        self.loop.call_soon_threadsafe(shut)
        done.wait(5.0)
