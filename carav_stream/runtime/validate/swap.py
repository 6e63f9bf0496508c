"""A node's block swapped while the graph runs: the new block checked against the running graph as the graph file
was (its parameters, graph-wide values, the ports of the edges it takes over, being a source or not)."""
from __future__ import annotations

from typing import Any

from carav_stream.runtime.block import PARAM_ERRORS
from carav_stream.runtime.graph import Graph
from carav_stream.runtime.registry import RegistryError
from carav_stream.runtime.validate.ports import port_mismatch


def swap_problems(graph: Graph, node: str, block_type: str, params: dict[str, Any]) -> list[str]:
    """Why `node` cannot be replaced by `block_type(**params)` while running; empty when it can.
    `params` are complete (graph-wide ones applied with Graph.params_for)."""
    if node not in graph.nodes:
        return [f"unknown node {node!r}; nodes are {sorted(graph.nodes)}"]
    try:
        new = graph.registry.get(block_type).cls
    except RegistryError as exc:
        return [str(exc)]
    old = graph.block_class(node)
    problems = [f"{block_type}.{p}: {t}" for p, t in new.param_problems(params)]
    problems += [f"{block_type}.{p.name}: graph-wide parameter; the graph runs with {graph.params[p.name]!r}, "
                 f"not {params[p.name]!r}" for p in new.params
                 if p.graph_wide and p.name in graph.params and p.name in params
                 and params[p.name] != graph.params[p.name]]
    def port(ports, name):
        return next((p for p in ports if p.name == name), None)

    ends = [(e, port(graph.block_class(e.src).outputs, e.src_port), port(new.inputs, e.dst_port), "input",
             e.dst_port) for e in graph.edges_into(node)]
    ends += [(e, port(new.outputs, e.src_port), port(graph.block_class(e.dst).inputs, e.dst_port), "output",
              e.src_port) for e in graph.edges_from(node)]
    for e, out, inp, side, name in ends:          # the new block's side of an edge may be missing, never the other
        if out is None or inp is None:
            problems.append(f"{block_type} has no {side} {name!r} (connected: '{e}')")
        elif port_mismatch(out, inp):
            problems.append(f"'{e}': {port_mismatch(out, inp)}")
    connected_in = {e.dst_port for e in graph.edges_into(node)}
    problems += [f"{block_type} input {p.name!r} is required but not connected at {node}"
                 for p in new.inputs if p.required and p.name not in connected_in]
    if old.is_source() != new.is_source():
        problems.append(f"{node} is {'a source' if old.is_source() else 'not a source'}; {block_type} is not alike")
    if not problems:
        try:
            new(**params)
        except PARAM_ERRORS as exc:
            problems.append(f"{block_type}: {exc}")
    return problems
