"""The test kit: test your own blocks and graphs as the project tests its own (docs/TESTING.md).

harness   BlockHarness: a block in-process, fed frames through the codec and the node's pairing, whole or split at
          random frame boundaries; check_declared, assert_outputs
golden    golden vectors from a reference of your own: check_vector, save_vectors, load_vectors
graphs    GraphRun and Graphs: graph files run as real processes, waits that follow progress, per-cycle records,
          swapping and killing a node, teardown of the process group
radar     the radar graph with your block in place of a built-in one: the fail-closed check, the false-alarm rate,
          bit-for-bit equality with run_algorithm1
plugin    the pytest plugin (entry point pytest11 "carav"): the `carav` fixture

`carav new block NAME` writes a block, its test (using this kit) and a graph snippet that wires it.
"""
from carav_stream.testing.golden import check_vector, load_vectors, save_vectors
from carav_stream.testing.harness import BlockHarness, Outputs, assert_outputs, check_declared, random_bounds, wire

__all__ = ["BlockHarness", "Outputs", "assert_outputs", "check_declared", "random_bounds", "wire", "check_vector",
           "load_vectors", "save_vectors"]
