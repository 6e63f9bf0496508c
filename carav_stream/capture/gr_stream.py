"""carav's cycles as a GNU Radio item stream, and a GNU Radio item stream cut back into carav's cycles.

The stream holds the samples of every chirp's sampling window, chirp after chirp, cycle after cycle:

    item (c N_r + k) M + m  =  sample m of chirp k of cycle c          (N = N_r M items per cycle)

complex64 items for an I/Q scene, float32 for an I-only one. Nothing in the stream says N_r, M or the rate: both
ends take them from the same scene. The tags the sink can send (with pass_tags; `carav_rho` only when asked, since
whoever reads the stream may be the attacker, and the activation sequence is the detector's secret):

    packet_len   int                  M                 first item of every chirp (GNU Radio's length tag)
    rx_rate      double               fs_hz             first item sent
    rx_time      (uint64 s, double s) c t_cycle + t_adc_start, the radar time of the cycle's first sample:
                                                        first item of every cycle
    carav_cycle  uint64               c                 first item of every cycle
    carav_chirp  int                  k                 first item of every chirp
    carav_seq    uint64               the frame's seq   first item of every frame
    carav_rho    u8 vector (N_r,)     the activation    first item of every cycle

StreamFramer cuts a received stream into cycles on the grid of item 0: cycle g is items [g N, (g + 1) N) of the
sender's stream (its offsets, with pass_tags; without, the first item received is item 0). It fails closed, like
the DCA1000 reassembler: a cycle touched by a gap in the offsets (messages dropped) or by items sent again
(offsets going back) is released with its reasons, missing items zero; a cycle nothing arrived for is not released
and counted lost; items before the first whole cycle are counted and skipped; the cycle the sender stops within is
released as incomplete. A tag that says the stream is not this scene's (packet_len other than M or off a chirp's
start, rx_rate other than fs, a carav tag off its item or out of range) raises StreamRefused, one line naming the
tag, its item and what the scene expects. Pure logic, no socket.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from carav_stream.capture.gr_zmq import Message, Tag
from carav_stream.capture.pmt import UInt64
from carav_stream.radar.scene import Scene

SRCID = "carav"
TAG_NAMES = ("packet_len", "rx_rate", "rx_time", "carav_cycle", "carav_chirp", "carav_seq", "carav_rho")
DEFAULT_TAGS = TAG_NAMES[:-1]               # carav_rho only when asked
REASONS = ("lost", "overlapping", "incomplete")
RATE_TOLERANCE = 1e-6                       # relative: rx_rate within a part per million of the scene's fs


class StreamRefused(ValueError):
    """A stream that cannot be this scene's; the text is one line naming the tag, its item and the scene's value."""


@dataclass(frozen=True)
class StreamLayout:
    n_chirps: int
    n_samples: int
    fs_hz: float
    t_cycle_s: float
    t_adc_start_s: float
    iq: bool

    @property
    def items_per_cycle(self) -> int:
        return self.n_chirps * self.n_samples

    @property
    def item(self) -> np.dtype:
        return np.dtype(np.complex64 if self.iq else np.float32)


def layout_of(scene: Scene) -> StreamLayout:
    return StreamLayout(scene.n_chirps, scene.n_samples, scene.fs_hz, scene.t_cycle_s, scene.t_adc_start_s, scene.iq)


def rx_time(layout: StreamLayout, cycle: int) -> tuple[UInt64, float]:
    """The rx_time value of cycle `cycle`'s first sample: whole seconds and the fraction, as UHD writes it."""
    t = cycle * layout.t_cycle_s + layout.t_adc_start_s
    whole = math.floor(t)
    return UInt64(whole), t - whole


