"""A headless GNU Radio flowgraph for tests/integration/test_gnuradio.py, run by the system's Python (where GNU
Radio is installed), not by pytest: a ZMQ PULL Source (or, with SOCKET req, a ZMQ REQ Source, which asks for
the items it has room for) with Pass Tags connected to carav's gr_zmq_sink, N_ITEMS of its complex items into a
File Sink, and every tag GNU Radio attached to them into a JSON file.

    /usr/bin/python3 gr_receive.py ADDRESS FILE TAGS_JSON N_ITEMS [pull | req]

Each tag is written as [offset, key, value, srcid], PMT values through pmt.to_python (a tuple as a list, a uniform
vector as a list). Ends when N_ITEMS have passed (a ZMQ source never ends by itself).
"""
import json
import sys
import time

import numpy as np
import pmt
from gnuradio import blocks, gr, zeromq


class TagCollector(gr.sync_block):
    """Keeps every tag of its input; passes nothing on."""

    def __init__(self) -> None:
        gr.sync_block.__init__(self, name="tag_collector", in_sig=[np.complex64], out_sig=None)
        self.tags = []

    def work(self, input_items, output_items):
        for t in self.get_tags_in_window(0, 0, len(input_items[0])):
            value = pmt.to_python(t.value)
            self.tags.append([t.offset, pmt.symbol_to_string(t.key),
                              value.tolist() if isinstance(value, np.ndarray) else value, pmt.to_python(t.srcid)])
        return len(input_items[0])


def main(address: str, path: str, tags_path: str, n_items: int, socket: str = "pull") -> None:
    tb = gr.top_block()
    head = blocks.head(gr.sizeof_gr_complex, n_items)
    collector = TagCollector()
    source = zeromq.req_source if socket == "req" else zeromq.pull_source
    tb.connect(source(gr.sizeof_gr_complex, 1, address, 100, True, -1), head)
    tb.connect(head, blocks.file_sink(gr.sizeof_gr_complex, path, False))
    tb.connect(head, collector)
    tb.start()
    while head.nitems_written(0) < n_items:     # the ZMQ source never ends by itself: stop once head has its items
        time.sleep(0.05)
    tb.stop()
    tb.wait()
    with open(tags_path, "w") as fh:
        json.dump(collector.tags, fh)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), *sys.argv[5:])
