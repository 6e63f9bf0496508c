"""Graph files: load a declarative TOML graph and validate all of it before any process starts.

    description = "..."
    seed = 7                          # any other top-level value is a graph-wide parameter, given to every
    scene = "table1"                  # block that declares a parameter of that name and does not set it
    block_paths = ["./my_blocks"]     # extra folders of block files, relative to the graph file
    connections = ["source.out -> sink.in", ...]

    [blocks]
    source = { type = "counter_source", rate_hz = 0.0 }
    sink   = { type = "jsonl_sink", path = "out.jsonl", restart = "on-failure", host = "b" }

    [run]      cycles, queue_frames, heartbeat_timeout_s, drain_timeout_s, ready_timeout_s
    [restart]  policy = "never" | "on-failure", max_restarts
    [hosts.b]  address = "127.0.0.1", bind = "127.0.0.1", port_base = 47000
    [security] curve_server_cert, curve_client_cert, curve_authorized   (ZeroMQ CURVE on tcp edges)

Every problem is reported at once, each located: `demo.toml: blocks.detector.eta: must be > 0, got -1.5`.

Relative file names: `block_paths` and `[security]` key files are relative to the graph file. A parameter that
names a file a block reads (`Param(file=True)`, e.g. `scene = "my_scene.toml"`) is taken relative to the graph
file's folder when the file exists there, so a graph and its scene file travel together; otherwise (preset
names, files elsewhere) the value is left as written, and relative paths are then relative to the working
directory, as are `--set` values and output files (`path` of the sinks).
"""
from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from carav_stream.block import Block, BlockError
from carav_stream.registry import Registry, RegistryError

EDGE_RE = re.compile(r"^\s*([A-Za-z_][\w]*)\.([A-Za-z_]\w*)\s*->\s*([A-Za-z_][\w]*)\.([A-Za-z_]\w*)\s*$")
NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
TOP_KEYS = {"description", "connections", "blocks", "run", "restart", "hosts", "security", "block_paths"}
NODE_KEYS = {"type", "host", "restart"}
RUN_DEFAULTS: dict[str, Any] = {"cycles": 0, "queue_frames": 8, "heartbeat_timeout_s": 15.0,
                                "drain_timeout_s": 30.0, "ready_timeout_s": 60.0}
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
    security: dict[str, Path]
    block_paths: list[Path]
    registry: Registry
    params: dict[str, Any] = field(default_factory=dict)   # graph-wide parameters

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
        order, seen = [], set()

        def visit(n: str) -> None:
            if n not in seen:
                seen.add(n)
                for e in self.edges_into(n):
                    visit(e.src)
                order.append(n)
        for n in self.nodes:
            visit(n)
        return order


