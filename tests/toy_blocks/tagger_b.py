"""Toy filter with tagger's ports, another block type (for swaps).

Graph   t = { type = "tagger_b", factor = 2.0 }
"""
from carav_stream.runtime.block import Block, In, Out, Param
from carav_stream.runtime.frames import Frame


class TaggerB(Block):
    version = "2"
    inputs = (In("inp", kind="numbers"),)
    outputs = (Out("out", kind="numbers", dtypes=("float64",)),)
    params = (Param("factor", float, 2.0, "payload multiplier"),
              Param("delay_s", float, 0.0, "sleep per frame (slow consumer)", low=0.0))

    def process(self, inp: Frame) -> Frame:
        if self.delay_s:
            import time
            time.sleep(self.delay_s)
        return inp.derive(inp.payload * self.factor, tag=f"b{self.factor:g}")
