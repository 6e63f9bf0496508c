"""Toy source: frame seq n carries a float64 payload [n, n, ...] of `n_values` values;
with `frames` > 0 the stream ends after that many.

With batch > 1 a frame carries up to `batch` cycles (header cycles, cycle = first cycle) as a (cycles,
n_values) payload of cycle indices, the last frame sized by the runtime's cycle budget.

Ports   out out   float64 (n_values,)
Graph   src = { type = "counter_source", n_values = 4 }
"""
import numpy as np

from carav_stream.runtime.block import Block, Out, Param
from carav_stream.runtime.frames import Frame


class CounterSource(Block):
    outputs = (Out("out", kind="numbers", dtypes=("float64",)),)
    params = (Param("n_values", int, 4, "values per frame", low=1),
              Param("rows", int, 0, "if > 0, payload is (rows, n_values) complex64 instead", low=0),
              Param("batch", int, 1, "cycles per frame", low=1),
              Param("frames", int, 0, "if > 0, the stream ends after this many frames", low=0))

    def start(self) -> None:
        self.next_cycle = 0

    def generate(self, seq: int) -> Frame | None:
        if self.frames and seq >= self.frames:
            return None
        if self.batch > 1:
            n = min(self.batch, self.cycle_budget or self.batch)
            c0, self.next_cycle = self.next_cycle, self.next_cycle + n
            return Frame.of(np.repeat(np.arange(c0, c0 + n, dtype=float)[:, None], self.n_values, axis=1),
                            cycle=c0, cycles=n)
        if self.rows:
            return Frame.of(np.full((self.rows, self.n_values), seq, dtype=np.complex64), value=seq)
        return Frame.of(np.full(self.n_values, float(seq)), value=seq)
