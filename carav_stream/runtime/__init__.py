"""The runtime: frames between processes, graphs, nodes and their supervisor. It knows nothing of radar.

What a block file needs is exported here:

    from carav_stream.runtime import Block, Frame, In, Out, Param

The exported names are imported when first asked for (they bring numpy): `carav run` imports the runtime's
launcher first, and starts the zygote that forks its nodes before anything heavy is imported.
"""
from typing import Any

__all__ = ["REQUIRED", "Block", "BlockError", "Frame", "FrameError", "In", "Out", "Param", "cycle_indices",
           "n_cycles", "per_cycle", "pick", "writing"]


def __getattr__(name: str) -> Any:
    """An exported name, imported on first use (PEP 562); AttributeError for any other (a submodule is imported
    by the import system then)."""
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    # start-up time: the block API imports numpy (module docstring)
    from carav_stream.core.params import REQUIRED, Param
    from carav_stream.runtime.block import Block, BlockError, In, Out, writing
    from carav_stream.runtime.cycles import cycle_indices, n_cycles, per_cycle, pick
    from carav_stream.runtime.frames import Frame, FrameError

    exported = {"REQUIRED": REQUIRED, "Param": Param, "Block": Block, "BlockError": BlockError, "In": In, "Out": Out,
                "writing": writing, "cycle_indices": cycle_indices, "n_cycles": n_cycles, "per_cycle": per_cycle,
                "pick": pick, "Frame": Frame, "FrameError": FrameError}
    globals().update(exported)
    return exported[name]
