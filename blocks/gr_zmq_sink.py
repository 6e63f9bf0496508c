"""GNU Radio ZMQ sink: carav's cycles as a GNU Radio stream, for a flowgraph's ZMQ PULL, SUB or REQ Source.

    item (c N_r + k) M + m  =  sample m of chirp k of cycle c        one gr-zeromq message per cycle (PUSH, PUB)

Binds a PUSH socket (GNU Radio's ZMQ PULL Source connects to it), a PUB socket (a ZMQ SUB Source; `key`, if
set, goes first in a part of its own) or a REP socket (a ZMQ REQ Source, which asks for up to n items at a time:
each cycle goes out in replies of at most what was asked, never two cycles in one) on `address`, and sends every
cycle of the frames it gets as the scene's
samples in sqrt(W): complex64 items for an I/Q scene, float32 for an I-only one (ADC codes are turned into samples
with the scene's lsb; float frames go as they are). With pass_tags, each message starts with gr-zeromq's tag
header (carav_stream/capture/gr_zmq.py) holding the tags named in `tags` (carav_stream/capture/gr_stream.py:
packet_len on every chirp, rx_rate, rx_time, carav_cycle, carav_chirp, carav_seq). `carav_rho`, the activation
sequences of the rho input, goes only when named, and only to this host (ipc:// or a loopback address): it is the
detector's secret, and whoever reads the stream may be the attacker. GNU Radio's source must be set to match:
IO type, Pass Tags, key; the stream says none of them.

A PUSH waits up to timeout_s for a receiver to take each message, a REP for each request, then the node fails naming
the address; a PUB never waits: it sends to the subscribers it has and drops the rest (a subscriber misses what was
sent before it connected). When the stream ends, queued messages have up to timeout_s to reach their receiver.

Ports   in  frames   ADC frames (int16 codes, float32 | complex64 samples) or the channel's rx (float32 |
                     complex64), (cycles, n_chirps, n_samples[, 2])
        in  rho      bool (cycles, n_chirps): the activation sequences (optional: only for the carav_rho tag)
Summary run.gr_stream_sent: address (as bound), messages, items, cycles, tags
Graph   gr = { type = "gr_zmq_sink", address = "tcp://127.0.0.1:5556", pass_tags = true }
"""
import numpy as np

from carav_stream.capture.gr_stream import DEFAULT_TAGS, TAG_NAMES, cycle_tags, layout_of
from carav_stream.capture.gr_zmq import Sender, check_address, encode, is_local
from carav_stream.radar.adc import adc_step, from_codes
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, BlockError, Frame, In, Param, cycle_indices


