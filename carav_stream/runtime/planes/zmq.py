"""The inline plane (`[run] transport = "zmq"`, the default): every frame's arrays travel inside its ZeroMQ
message, as raw buffer parts behind the header (runtime/frames.py), on every edge. It gives no port any resources,
so its nodes open no writer and no reader: a port without resources sends inline, on any plane."""
from __future__ import annotations

from carav_stream.runtime.planes import Plane, PortResources


class ZmqPlane(Plane):
    def open_port(self, port: str, edges: list[str]) -> PortResources | None:
        return None
