"""The GNU Radio side of `python3 dev.py bench gr-bridge`, run by the system's Python (where GNU Radio is installed),
not by the project's environment, and never imported:

    /usr/bin/python3 bench/gr_peer.py version
    /usr/bin/python3 bench/gr_peer.py receive ADDRESS ITEM TAGGED TOTAL_ITEMS WARM_ITEMS
    /usr/bin/python3 bench/gr_peer.py send ADDRESS ITEM TAGGED TOTAL_ITEMS N_SAMPLES

receive: a ZMQ PULL Source (Pass Tags = TAGGED) connected to ADDRESS, into a probe that counts the items and notes
the monotonic clock (CLOCK_MONOTONIC, the same in every process of the host) when WARM_ITEMS and TOTAL_ITEMS have
passed; prints "ready" once the flowgraph runs, then one JSON line {"items", "t_warm_s", "t_end_s"}.

send: a Vector Source repeating one stretch of N_SAMPLES x 64 items (a ramp), Head of TOTAL_ITEMS, with TAGGED a
Stream to Tagged Stream (packet_len every N_SAMPLES items), into a ZMQ PUSH Sink (Pass Tags = TAGGED) bound on
ADDRESS; prints "sent" once the flowgraph has run, then holds its sockets open until its standard input closes, so
that what its sink still queues reaches the receiver.

ITEM is float32 or complex64 (GNU Radio's float and complex); TAGGED is 0 or 1.
"""
import json
import sys
import time

import numpy as np
from gnuradio import blocks, gr, zeromq

ITEMS = {"float32": (np.float32, gr.sizeof_float, "f"), "complex64": (np.complex64, gr.sizeof_gr_complex, "c")}


class Probe(gr.sync_block):
    """Counts its input's items; notes the clock when `warm` and `total` items have passed."""

    def __init__(self, dtype, warm: int, total: int) -> None:
        gr.sync_block.__init__(self, name="probe", in_sig=[dtype], out_sig=None)
        self.warm, self.total, self.items = warm, total, 0
        self.t_warm_s = self.t_end_s = None

    def work(self, input_items, output_items):
        self.items += len(input_items[0])
        now = time.monotonic()
        if self.t_warm_s is None and self.items >= self.warm:
            self.t_warm_s = now
        if self.t_end_s is None and self.items >= self.total:
            self.t_end_s = now
        return len(input_items[0])


def receive(address: str, item: str, tagged: bool, total: int, warm: int) -> None:
    dtype, size, _ = ITEMS[item]
    tb = gr.top_block()
    probe = Probe(dtype, warm, total)
    tb.connect(zeromq.pull_source(size, 1, address, 100, tagged, -1), probe)
    tb.start()
    print("ready", flush=True)
    while probe.t_end_s is None:              # a ZMQ source never ends by itself: stop once the probe has all
        time.sleep(0.01)
    tb.stop()
    tb.wait()
    print(json.dumps({"items": probe.items, "t_warm_s": probe.t_warm_s, "t_end_s": probe.t_end_s}), flush=True)


def send(address: str, item: str, tagged: bool, total: int, n_samples: int) -> None:
    dtype, size, letter = ITEMS[item]
    stretch = np.arange(64 * n_samples).astype(dtype)
    tb = gr.top_block()
    source = getattr(blocks, f"vector_source_{letter}")(stretch.tolist(), True)
    head = blocks.head(size, total)
    sink = zeromq.push_sink(size, 1, address, 100, tagged, -1)
    if tagged:
        tb.connect(source, head, blocks.stream_to_tagged_stream(size, 1, n_samples, "packet_len"), sink)
    else:
        tb.connect(source, head, sink)
    tb.run()
    print("sent", flush=True)
    sys.stdin.read()


if __name__ == "__main__":
    if sys.argv[1] == "version":
        print(gr.version())
    elif sys.argv[1] == "receive":
        receive(sys.argv[2], sys.argv[3], sys.argv[4] == "1", int(sys.argv[5]), int(sys.argv[6]))
    else:
        send(sys.argv[2], sys.argv[3], sys.argv[4] == "1", int(sys.argv[5]), int(sys.argv[6]))