def cycle_tags(layout: StreamLayout, offset: int, cycle: int, names: frozenset[str] | set[str], *,
               seq: int | None = None, rate: bool = False, rho: np.ndarray | None = None) -> list[Tag]:
    """The tags of one cycle whose first item has stream `offset`: those of `names` (TAG_NAMES); carav_seq when
    `seq` is given (the cycle starts a frame), rx_rate when `rate` (the first item sent), carav_rho from `rho`."""
    tags = []
    if rate and "rx_rate" in names:
        tags.append(Tag(offset, "rx_rate", float(layout.fs_hz), SRCID))
    if "rx_time" in names:
        tags.append(Tag(offset, "rx_time", rx_time(layout, cycle), SRCID))
    if "carav_cycle" in names:
        tags.append(Tag(offset, "carav_cycle", UInt64(cycle), SRCID))
    if seq is not None and "carav_seq" in names:
        tags.append(Tag(offset, "carav_seq", UInt64(seq), SRCID))
    if "carav_rho" in names:
        if rho is None or rho.shape != (layout.n_chirps,):
            raise ValueError(f"carav_rho: cycle {cycle} needs its activation sequence of {layout.n_chirps} chirps")
        tags.append(Tag(offset, "carav_rho", np.asarray(rho, dtype=np.uint8), SRCID))
    for k in range(layout.n_chirps):
        at = offset + k * layout.n_samples
        if "packet_len" in names:
            tags.append(Tag(at, "packet_len", layout.n_samples, SRCID))
        if "carav_chirp" in names:
            tags.append(Tag(at, "carav_chirp", k, SRCID))
    return tags


@dataclass
class Framed:
    """Cycles out of the framer, in stream order: their samples (n, N_r, M), and per cycle its grid index, its
    carav cycle index (carav_cycle tags, else the grid index), the reasons it is damaged, its activation sequence
    from a carav_rho tag (None without), and the rx_time of its first item (seconds; None without)."""

    samples: np.ndarray
    grid: list[int]
    cycles: list[int]
    damage: list[tuple[str, ...]]
    rho: list[np.ndarray | None]
    rx_time_s: list[float | None]


