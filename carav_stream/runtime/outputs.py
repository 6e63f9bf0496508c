"""Output delivery of a node: one PUSH connection per edge, back-pressure, cut edges and resumed connections.

A frame sent on an output port goes to every edge of that port in order; a full consumer queue blocks the send
(heartbeats and control are served meanwhile through `idle`), so nothing is dropped. An edge whose consumer died
for good is cut: what cannot be delivered on it is counted as undeliverable. When a consumer is restarted, the
edge connects afresh at once (what the old connection held is lost with it, and counted) and first sends a
header-only resume marker {resume: true, seq: X}: nothing before X comes on that stream. The connections queue
only towards a consumer they reached (transport.connect_output): what the old one held towards the dead
incarnation is dropped when it breaks, never delivered to the new one after the marker.

A tap edge (its consumer's port is a tap, block.In.tap) never blocks: a frame its queue has no room for, or
sent while its consumer is being restarted, is skipped for it and counted as skipped on that edge, never as lost
(the end of stream's count is of the frames sent, so the consumer finds nothing missing). The end of stream
itself is delivered like on any edge.

The sockets come from `connect(endpoint)` and messages leave through `send(sock, parts)`: ZeroMQ in a node, any
stand-ins in a test.
"""
from __future__ import annotations

import collections
import time
from collections.abc import Callable
from typing import Any

import zmq

from carav_stream.runtime import transport
from carav_stream.runtime.frames import Frame, encode
from carav_stream.runtime.protocol import OutEdge


