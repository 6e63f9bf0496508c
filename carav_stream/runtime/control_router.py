"""The supervisor's end of the control plane: its ROUTER socket, which node each connection is, and what it refuses.

A message is a node's only if the kernel says a process of that node sent it: ZeroMQ's Peer-Address of the ipc
connection ends in the sender's pid (senders.py), and every pid the supervisor started for a node stays that
node's for the whole run. The name a message gives and the connection's identity count for nothing. A node's
current incarnation says hello as soon as it connects; from then on its connection is where the supervisor's
messages to that node go (a restarted node's new process gets a new one). Messages to a node wait until that
connection is known, so a node hears everything said to it since it was started.

Refused, counted by reason (the first MAX_LOGGED logged): a message from a process that is no node's, one that
names another node than its sender's, one that is not two parts (connection, body), one whose body is not a
msgpack map. A refused message changes nothing. A message from an ended incarnation of a node (its last words,
read after the new one started) is neither the node's word nor a forgery: it is left aside.
"""
from __future__ import annotations

import collections
from collections.abc import Callable, Iterator
from typing import Any

import zmq

from carav_stream.runtime.protocol import unpack
from carav_stream.runtime.senders import sender_pid

MAX_LOGGED = 20          # refusals logged one by one; the rest are counted
MAX_REASONS = 20         # distinct reasons kept for the summary; the rest are counted under OTHER
OTHER = "other reasons"


class ControlRouter:
    """`sock` is the bound ROUTER; `log(line)` tells the user."""

    def __init__(self, sock: zmq.Socket, log: Callable[[str], None]) -> None:
        self.sock, self.log = sock, log
        self.owner: dict[int, str] = {}                  # pid of every incarnation -> its node
        self.current: dict[str, int] = {}                # node -> pid of its current incarnation
        self.routes: dict[str, bytes] = {}               # node -> its current incarnation's connection
        self.outbox: dict[str, list[bytes]] = {}         # node -> messages waiting for that connection
        self.refused: collections.Counter[str] = collections.Counter()
        self.n_refused = 0

    def started(self, node: str, pid: int) -> None:
        """A new process `pid` of `node` was started: its messages are the node's from now on, and messages to the
        node wait for its connection (what was queued for the process before it is dropped with it)."""
        self.owner[pid] = node
        self.current[node] = pid
        self.routes.pop(node, None)
        self.outbox[node] = []

    def send(self, node: str, body: bytes) -> None:
        route = self.routes.get(node)
        if route is None:
            self.outbox.setdefault(node, []).append(body)
        else:
            self.sock.send_multipart([route, body])

    def receive(self) -> Iterator[tuple[str, dict[str, Any]]]:
        """(node, message) for every queued message a node's current process sent; the others are refused or left
        aside."""
        while True:
            try:
                parts = self.sock.recv_multipart(zmq.NOBLOCK, copy=False)
            except zmq.Again:
                return
            got = self.judge(parts)
            if got is not None:
                yield got

    def judge(self, parts: list[zmq.Frame]) -> tuple[str, dict[str, Any]] | None:
        """(node, message) if the message is its current process's; None after refusing it or leaving it aside."""
        pid = sender_pid(parts[-1])
        node = self.owner.get(pid) if pid is not None else None
        sender = f"process {pid}" if node is None else f"node {node!r}'s process {pid}"
        if len(parts) != 2:
            return self.refuse(f"a message of {len(parts)} parts from {sender}")
        try:
            msg = unpack(parts[1].bytes)
        except ValueError as exc:
            return self.refuse(f"a message from {sender} that is {exc}")
        claimed = msg.get("node")
        if node is None:
            said = f" (it says it is node {claimed!r})" if isinstance(claimed, str) else ""
            return self.refuse(f"sent by process {pid}, which is no process of this run's nodes{said}")
        if claimed is not None and claimed != node:
            return self.refuse(f"sent by {sender}, naming node {claimed!r}")
        if pid != self.current[node]:
            return None
        route = parts[0].bytes
        if self.routes.get(node) != route:
            self.routes[node] = route
            for body in self.outbox.pop(node, []):
                self.sock.send_multipart([route, body])
        return node, msg

    def refuse(self, reason: str) -> None:
        self.n_refused += 1
        key = reason if reason in self.refused or len(self.refused) < MAX_REASONS else OTHER
        self.refused[key] += 1
        if self.n_refused <= MAX_LOGGED:
            self.log(f"carav: control message #{self.n_refused} refused: {reason}")
        return None
