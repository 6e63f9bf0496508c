"""Toy source: frame seq n carries a float64 payload [n, n, ...] of `n_values` values.

Ports   out out   float64 (n_values,)
Graph   src = { type = "counter_source", n_values = 4 }
"""
import numpy as np

from carav_stream.block import Block, Out, Param
from carav_stream.frames import Frame


class CounterSource(Block):
    outputs = (Out("out", kind="numbers", dtypes=("float64",)),)
    params = (Param("n_values", int, 4, "values per frame", low=1),
              Param("rows", int, 0, "if > 0, payload is (rows, n_values) complex64 instead", low=0))

    def generate(self, seq: int) -> Frame:
        if self.rows:
            return Frame.of(np.full((self.rows, self.n_values), seq, dtype=np.complex64), value=seq)
        return Frame.of(np.full(self.n_values, float(seq)), value=seq)
