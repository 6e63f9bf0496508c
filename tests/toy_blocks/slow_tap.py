"""Toy observer: a tap input (block.In.tap) that takes `delay_s` per frame and writes the seqs it saw to `path`.

Graph   view = { type = "slow_tap", delay_s = 0.02, path = "seen.txt" }
"""
import time

from carav_stream.runtime.block import Block, In, Param
from carav_stream.runtime.frames import Frame


class SlowTap(Block):
    inputs = (In("inp", tap=True),)
    params = (Param("delay_s", float, 0.02, "time taken per frame", low=0.0),
              Param("path", str, "seen.txt", "file of the seqs seen, one per line", output=True))

    def start(self) -> None:
        self.fh = open(self.path, "w", buffering=1)

    def process(self, inp: Frame) -> None:
        time.sleep(self.delay_s)
        self.fh.write(f"{inp.seq}\n")

    def finish(self) -> None:
        self.fh.close()
