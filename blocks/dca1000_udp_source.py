"""DCA1000 live source: the card's raw-data UDP stream, cycle by cycle, into the detector and estimator. Fail closed.

    cycle c = bytes [c B, (c + 1) B) of the stream;   damaged(c)  =>  nonfinite(c) > 0  =>  the detector's verdict
    is "invalid" and the gate refuses c

Receives the datagrams the DCA1000 sends in raw mode (a 4-byte sequence number, a 6-byte byte count, up to 1456
bytes of the capture's words) on `address`:`port`, reassembles cycles of the scene's chirps in the layout of
dca1000_source (lanes, encoding, real or complex: carav_stream/capture/dca1000.py), keeps receiver `rx` or the
scene's receivers (`receivers`, as for dca1000_source), and sends them with their activation sequences (from
exactly one of `activation` and `pattern`, as for dca1000_source). Every cycle touched by a lost, truncated,
duplicated, reordered or overlapping packet, and the cycle the sender stops within, is sent with per_cycle
`nonfinite` = its sample count (none of its samples is trusted: rms_detector judges it invalid, gate refuses it,
never judged clean) and its reasons in `damage`. The stream ends when no packet has come for idle_timeout_s (and
none waits in the socket).

The socket: blocks never touch the runtime's sockets, files or processes; this one is the radar's data, as
dca1000_source's .bin file is. It is opened in start(), inside the block's own process, by a capture-side helper
(carav_stream/capture/dca1000_udp.py: UdpReceiver, whose thread drains the socket so that the kernel's buffer only
has to cover its pauses), and all the stream logic is the helper's pure Reassembler, tested without sockets.

Ports   out frames   int16 (cycles, n_chirps, n_samples[, 2]): receiver rx's codes; (cycles, receivers, n_chirps,
                     n_samples[, 2]) for a scene with several receivers; per_cycle nonfinite (every receiver's
                     samples) and damage (its reasons, comma-separated; "" for a whole, clean cycle)
        out rho      bool (cycles, n_chirps): the activation sequences (private edge to the detector)
Summary run.live_capture: packets, bytes, cycles, damaged_cycles, late_packets, bytes_before_first_cycle, a count
        per reason, sender_stopped; dropped_by_host, the datagrams this host's kernel dropped because the receiver did
        not drain its socket in time (its drop counter; null where it cannot be read): of `lost`, these are the
        host's and the rest the link's, the cycles refused either way; rcvbuf_granted_bytes, the receive buffer the
        kernel granted
Graph   radar = { type = "dca1000_udp_source", port = 4098, n_rx = 4, pattern = "1010..." }
"""
import ipaddress

import numpy as np

from carav_stream.capture.activation_log import capture_activation
from carav_stream.capture.dca1000 import (
    CAPTURE_PARAMS,
    capture_layout,
    capture_receivers,
    check_loops,
    decode,
    receiver_frames,
)
from carav_stream.capture.dca1000_udp import DATA_PORT, REASONS, Reassembler, UdpReceiver
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, BlockError, Frame, Out, Param


class Dca1000UdpSource(Block):
    outputs = (Out("frames", kind="adc_frame", dtypes=("int16",), doc="ADC codes per cycle: rx's, or the scene's "
                                                                       "receivers'"),
               Out("rho", kind="rho", dtypes=("bool",), doc="activation sequences (private)", private=True))
    params = (Param("address", str, "127.0.0.1", "address to receive on (the host's address on the card's link)"),
              Param("port", int, DATA_PORT, "UDP data port", low=1, high=65535),
              *CAPTURE_PARAMS,
              Param("idle_timeout_s", float, 5.0, "the stream ends after this long without a packet", unit="s",
                    low=0.0, strict=True),
              SCENE,
              Param("batch", int, 16, "cycles per frame", low=1, high=4096))

    def check_params(self) -> None:
        scene = scene_of(self.scene)
        self.layout = capture_layout(scene, self.n_rx, self.lanes, self.encoding)
        self.chosen = capture_receivers(scene, self.n_rx, self.rx, self.receivers)
        try:
            ipaddress.ip_address(self.address)
        except ValueError:
            raise ValueError(f"address: {self.address!r} is not an IP address") from None
        self.fixed, cycles, self.log_rho = capture_activation(self.activation, self.pattern, scene.n_chirps)
        check_loops(self.fixed[None] if self.fixed is not None else self.log_rho, scene.n_slots,
                    "pattern" if self.fixed is not None else f"activation: {self.activation}")
        if self.fixed is not None:
            return
        if np.any(cycles != np.arange(len(cycles))):
            raise ValueError(f"activation: {self.activation}: a capture's log lists cycles 0, 1, 2, ... in order")

    def start(self) -> None:
        self.receiver = UdpReceiver(self.address, self.port, Reassembler(self.layout.bytes_per_cycle))

    def generate(self, seq: int) -> dict[str, Frame] | None:
        want = min(self.batch, self.cycle_budget or self.batch)
        got = self.receiver.take(want, want, self.idle_timeout_s)
        if got is None:
            return None
        n = len(got.damage)
        codes = receiver_frames(decode(np.frombuffer(got.data, "<i2"), self.layout), self.chosen)
        cycles = np.arange(got.first_cycle, got.first_cycle + n)
        if self.fixed is not None:
            rho = np.tile(self.fixed, (n, 1))
        elif cycles[-1] < len(self.log_rho):
            rho = self.log_rho[cycles]
        else:
            raise BlockError(f"activation: {self.activation}: no sequence for cycle {cycles[-1]} of the stream")
        samples = int(np.prod(codes.shape[1:-1] if self.layout.complex else codes.shape[1:]))
        per = {"nonfinite": [samples if d else 0 for d in got.damage], "damage": [",".join(d) for d in got.damage]}
        header = {"cycle": got.first_cycle, "cycles": n}
        return {"frames": Frame.of(codes, per_cycle=per, **header), "rho": Frame.of(rho, **header)}

    def finish(self) -> None:
        self.receiver.close()

    def summary(self) -> dict:
        self.receiver.note_host_drops()
        c = self.receiver.reassembler.counts
        live = {"packets": c["packets"], "bytes": c["bytes"], "cycles": c["cycles"],
                "damaged_cycles": c["damaged_cycles"], "late_packets": c["late"],
                "bytes_before_first_cycle": c["skipped_bytes"], **{k: c[k] for k in REASONS},
                "dropped_by_host": c.get("dropped_by_host"),
                "rcvbuf_granted_bytes": self.receiver.rcvbuf_granted_bytes,
                "sender_stopped": self.receiver.stopped}
        return {"run": {"live_capture": live}}
