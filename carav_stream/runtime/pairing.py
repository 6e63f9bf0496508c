"""Input pairing of a node, without sockets: which received frames go to the block together, and when.

Frames arrive on each input port in seq order (a repeated or older seq is refused). A block that pairs its
inputs gets one frame per input, all with the same seq; a frame whose partner can never come (another input
holds a later seq, received or resumed past it, or ended) is handed to the block's `unpaired` instead, and a
partner arriving after its seq was handled is refused: the block sees every seq once and its outputs stay in
order. A block that merges its inputs gets every frame alone, in arrival order per port.

After a crash, frames lost with the dead node mean some partners never come: a node restarted, or fed by a
restarted node (`recovering`), gives up on a partner once a full buffer has waited `stall_s`.

Every header field the pairing acts on is checked against what the node already knows before any state moves
(`check`, then `accept`): a refused message leaves the stream as it was.

- sender: on a local edge the kernel names the process that connected (ZeroMQ's `Peer-Address` over ipc ends
  in its pid); a message from any process but an incarnation of the port's producer, whose pid and start time the
  supervisor tells the node (`producers`: it starts producers before their consumers), is refused, and so is a
  message from such a pid held by a process that started at another time (senders.py: why a pid the supervisor
  names cannot change hands while the run lasts), so no other process on the host can speak for a producer.
- seq: every seq in a graph comes from a source, which generates a seq only below the lease its supervisor
  granted; a frame inherits the seq of its inputs, and a node adds at most 1 to the last seq it handled (the
  frames its block returns at the end, the resume marker). So no seq on a port can exceed the largest lease of
  the sources upstream plus the graph's depth. The supervisor tells each consumer that bound per port
  (`bounds`: lease + LEASE_FRAMES + the number of nodes); the extra lease covers a grant the consumer has not
  read yet (a source asks for the next lease half a lease ahead, so a consumer lags by at most one grant). A
  seq beyond the bound is refused; a port without a bound (fed from another host) is not checked.
- end of stream: `count` must be an int >= 0 and, on a local edge, at least the data frames received from the
  process that sends it (`count` is what that incarnation of the producer sent).
- resume: `resume = true`, no arrays, a seq within the bound.
- cycles: `frame_cycles_problem` (a frame that states `cycles` must carry that many rows of payload or of a
  per-cycle column).
"""
from __future__ import annotations

import collections
import time
from collections.abc import Callable
from typing import Any

from carav_stream.runtime.frames import Frame
from carav_stream.runtime.senders import start_ticks

RECOVERY_STALL_S = 2.0   # after a crash: how long a full input buffer waits for a partner before giving up


def frame_cycles_problem(header: dict[str, Any]) -> str | None:
    """Why a decoded frame's `cycles` cannot be believed, or None. A frame stating `cycles` = n carries n rows:
    its "data" array's leading dimension is n, or a per_cycle column lists n values; the runtime and blocks then
    size per-cycle work by n, bounded by what actually arrived. A frame without `cycles` carries 1."""
    if "cycles" not in header:
        return None
    n = header["cycles"]
    data = next((spec for spec in header["arrays"] if spec[0] == "data"), None)
    if data is not None and data[2] and data[2][0] == n:
        return None
    per = header.get("per_cycle")
    if isinstance(per, dict) and any(isinstance(v, list) and len(v) == n for v in per.values()):
        return None
    rows = f"a payload of shape {tuple(data[2])}" if data is not None else "no payload"
    return (f"cycles = {n} with {rows} and no per_cycle column of {n} values: a frame carries as many rows as "
            "the cycles it states")


