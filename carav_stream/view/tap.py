"""A page's port tap: one port of the running graph watched for the scope and the spectrum (runtime/port_tap.py).

TapWatch asks the run's supervisor for a tap of `node.port` (the admin request `tap`, as `carav swap` asks for a
swap) and asks again every RENEW_S, for LEASE_S each time: a page that goes away (its tab closed, the view node
gone) leaves the tap to end by itself. Its copies arrive on a SUB socket of a daemon thread of its own; nothing
the page does waits for them, and the node never waits for the page (its PUB socket drops what is not read).

TapSlot keeps what the page shows, and counts what it does not: a copy that arrives while the page shows the one
before it (sent to the browser, not yet painted there: view.sync) is dropped, and one the page had not taken yet
is replaced by a newer one; both are counted. With the counts each copy carries (the frames the port sent since
the tap began, the copies the node sent), `stats()` says how many frames of the port the page skipped since its
first copy, and where: between the node's samples (the tap's rate), in transit (dropped by the node's PUB
socket, or before the subscription reached it), or on the page.
"""
from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import zmq

from carav_stream.runtime.frames import Frame, FrameError, decode
from carav_stream.runtime.protocol import unpack

RENEW_S = 2.0          # the page asks for its tap again this often
LEASE_S = 6.0          # each ask keeps the tap for this long
RATE_WINDOW_S = 5.0    # the shown rate is measured over this


@dataclass(frozen=True)
class TapCopy:
    """One copy of a frame: the tap's counts (runtime/port_tap.py) and the frame (header and payload rows)."""
    info: dict[str, Any]
    frame: Frame
    t_s: float            # monotonic time it arrived


class TapSlot:
    """The copies of one tap between the receiving thread (`arrived`) and the page (`take`, `shown`)."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.lock = threading.Lock()
        self.clock = clock
        self.pending: TapCopy | None = None
        self.showing = False
        self.received = self.taken = self.dropped_showing = self.replaced = self.unreadable = 0
        self.port_frames = self.node_sent = 0       # over the segments before the current one
        self.segment: tuple[int, int, int] | None = None   # incarnation, frames and sent at its first copy,
        self.last: tuple[int, int] = (0, 0)                # and at its latest one: frames, sent
        self.shown_at: deque[float] = deque()
        self.error: str | None = None               # why there is no tap (the supervisor's refusal, no answer)

    def arrived(self, info: dict[str, Any], frame: Frame) -> None:
        """A copy came: counted, and kept for the page unless the page is showing the one before it."""
        with self.lock:
            self.received += 1
            self._count(info)
            if self.showing:
                self.dropped_showing += 1
                return
            if self.pending is not None:
                self.replaced += 1
            self.pending = TapCopy(info, frame, self.clock())

    def _count(self, info: dict[str, Any]) -> None:
        """Follow the node's counts; a new segment when they start afresh (a restarted node, a tap asked anew)."""
        inc, frames, sent = (info.get(k) for k in ("incarnation", "frames", "sent"))
        if not all(type(v) is int for v in (inc, frames, sent)):
            return
        seg = self.segment
        if seg is None:                 # the page's first copy: what the port sent before it is not counted
            self.segment = (inc, frames, sent)
        elif inc != seg[0] or frames < self.last[0] or sent < self.last[1]:
            self.port_frames += self.last[0] - seg[1] + 1
            self.node_sent += self.last[1] - seg[2] + 1
            self.segment = (inc, 1, 1)  # a new segment began after the page's first copy: all of it counts
        self.last = (frames, sent)

    def unread(self) -> None:
        with self.lock:
            self.unreadable += 1

    def take(self) -> TapCopy | None:
        """The copy to show now, if one came and the page is not showing the one before."""
        with self.lock:
            if self.showing or self.pending is None:
                return None
            copy, self.pending, self.showing = self.pending, None, True
            self.taken += 1
            now = self.clock()
            self.shown_at.append(now)
            while self.shown_at and self.shown_at[0] < now - RATE_WINDOW_S:
                self.shown_at.popleft()
            return copy

    def shown(self) -> None:
        """The browser has shown the last copy taken: the next may come."""
        with self.lock:
            self.showing = False

    def stats(self) -> dict[str, Any]:
        """Frames of the port since the page's first copy, copies the node sent, received, shown, and the shown
        rate over the last RATE_WINDOW_S; skipped = frames - shown, and where: at the node, in transit, on the
        page (dropped while showing, replaced, or waiting)."""
        with self.lock:
            seg = self.segment
            frames = self.port_frames + (self.last[0] - seg[1] + 1 if seg else 0)
            sent = self.node_sent + (self.last[1] - seg[2] + 1 if seg else 0)
            now = self.clock()
            recent = [t for t in self.shown_at if t >= now - RATE_WINDOW_S]
            span = now - recent[0] if len(recent) > 1 else 0.0
            return {"frames": frames, "sent": sent, "received": self.received, "shown": self.taken,
                    "skipped": max(0, frames - self.taken), "at_node": max(0, frames - sent),
                    "in_transit": max(0, sent - self.received), "dropped_showing": self.dropped_showing,
                    "replaced": self.replaced, "unreadable": self.unreadable,
                    "shown_hz": (len(recent) - 1) / span if span > 0 else 0.0, "error": self.error}


