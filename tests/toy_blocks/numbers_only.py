"""Toy sink accepting only int32 'counts' (for type-mismatch tests).

Graph   s = { type = "numbers_only" }
"""
from carav_stream.runtime.block import Block, In


class NumbersOnly(Block):
    inputs = (In("inp", kind="counts", dtypes=("int32",)),)

    def process(self, inp):
        return None
