"""The CURVE keys of a run's tcp edges: the graph's own ([security] key files), or keys made for the run.

A supervisor that runs every node of a graph makes keys for the run when the graph names none and does not say
`tcp = "plain"`: a server and a client key pair (zmq.curve_keypair) written into the run's own folder (mode 0700,
removed with it), readable by no other user. Validation has made sure that every host of such a graph is this
machine (runtime/validate/security.py). A supervisor that runs one host's part (`--host`) cannot share keys it
makes with the others: such a run needs the graph's own keys (`split_run_problem`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from carav_stream.runtime.curve import key_files, write_keys
from carav_stream.runtime.graph import Edge, Graph
from carav_stream.runtime.validate.security import MAKE_KEYS, plain_warning, tcp_edges


def run_tcp_edges(graph: Graph, host: str | None) -> list[Edge]:
    """The tcp edges with an end on `host` (every tcp edge of the graph when None)."""
    return [e for e in tcp_edges(graph.nodes, graph.edges)
            if host is None or host in (graph.nodes[e.src].host, graph.nodes[e.dst].host)]


def split_run_problem(graph: Graph, host: str | None) -> str | None:
    """Why a supervisor cannot run host `host`'s part of `graph` alone (its tcp edges would need keys made for a
    run that spans other supervisors), or None."""
    if host is None or graph.security.get("tcp") == "plain" or key_files(graph.security):
        return None
    edges = run_tcp_edges(graph, host)
    if not edges:
        return None
    return (f"--host {host}: edge '{edges[0]}' joins a host that another supervisor runs, and keys made for one "
            f"run cannot be shared: a graph run in parts needs its own CURVE keys; {MAKE_KEYS}")


def plan_keys(graph: Graph, host: str | None, folder: Path) -> tuple[dict[str, str], dict[str, Any]]:
    """The key files every node's spec names (made in `folder` when the run makes its own; {} without CURVE) and
    the summary's account of them: `tcp` (none: no tcp edge here, curve or plain), `keys` (graph or run) and
    `warnings`. ValueError for a part of a graph that split_run_problem refuses."""
    edges = run_tcp_edges(graph, host)
    if not edges:
        return {}, {"tcp": "none", "keys": None, "warnings": []}
    if graph.security.get("tcp") == "plain":
        return {}, {"tcp": "plain", "keys": None, "warnings": [plain_warning(edges)]}
    files = key_files(graph.security)
    if files:
        return files, {"tcp": "curve", "keys": "graph", "warnings": []}
    problem = split_run_problem(graph, host)
    if problem is not None:
        raise ValueError(problem)
    return write_keys(folder), {"tcp": "curve", "keys": "run", "warnings": []}
