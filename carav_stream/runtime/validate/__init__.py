"""Graph validation: every check runs before any process starts, and every problem is reported, located.

Checks, by stage (build.py runs them in order): the tables and their keys, hosts and restart policies (tables.py);
unknown block types (and conflicting block folders); parameters (type, range, NaN and infinity, required values,
cross-parameter checks of the block) and graph-wide parameters (one value for the whole graph, checked once: a
scene error is reported once, not once per block) (params.py); connections (unknown nodes and ports, port kinds and
dtypes), inputs connected twice or not at all, cycles (naming their blocks) (ports.py); [security] and the tcp
edges it protects (security.py). A block swapped into a running graph is checked the same way (swap.py).

Templates: a graph that leaves parameters for whoever runs it to give says so, `template = ["source.path"]`
(`node.param` each, of a node of the graph and a parameter its block declares). Checked as a template
(`carav validate`, `open_ok=True`), a listed parameter may stay without a value and the block's cross-parameter
checks wait for it; run (`carav run`), it is a missing required parameter like any other, and the message says how
to give it.
"""
from carav_stream.runtime.validate.build import build_graph
from carav_stream.runtime.validate.ports import port_mismatch
from carav_stream.runtime.validate.swap import swap_problems

__all__ = ["build_graph", "port_mismatch", "swap_problems"]
