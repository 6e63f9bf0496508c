"""Toy filter that raises at a chosen seq (once per process), to test crash reporting and restarts.

Graph   c = { type = "crasher", at_seq = 10 }
"""
import os

from carav_stream.runtime.block import Block, In, Out, Param
from carav_stream.runtime.frames import Frame


class Crasher(Block):
    inputs = (In("inp", kind="numbers"),)
    outputs = (Out("out", kind="numbers", dtypes=("float64",)),)
    params = (Param("at_seq", int, 10, "seq at which to raise", low=0),
              Param("marker", str, "", "if set, crash only when this file does not exist yet (then create it)"))

    def process(self, inp: Frame) -> Frame:
        if inp.seq >= self.at_seq and (not self.marker or not os.path.exists(self.marker)):
            if self.marker:
                open(self.marker, "w").close()
            raise RuntimeError(f"deliberate crash at seq {inp.seq}")
        return inp.derive(keep_data=True)