class GrZmqSink(Block):
    inputs = (In("frames", dtypes=("int16", "float32", "complex64"), doc="ADC frames or the channel's rx"),
              In("rho", kind="rho", dtypes=("bool",), required=False, doc="activation sequences (carav_rho only)"))
    params = (Param("address", str, "tcp://127.0.0.1:5556", "where to bind (GNU Radio's ZMQ source connects)"),
              Param("socket", str, "push", "push: for a ZMQ PULL Source; pub: for a ZMQ SUB Source; rep: for a "
                    "ZMQ REQ Source", choices=("push", "pub", "rep")),
              Param("pass_tags", bool, False, "send gr-zeromq's tag header (the source's Pass Tags must match)"),
              Param("tags", list, list(DEFAULT_TAGS), f"tags sent with pass_tags, of {', '.join(TAG_NAMES)}"),
              Param("key", str, "", "the PUB key (pub only; empty: none)"),
              Param("timeout_s", float, 10.0, "the longest a PUSH waits for a receiver, a REP for a request",
                    unit="s", low=0.0, strict=True),
              SCENE)

    def check_params(self) -> None:
        self.layout = layout_of(scene_of(self.scene))
        check_address(self.address)
        unknown = [t for t in self.tags if t not in TAG_NAMES]
        if unknown:
            raise ValueError(f"tags: {unknown} unknown; the tags are {', '.join(TAG_NAMES)}")
        if self.key and self.socket != "pub":
            raise ValueError(f"key: {self.key!r}: only a PUB socket sends a key (socket = \"pub\")")
        if "carav_rho" in self.tags and not is_local(self.address):
            raise ValueError(f"tags: carav_rho would put the activation sequence, the detector's secret, on the "
                             f"network in clear at {self.address}; send it to ipc:// or a loopback address only")

    def start(self) -> None:
        self.sender = Sender(self.address, self.socket)
        self.names = frozenset(self.tags) if self.pass_tags else frozenset()
        self.offset = self.messages = self.cycles = self.n_tags = 0

    def process(self, frames: Frame, rho: Frame | None = None) -> None:
        lay, scene = self.layout, scene_of(self.scene)
        if frames.payload.dtype == np.int16 and adc_step(scene) is None:
            raise BlockError(f"frame seq {frames.seq}: int16 codes, but scene {scene.name} has an ideal ADC "
                             "(adc_bits 0): no lsb to turn them into samples")
        x = from_codes(scene, frames.payload) if frames.payload.dtype == np.int16 else frames.payload
        shape = (len(cycle_indices(frames)), lay.n_chirps, lay.n_samples)
        if x.dtype != lay.item or x.shape != shape:
            raise BlockError(f"frame seq {frames.seq}: {frames.payload.dtype} {frames.payload.shape} is not "
                             f"{shape[0]} cycles of the scene's {lay.n_chirps} chirps of {lay.n_samples} "
                             f"{'I/Q' if lay.iq else 'real'} samples")
        r = None
        if "carav_rho" in self.names:
            r = None if rho is None else np.asarray(rho.payload)
            if r is None or r.shape != shape[:2]:
                raise BlockError(f"frame seq {frames.seq}: tags name carav_rho, but the rho input gives "
                                 f"{'nothing' if r is None else r.shape} for its {shape[0]} cycles")
        for i, c in enumerate(cycle_indices(frames)):
            tags = cycle_tags(lay, self.offset, c, self.names, seq=frames.seq if i == 0 else None,
                              rate=self.messages == 0, rho=None if r is None else r[i]) if self.names else []
            self._send(x[i].ravel(), tags, c)
            self.offset += lay.items_per_cycle
            self.n_tags += len(tags)
        self.cycles += shape[0]

    def _send(self, items: np.ndarray, tags: list, cycle: int) -> None:
        """One cycle's items from stream offset self.offset: one message, or (REP) a reply to each request."""
        if self.socket != "rep":
            parts = encode(items, offset=self.offset if self.pass_tags else None, tags=tags, key=self.key.encode())
            if not self.sender.send(parts, self.timeout_s):
                raise BlockError(f"{self.sender.address}: no receiver took cycle {cycle} within {self.timeout_s:g} "
                                 "s (is GNU Radio's ZMQ PULL Source connected to this address?)")
            self.messages += 1
            return
        pos = 0
        while pos < len(items):
            n = self.sender.wait_request(self.timeout_s)
            if n is None:
                raise BlockError(f"{self.sender.address}: no request for cycle {cycle} within {self.timeout_s:g} s "
                                 "(is GNU Radio's ZMQ REQ Source connected to this address?)")
            first, k = self.offset + pos, min(n, len(items) - pos)
            self.sender.send(encode(items[pos:pos + k], offset=first if self.pass_tags else None,
                                    tags=[t for t in tags if first <= t.offset < first + k]), self.timeout_s)
            pos += k
            self.messages += 1

    def unpaired(self, port: str, frame: Frame) -> None:
        if port == "frames":     # no sequence for these cycles: sent without one, or refused if carav_rho is asked
            self.process(frame)

    def finish(self) -> None:
        self.sender.close(self.timeout_s)

    def summary(self) -> dict:
        return {"run": {"gr_stream_sent": {"address": self.sender.address, "messages": self.messages,
                                           "items": self.offset, "cycles": self.cycles, "tags": self.n_tags}}}
