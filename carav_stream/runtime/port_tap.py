"""Port taps: a sampled, read-only copy of the frames an output port sends, for an observer that asks for it while
the graph runs (the live view's scope and spectrum). A port tap is no edge of the graph: the graph's edges and
their counts are the same with it or without it. (A tap *input*, block.In.tap, is an edge its consumer declares.)

    observer --Admin.TAP {node, port, rate_hz, rows, for_s}--> supervisor   (the admin socket, as `carav swap`)
    supervisor --Control.TAP {port, rate_hz, rows, for_s, endpoint}--> node  (its control connection)
    node --PUB [topic "node.port", tap info, header, payload]--> observer's SUB at `endpoint`

The endpoint is an ipc socket the node binds in the run folder (mode 0700: this user's processes only), one per
node, `tap-<node>`. Who may ask is who may use the admin socket; the supervisor refuses a node that is not its
own, an output its block does not have, and a port its block declares private (block.Out.private), whose frames
go only where the graph's edges take them.

What a tap carries: the frame's header as the node stamped it for its edges (stream, seq, cycle, per_cycle, ...)
and its payload (the array "data"), only the last `rows` rows of its leading axis, copied; never the frame's
other named arrays. The tap info (msgpack map) says how much the observer missed: `frames` sent on the port since
the tap began in this process, `sent` tap messages so far, `rate_hz`, `rows` [first row copied, rows in the
payload], `incarnation` (a restarted node's counts start afresh).

It never slows the node: a frame is copied only when one is due (at most `rate_hz` a second, at most
MAX_RATE_HZ), and the PUB socket never waits: with no reader connected it drops the message, and a reader with
SNDHWM messages unread gets none until it reads. A tap lasts `for_s` seconds (at most MAX_LEASE_S) unless asked
again, so an observer that goes away leaves nothing running; for_s = 0 ends it at once.
"""
from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgpack
import numpy as np
import zmq

from carav_stream.runtime import transport
from carav_stream.runtime.frames import Frame, FrameError, encode_with_header, header_packer
from carav_stream.runtime.node_state import NodeState

MAX_RATE_HZ = 10.0       # tapped frames a second, at most
MAX_LEASE_S = 60.0       # a tap asked for longer is refused
MAX_ROWS = 64            # rows of the payload's leading axis a tap copies, at most
SNDHWM = 2               # tap messages queued towards one reader; more are dropped


@dataclass
class _Tap:
    rate_hz: float
    rows: int
    until: float          # monotonic time the tap ends unless asked again
    next_at: float = 0.0  # monotonic time the next copy is due
    frames: int = 0       # frames sent on the port since the tap began
    sent: int = 0         # tap messages sent


class PortTaps:
    """The port taps of one node process: `apply(msg)` for each Control.TAP, `offer(port, header, frame)` for each
    frame sent on a tapped port (the caller looks at `ports` first: nothing else runs for an untapped port)."""

    def __init__(self, ctx: zmq.Context, node: str, incarnation: int = 0, clock: Callable[[], float] = time.monotonic,
                 send: Callable[..., None] = transport.send_message) -> None:
        self.ctx, self.node, self.incarnation = ctx, node, incarnation
        self.clock, self._send = clock, send
        self.ports: dict[str, _Tap] = {}
        self.sock: zmq.Socket | None = None
        self.endpoint: str | None = None
        self.packer = header_packer()
        self.totals: dict[str, dict[str, int]] = {}   # per port, over every tap of it: frames, sent

    def apply(self, msg: dict[str, Any]) -> None:
        """Start, renew (new rate, rows and end) or stop (for_s 0) the tap of msg's port."""
        port, rate, rows, for_s = msg.get("port"), msg.get("rate_hz"), msg.get("rows"), msg.get("for_s")
        if not isinstance(port, str):
            return
        if not _number(for_s) or for_s <= 0:
            self.ports.pop(port, None)
            return
        if not (_number(rate) and 0 < rate <= MAX_RATE_HZ and type(rows) is int and 0 < rows <= MAX_ROWS):
            return
        if not self.bind(msg.get("endpoint")):
            return
        now = self.clock()
        tap = self.ports.get(port)
        if tap is None:
            self.ports[port] = _Tap(float(rate), rows, now + float(for_s))
        else:
            tap.rate_hz, tap.rows, tap.until = float(rate), rows, now + float(for_s)

    def bind(self, endpoint: Any) -> bool:
        """The node's PUB socket bound at `endpoint` (once); False, said in the node's log, if it cannot be."""
        if self.sock is not None:
            return endpoint == self.endpoint
        if not isinstance(endpoint, str) or not endpoint.startswith("ipc://"):
            return False
        sock = self.ctx.socket(zmq.PUB)
        sock.sndhwm = SNDHWM
        sock.linger = 0
        try:
            sock.bind(endpoint)
        except zmq.ZMQError as exc:
            sock.close()
            print(f"{self.node}: port tap not started: cannot bind {endpoint}: {exc}", file=sys.stderr, flush=True)
            return False
        self.sock, self.endpoint = sock, endpoint
        return True

    def offer(self, port: str, header: dict[str, Any], frame: Frame) -> None:
        """A frame sent on tapped `port` with its stamped `header` (not packed yet): counted, and copied to the
        tap when one is due."""
        tap = self.ports[port]
        now = self.clock()
        if now > tap.until:
            del self.ports[port]
            return
        tap.frames += 1
        total = self.totals.setdefault(port, {"frames": 0, "sent": 0})
        total["frames"] += 1
        if now < tap.next_at:
            return
        tap.next_at = now + 1.0 / tap.rate_hz
        data = frame.arrays.get("data")
        n = int(data.shape[0]) if data is not None and data.ndim else 0
        first = max(0, n - tap.rows)
        arrays = {} if data is None else {"data": (data[first:] if data.ndim else data).copy()}
        info = {"port": port, "frames": tap.frames, "sent": tap.sent + 1, "rate_hz": tap.rate_hz,
                "rows": [first, n], "incarnation": self.incarnation}
        try:
            parts = encode_with_header(dict(header), Frame(None, arrays), self.packer)
        except FrameError:
            return          # the frame's own send reports the header that cannot be encoded
        try:
            self._send(self.sock, [f"{self.node}.{port}".encode(), msgpack.packb(info), *parts], zmq.NOBLOCK)
        except zmq.Again:   # a PUB socket drops rather than refuse; any transport that refuses drops it too
            return
        tap.sent += 1
        total["sent"] += 1

    def counters(self) -> dict[str, dict[str, int]]:
        """Per port ever tapped by this process: frames sent on it while tapped, tap messages sent."""
        return {port: dict(c) for port, c in self.totals.items()}

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close(linger=0)


