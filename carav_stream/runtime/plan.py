"""A run's plan: the NodeSpec of every node of a graph that runs on this host, with its endpoints and, over
shared memory, its segments. The supervisor writes each spec to the run folder and starts a node on it.

Endpoints: an edge between two nodes of one host is an ipc endpoint in the run folder, named after its input
(`<node>.<port>`); an edge across hosts is a TCP port of the receiving host, counted up from its port_base in
the order of (node, port) of the inputs. The consumer binds, the producer connects.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from carav_stream.runtime import shm, transport
from carav_stream.runtime.graph import Graph
from carav_stream.runtime.protocol import LEASE_FRAMES, NodeSpec, OutEdge

# A node waits for its go this long past the graph's run.ready_timeout_s (the supervisor's own wait for every
# node to be ready), then exits: the supervisor sends go at the latest when that wait ends.
START_SLACK_S = 30.0

ShmOut = dict[tuple[str, str], dict[str, Any]]   # (node, port) -> {fd, edges}: a producer's segment
ShmIn = dict[tuple[str, str], list[int]]         # (node, port) -> [fd, edge index]: a consumer's


def local_nodes(graph: Graph, host: str | None) -> list[str]:
    """The nodes of `graph` on `host`, in the graph's order; every node when host is None."""
    if host is None:
        return list(graph.nodes)
    return [n for n, node in graph.nodes.items() if node.host == host]


def plan_specs(graph: Graph, host: str | None, run_dir: Path, cycles: int | None,
               segments: list[int]) -> dict[str, NodeSpec]:
    """The spec of every local node, in the graph's order. The file descriptors of the shared-memory segments
    it creates are appended to `segments` as they are made (the caller closes them when the run ends);
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
    shm_out, shm_in = plan_segments(graph, host, segments)
    specs = {}
    for name in local_nodes(graph, host):
        node = g.nodes[name]
        outputs: dict[str, list[OutEdge]] = {}
        for e in g.edges_from(name):
            tap = any(p.name == e.dst_port and p.tap for p in g.block_class(e.dst).inputs)
            outputs.setdefault(e.src_port, []).append(OutEdge(str(e), endpoints[(e.dst, e.dst_port)][1], tap))
        specs[name] = NodeSpec(
            shm_out={port: seg for (n, port), seg in shm_out.items() if n == name},
            shm_in={port: ref for (n, port), ref in shm_in.items() if n == name},
            name=name, type=node.type, params=node.params, control=control,
            inputs={e.dst_port: endpoints[(e.dst, e.dst_port)][0] for e in g.edges_into(name)},
            outputs={port: tuple(edges) for port, edges in outputs.items()},
            queue_frames=int(g.run["queue_frames"]), drain_timeout_s=float(g.run["drain_timeout_s"]),
            start_timeout_s=float(g.run["ready_timeout_s"]) + START_SLACK_S,
            max_cycles=int(cycles or 0) if not g.edges_into(name) else 0,
            seq_lease=0 if g.edges_into(name) else LEASE_FRAMES,
            block_paths=tuple(str(p) for p in g.registry.paths[1:]),
            security={k: str(v) for k, v in g.security.items()})
    return specs


def plan_segments(graph: Graph, host: str | None, segments: list[int]) -> tuple[ShmOut, ShmIn]:
    """With run.transport = "shm": a shared-memory segment (runtime/shm.py) for every output port of a local
    node whose edges all stay on this host; {(node, port): {fd, edges}} for producers and
    {(node, port): [fd, edge index]} for consumers. A port with an edge to another host stays inline. The
    segments' file descriptors are appended to `segments`."""
    g = graph
    shm_out: ShmOut = {}
    shm_in: ShmIn = {}
    if g.run["transport"] != "shm":
        return shm_out, shm_in
    local = set(local_nodes(graph, host))
    ports: dict[tuple[str, str], list] = {}
    for e in g.edges:
        if e.src in local:
            ports.setdefault((e.src, e.src_port), []).append(e)
    n_slots = min(shm.MAX_SLOTS, 6 * int(g.run["queue_frames"]) + 4)   # ZeroMQ queues, pairing, in hand
    for (src, port), edges in ports.items():
        if any(e.dst not in local for e in edges) or len(edges) > shm.MAX_EDGES:
            continue
        fd = shm.create_segment(n_slots, len(edges), f"carav-{src}.{port}")
        segments.append(fd)
        shm_out[(src, port)] = {"fd": fd, "edges": [str(e) for e in edges]}
        for i, e in enumerate(edges):
            shm_in[(e.dst, e.dst_port)] = [fd, i]
    return shm_out, shm_in
