"""What a node's supervisor has told it: the state that control messages set, without sockets.

The node reads its DEALER socket and hands every message to `ControlState.apply`; its loops then look at the
flags (go, stopping, released), the pending swap, and the edges and ports the message names.
"""
from __future__ import annotations

from typing import Any

from carav_stream.runtime.protocol import Control


class ControlState:
    def __init__(self, *, go: bool, recovering: bool = False, seq_lease: int = 0,
                 input_bounds: dict[str, int] | None = None,
                 producers: dict[str, list[list[int]]] | None = None) -> None:
        self.go = go                                  # sources wait for it; other nodes start at once
        self.told_go = False                          # Control.GO came (every node must get it, in time)
        self.stopping = False                         # sources: stop generating
        self.released = False                         # every node drained: exit
        self.recovering = recovering                  # an upstream node was restarted: partners may be lost
        self.pending_swap: dict[str, Any] | None = None
        self.taps: list[dict[str, Any]] = []          # port taps asked (Control.TAP), not yet applied
        self.ended_ports: set[str] = set()            # inputs whose producer died for good
        self.cut_edges: set[str] = set()              # outputs whose consumer died for good
        self.reconnect_edges: set[str] = set()        # outputs whose consumer was restarted
        self.seq_lease = seq_lease                    # sources: seqs below this may be generated
        self.input_bounds = dict(input_bounds or {})  # input port -> highest seq its producer can send (grows)
        # input port -> {pid: start time} of the processes that fed it, the current producer last (an ended one's
        # frames may still be queued; senders.py: why its pid cannot change hands while the run lasts)
        self.producers = {port: {pid: start for pid, start in pairs} for port, pairs in (producers or {}).items()}

    def apply(self, msg: dict[str, Any]) -> None:
        """Take one control message into the state; unknown kinds are ignored (a newer supervisor's)."""
        kind = msg.get("type")
        if kind == Control.GO:
            self.go = self.told_go = True
        elif kind == Control.STOP:
            self.stopping = True
        elif kind == Control.EXIT:
            self.released = True
        elif kind == Control.SWAP:
            self.pending_swap = msg
        elif kind == Control.EOS:
            self.ended_ports.update(_names(msg, "ports"))
        elif kind == Control.CUT:
            self.cut_edges.update(_names(msg, "edges"))
        elif kind == Control.RECONNECT:
            self.reconnect_edges.update(_names(msg, "edges"))
        elif kind == Control.RECOVER:
            self.recovering = True
        elif kind == Control.LEASE:
            if type(msg.get("upto")) is int:
                self.seq_lease = max(self.seq_lease, msg["upto"])
            for port, bound in _ints(msg, "inputs").items():
                self.input_bounds[port] = max(self.input_bounds.get(port, bound), bound)
        elif kind == Control.TAP:
            self.taps.append(msg)
        elif kind == Control.PEERS:
            for port, (pid, start) in _pairs(msg, "inputs").items():
                pids = self.producers.setdefault(port, {})
                pids.pop(pid, None)
                pids[pid] = start

    def take_swap(self) -> dict[str, Any] | None:
        msg, self.pending_swap = self.pending_swap, None
        return msg


def _names(msg: dict[str, Any], key: str) -> list[str]:
    value = msg.get(key, [])
    return [v for v in value if isinstance(v, str)] if isinstance(value, list) else []


def _pairs(msg: dict[str, Any], key: str) -> dict[str, tuple[int, int]]:
    value = msg.get(key, {})
    if not isinstance(value, dict):
        return {}
    return {k: (v[0], v[1]) for k, v in value.items()
            if isinstance(k, str) and isinstance(v, list) and len(v) == 2 and all(type(x) is int for x in v)}


def _ints(msg: dict[str, Any], key: str) -> dict[str, int]:
    value = msg.get(key, {})
    return {k: v for k, v in value.items() if isinstance(k, str) and type(v) is int} if isinstance(value, dict) else {}
