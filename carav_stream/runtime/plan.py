"""A run's plan: the NodeSpec of every node of a graph that runs on this host, with its endpoints and what its
data plane gave its ports (runtime/planes/), and the highest seq each input can carry (input_bounds). The
supervisor writes each spec to the run folder and starts a node on it.

Endpoints: an edge between two nodes of one host is an ipc endpoint in the run folder, named after its input
(`<node>.<port>`); an edge across hosts is a TCP port of the receiving host, counted up from its port_base in
the order of (node, port) of the inputs. The consumer binds, the producer connects.
"""
from __future__ import annotations

from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any

from carav_stream.runtime import transport
from carav_stream.runtime.graph import Graph
from carav_stream.runtime.planes import Plane
from carav_stream.runtime.protocol import LEASE_FRAMES, NodeSpec, OutEdge

# A node waits for its go this long past the graph's run.ready_timeout_s (the supervisor's own wait for every
# node to be ready), then exits: the supervisor sends go at the latest when that wait ends.
START_SLACK_S = 30.0

Ends = dict[tuple[str, str], Any]      # (node, port) -> the resources the plane gave that port's end


def local_nodes(graph: Graph, host: str | None) -> list[str]:
    """The nodes of `graph` on `host`, in the graph's order; every node when host is None."""
    if host is None:
        return list(graph.nodes)
    return [n for n, node in graph.nodes.items() if node.host == host]


def plan_specs(graph: Graph, host: str | None, run_dir: Path, cycles: int | None, plane: Plane,
               keys: dict[str, str] | None = None) -> dict[str, NodeSpec]:
    """The spec of every local node, in the graph's order, with what the run's `plane` gave its ports (the caller
    closes the plane when the run ends) and the CURVE key files of its tcp edges (`keys`: curve_keys.plan_keys);
    ValueError for an edge across hosts to a host without port_base."""
    g = graph
    endpoints: dict[tuple[str, str], tuple[str, str]] = {}   # input -> (bind, connect)
    cross_ports: dict[str, int] = {}
    for e in sorted(g.edges, key=lambda e: (e.dst, e.dst_port)):
        dst_host = g.hosts[g.nodes[e.dst].host]
        if g.nodes[e.src].host == g.nodes[e.dst].host:
            ep = transport.ipc_endpoint(run_dir, f"{e.dst}.{e.dst_port}")
            endpoints[(e.dst, e.dst_port)] = (ep, ep)
        else:
            if not dst_host.port_base:
                raise ValueError(f"{g.path.name}: edge '{e}' crosses hosts; set hosts.{dst_host.name}.port_base")
            port = dst_host.port_base + cross_ports.setdefault(dst_host.name, 0)
            cross_ports[dst_host.name] += 1
            endpoints[(e.dst, e.dst_port)] = (f"tcp://{dst_host.bind}:{port}", f"tcp://{dst_host.address}:{port}")
    control = transport.ipc_endpoint(run_dir, "control")
    ends_out, ends_in, fds = plan_plane(graph, host, plane)
    specs = {}
    for name in local_nodes(graph, host):
        node = g.nodes[name]
        outputs: dict[str, list[OutEdge]] = {}
        for e in g.edges_from(name):
            tap = any(p.name == e.dst_port and p.tap for p in g.block_class(e.dst).inputs)
            outputs.setdefault(e.src_port, []).append(OutEdge(str(e), endpoints[(e.dst, e.dst_port)][1], tap))
        specs[name] = NodeSpec(
            plane=plane.name, plane_out={port: res for (n, port), res in ends_out.items() if n == name},
            plane_in={port: res for (n, port), res in ends_in.items() if n == name},
            inherit_fds=sorted(fds.get(name, ())),
            name=name, type=node.type, params=node.params, control=control,
            inputs={e.dst_port: endpoints[(e.dst, e.dst_port)][0] for e in g.edges_into(name)},
            outputs={port: tuple(edges) for port, edges in outputs.items()},
            queue_frames=int(g.run["queue_frames"]), drain_timeout_s=float(g.run["drain_timeout_s"]),
            start_timeout_s=float(g.run["ready_timeout_s"]) + START_SLACK_S,
            max_cycles=int(cycles or 0) if not g.edges_into(name) else 0,
            seq_lease=0 if g.edges_into(name) else LEASE_FRAMES,
            block_paths=tuple(str(p) for p in g.registry.paths[1:]),
            security=dict(keys or {}))
    return specs


def plan_plane(graph: Graph, host: str | None, plane: Plane) -> tuple[Ends, Ends, dict[str, set[int]]]:
    """What `plane` gives every output port of a local node whose edges all stay on this host (a port with an
    edge to another host stays inline): the producers' resources {(node, port): ...}, the consumers' likewise,
    and {node: file descriptors it inherits}."""
    local = set(local_nodes(graph, host))
    ports: dict[tuple[str, str], list] = {}
    for e in graph.edges:
        if e.src in local:
            ports.setdefault((e.src, e.src_port), []).append(e)
    ends_out: Ends = {}
    ends_in: Ends = {}
    fds: dict[str, set[int]] = {}
    for (src, port), edges in ports.items():
        if any(e.dst not in local for e in edges):
            continue
        got = plane.open_port(f"{src}.{port}", [str(e) for e in edges])
        if got is None:
            continue
        ends_out[(src, port)] = got.producer
        fds.setdefault(src, set()).update(got.fds)
        for e, resources in zip(edges, got.consumers, strict=True):
            ends_in[(e.dst, e.dst_port)] = resources
            fds.setdefault(e.dst, set()).update(got.fds)
    return ends_out, ends_in, fds


def input_sources(graph: Graph, local: Collection[str]) -> dict[tuple[str, str], frozenset[str] | None]:
    """The sources whose seqs reach each input (node, port) of the `local` nodes; None when one of them runs on
    another host."""
    return {(e.dst, e.dst_port): _sources_upstream(graph, local, e.src) for e in graph.edges if e.dst in local}


def _sources_upstream(graph: Graph, local: Collection[str], name: str) -> frozenset[str] | None:
    """The sources whose seqs reach node `name`'s outputs (itself if a source); None if one is not local."""
    seen, todo, found = {name}, [name], set()
    while todo:
        n = todo.pop()
        if n not in local:
            return None
        into = graph.edges_into(n)
        if not into:
            found.add(n)
        for e in into:
            if e.src not in seen:
                seen.add(e.src)
                todo.append(e.src)
    return frozenset(found)


def input_bounds(graph: Graph, sources: dict[tuple[str, str], frozenset[str] | None], name: str,
                 lease_of: Callable[[str], int]) -> dict[str, int]:
    """The highest seq each input of node `name` can carry (pairing.py argues the bound): the largest lease
    (`lease_of(source)`) of its `sources`, one lease more for a grant not read yet, plus the graph's depth; inputs
    fed from another host are left out."""
    slack = LEASE_FRAMES + len(graph.nodes)
    return {port: max(lease_of(s) for s in srcs) + slack
            for (dst, port), srcs in sources.items() if dst == name and srcs}
