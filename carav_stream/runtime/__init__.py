"""The runtime: frames between processes, graphs, nodes and their supervisor. It knows nothing of radar.

What a block file needs is exported here:

    from carav_stream.runtime import Block, Frame, In, Out, Param
"""
from carav_stream.core.params import REQUIRED, Param
from carav_stream.runtime.block import Block, BlockError, In, Out, writing
from carav_stream.runtime.cycles import cycle_indices, n_cycles, per_cycle, pick
from carav_stream.runtime.frames import Frame, FrameError

__all__ = ["REQUIRED", "Block", "BlockError", "Frame", "FrameError", "In", "Out", "Param", "cycle_indices",
           "n_cycles", "per_cycle", "pick", "writing"]