def parse_value(text: str) -> Any:
    """A --set value: a TOML literal (3, 1.5, true, "x", [1, 2]) or else the bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def load_graph(path: str | Path, overrides: list[str] = (), extra_block_paths: list[str | Path] = ()) -> Graph:
    """Read and fully validate a graph file; raises GraphError listing every problem."""
    path = Path(path)
    where = path.name
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise GraphError([f"{path}: graph file not found"]) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise GraphError([f"{where}: not valid TOML: {exc}"]) from None
    problems: list[str] = []
    block_paths = [(path.parent / p).resolve() for p in _list_of_str(data.get("block_paths", []), where,
                                                                     "block_paths", problems)]
    registry = Registry([*block_paths, *extra_block_paths])
    problems += [f"{where}: {c}" for c in registry.conflicts]
    blocks = data.get("blocks")
    if not isinstance(blocks, dict) or not blocks:
        problems.append(f"{where}: blocks: a [blocks] table with at least one node is required")
        blocks = {}
    graph_params = {k: v for k, v in data.items() if k not in TOP_KEYS}
    run = _table(data, "run", where, problems, RUN_DEFAULTS)
    restart_default = _restart(data.get("restart", {}), f"{where}: restart", problems)
    hosts = _hosts(data.get("hosts", {}), where, problems)
    nodes: dict[str, Node] = {}
    for name, spec in blocks.items():
        node = _node(name, spec, where, hosts, restart_default, problems)
        if node:
            nodes[name] = node
    from_file = {n: dict(node.params) for n, node in nodes.items()}
    _apply_overrides(nodes, overrides, where, problems)
    classes: dict[str, type[Block]] = {}
    for node in nodes.values():
        try:
            classes[node.name] = registry.get(node.type).cls
        except RegistryError as exc:
            problems.append(f"{where}: blocks.{node.name}.type: {exc}")
    _resolve_files(path.parent, nodes, classes, graph_params, from_file)
    _apply_graph_params(nodes, classes, graph_params, where, problems)
    for node in nodes.values():
        if node.name in classes:
            _check_params(node, classes[node.name], where, problems)
    edges = _edges(data.get("connections", []), nodes, classes, where, problems)
    _check_inputs(nodes, classes, edges, where, problems)
    _check_cycles(nodes, edges, where, problems)
    security = _security(data.get("security", {}), path, where, problems)
    if problems:
        raise GraphError(problems)
    return Graph(path, str(data.get("description", "")), nodes, edges, run, hosts, security, block_paths, registry,
                 graph_params)


def _list_of_str(value: Any, where: str, key: str, problems: list[str]) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        problems.append(f"{where}: {key}: must be a list of strings, got {value!r}")
        return []
    return value


def _table(data: dict, key: str, where: str, problems: list[str], defaults: dict[str, Any]) -> dict[str, Any]:
    table = data.get(key, {})
    if not isinstance(table, dict):
        problems.append(f"{where}: {key}: must be a table, got {type(table).__name__}")
        return dict(defaults)
    result = dict(defaults)
    for k, v in table.items():
        if k not in defaults:
            problems.append(f"{where}: {key}.{k}: unknown setting; expected one of {sorted(defaults)}")
        elif not isinstance(v, (int, float)) or isinstance(v, bool) or v < 0:
            problems.append(f"{where}: {key}.{k}: must be a number >= 0, got {v!r}")
        else:
            result[k] = type(defaults[k])(v)
    return result


def _restart(spec: Any, where: str, problems: list[str], default: Restart = Restart()) -> Restart:
    if isinstance(spec, str):
        spec = {"policy": spec}
    if not isinstance(spec, dict):
        problems.append(f"{where}: must be a policy name or a table, got {spec!r}")
        return default
    unknown = set(spec) - {"policy", "max_restarts"}
    if unknown:
        problems.append(f"{where}: unknown keys {sorted(unknown)}; expected policy, max_restarts")
    policy = spec.get("policy", default.policy)
    if policy not in RESTART_POLICIES:
        problems.append(f"{where}.policy: must be one of {list(RESTART_POLICIES)}, got {policy!r}")
        policy = default.policy
    max_restarts = spec.get("max_restarts", default.max_restarts)
    if not isinstance(max_restarts, int) or isinstance(max_restarts, bool) or max_restarts < 0:
        problems.append(f"{where}.max_restarts: must be an integer >= 0, got {max_restarts!r}")
        max_restarts = default.max_restarts
    return Restart(policy, max_restarts)


def _hosts(spec: Any, where: str, problems: list[str]) -> dict[str, Host]:
    hosts = {LOCAL_HOST: Host(LOCAL_HOST)}
    if not isinstance(spec, dict):
        problems.append(f"{where}: hosts: must be a table of hosts")
        return hosts
    for name, h in spec.items():
        if not isinstance(h, dict):
            problems.append(f"{where}: hosts.{name}: must be a table")
            continue
        unknown = set(h) - {"address", "bind", "port_base"}
        if unknown:
            problems.append(f"{where}: hosts.{name}: unknown keys {sorted(unknown)}; expected address, bind, port_base")
        port_base = h.get("port_base", 0)
        if not isinstance(port_base, int) or not (1024 <= port_base <= 65000):
            problems.append(f"{where}: hosts.{name}.port_base: must be an integer port in 1024..65000, got {port_base!r}")
        address = h.get("address", "127.0.0.1")
        # Loopback unless the graph says otherwise: bind defaults to the loopback address, not to `address`.
        hosts[name] = Host(name, str(address), str(h.get("bind", "127.0.0.1")), port_base if isinstance(port_base, int) else 0)
    return hosts


def _node(name: str, spec: Any, where: str, hosts: dict[str, Host], restart: Restart,
          problems: list[str]) -> Node | None:
    loc = f"{where}: blocks.{name}"
    if not NAME_RE.match(name):
        problems.append(f"{loc}: node names must be identifiers (letters, digits, _)")
    if not isinstance(spec, dict):
        problems.append(f"{loc}: must be a table like {{ type = \"...\" }}, got {spec!r}")
        return None
    if not isinstance(spec.get("type"), str):
        problems.append(f"{loc}.type: missing or not a string; every node names its block type")
        return None
    host = spec.get("host", LOCAL_HOST)
    if host not in hosts:
        problems.append(f"{loc}.host: unknown host {host!r}; declare it under [hosts.{host}]")
        host = LOCAL_HOST
    node_restart = _restart(spec["restart"], f"{loc}.restart", problems, restart) if "restart" in spec else restart
    params = {k: v for k, v in spec.items() if k not in NODE_KEYS}
    return Node(name, spec["type"], params, host, node_restart)


def _apply_overrides(nodes: dict[str, Node], overrides: list[str], where: str, problems: list[str]) -> None:
    for item in overrides:
        key, sep, value = item.partition("=")
        node, dot, param = key.strip().partition(".")
        if not sep or not dot:
            problems.append(f"--set {item!r}: expected node.param=value")
        elif node not in nodes:
            problems.append(f"--set {item!r}: unknown node {node!r}; nodes are {sorted(nodes)}")
        else:
            nodes[node].params[param] = parse_value(value.strip())


def _resolve_files(folder: Path, nodes: dict[str, Node], classes: dict[str, type[Block]],
                   graph_params: dict[str, Any], from_file: dict[str, dict[str, Any]]) -> None:
    """Values of file parameters written in the graph file (not `--set`) that name a file in the graph
    file's folder become absolute paths to it."""
    def resolve(value: Any) -> Any:
        if isinstance(value, str) and value and not Path(value).is_absolute() and (folder / value).is_file():
            return str((folder / value).resolve())
        return value

    file_params = {n: {p.name for p in cls.params if p.file} for n, cls in classes.items()}
    for key in set().union(*file_params.values()) & graph_params.keys():
        graph_params[key] = resolve(graph_params[key])
    for n, names in file_params.items():
        params, written = nodes[n].params, from_file[n]
        for key in names & written.keys():
            if params.get(key) is written[key]:          # still the graph file's value, not a --set override
                params[key] = resolve(params[key])


