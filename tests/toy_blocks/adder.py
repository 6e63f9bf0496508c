"""Toy two-input block: adds the payloads of both inputs with the same seq.

Graph   add = { type = "adder" }
"""
from carav_stream.runtime.block import Block, In, Out
from carav_stream.runtime.frames import Frame


class Adder(Block):
    inputs = (In("a", kind="numbers"), In("b", kind="numbers"))
    outputs = (Out("out", kind="numbers", dtypes=("float64",)),)

    def process(self, a: Frame, b: Frame) -> Frame:
        return a.derive(a.payload + b.payload)