class Outputs:
    def __init__(self, edges: dict[str, tuple[OutEdge, ...]], connect: Callable[[str], Any],
                 idle: Callable[[], None], send: Callable[..., None] = transport.send_message,
                 tick_s: float = transport.TICK_S, wait_room: Callable[[Any, float], None] | None = None) -> None:
        self.endpoints = {e.edge: e.connect for port_edges in edges.values() for e in port_edges}
        self.taps = {e.edge for port_edges in edges.values() for e in port_edges if e.tap}
        self._connect, self.idle, self._send, self.tick_s = connect, idle, send, tick_s
        # how a send waiting to resume waits: until the fresh connection can take a message (transport.wait_room),
        # a tick at most; a stand-in's sockets in a test: the tick
        self._wait_room = wait_room or (lambda sock, timeout_s: time.sleep(timeout_s))
        self.sockets: dict[str, list[tuple[str, Any]]] = {
            port: [(e.edge, connect(e.connect)) for e in port_edges] for port, port_edges in edges.items()}
        self.edge_of = {edge: (port, i) for port, es in self.sockets.items() for i, (edge, _) in enumerate(es)}
        self.reconnect: set[str] = set()          # edges whose consumer was restarted, not yet resumed
        self.resuming: dict[str, int] = {}        # per edge connected afresh: resume messages queued on it so far
        self.cut: set[str] = set()                # edges whose consumer died for good
        self.sent_seq: dict[str, int] = {}        # per edge: seq of the last frame ZeroMQ took
        self.c_sent = collections.Counter()       # per edge
        self.c_undeliverable = collections.Counter()
        self.c_skipped = collections.Counter()    # per tap edge: frames skipped because its queue was full
        self.eos_sent = False
        self.blocked_on: str | None = None        # the edge a send is waiting on (full queue, resume): diagnostics

    def send(self, port: str, parts: list[Any], seq: int) -> list[str]:
        """Send one encoded frame on every edge of `port`, blocking under back-pressure; the edges that did not
        get it (skipped taps, cut edges)."""
        edges = self.sockets.get(port, ())
        missed: list[str] = []
        if len(edges) == 1 and not (self.cut or self.reconnect or self.taps):   # the usual case: one consumer,
            edge, sock = edges[0]                          # room in its queue, and ZeroMQ takes the message at once
            try:
                self._send(sock, parts)
                self.c_sent[edge] += 1
                self.sent_seq[edge] = seq
                return missed
            except zmq.Again:
                pass
        for i, (edge, sock) in enumerate(edges):
            if edge in self.taps and edge not in self.cut:
                if edge not in self.reconnect and self.offer(sock, parts):
                    self.c_sent[edge] += 1
                    self.sent_seq[edge] = seq
                else:
                    self.c_skipped[edge] += 1
                    missed.append(edge)
            elif self.deliver(port, i, parts):
                self.c_sent[edge] += 1
                self.sent_seq[edge] = seq
            else:
                self.c_undeliverable[edge] += 1
                missed.append(edge)
        return missed

    def offer(self, sock: Any, parts: list[Any]) -> bool:
        """One attempt to queue a message on a tap edge without waiting: False if its queue is full. ZeroMQ
        queues a multipart message whole or not at all, and judges room on its first part."""
        try:
            self._send(sock, parts, zmq.NOBLOCK)
        except zmq.Again:
            return False
        return True

    def deliver(self, port: str, i: int, parts: list[Any]) -> bool:
        """Send on edge i of `port`, blocking under back-pressure; on the fresh connection if its consumer was
        restarted meanwhile. False only if the edge was cut (its consumer died for good)."""
        edges = self.sockets[port]
        try:
            while True:
                edge, sock = edges[i]
                if edge in self.cut:
                    return False
                if edge in self.reconnect:          # not resumed yet (no room for the marker): resume retries
                    self.blocked_on = f"{edge} (waiting to resume)"
                    self._wait_room(sock, self.tick_s)
                    self.idle()
                    continue
                try:
                    self._send(sock, parts)
                    return True
                except zmq.Again:
                    self.blocked_on = f"{edge} (queue full)"
                    self.idle()
                    if edge in self.cut:
                        return False
        finally:
            self.blocked_on = None

    def restart(self, edges: set[str]) -> None:
        """The consumers of `edges` were restarted: each connects afresh on the next `resume_all`, even one
        still resuming towards an earlier incarnation."""
        for edge in edges & self.edge_of.keys():
            self.reconnect.add(edge)
            self.resuming.pop(edge, None)

    def resume_all(self, marker: Callable[[str, str], list[list[Any]]]) -> None:
        """Connect afresh to every restarted consumer and send it `marker(port, edge)` first (the resume marker,
        and the end of stream if this node had finished). Done at once, even while this node is blocked
        elsewhere, because that consumer may be what it is blocked on. A fresh connection takes messages once it
        reached the consumer: until then the next call goes on where this one stopped, on the same connection."""
        for edge in [*self.reconnect]:
            port, i = self.edge_of[edge]
            if edge not in self.resuming:
                self.sockets[port][i][1].close(linger=0)
                self.sockets[port][i] = (edge, self._connect(self.endpoints[edge]))
                self.resuming[edge] = 0
            sock = self.sockets[port][i][1]
            try:
                for msg in marker(port, edge)[self.resuming[edge]:]:
                    self._send(sock, msg)
                    self.resuming[edge] += 1
            except zmq.Again:
                continue
            del self.resuming[edge]
            self.reconnect.discard(edge)

    def resume_seq(self, edge: str, next_seq: int) -> int:
        """Where the stream on `edge` resumes: after the last frame ZeroMQ took, or at the node's next seq."""
        return max(self.sent_seq.get(edge, -1) + 1, next_seq)

    def send_eos(self, message: Callable[[str, str], list[Any]]) -> None:
        """End of stream on every edge (message(port, edge): with the count of frames sent on it)."""
        for port, edges in self.sockets.items():
            for i, (edge, _) in enumerate(edges):
                self.deliver(port, i, message(port, edge))
        self.eos_sent = True

    def close(self, crashed: bool = False) -> None:
        """Close every connection: queued frames still leave (linger), except towards a dead consumer or after
        a crash."""
        for edges in self.sockets.values():
            for edge, sock in edges:
                sock.close(linger=0 if crashed or edge in self.cut else None)


def runtime_message(node: str, block_type: str, port: str, **header: Any) -> list[Any]:
    """A header-only message of the runtime's own (end of stream, resume marker) on output `port`."""
    return encode(Frame(header), stream=f"{node}.{port}", node=node, block=block_type)
