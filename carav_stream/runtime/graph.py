"""The graph model: nodes, edges, hosts, restart policies and graph-wide parameters, as `loader.load_graph`
builds them from graph files (the file format and composition rules are described there)."""
from __future__ import annotations

import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from carav_stream.runtime import planes
from carav_stream.runtime.block import PARAM_ERRORS, Block
from carav_stream.runtime.registry import Registry

TOP_KEYS = {"include", "description", "connections", "remove_connections", "blocks", "run", "restart", "hosts",
            "security", "block_paths", "template"}
NODE_KEYS = {"type", "host", "restart"}
RUN_DEFAULTS: dict[str, Any] = {"cycles": 0, "queue_frames": 8, "heartbeat_timeout_s": 15.0,
                                "drain_timeout_s": 30.0, "ready_timeout_s": 60.0, "transport": planes.DEFAULT,
                                "zygote": True}
# the data planes of same-host edges a graph may name (runtime/planes/: arrays in ZeroMQ messages, in shared
# memory, and those of CARAV_PLANE_PATH's folders when this module is first imported)
TRANSPORTS = planes.names()
RESTART_POLICIES = ("never", "on-failure")
LOCAL_HOST = "local"


class GraphError(ValueError):
    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("\n".join(problems))


@dataclass(frozen=True)
class Restart:
    policy: str = "never"
    max_restarts: int = 3


@dataclass(frozen=True)
class Edge:
    src: str
    src_port: str
    dst: str
    dst_port: str

    def __str__(self) -> str:
        return f"{self.src}.{self.src_port} -> {self.dst}.{self.dst_port}"


@dataclass
class Node:
    name: str
    type: str
    params: dict[str, Any]
    host: str = LOCAL_HOST
    restart: Restart = field(default_factory=Restart)


@dataclass(frozen=True)
class Host:
    name: str
    address: str = "127.0.0.1"
    bind: str = "127.0.0.1"
    port_base: int = 0


@dataclass
class Graph:
    path: Path
    description: str
    nodes: dict[str, Node]
    edges: list[Edge]
    run: dict[str, Any]
    hosts: dict[str, Host]
    security: dict[str, Any]       # [security]: CURVE key files (Paths) and `tcp` (validate/security.py)
    block_paths: list[Path]
    registry: Registry
    params: dict[str, Any] = field(default_factory=dict)   # graph-wide parameters
    warnings: list[str] = field(default_factory=list)      # the blocks' param_warnings(), each once
    open_params: list[str] = field(default_factory=list)   # a template's `node.param`s still without a value
    composed: list[str] = field(default_factory=list)      # what composition replaced: connections, parameters
    # the blocks' param_warnings() a loader left for later (load_graph's checks_later), each with its place
    later_checks: list[tuple[str, Callable[[], list[str]]]] = field(default_factory=list, repr=False)

    def run_later_checks(self) -> list[str]:
        """Run the checks left for later: their warnings join `warnings` (each text once); returns their problems,
        each located as validation locates them (an empty list: the graph is valid)."""
        problems = []
        for where, check in self.later_checks:
            try:
                found = check()
            except PARAM_ERRORS as exc:
                problems.append(f"{where}: {exc}")
            else:
                self.warnings += [w for w in found if w not in self.warnings]
        self.later_checks = []
        return problems

    def params_for(self, block_type: str, explicit: dict[str, Any]) -> dict[str, Any]:
        """A block's parameters: the graph-wide ones it declares, overridden by `explicit`."""
        return with_graph_params(self.registry.get(block_type).cls, self.params, explicit)

    def block_class(self, node: str) -> type[Block]:
        return self.registry.get(self.nodes[node].type).cls

    def edges_into(self, node: str) -> list[Edge]:
        return [e for e in self.edges if e.dst == node]

    def edges_from(self, node: str) -> list[Edge]:
        return [e for e in self.edges if e.src == node]

    def sources(self) -> list[str]:
        return [n for n in self.nodes if not self.edges_into(n)]

    def topological_order(self) -> list[str]:
        from graphlib import TopologicalSorter
        sorter = TopologicalSorter({n: [e.src for e in self.edges_into(n)] for n in self.nodes})
        return list(sorter.static_order())


def with_graph_params(cls: type[Block], graph_params: dict[str, Any], explicit: dict[str, Any]) -> dict[str, Any]:
    """The graph-wide parameters `cls` declares, overridden by the node's own (`explicit`)."""
    declared = {p.name for p in cls.params}
    return {**{k: v for k, v in graph_params.items() if k in declared}, **explicit}


def parse_value(text: str) -> Any:
    """A --set value: a TOML literal (3, 1.5, true, "x", [1, 2], nan) or else the bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


@dataclass
class Source:
    """A graph file's data after composition, with the folders that relative names written in it refer to."""

    data: dict[str, Any]
    folders: dict[str, Path]        # "top:<key>" or "node:<name>:<param>" -> folder of the file that wrote it
    files: list[Path]               # the graph file first, then every file it includes
    # per node an including graph changed without a type: its spec in the included graph, and the keys it restated
    bases: dict[str, dict[str, Any]] = field(default_factory=dict)
    restated: dict[str, set[str]] = field(default_factory=dict)
    composed: list[str] = field(default_factory=list)       # what composition replaced, in words
