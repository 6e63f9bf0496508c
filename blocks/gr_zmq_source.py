"""GNU Radio ZMQ source: a GNU Radio flowgraph's stream, from its ZMQ PUSH, PUB or REP Sink, as the scene's cycles.
Fail closed.

    cycle g = items [g N, (g + 1) N) of the sender's stream (N = n_chirps n_samples);   damaged(g) => nonfinite(g) > 0

Connects a PULL socket (to a ZMQ PUSH Sink), a SUB socket (to a ZMQ PUB Sink; `key` is the sink's key) or a REQ
socket (to a ZMQ REP Sink: it asks for a cycle's items at a time, and the sink replies with at most as many as its
flowgraph has ready) to `address`, where the GNU Radio sink is bound, and reads gr-zeromq messages: items only, or
with pass_tags (set as the sink's) a header with the items' offset and the tags (carav_stream/capture/gr_zmq.py).
The items are the scene's samples in its unit, sqrt(W): complex64 for an I/Q scene, float32 for an I-only one; they
are cut into cycles (carav_stream/capture/gr_stream.py: untagged, the first item received starts cycle 0), put
through the scene's ADC as adc_framer does (int16 codes, clipped and non-finite samples counted; a scene with an
ideal ADC keeps the samples) and sent with their activation sequences, from exactly one of `activation` (a log of
cycles 0, 1, 2, ...), `pattern` (the same every cycle) and `rho_from_tags` (the carav_rho tags a gr_zmq_sink sends
when asked to).

A cycle touched by dropped messages (a gap in the offsets) or repeated ones, one without its carav_rho tag
(rho_from_tags), and the cycle the sender stops within are sent with per_cycle nonfinite = their sample count and
their reasons in `damage`: rms_detector judges them invalid, the gate refuses them. A cycle nothing came for is
not sent (per_cycle cycle_index names the cycles sent, when they do not follow one another). A message that is
not what the settings say (bad magic, wrong item size: carav_stream/capture/gr_zmq.py) or a tag that says the
stream is not this scene's (packet_len, rx_rate, carav_chirp) ends the node with one line naming it and its
message. The stream ends when no message has come for idle_timeout_s (first_timeout_s before the first one: the
flowgraph may start after the graph).

Ports   out frames   int16 (cycles, n_chirps, n_samples[, 2]) codes, or float32 | complex64 samples (ideal ADC);
                     per_cycle clipped, nonfinite, damage (its reasons, comma-separated; "" for a whole cycle),
                     and, when the stream has rx_time tags, rx_time_s (the tag on a cycle's first item, else null)
        out rho      bool (cycles, n_chirps): the activation sequences (private edge to the detector)
Summary run.gr_stream: messages, items, cycles, damaged_cycles, per reason (lost, overlapping, incomplete,
        no_activation) the cycles damaged for it, lost_cycles (nothing came), lost_items, overlapping_items,
        items_before_first_cycle, other_key (messages of another PUB key), tags, sender_stopped
Graph   gr = { type = "gr_zmq_source", address = "tcp://127.0.0.1:5555", pattern = "1010..." }
"""
import time

import numpy as np

from carav_stream.capture.activation_log import capture_activation
from carav_stream.capture.gr_stream import StreamFramer, StreamRefused, layout_of
from carav_stream.capture.gr_zmq import GrZmqError, OtherKey, Receiver, check_address, decode
from carav_stream.radar.adc import adc_codes
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, BlockError, Frame, Out, Param

TICK_S = 0.02        # between two looks at the socket while a frame is not ready (the runtime serves control)
HOLD_S = 0.5         # the longest whole cycles wait for the rest of a frame's batch (a slow stream)


