"""A headless GNU Radio flowgraph for tests/integration/test_gnuradio.py, run by the system's Python (where GNU
Radio is installed), not by pytest: a known complex signal with tags, through Stream to Tagged Stream
(packet_len every n_samples items), into a ZMQ PUSH Sink (or, with SOCKET rep, a ZMQ REP Sink, which sends only
what its REQ Source asks for) with Pass Tags and, the same items, into a File Sink.

    /usr/bin/python3 gr_send.py ADDRESS FILE N_ITEMS N_SAMPLES RATE_HZ [push | rep]

The signal: a tone at RATE_HZ / 8 plus Gaussian noise of RMS 0.1 (numpy, seed 1); tags rx_rate = RATE_HZ and
rx_time = (7, 0.5) on item 0. Prints "sent" once the flowgraph has run, then holds its sockets open until its
standard input closes, so that the ZMQ sink's queue reaches the receiver before the process ends.
"""
import sys

import numpy as np
import pmt
from gnuradio import blocks, gr, zeromq


def main(address: str, path: str, n_items: int, n_samples: int, rate_hz: float, socket: str = "push") -> None:
    rng = np.random.default_rng(1)
    t = np.arange(n_items)
    x = (np.exp(2j * np.pi * t / 8) + 0.1 * (rng.standard_normal(n_items) + 1j * rng.standard_normal(n_items))
         / np.sqrt(2)).astype(np.complex64)
    src_id = pmt.intern("gr_send")
    tags = [gr.python_to_tag((0, pmt.intern("rx_rate"), pmt.from_double(rate_hz), src_id)),
            gr.python_to_tag((0, pmt.intern("rx_time"), pmt.make_tuple(pmt.from_uint64(7), pmt.from_double(0.5)),
                                src_id))]
    tb = gr.top_block()
    source = blocks.vector_source_c(x.tolist(), False, 1, tags)
    tagged = blocks.stream_to_tagged_stream(gr.sizeof_gr_complex, 1, n_samples, "packet_len")
    tb.connect(source, tagged)
    sink = zeromq.rep_sink if socket == "rep" else zeromq.push_sink
    tb.connect(tagged, sink(gr.sizeof_gr_complex, 1, address, 100, True, -1))
    tb.connect(tagged, blocks.file_sink(gr.sizeof_gr_complex, path, False))
    tb.run()
    print("sent", flush=True)
    sys.stdin.read()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]), *sys.argv[6:])
