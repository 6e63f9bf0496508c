"""The live view's web server: a Bokeh server on its own thread and event loop, serving one page at `/`.

Bokeh's server keeps a document per browser tab in sync with Python over a websocket: the page module changes
plot data in Python and Bokeh sends only the change (a `stream` sends the new points alone). It runs on a thread
of the live_view node's process, never in the radar chain's processes; a slow or closed browser slows only that
thread (its websocket writes queue in tornado), and the node's taps skip frames rather than wait for it.
"""
from __future__ import annotations

import asyncio
import socket
import threading
from collections.abc import Callable
from typing import Any


def free_port(host: str) -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


class ViewServer:
    """serve(make_document, host, port) on a daemon thread; `url` once started; stop() ends it."""

    def __init__(self, make_document: Callable[[Any], None], host: str, port: int) -> None:
        self.make_document, self.host = make_document, host
        self.port = port or free_port(host)
        self.url = f"http://{host}:{self.port}/"
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
            origins = [f"{self.host}:{self.port}", f"localhost:{self.port}", f"127.0.0.1:{self.port}"]
            self.server = Server({"/": Application(FunctionHandler(self.make_document))}, io_loop=IOLoop.current(),
                                 address=self.host, port=self.port, allow_websocket_origin=origins)
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