def with_graph_params(cls: type[Block], graph_params: dict[str, Any], explicit: dict[str, Any]) -> dict[str, Any]:
    """The graph-wide parameters `cls` declares, overridden by the node's own (`explicit`)."""
    declared = {p.name for p in cls.params}
    return {**{k: v for k, v in graph_params.items() if k in declared}, **explicit}


def _apply_graph_params(nodes: dict[str, Node], classes: dict[str, type[Block]], graph_params: dict[str, Any],
                        where: str, problems: list[str]) -> None:
    if len(classes) == len(nodes):   # with an unknown block type, an unused key may be that block's
        declared = {p.name for cls in classes.values() for p in cls.params}
        problems += [f"{where}: {key}: no block of this graph takes a parameter {key!r} (top-level keys are "
                     f"graph-wide parameters, or one of {sorted(TOP_KEYS)})" for key in graph_params if key not in declared]
    for n, cls in classes.items():
        nodes[n].params = with_graph_params(cls, graph_params, nodes[n].params)


def _check_params(node: Node, cls: type[Block], where: str, problems: list[str]) -> None:
    found = cls.param_problems(node.params)
    problems += [f"{where}: blocks.{node.name}.{p}: {text}" for p, text in found]
    if not found:
        try:
            cls(**node.params)   # cross-parameter checks; __init__ does no I/O by contract
        except (BlockError, ValueError, TypeError) as exc:
            problems.append(f"{where}: blocks.{node.name}: {exc}")


def _edges(spec: Any, nodes: dict[str, Node], classes: dict[str, type[Block]], where: str,
           problems: list[str]) -> list[Edge]:
    edges: list[Edge] = []
    for i, text in enumerate(_list_of_str(spec, where, "connections", problems)):
        loc = f"{where}: connections[{i}] {text!r}"
        m = EDGE_RE.match(text)
        if not m:
            problems.append(f"{loc}: expected 'node.port -> node.port'")
            continue
        edge = Edge(*m.groups())
        ok = True
        for node, port, side in ((edge.src, edge.src_port, "outputs"), (edge.dst, edge.dst_port, "inputs")):
            if node not in nodes:
                problems.append(f"{loc}: unknown node {node!r}")
                ok = False
            elif node in classes and port not in {p.name for p in getattr(classes[node], side)}:
                names = [p.name for p in getattr(classes[node], side)]
                problems.append(f"{loc}: {node} ({nodes[node].type}) has no {side[:-1]} port {port!r}; "
                                f"its {side} are {names}")
                ok = False
        if ok and edge.src in classes and edge.dst in classes:
            out = next(p for p in classes[edge.src].outputs if p.name == edge.src_port)
            inp = next(p for p in classes[edge.dst].inputs if p.name == edge.dst_port)
            problem = port_mismatch(out, inp)
            if problem:
                problems.append(f"{loc}: {problem}")
        if ok:
            edges.append(edge)
    return edges


