"""A node's control link: the DEALER socket to its supervisor's ROUTER, what the supervisor told it
(control.ControlState), the reports it sends (protocol.Report), heartbeats, the deadline for its go, and a
source's seq leases.

Re-entrancy: `idle()` is the one callback a node hands to whatever may block (a send waiting for room in a full
queue, a producer waiting for room on its data plane) and calls between frames and whenever a receive times out;
at most every CONTROL_S it serves the link (`serve`). Serving sends a heartbeat when one is due (its counters
come from the node), applies every queued control message to the state, and then calls the node's `on_control`,
which acts on the ports at once: an input whose producer died for good ends, an edge whose consumer died for good
is cut, and an edge whose consumer was restarted connects afresh and sends its resume marker, even in the middle
of a send to another edge (that consumer may be what the send waits for). Serving never runs the block and never
swaps it: a swap asked is only taken between two frames, by the node's block driver (node_driver.py).

Sequence leases: a source generates a seq only below the lease its supervisor granted and asks for more ahead of
time (`within_lease`), so a restarted source resumes beyond every seq its killed incarnation may have sent (from
the lease, not from counters that a SIGKILL leaves stale): no consumer ever sees one seq with two contents.

Start: a node that is not told to go (Control.GO) within its spec's start_timeout_s exits (status 1): its
supervisor is gone or cannot run the graph, and nobody else could stop it.

Senders: the socket's identity is random (no other process can know it, let alone take it first); the node
says hello at once, and the supervisor takes that connection as the node's once the kernel's pid of it is the
node's (senders.py), never for the name a message gives. The node takes control messages only from its
supervisor's process (spec.supervisor_pid), by the same pid: a message from any other is refused and named in
the node's log.
"""
from __future__ import annotations

import os
import secrets
import sys
import time
from collections.abc import Callable
from typing import Any

import zmq

from carav_stream.runtime import transport
from carav_stream.runtime.control import ControlState
from carav_stream.runtime.protocol import LEASE_FRAMES, NodeSpec, Report, pack, unpack
from carav_stream.runtime.senders import sender_pid

HEARTBEAT_S = 0.5
CONTROL_S = 0.01         # while frames flow, the control socket is looked at no more often than this


def connection_id() -> bytes:
    """A random identity for a control connection (ZeroMQ reserves those starting with a zero byte)."""
    return b"n" + secrets.token_bytes(15)


class ControlLink:
    """`counters()` gives a heartbeat's counters; `on_control()` acts on what the served messages changed."""

    def __init__(self, ctx: zmq.Context, spec: NodeSpec, *, source: bool, counters: Callable[[], dict[str, Any]],
                 on_control: Callable[[], None]) -> None:
        self.name = spec.name
        self.sock = ctx.socket(zmq.DEALER)
        self.sock.identity = connection_id()
        self.sock.linger = 2000
        self.sock.connect(spec.control)
        self.supervisor_pid = spec.supervisor_pid
        self.n_refused = 0
        self.ctl = ControlState(go=not source, recovering=spec.recovering, seq_lease=spec.seq_lease,
                                input_bounds=spec.input_bounds, producers=spec.producers)
        self.counters, self.on_control = counters, on_control
        self.start_timeout_s = spec.start_timeout_s
        self.go_by = time.monotonic() + spec.start_timeout_s if spec.start_timeout_s else None
        self.lease_asked = 0
        self.next_hb = 0.0
        self.next_control = 0.0
        self.tell(Report.HELLO)

    def tell(self, kind: Report, **fields: Any) -> None:
        self.sock.send(pack(kind, node=self.name, pid=os.getpid(), **fields))

    def idle(self) -> None:
        """Serve the link at most every CONTROL_S; called between frames and every transport.TICK_S while blocked
        in ZeroMQ or waiting for room on the data plane."""
        now = time.monotonic()
        if now >= self.next_control:
            self.next_control = now + CONTROL_S
            self.serve()

    def serve(self) -> None:
        """Send a heartbeat if one is due, take every queued control message, and act on what they said."""
        now = time.monotonic()
        if now >= self.next_hb:
            self.tell(Report.HEARTBEAT, counters=self.counters())
            self.next_hb = now + HEARTBEAT_S
        while self.sock.get(zmq.EVENTS) & zmq.POLLIN:
            self.take(self.sock.recv(copy=False))
        if self.go_by is not None and not self.ctl.told_go and now > self.go_by:
            # no supervisor to report to or to be stopped by: leave at once, saying why in the node's log
            print(f"{self.name}: not told to go within {self.start_timeout_s:.0f} s of starting; its "
                  "supervisor is gone or cannot start the graph; exiting", file=sys.stderr, flush=True)
            os._exit(1)
        self.on_control()

    def take(self, part: zmq.Frame) -> None:
        """Apply one control message, if it comes from the supervisor's process."""
        sender = sender_pid(part)
        if self.supervisor_pid and sender != self.supervisor_pid:
            self.n_refused += 1
            print(f"{self.name}: control message #{self.n_refused} refused: sent by process {sender}, not by the "
                  f"supervisor (process {self.supervisor_pid})", file=sys.stderr, flush=True)
            return
        try:
            msg = unpack(part.bytes)
        except ValueError as exc:
            print(f"{self.name}: control message refused: {exc}", file=sys.stderr, flush=True)
            return
        self.ctl.apply(msg)

    def wait(self, seconds: float) -> None:
        """Wait up to `seconds` for a control message, then serve the link."""
        self.sock.poll(seconds * 1000)
        self.serve()

    def within_lease(self, seq: int) -> bool:
        """Ask for more seqs half a lease ahead; False (after waiting on control) while `seq` is beyond the lease."""
        if seq + LEASE_FRAMES // 2 >= self.ctl.seq_lease and self.lease_asked < seq + LEASE_FRAMES:
            self.lease_asked = seq + LEASE_FRAMES
            self.tell(Report.LEASE, upto=self.lease_asked)
        if seq < self.ctl.seq_lease:
            return True
        self.wait(transport.TICK_S)
        return False

    def until_released(self, timeout_s: float) -> None:
        """Serve the link until the supervisor releases the node, or for `timeout_s` at most."""
        deadline = time.monotonic() + timeout_s
        while not self.ctl.released and time.monotonic() < deadline:
            self.wait(HEARTBEAT_S)

    def close(self) -> None:
        self.sock.close(linger=2000)