def _number(x: Any) -> bool:
    return type(x) in (int, float) and np.isfinite(x)


# -- the supervisor's side ------------------------------------------------------------------------------------------
def tap_endpoint(run_dir: Path, node: str) -> str:
    """Where node `node` binds its port taps (transport.ipc_endpoint: ValueError if the path is too long)."""
    return transport.ipc_endpoint(run_dir, f"tap-{node}")


def output_ports(graph: Any, nodes: dict[str, NodeState]) -> list[dict[str, Any]]:
    """Every output port of the nodes on this host (their running block's, swaps included), in the graph's order:
    node, port, kind, dtypes, doc, private, edges (how many edges of the graph leave it)."""
    out = []
    for name, st in nodes.items():
        for p in graph.registry.get(st.spec.type).cls.outputs:
            out.append({"node": name, "port": p.name, "kind": p.kind, "dtypes": list(p.dtypes), "doc": p.doc,
                        "private": p.private,
                        "edges": sum(1 for e in graph.edges_from(name) if e.src_port == p.name)})
    return out


def tap_request(graph: Any, nodes: dict[str, NodeState], run_dir: Path | None, req: dict[str, Any]
                ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """The answer to an admin tap request and the Control.TAP to send its node (None when refused): every problem
    named at once."""
    node, port = req.get("node"), req.get("port")
    rate, rows, for_s = req.get("rate_hz", 4.0), req.get("rows", 1), req.get("for_s", 10.0)
    problems = []
    if node not in nodes:
        problems.append(f"node {node!r} does not run on this host (its nodes: {', '.join(nodes)})")
    else:
        outs = {p.name: p for p in graph.registry.get(nodes[node].spec.type).cls.outputs}
        if port not in outs:
            problems.append(f"node {node!r} has no output port {port!r} (its outputs: {', '.join(outs)})")
        elif outs[port].private:
            problems.append(f"{node}.{port} is private: its frames go only where the graph's edges take them, "
                            "never to a tap")
    if not (_number(rate) and 0 < rate <= MAX_RATE_HZ):
        problems.append(f"rate_hz must be a number in (0, {MAX_RATE_HZ:g}], got {rate!r}")
    if not (type(rows) is int and 0 < rows <= MAX_ROWS):
        problems.append(f"rows must be an integer in [1, {MAX_ROWS}], got {rows!r}")
    if not (_number(for_s) and 0 <= for_s <= MAX_LEASE_S):
        problems.append(f"for_s must be a number of seconds in [0, {MAX_LEASE_S:g}] (0 ends the tap), got {for_s!r}")
    endpoint = None
    if not problems and run_dir is None:
        problems.append("this supervisor has no run folder for the taps' sockets")
    elif not problems:
        try:
            endpoint = tap_endpoint(run_dir, node)
        except ValueError as exc:
            problems.append(str(exc))
    if problems:
        return {"ok": False, "error": "; ".join(problems)}, None
    fields = {"port": port, "rate_hz": float(rate), "rows": rows, "for_s": float(for_s), "endpoint": endpoint}
    return {"ok": True, "topic": f"{node}.{port}", **fields}, fields