def port_mismatch(out, inp) -> str | None:
    """Why output port `out` cannot feed input port `inp`, or None when it can."""
    if inp.kind != "any" and out.kind != "any" and inp.kind != out.kind:
        return f"port kinds differ: {out.name} carries {out.kind!r}, {inp.name} expects {inp.kind!r}"
    if inp.dtypes and out.dtypes and not set(inp.dtypes) & set(out.dtypes):
        return f"dtypes differ: {out.name} sends {list(out.dtypes)}, {inp.name} accepts {list(inp.dtypes)}"
    return None


def _check_inputs(nodes: dict[str, Node], classes: dict[str, type[Block]], edges: list[Edge], where: str,
                  problems: list[str]) -> None:
    seen: dict[tuple[str, str], Edge] = {}
    for e in edges:
        key = (e.dst, e.dst_port)
        if key in seen:
            problems.append(f"{where}: input {e.dst}.{e.dst_port} is connected twice: '{seen[key]}' and '{e}'")
        seen[key] = e
    for name, cls in classes.items():
        for p in cls.inputs:
            if p.required and (name, p.name) not in seen:
                problems.append(f"{where}: input {name}.{p.name} ({nodes[name].type}) is not connected")


def _check_cycles(nodes: dict[str, Node], edges: list[Edge], where: str, problems: list[str]) -> None:
    succ: dict[str, list[str]] = {n: [] for n in nodes}
    for e in edges:
        if e.src in succ:
            succ[e.src].append(e.dst)
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for m in succ.get(n, []):
            if state.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if m not in state:
                found = visit(m)
                if found:
                    return found
        stack.pop()
        state[n] = 2
        return None
    for n in nodes:
        if n not in state:
            cycle = visit(n)
            if cycle:
                problems.append(f"{where}: connections form a cycle: {' -> '.join(cycle)}")
                return


def _security(spec: Any, path: Path, where: str, problems: list[str]) -> dict[str, Path]:
    keys = ("curve_server_cert", "curve_client_cert", "curve_authorized")
    if not isinstance(spec, dict):
        problems.append(f"{where}: security: must be a table")
        return {}
    result: dict[str, Path] = {}
    for k, v in spec.items():
        if k not in keys:
            problems.append(f"{where}: security.{k}: unknown key; expected {list(keys)}")
        elif not isinstance(v, str) or not (path.parent / v).exists():
            problems.append(f"{where}: security.{k}: key file or folder {v!r} not found next to the graph")
        else:
            result[k] = (path.parent / v).resolve()
    if result and set(result) != set(keys):
        problems.append(f"{where}: security: CURVE needs all of {list(keys)}; missing "
                        f"{sorted(set(keys) - set(result))}")
    return result


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
    for e in graph.edges_into(node):
        inp = next((p for p in new.inputs if p.name == e.dst_port), None)
        src_out = next(p for p in graph.block_class(e.src).outputs if p.name == e.src_port)
        if inp is None:
            problems.append(f"{block_type} has no input {e.dst_port!r} (connected: '{e}')")
        elif port_mismatch(src_out, inp):
            problems.append(f"'{e}': {port_mismatch(src_out, inp)}")
    for e in graph.edges_from(node):
        out = next((p for p in new.outputs if p.name == e.src_port), None)
        dst_in = next(p for p in graph.block_class(e.dst).inputs if p.name == e.dst_port)
        if out is None:
            problems.append(f"{block_type} has no output {e.src_port!r} (connected: '{e}')")
        elif port_mismatch(out, dst_in):
            problems.append(f"'{e}': {port_mismatch(out, dst_in)}")
    connected_in = {e.dst_port for e in graph.edges_into(node)}
    problems += [f"{block_type} input {p.name!r} is required but not connected at {node}"
                 for p in new.inputs if p.required and p.name not in connected_in]
    if old.is_source() != new.is_source():
        problems.append(f"{node} is {'a source' if old.is_source() else 'not a source'}; {block_type} is not alike")
    if not problems:
        try:
            new(**params)
        except (BlockError, ValueError, TypeError) as exc:
            problems.append(f"{block_type}: {exc}")
    return problems
