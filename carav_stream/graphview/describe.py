"""What a picture of a graph writes: each node's name, block type and the parameters the graph sets for it, and
each connection's stream, read from the block classes' port declarations (`In`/`Out`: kind, dtypes, doc) without
building a block.

A stream is named by its producer's port (its kind, dtypes and description), the consumer's port filling in what
the producer leaves open ("any"). Its transport is where the frames travel: `tcp` between hosts; on one host `ipc`
(ZeroMQ messages through the run folder), or the data plane the graph asks for (`[run] transport`, e.g. `shm`:
the header over ipc, the arrays in shared memory) for an output port whose edges all stay on the host, as the
run's plan gives them (runtime/plan.py). A `tap` edge never slows its producer (runtime/block.py: In.tap).
"""
from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import Any

from carav_stream.runtime import planes
from carav_stream.runtime.graph import LOCAL_HOST, Edge, Graph

MAX_PARAMS = 4          # parameter lines under a node's type; more are counted in one line
MAX_VALUE_CHARS = 20    # a longer value (a file name, a list) is cut, its end shown
LABEL_CHARS = 24        # a connection's label is wrapped to lines of this many characters


@dataclass(frozen=True)
class NodeText:
    """What a node's box says, and its ports in declaration order."""

    name: str
    type: str
    host: str                       # "" when the whole graph runs on one host
    params: tuple[str, ...]         # "model = smart", the variant first, then as the graph writes them
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    connected: frozenset[tuple[str, str]]   # ("in" | "out", port) of the ports a connection uses


@dataclass(frozen=True)
class Stream:
    """What travels on one connection."""

    edge: Edge
    kind: str                       # the port kind ("adc_frame"), "any" when neither port names one
    dtypes: str                     # "int16|float32", "header only", or "any dtype"
    doc: str                        # the producing (else consuming) port's description, "" if neither has one
    transport: str                  # "ipc", "tcp", or a data plane's name ("shm")
    tap: bool

    @property
    def tail(self) -> str:
        """dtypes · transport [· tap]"""
        return " · ".join(self.tail_parts)

    @property
    def tail_parts(self) -> list[str]:
        return [self.dtypes, self.transport, *(["tap"] if self.tap else [])]

    @property
    def lines(self) -> list[str]:
        return [text for text, _ in self.label]

    @property
    def label(self) -> list[tuple[str, str]]:
        """The label's lines with their role ("kind", "doc", "tail"), each of LABEL_CHARS at most where words
        allow: the kind, the description, dtypes · transport."""
        tail: list[str] = []
        for part in self.tail_parts:
            if tail and len(tail[-1]) + 3 + len(part) <= LABEL_CHARS:
                tail[-1] += " · " + part
            else:
                tail.append(part)
        return [(self.kind, "kind"), *((t, "doc") for t in textwrap.wrap(self.doc, LABEL_CHARS)),
                *((t, "tail") for t in tail)]


def node_text(graph: Graph, name: str) -> NodeText:
    node = graph.nodes[name]
    cls = graph.block_class(name)
    hosts = {n.host for n in graph.nodes.values()}
    used = {("in", e.dst_port) for e in graph.edges_into(name)} | {("out", e.src_port) for e in graph.edges_from(name)}
    return NodeText(name, node.type, node.host if hosts != {LOCAL_HOST} else "", param_lines(graph, name),
                    tuple(p.name for p in cls.inputs), tuple(p.name for p in cls.outputs), frozenset(used))


def param_lines(graph: Graph, name: str) -> tuple[str, ...]:
    """The parameters the graph (or --set) gives the node itself, not the graph-wide ones every block shares; the
    block's variant (the attacker's model) first; at most MAX_PARAMS lines."""
    cls = graph.block_class(name)
    declared = {p.name: p for p in cls.params}
    own = {k: v for k, v in graph.nodes[name].params.items()
           if k not in graph.params and not (k in declared and declared[k].graph_wide)}
    if cls.variant in own:
        own = {cls.variant: own[cls.variant], **own}
    lines = []
    for key, value in own.items():
        unit = declared[key].unit if key in declared else ""
        lines.append(f"{key} = {short(value)}{' ' + unit if unit else ''}")
    if len(lines) > MAX_PARAMS:
        lines[MAX_PARAMS - 1:] = [f"+{len(lines) - MAX_PARAMS + 1} more parameters"]
    return tuple(lines)


def short(value: Any) -> str:
    """A parameter value as a graph file would write it, cut to MAX_VALUE_CHARS keeping its end (a file's name)."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = f"{value:g}"
    else:
        text = str(value)
    return text if len(text) <= MAX_VALUE_CHARS else "…" + text[-(MAX_VALUE_CHARS - 1):]


def stream(graph: Graph, edge: Edge) -> Stream:
    out = next(p for p in graph.block_class(edge.src).outputs if p.name == edge.src_port)
    inp = next(p for p in graph.block_class(edge.dst).inputs if p.name == edge.dst_port)
    kind = out.kind if out.kind != "any" else inp.kind
    dtypes = out.dtypes or inp.dtypes
    text = ("header only" if dtypes == ("none",) else "|".join(dtypes)) if dtypes else "any dtype"
    return Stream(edge, kind, text, out.doc or inp.doc, transport(graph, edge), inp.tap)


def transport(graph: Graph, edge: Edge) -> str:
    """tcp between hosts; on one host the graph's data plane for a port whose edges all stay there, else ipc."""
    host = graph.nodes[edge.src].host
    if graph.nodes[edge.dst].host != host:
        return "tcp"
    plane = str(graph.run["transport"])
    siblings = [e for e in graph.edges_from(edge.src) if e.src_port == edge.src_port]
    if plane == planes.DEFAULT or any(graph.nodes[e.dst].host != host for e in siblings):
        return "ipc"
    return plane


def graph_line(graph: Graph) -> str:
    """The graph-wide parameters, `scene = table1, seed = 7, batch = 32`."""
    return ", ".join(f"{k} = {short(v)}" for k, v in graph.params.items())