class GrZmqSource(Block):
    outputs = (Out("frames", kind="adc_frame", dtypes=("int16", "float32", "complex64"), doc="the stream's cycles"),
               Out("rho", kind="rho", dtypes=("bool",), doc="activation sequences (private)", private=True))
    params = (Param("address", str, "tcp://127.0.0.1:5555", "the GNU Radio ZMQ sink's address (it binds)"),
              Param("socket", str, "pull", "pull: a ZMQ PUSH Sink; sub: a ZMQ PUB Sink; req: a ZMQ REP Sink",
                    choices=("pull", "sub", "req")),
              Param("pass_tags", bool, False, "the sink's Pass Tags: a header with offsets and tags"),
              Param("key", str, "", "the PUB sink's key (sub only; empty: none)"),
              Param("activation", str, "", "activation log of the stream's cycles 0, 1, 2, ...", file=True),
              Param("pattern", str, "", "fixed activation pattern of every cycle, n_chirps digits 0 | 1"),
              Param("rho_from_tags", bool, False, "activation sequences from the stream's carav_rho tags"),
              Param("first_timeout_s", float, 60.0, "the stream ends if no message has come this long after the "
                    "start", unit="s", low=0.0, strict=True),
              Param("idle_timeout_s", float, 5.0, "the stream ends after this long without a message, once one has "
                    "come", unit="s", low=0.0, strict=True),
              SCENE,
              Param("batch", int, 16, "cycles per frame", low=1, high=4096))

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)
        self.layout = layout_of(self.scene_obj)
        check_address(self.address)
        if self.key and self.socket != "sub":
            raise ValueError(f"key: {self.key!r}: only a PUB sink has a key (socket = \"sub\")")
        if self.rho_from_tags:
            if self.activation or self.pattern or not self.pass_tags:
                raise ValueError("rho_from_tags: the sequences come from the tags alone: pass_tags = true, and "
                                 "neither activation nor pattern")
            self.fixed = self.log_rho = None
            return
        self.fixed, cycles, self.log_rho = capture_activation(self.activation, self.pattern, self.layout.n_chirps)
        if self.fixed is None and np.any(cycles != np.arange(len(cycles))):
            raise ValueError(f"activation: {self.activation}: the log must list cycles 0, 1, 2, ... in order")

    def start(self) -> None:
        self.receiver = Receiver(self.address, self.socket, self.key.encode(), self.layout.items_per_cycle)
        self.framer = StreamFramer(self.layout)
        self.last_message = time.monotonic()
        self.stopped = False
        self.ready_since: float | None = None

    def _want(self) -> int:
        return min(self.batch, self.cycle_budget or self.batch)

    def _pump(self, wait_s: float = 0.0) -> None:
        """Feed the framer what waits in the socket (until a batch is whole); note a sender gone silent."""
        while self.framer.complete() < self._want():
            parts = self.receiver.receive(wait_s)
            if parts is None:
                first = self.framer.counts["messages"] + self.framer.counts["other_key"] == 0
                if time.monotonic() - self.last_message >= (self.first_timeout_s if first else self.idle_timeout_s):
                    self.stopped = True
                return
            self.last_message, wait_s = time.monotonic(), 0.0
            n = self.framer.counts["messages"] + self.framer.counts["other_key"] + 1
            try:
                self.framer.feed(decode(parts, self.layout.item, tagged=self.pass_tags, key=self.key.encode()))
            except OtherKey:
                self.framer.counts["other_key"] += 1
            except StreamRefused as exc:
                raise BlockError(f"{self.address}: message {n}: not scene {self.scene_obj.name}'s stream: {exc}",
                                 retry=False) from None
            except GrZmqError as exc:
                raise BlockError(f"{self.address}: message {n}: {exc}", retry=False) from None

    def ready_in(self, seq: int) -> float:
        if not self.stopped:
            self._pump()
        whole = self.framer.complete()
        if whole and self.ready_since is None:
            self.ready_since = time.monotonic()
        if self.stopped or whole >= self._want() or whole and time.monotonic() - self.ready_since >= HOLD_S:
            return 0.0
        return TICK_S

    def generate(self, seq: int) -> dict[str, Frame] | None:
        while (got := self.framer.take(self._want())) is None and not self.stopped:
            self._pump(TICK_S)
        if got is None:
            got = self.framer.flush()
            if got is None:
                return None
        self.ready_since = None
        n, samples_per_cycle = len(got.cycles), self.layout.items_per_cycle
        damage = [list(d) for d in got.damage]
        rho = self._rho(got, damage)
        codes, clipped, nonfinite = adc_codes(self.scene_obj, got.samples)
        per = {"clipped": clipped.tolist(),
               "nonfinite": [samples_per_cycle if d else int(x) for d, x in zip(damage, nonfinite)],
               "damage": [",".join(d) for d in damage]}
        if any(t is not None for t in got.rx_time_s):
            per["rx_time_s"] = got.rx_time_s
        if got.cycles != list(range(got.cycles[0], got.cycles[0] + n)):
            per["cycle_index"] = got.cycles
        header = {"cycle": got.cycles[0], "cycles": n}
        return {"frames": Frame.of(codes, per_cycle=per, **header),
                "rho": Frame.of(rho, **header, **({"per_cycle": {"cycle_index": got.cycles}}
                                                  if "cycle_index" in per else {}))}

    def _rho(self, got, damage: list[list[str]]) -> np.ndarray:
        if self.fixed is not None:
            return np.tile(self.fixed, (len(got.cycles), 1))
        if self.log_rho is not None:
            if max(got.cycles) >= len(self.log_rho):
                raise BlockError(f"activation: {self.activation}: no sequence for cycle {max(got.cycles)} of the "
                                 "stream", retry=False)
            return self.log_rho[got.cycles]
        rho = np.zeros((len(got.cycles), self.layout.n_chirps), dtype=bool)
        for i, row in enumerate(got.rho):
            if row is None:           # no sequence, no verdict: the cycle is refused, never judged clean
                damage[i].append("no_activation")
                self.framer.counts["no_activation"] += 1
                self.framer.counts["damaged_cycles"] += not got.damage[i]
            else:
                rho[i] = row
        return rho

    def finish(self) -> None:
        self.receiver.close()

    def summary(self) -> dict:
        c = self.framer.counts
        keys = ("messages", "items", "cycles", "damaged_cycles", "lost", "overlapping", "incomplete", "no_activation",
                "lost_cycles", "lost_items", "overlapping_items", "items_before_first_cycle", "other_key", "tags")
        return {"run": {"gr_stream": {**{k: c[k] for k in keys}, "sender_stopped": self.stopped}}}