class Pairing:
    """The input side of a node: per-port buffers, end-of-stream marks and the last seq seen per port.

    `bounds` (port -> highest seq its producer can send) and `producers` (port -> {pid: start time} of its
    producer's incarnations, the current one last: frames an ended one sent may still be queued) are the node's
    dicts, kept up to date by its control messages. A port without a bound is not checked against one; a message
    with a sender (a local edge) on a port without producers is refused.
    `start_of(pid)` reads a process's start time (senders.start_ticks), once per pid that matches."""

    def __init__(self, ports: list[str], limit: int, *, recovering: bool = False,
                 stall_s: float = RECOVERY_STALL_S, clock: Callable[[], float] = time.monotonic,
                 bounds: dict[str, int] | None = None, producers: dict[str, dict[int, int]] | None = None,
                 start_of: Callable[[int], int | None] = start_ticks) -> None:
        self.ports = list(ports)
        self.limit = limit                         # frames buffered per input while pairing
        self.recovering = recovering
        self.stall_s, self.clock = stall_s, clock
        self.stalled_since: float | None = None
        self.buffers = {p: collections.deque() for p in self.ports}
        self.most_buffered: dict[str, int] = {}     # port -> the most frames its buffer ever held at once
        self.eos: dict[str, int | None] = {}       # port -> frames its producer announced (None: upstream gone)
        self.last_seq: dict[str, int] = {}
        self.handled = -1                          # last seq handed to the block (a later partner is late)
        self.bounds = {} if bounds is None else bounds
        self.producers = {} if producers is None else producers
        self.start_of = start_of
        self.verified: dict[int, int] = {}             # pid -> the start time read and found to agree
        self.received: dict[tuple[str, int], int] = {}   # (port, sender pid) -> data frames taken

    def admit(self, port: str, frame: Frame, sender: int | None = None) -> tuple[bool, str | None]:
        """Judge a decoded message from `port` (sent by process `sender`, when the transport names it):
        (True, None) for a data frame to hand on; (False, None) for an end of stream or a resume marker
        (noted); (False, reason) for a message refused, which changes nothing."""
        reason = self.check(port, frame, sender)
        if reason is not None:
            return False, reason
        return self.accept(port, frame, sender), None

    def check(self, port: str, frame: Frame, sender: int | None = None) -> str | None:
        """Why the message from `port` must be refused, or None; changes nothing. Who sent it is judged first
        (a message from another process is refused whatever it says), then its fields against the stream."""
        if sender is not None:
            producers = self.producers.get(port)
            if producers is None:
                return f"sent by process {sender} before this input's producer was named"
            reason = self.check_sender(sender, producers)
            if reason is not None:
                return reason
        return self.check_stream(port, frame, sender)

    def check_sender(self, sender: int, producers: dict[int, int]) -> str | None:
        """Why process `sender` is no incarnation of the producer whose incarnations are `producers`, or None."""
        start = producers.get(sender)
        if start is None:
            current = next(reversed(producers), None)
            return f"sent by process {sender}, not by this input's producer (process {current})"
        if self.verified.get(sender) != start:
            now = self.start_of(sender)
            if now != start:
                return (f"sent by process {sender}, which started at tick {now}, not by the incarnation of this "
                        f"input's producer that had that pid (started at tick {start})")
            self.verified[sender] = start
        return None

    def check_stream(self, port: str, frame: Frame, sender: int | None) -> str | None:
        """Why the message's header cannot belong to the stream on `port` as far as it got, or None."""
        h = frame.header
        seq = h["seq"]
        last = self.last_seq.get(port)
        bound = self.bounds.get(port)
        if bound is not None and seq > bound:
            return (f"seq {seq} is beyond every seq this input's producer can have been granted (at most "
                    f"{bound})")
        if h["eos"]:                             # decode guarantees the key
            count = h.get("count")
            if type(count) is not int or count < 0:
                return f"end of stream: count must be an int >= 0, got {count!r}"
            if h["arrays"] or "resume" in h:
                return "an end of stream carries no arrays and no resume"
            received = self.received.get((port, sender), 0)
            if sender is not None and count < received:
                return f"end of stream announces {count} frames, but {received} came from its sender"
            return None
        if "resume" in h:
            if h["resume"] is not True or h["arrays"]:
                return "a resume marker must say resume = true and carry no arrays"
            return None
        cycles = frame_cycles_problem(h)
        if cycles is not None:
            return cycles
        if last is not None and seq <= last:
            return f"seq {seq} after {last}: duplicate or out of order"
        if seq <= self.handled:
            return (f"seq {seq} came after the node handled seq {self.handled} without it "
                    "(its partner was given up)")
        return None

    def accept(self, port: str, frame: Frame, sender: int | None = None) -> bool:
        """Note a message `check` passed: True for a data frame to hand on, False for an end of stream or a
        resume marker (nothing before its seq comes on this stream)."""
        h = frame.header
        seq = h["seq"]
        if h["eos"]:
            self.eos[port] = h["count"]
            return False
        last = self.last_seq.get(port)
        if "resume" in h:
            if last is None or seq - 1 > last:
                self.last_seq[port] = seq - 1
            return False
        self.last_seq[port] = seq
        key = (port, sender)
        self.received[key] = self.received.get(key, 0) + 1
        return True

    def push(self, port: str, frame: Frame) -> None:
        b = self.buffers[port]
        b.append(frame)
        if len(b) > self.most_buffered.get(port, 0):
            self.most_buffered[port] = len(b)

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