class TapWatch:
    """Watch `node`.`port` at `rate_hz` on a daemon thread: `ask(**fields)` sends the admin tap request and returns
    the supervisor's answer (raising LookupError, TimeoutError or OSError when there is none); copies go to
    `slot`. `stop()` ends the thread, which asks the supervisor to end the tap."""

    def __init__(self, ask: Callable[..., dict[str, Any]], node: str, port: str, rate_hz: float,
                 slot: TapSlot | None = None) -> None:
        self.ask, self.node, self.port, self.rate_hz = ask, node, port, rate_hz
        self.topic = f"{node}.{port}".encode()
        self.slot = slot or TapSlot()
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._run, name=f"live-view-tap-{node}.{port}", daemon=True)

    def start(self) -> TapWatch:
        self.thread.start()
        return self

    def stop(self) -> None:
        self.stopped.set()

    def _renew(self, for_s: float) -> dict[str, Any] | None:
        """Ask for the tap for `for_s` seconds; the answer, or None (the reason in the slot)."""
        try:
            reply = self.ask(node=self.node, port=self.port, rate_hz=self.rate_hz, rows=1, for_s=for_s)
        except (LookupError, TimeoutError, OSError) as exc:
            self.slot.error = f"no answer from the run's supervisor: {exc}"
            return None
        if not reply.get("ok"):
            self.slot.error = f"refused: {reply.get('error')}"
            return None
        self.slot.error = None
        return reply

    def _run(self) -> None:
        sub: zmq.Socket | None = None
        renew_at = 0.0
        try:
            while not self.stopped.is_set():
                if time.monotonic() >= renew_at:
                    reply = self._renew(LEASE_S)
                    if reply is None and self.slot.error and self.slot.error.startswith("refused"):
                        return                                  # the supervisor said no: asking again would too
                    renew_at = time.monotonic() + RENEW_S
                    if reply is not None and sub is None:
                        sub = _subscriber(reply["endpoint"], self.topic)
                if sub is None:
                    self.stopped.wait(0.1)
                elif sub.poll(100):
                    self._receive(sub)
        finally:
            if sub is not None:
                sub.close(linger=0)
                self._renew(0.0)

    def _receive(self, sub: zmq.Socket) -> None:
        """Every copy queued on `sub`, to the slot (a message that is not a valid copy of this port is counted)."""
        while True:
            try:
                parts = sub.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            try:
                if parts[0] != self.topic:
                    raise FrameError(f"topic {parts[0][:40]!r}")
                info = unpack(parts[1])
                frame = decode(parts[2:])
            except (ValueError, IndexError):          # FrameError is a ValueError
                self.slot.unread()
                continue
            self.slot.arrived(info, frame)


def _subscriber(endpoint: str, topic: bytes) -> zmq.Socket:
    sock = zmq.Context.instance().socket(zmq.SUB)
    sock.rcvhwm = 2           # what the page cannot read is left to the node's PUB, which drops it
    sock.linger = 0
    sock.subscribe(topic)
    sock.connect(endpoint)
    return sock
