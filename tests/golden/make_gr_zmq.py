"""Capture what GNU Radio's own ZMQ sinks send, for tests/capture/test_gr_zmq_golden.py: run it with the system's
Python, where GNU Radio is installed (Debian: apt-get install gnuradio), from the repository's root:

    /usr/bin/python3 tests/golden/make_gr_zmq.py          (writes tests/golden/gr_zmq.json)

Three flowgraphs, each received by a plain ZeroMQ socket of this script, every message's parts stored as hex:

    tagged_push    64 complex items (item i = (i + 0.5) - i j) with tags of every PMT type the decoder reads,
                   through a ZMQ PUSH Sink with Pass Tags
    untagged_push  the same items through a ZMQ PUSH Sink without Pass Tags
    tagged_pub     float items (item i = i / 4) repeated, tagged packet_len every 16 items, through a ZMQ PUB Sink with
                   key "carav" and Pass Tags, at most 40 items per message; the first messages the subscriber gets
                   (GNU Radio numbers its items from the start; the subscriber may have missed some)

The script does not import carav_stream: what it stores is GNU Radio's, not ours.
"""
import json
import sys
import time
from pathlib import Path

import numpy as np
import pmt
import zmq
from gnuradio import blocks, gr, zeromq

OUT = Path(__file__).with_name("gr_zmq.json")
N = 64


def tags_for_push() -> list:
    src = pmt.intern("golden")
    d = pmt.dict_add(pmt.dict_add(pmt.make_dict(), pmt.intern("gain_db"), pmt.from_double(-3.5)),
                     pmt.intern("chan"), pmt.from_long(2))
    tags = [(16 * k, pmt.intern("packet_len"), pmt.from_long(16), src) for k in range(4)]
    tags += [(0, pmt.intern("rx_time"), pmt.make_tuple(pmt.from_uint64(12), pmt.from_double(0.25)), src),
             (0, pmt.intern("rx_rate"), pmt.from_double(2.5e6), src),
             (5, pmt.intern("label"), pmt.intern("chirp"), pmt.PMT_F),
             (6, pmt.intern("big"), pmt.from_long(-(2 ** 40)), src),
             (7, pmt.intern("count"), pmt.from_uint64(2 ** 63 + 5), src),
             (8, pmt.intern("phase"), pmt.from_complex(1.5 - 2j), src),
             (9, pmt.intern("flag"), pmt.PMT_T, src),
             (10, pmt.intern("none"), pmt.PMT_NIL, src),
             (11, pmt.intern("pair"), pmt.cons(pmt.from_long(1), pmt.from_double(2.0)), src),
             (12, pmt.intern("list"), pmt.list2(pmt.intern("a"), pmt.from_long(-7)), src),
             (13, pmt.intern("meta"), d, src),
             (14, pmt.intern("rho"), pmt.init_u8vector(4, [1, 0, 1, 1]), src),
             (15, pmt.intern("taps"), pmt.init_f32vector(2, [0.5, -1.25]), src),
             (17, pmt.intern("vec"), pmt.make_vector(2, pmt.from_long(3)), src)]
    return [gr.python_to_tag(t) for t in tags]


def receive(sock: zmq.Socket, n_messages: int | None, quiet_s: float = 2.0) -> list[list[str]]:
    """Messages (their parts as hex) until n_messages came, or none for quiet_s."""
    out = []
    while n_messages is None or len(out) < n_messages:
        if not sock.poll(int(quiet_s * 1000)):
            break
        out.append([p.hex() for p in sock.recv_multipart()])
    return out


def push(pass_tags: bool, address: str) -> list[list[str]]:
    items = (np.arange(N) + 0.5 - 1j * np.arange(N)).astype(np.complex64)
    tb = gr.top_block()
    src = blocks.vector_source_c(items.tolist(), False, 1, tags_for_push())
    tb.connect(src, zeromq.push_sink(gr.sizeof_gr_complex, 1, address, 100, pass_tags, -1))
    ctx = zmq.Context()
    sock = ctx.socket(zmq.PULL)
    sock.connect(address)
    tb.start()
    messages = receive(sock, None)
    tb.stop()
    tb.wait()
    sock.close(0)
    ctx.term()
    return messages


def pub(address: str) -> list[list[str]]:
    items = (np.arange(N) / 4).astype(np.float32)
    tags = [gr.python_to_tag((16 * k, pmt.intern("packet_len"), pmt.from_long(16), pmt.intern("golden")))
            for k in range(4)]
    tb = gr.top_block()
    src = blocks.vector_source_f(items.tolist(), True, 1, tags)
    throttle = blocks.throttle(gr.sizeof_float, 20000)
    tb.connect(src, throttle, zeromq.pub_sink(gr.sizeof_float, 1, address, 100, True, -1, "carav"))
    ctx = zmq.Context()
    sock = ctx.socket(zmq.SUB)
    sock.setsockopt(zmq.SUBSCRIBE, b"carav")
    sock.connect(address)
    tb.start(40)               # at most 40 items per scheduler call: small messages
    time.sleep(0.2)            # the subscriber joins a stream that has begun: its first offsets are not 0
    messages = receive(sock, 4)
    tb.stop()
    tb.wait()
    sock.close(0)
    ctx.term()
    return messages


def main() -> int:
    captures = {"tagged_push": {"item": "complex64", "pass_tags": True, "key": "",
                                "messages": push(True, "tcp://127.0.0.1:5791")},
                "untagged_push": {"item": "complex64", "pass_tags": False, "key": "",
                                  "messages": push(False, "tcp://127.0.0.1:5792")},
                "tagged_pub": {"item": "float32", "pass_tags": True, "key": "carav",
                               "messages": pub("tcp://127.0.0.1:5793")}}
    for name, c in captures.items():
        if not c["messages"]:
            print(f"{name}: no message received", file=sys.stderr)
            return 1
    OUT.write_text(json.dumps({"gnuradio": gr.version(), "byteorder": sys.byteorder, "captures": captures},
                              indent=1) + "\n")
    print(f"wrote {OUT}: " + ", ".join(f"{k} {len(v['messages'])} messages" for k, v in captures.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