@dataclass
class StreamFramer:
    layout: StreamLayout
    counts: Counter = field(default_factory=Counter)

    def __post_init__(self) -> None:
        self.n = self.layout.items_per_cycle
        self.open: dict[int, np.ndarray] = {}     # grid index -> its items (zeros where none came), in stream order
        self.expected: int | None = None           # stream offset after the last item placed
        self.start = 0                             # offset of the first whole cycle
        self.damage: dict[int, set[str]] = {}
        self.meta: dict[str, dict[int, object]] = {"cycle": {}, "rho": {}, "rx_time": {}}
        self.delta = 0                             # carav cycle index - grid index, from the last carav_cycle tag

    def _mark(self, g: int, reason: str) -> None:
        reasons = self.damage.setdefault(g, set()) if g * self.n >= self.start else {reason}
        if reason not in reasons:
            reasons.add(reason)
            self.counts[reason] += 1            # cycles damaged for this reason

    def feed(self, message: Message) -> None:
        items, n = message.items, len(message.items)
        self.counts["messages"] += 1
        self.counts["items"] += n
        offset = message.offset if message.offset is not None else (self.expected or 0)
        if self.expected is None:                  # the first message: start at the first whole cycle
            self.start = -(-offset // self.n) * self.n
            self.expected = offset
        end = offset + n
        if offset > self.expected:                 # messages dropped: the items between are missing
            self.counts["lost_items"] += offset - self.expected
            skipped = offset // self.n - -(-self.expected // self.n)
            self.counts["lost_cycles"] += max(skipped, 0)
            if self.expected % self.n:
                self._mark(self.expected // self.n, "lost")
            if offset % self.n:
                self._mark(offset // self.n, "lost")
        elif offset < self.expected:               # items sent again, or a sender that started over
            stop = min(self.expected, end)
            self.counts["overlapping_items"] += stop - offset
            for g in range(offset // self.n, (stop - 1) // self.n + 1):
                if g in self.open:
                    self._mark(g, "overlapping")
        fresh = max(offset, self.expected)        # the first item not placed before
        self.counts["items_before_first_cycle"] += max(min(end, self.start) - fresh, 0)
        w = max(fresh, self.start)
        self._tags(message.tags, w)
        while w < end:                             # write the new items, cycle by cycle
            g = w // self.n
            stop = min(end, (g + 1) * self.n)
            self.open.setdefault(g, np.zeros(self.n, self.layout.item))[w - g * self.n:stop - g * self.n] = \
                items[w - offset:stop - offset]
            w = stop
        self.expected = max(self.expected, end)

    def _tags(self, tags: tuple[Tag, ...], first_new: int) -> None:
        lay, m = self.layout, self.layout.n_samples
        for tag in tags:
            o, key, v = tag.offset, tag.key, tag.value
            self.counts["tags"] += 1
            if key == "packet_len" and (type(v) not in (int, UInt64) or v != m):
                raise StreamRefused(f"packet_len {v!r} at item {o}: the scene's chirps are {m} samples long")
            if key == "packet_len" and o % m:
                raise StreamRefused(f"packet_len at item {o} is not where a chirp starts (every {m} items from "
                                    "item 0)")
            if key == "rx_rate" and (type(v) is not float or abs(v - lay.fs_hz) > RATE_TOLERANCE * lay.fs_hz):
                raise StreamRefused(f"rx_rate {v!r} Hz at item {o}: the scene samples at {lay.fs_hz:g} Hz")
            if key == "carav_chirp" and (type(v) is not int or o % m or v != (o // m) % lay.n_chirps):
                raise StreamRefused(f"carav_chirp {v!r} at item {o}: item {o} is sample {o % m} of chirp "
                                    f"{(o // m) % lay.n_chirps} of {lay.n_chirps} on the scene's grid")
            if key in ("carav_cycle", "carav_rho", "rx_time") and o % self.n:
                if key == "rx_time":               # a receiver's timestamp within a cycle: kept out of the cycles'
                    self.counts["tags_ignored"] += 1
                    continue
                raise StreamRefused(f"{key} at item {o} is not where a cycle starts (every {self.n} items: "
                                    f"{lay.n_chirps} chirps of {m} samples)")
            record = {"carav_cycle": "cycle", "carav_rho": "rho", "rx_time": "rx_time"}.get(key)
            if record is None:
                self.counts["tags_ignored" if key not in TAG_NAMES else "tags_checked"] += 1
                continue
            value = self._value(key, v, o)
            if o < first_new:                      # its cycle was released, or its items came before
                self.counts["tags_ignored"] += 1
                continue
            self.meta[record][o // self.n] = value

    def _value(self, key: str, v: object, o: int) -> object:
        if key == "carav_cycle":
            if type(v) not in (int, UInt64) or v < 0:
                raise StreamRefused(f"carav_cycle {v!r} at item {o}: a cycle index is an integer >= 0")
            return int(v)
        if key == "carav_rho":
            if not isinstance(v, np.ndarray) or v.shape != (self.layout.n_chirps,) or np.any((v != 0) & (v != 1)):
                raise StreamRefused(f"carav_rho at item {o}: {v!r:.60} is not {self.layout.n_chirps} values 0 or 1 "
                                    "(the scene's chirps per cycle)")
            return v.astype(bool)
        if not (isinstance(v, tuple) and len(v) == 2 and type(v[0]) in (int, UInt64) and type(v[1]) is float):
            raise StreamRefused(f"rx_time {v!r:.60} at item {o}: expected (uint64 seconds, double fraction)")
        return v[0] + v[1]

    def complete(self) -> int:
        """Cycles ready to release: every open cycle the stream has gone past."""
        if self.expected is None:
            return 0
        done = self.expected // self.n
        return sum(1 for g in self.open if g < done)

    def take(self, max_cycles: int) -> Framed | None:
        ready = [g for g in self.open if g < (self.expected or 0) // self.n][:max_cycles]
        if not ready:
            return None
        samples = np.stack([self.open.pop(g) for g in ready]).reshape(len(ready), self.layout.n_chirps,
                                                                      self.layout.n_samples)
        cycles = []
        for g in ready:
            if g in self.meta["cycle"]:
                self.delta = self.meta["cycle"].pop(g) - g
            cycles.append(g + self.delta)
        damage = [tuple(sorted(self.damage.pop(g, ()))) for g in ready]
        self.counts["cycles"] += len(ready)
        self.counts["damaged_cycles"] += sum(1 for d in damage if d)
        return Framed(samples, ready, cycles, damage, [self.meta["rho"].pop(g, None) for g in ready],
                      [self.meta["rx_time"].pop(g, None) for g in ready])

    def flush(self) -> Framed | None:
        """At the end of the stream: the cycle the sender stopped within, zero-padded and damaged (incomplete)."""
        if self.expected is None or self.expected % self.n == 0 or self.expected // self.n not in self.open:
            return self.take(len(self.open))
        self._mark(self.expected // self.n, "incomplete")
        self.expected = -(-self.expected // self.n) * self.n
        return self.take(len(self.open))
