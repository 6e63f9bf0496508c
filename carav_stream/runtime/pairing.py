"""Input pairing of a node, without sockets: which received frames go to the block together, and when.

Frames arrive on each input port in seq order (a repeated or older seq is refused). A block that pairs its
inputs gets one frame per input, all with the same seq; a frame whose partner can never come (another input
holds a later seq, received or resumed past it, or ended) is handed to the block's `unpaired` instead, and a
partner arriving after its seq was handled is refused: the block sees every seq once and its outputs stay in
order. A block that merges its inputs gets every frame alone, in arrival order per port.

After a crash, frames lost with the dead node mean some partners never come: a node restarted, or fed by a
restarted node (`recovering`), gives up on a partner once a full buffer has waited `stall_s`.
"""
from __future__ import annotations

import collections
import time
from collections.abc import Callable

from carav_stream.runtime.frames import Frame

RECOVERY_STALL_S = 2.0   # after a crash: how long a full input buffer waits for a partner before giving up


class Pairing:
    """The input side of a node: per-port buffers, end-of-stream marks and the last seq seen per port."""

    def __init__(self, ports: list[str], limit: int, *, recovering: bool = False,
                 stall_s: float = RECOVERY_STALL_S, clock: Callable[[], float] = time.monotonic) -> None:
        self.ports = list(ports)
        self.limit = limit                         # frames buffered per input while pairing
        self.recovering = recovering
        self.stall_s, self.clock = stall_s, clock
        self.stalled_since: float | None = None
        self.buffers = {p: collections.deque() for p in self.ports}
        self.eos: dict[str, int | None] = {}       # port -> frames its producer announced (None: upstream gone)
        self.last_seq: dict[str, int] = {}
        self.handled = -1                          # last seq handed to the block (a later partner is late)

    def admit(self, port: str, frame: Frame) -> tuple[bool, str | None]:
        """Judge a decoded message from `port`: (True, None) for a data frame to hand on; (False, None) for an
        end of stream or a resume marker (noted); (False, reason) for a message to refuse."""
        h = frame.header
        seq = h["seq"]
        if h["eos"]:                            # decode guarantees the key
            self.eos[port] = h.get("count")
            return False, None
        last = self.last_seq.get(port)
        if "resume" in h:                       # a producer's fresh connection: nothing before seq comes
            if h["resume"] is not True or h["arrays"]:
                return False, "a resume marker must say resume = true and carry no arrays"
            if last is None or seq - 1 > last:
                self.last_seq[port] = seq - 1
            return False, None
        if last is not None and seq <= last:
            return False, f"seq {seq} after {last}: duplicate or out of order"
        if seq <= self.handled:
            return False, (f"seq {seq} came after the node handled seq {self.handled} without it "
                           "(its partner was given up)")
        self.last_seq[port] = seq
        return True, None

    def push(self, port: str, frame: Frame) -> None:
        self.buffers[port].append(frame)

    def wanted(self) -> list[str]:
        """Ports worth receiving from: not ended and with room in their buffer."""
        return [p for p, b in self.buffers.items() if p not in self.eos and len(b) < self.limit]

    def finished(self) -> bool:
        """Every input ended and nothing is left to hand on."""
        return all(p in self.eos for p in self.ports) and not any(self.buffers.values())

    def next_set(self, merge: bool) -> tuple[str, list[Frame], str | None] | None:
        """The next frames for the block, or None while a partner may still come:
        ("process", frames in port order, None), ("process", [frame], port) when merging, or
        ("unpaired", [frame], port) for a frame whose partners can never come."""
        heads = {p: b[0] for p, b in self.buffers.items() if b}
        if not heads:
            return None
        if merge:
            port = next(iter(heads))
            return "process", [self.buffers[port].popleft()], port
        seq = min(f.seq for f in heads.values())
        group = [p for p in self.ports if p in heads and heads[p].seq == seq]
        if len(group) == len(self.ports):
            self.stalled_since = None
            self.handled = seq
            return "process", [self.buffers[p].popleft() for p in self.ports], None
        if not any(self.lacks(p, seq) for p in self.ports) and not self.given_up():
            return None                          # a partner may still come
        self.handled = seq                       # a partner that comes after this is late (admit refuses it)
        port = group[0]
        return "unpaired", [self.buffers[port].popleft()], port

    def lacks(self, port: str, seq: int) -> bool:
        """Input `port` can never supply a frame with `seq`: it holds a later one, it received one past `seq`
        (or its producer said it resumed past it), or its stream has ended."""
        buf = self.buffers[port]
        if buf:
            return buf[0].seq > seq
        return port in self.eos or self.last_seq.get(port, -1) >= seq

    def describe(self) -> str:
        """One line on each input: frames buffered (from which seq), the last seq received, end of stream."""
        out = []
        for p, b in self.buffers.items():
            ended = "" if p not in self.eos else (" ended (upstream gone)" if self.eos[p] is None
                                                   else f" ended after {self.eos[p]} frames")
            head = f" from seq {b[0].seq}" if b else ""
            out.append(f"{p}: {len(b)} buffered{head}, last seq {self.last_seq.get(p)}{ended}")
        handled = f"; handed on up to seq {self.handled}" if self.handled >= 0 else ""
        return "; ".join(out) + handled + ("; recovering" if self.recovering else "")

    def given_up(self) -> bool:
        """In recovery only: a full buffer has waited stall_s for an empty partner input, which in a graph that
        lost frames with a crashed node means the partner is gone (and the graph is stalled)."""
        if not (self.recovering and any(len(b) >= self.limit for b in self.buffers.values())):
            self.stalled_since = None
            return False
        now = self.clock()
        if self.stalled_since is None:
            self.stalled_since = now
        return now - self.stalled_since >= self.stall_s
