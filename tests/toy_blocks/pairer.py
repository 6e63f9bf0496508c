"""Toy two-input block that says how it handled each seq: `paired` (both inputs came) or `alone` (one input had
no partner; the runtime decided it never will).

Graph   p = { type = "pairer" }
"""
from carav_stream.runtime.block import Block, In, Out
from carav_stream.runtime.frames import Frame


class Pairer(Block):
    inputs = (In("a", kind="numbers"), In("b", kind="numbers"))
    outputs = (Out("out", kind="numbers", dtypes=("float64",)),)

    def process(self, a: Frame, b: Frame) -> Frame:
        return a.derive(a.payload + b.payload, handled="paired")

    def unpaired(self, port: str, frame: Frame) -> Frame:
        return frame.derive(keep_data=True, handled="alone", port=port)
