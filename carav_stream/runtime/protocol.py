"""What crosses a process boundary besides frames: the node spec and the control and admin messages.

    supervisor --NodeSpec (msgpack file)--> node process
    supervisor --Control--> node   (ROUTER -> DEALER)     node --Report--> supervisor
    carav status|stop|swap, the live view --Admin--> supervisor (REQ -> REP)
    node --port tap (PUB, port_tap.py)--> an observer that asked for it through the supervisor

Every message is one msgpack map with a "type" key, packed and unpacked here only: no extension types, string
keys, never a pickle.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace
from enum import StrEnum
from typing import Any

import msgpack

LEASE_FRAMES = 64    # sources: seqs granted at a time (a restarted source skips at most this many)


class Control(StrEnum):
    """Supervisor to node."""

    GO = "go"                  # start generating (sources) once every node is ready
    STOP = "stop"              # sources: stop generating, send end of stream
    EXIT = "exit"              # every node drained: exit now
    SWAP = "swap"              # replace the block at the next frame boundary (block, params, id)
    EOS = "eos"                # an upstream node died for good: these input ports end here (ports)
    CUT = "cut"                # a downstream node died for good: stop feeding these edges (edges)
    RECONNECT = "reconnect"    # a downstream node was restarted: connect afresh to these edges (edges)
    RECOVER = "recover"        # an upstream node was restarted: partners of buffered frames may be lost
    LEASE = "lease"            # sources: you may generate every seq below `upto`; consumers: `inputs`
                               # {port: highest seq its producer can send}
    PEERS = "peers"            # consumers: `inputs` {port: [pid, start time] of the process that feeds it}
    TAP = "tap"                # copy output `port`'s frames to a port tap (port_tap.py): rate_hz, rows, for_s
                               # (0: stop), endpoint


class Report(StrEnum):
    """Node to supervisor; every report carries the node's name and pid. The supervisor takes a report only from
    a process of the node it names (the kernel's pid of the connection: senders.py)."""

    HELLO = "hello"            # the control connection is up (sent at once: where the supervisor's messages go)
    READY = "ready"            # sockets open, block started (block, version)
    HEARTBEAT = "hb"           # alive, with counters
    DONE = "done"              # drained and finished (counters, history, lost, upstream_gone)
    ERROR = "error"            # the block or the node failed (error, traceback, counters)
    REJECT = "reject"          # a message refused on an input (port, reason, count), or with what="connection"
                               # a tcp connection refused at its CURVE handshake
    SWAPPED = "swapped"        # a swap took effect (id, block, version, generation, next_seq)
    SWAP_FAILED = "swap_failed"   # a swap could not be made; the old block runs on (id, error)
    LEASE = "lease"            # sources: asks to generate seqs below `upto` (answered by Control.LEASE)


class Admin(StrEnum):
    """carav command line to supervisor; answered with {"ok": bool, ...}."""

    STATUS = "status"
    STOP = "stop"
    SWAP = "swap"
    PORTS = "ports"            # the output ports of the nodes on this host, and whether each may be tapped
    TAP = "tap"                # start, renew or stop a port tap (port_tap.py)


def pack(kind: str, **fields: Any) -> bytes:
    """One control, report or admin message."""
    return msgpack.packb({"type": str(kind), **fields}, use_bin_type=True)


def unpack(raw: bytes) -> dict[str, Any]:
    """A message as a dict; ValueError for anything that is not a msgpack map (extension types refused)."""
    try:
        msg = msgpack.unpackb(raw, raw=False, strict_map_key=True, ext_hook=_no_ext)
    except _Refused:
        raise
    except Exception as exc:   # msgpack raises several unrelated types on garbled input
        raise ValueError(f"not valid msgpack: {type(exc).__name__}: {exc}") from None
    if not isinstance(msg, dict):
        raise ValueError(f"expected a map, got {type(msg).__name__}")
    return msg


class _Refused(ValueError):
    pass


def _no_ext(code: int, data: bytes) -> Any:
    raise _Refused(f"msgpack extension type {code} refused")


@dataclass(frozen=True)
class OutEdge:
    """One edge leaving an output port: its name ("a.out -> b.inp"), the endpoint to connect to, and whether its
    consumer's port is a tap (block.In.tap: frames it has no room for are skipped, not waited for)."""

    edge: str
    connect: str
    tap: bool = False


@dataclass(frozen=True)
class NodeSpec:
    """Everything a node process needs, written by the supervisor (a new spec for every restart and swap)."""

    name: str
    type: str
    params: dict[str, Any]
    control: str                                       # the supervisor's ROUTER endpoint
    inputs: dict[str, str]                             # input port -> endpoint it binds
    outputs: dict[str, tuple[OutEdge, ...]]            # output port -> its edges
    queue_frames: int = 8
    drain_timeout_s: float = 30.0
    max_cycles: int = 0                                # sources: cycles to generate (0 = until stopped)
    block_paths: tuple[str, ...] = ()
    security: dict[str, str] = field(default_factory=dict)
    generation: int = 0                                # blocks swapped in before this process
    incarnation: int = 0                               # restarts of this node before this process
    start_seq: int = 0                                 # a restarted source resumes its sequence here
    seq_lease: int = 0                                 # sources: seqs below this may be generated (more on request)
    start_cycles: int = 0                              # sources: cycles earlier incarnations generated (budget)
    start_timeout_s: float = 0.0                       # exit if not told to go within this (0: wait for ever)
    input_bounds: dict[str, int] = field(default_factory=dict)   # input port -> highest seq its producer can send
    # input port -> [pid, start time] of each incarnation of its producer (local edges), the current one last
    producers: dict[str, list[list[int]]] = field(default_factory=dict)
    supervisor_pid: int = 0                            # control messages are taken only from it (0: from any)
    recovering: bool = False                           # restarted, or fed by a restarted node
    plane: str = "zmq"                                 # the run's data plane (runtime/planes/)
    plane_out: dict[str, Any] = field(default_factory=dict)   # output port -> what its plane writer opens
    plane_in: dict[str, Any] = field(default_factory=dict)    # input port -> what its plane reader opens
    inherit_fds: list[int] = field(default_factory=list)      # file descriptors of those, inherited from the
                                                              # supervisor

    def to_wire(self) -> bytes:
        d = asdict(self)
        d["outputs"] = {port: [asdict(e) for e in edges] for port, edges in self.outputs.items()}
        d["block_paths"] = list(self.block_paths)
        return msgpack.packb(d, use_bin_type=True)

    @classmethod
    def from_wire(cls, raw: bytes) -> NodeSpec:
        d = unpack(raw)
        known = {f.name for f in fields(cls)}
        unknown = set(d) - known
        if unknown:
            raise ValueError(f"node spec: unknown keys {sorted(unknown)}")
        d["outputs"] = {port: tuple(OutEdge(**e) for e in edges) for port, edges in d.get("outputs", {}).items()}
        d["block_paths"] = tuple(d.get("block_paths", ()))
        return cls(**d)

    def with_(self, **changes: Any) -> NodeSpec:
        return replace(self, **changes)
