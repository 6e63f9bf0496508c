"""Toy filter: passes frames on, adding `offset` to the payload and header field `tag`.

Graph   t = { type = "tagger", tag = "a", offset = 0.0 }
"""
from carav_stream.runtime.block import Block, In, Out, Param
from carav_stream.runtime.frames import Frame


class Tagger(Block):
    inputs = (In("inp", kind="numbers"),)
    outputs = (Out("out", kind="numbers", dtypes=("float64",)),)
    params = (Param("tag", str, "a", "label written into each frame"),
              Param("offset", float, 0.0, "added to the payload"),
              Param("delay_s", float, 0.0, "sleep per frame (slow consumer)", low=0.0))

    def process(self, inp: Frame) -> Frame:
        if self.delay_s:
            import time
            time.sleep(self.delay_s)
        return inp.derive(inp.payload + self.offset, tag=self.tag)
