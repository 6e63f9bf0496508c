"""Graph validation: every check runs before any process starts, and every problem is reported, located.

Checks: the tables and their keys, hosts and restart policies, unknown block types (and conflicting block
folders), parameters (type, range, NaN and infinity, required values, cross-parameter checks of the block),
graph-wide parameters (one value for the whole graph, checked once: a scene error is reported once, not once per
block), connections (unknown nodes and ports, port kinds and dtypes), inputs connected twice or not at all, cycles
(naming their blocks), CURVE key files.

Templates: a graph that leaves parameters for whoever runs it to give says so, `template = ["source.path"]`
(`node.param` each, of a node of the graph and a parameter its block declares). Checked as a template
(`carav validate`, `open_ok=True`), a listed parameter may stay without a value and the block's cross-parameter
checks wait for it; run (`carav run`), it is a missing required parameter like any other, and the message says how
to give it.
"""
from __future__ import annotations

import os
import re
from graphlib import CycleError, TopologicalSorter
from pathlib import Path
from typing import Any

from carav_stream.core.params import REQUIRED, Param
from carav_stream.runtime.block import Block, BlockError
from carav_stream.runtime.graph import (
    LOCAL_HOST,
    NODE_KEYS,
    RESTART_POLICIES,
    RUN_DEFAULTS,
    TOP_KEYS,
    TRANSPORTS,
    Edge,
    Graph,
    GraphError,
    Host,
    Node,
    Restart,
    Source,
    parse_value,
    with_graph_params,
)
from carav_stream.runtime.registry import Registry, RegistryError

EDGE_RE = re.compile(r"^\s*([A-Za-z_][\w]*)\.([A-Za-z_]\w*)\s*->\s*([A-Za-z_][\w]*)\.([A-Za-z_]\w*)\s*$")
NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
CHOICES = {"transport": TRANSPORTS}      # settings of [run] with a fixed set of values


def build_graph(path: Path, source: Source, overrides: list[str], extra_block_paths: list[str | Path],
                problems: list[str], open_ok: bool = False) -> Graph:
    """The validated Graph of a composed graph file; raises GraphError listing every problem.

    `open_ok`: a template's listed parameters may stay without a value (module docstring)."""
    data, where = source.data, path.name
    block_paths = [Path(p).resolve() for p in _list_of_str(data.get("block_paths", []), where, "block_paths",
                                                           problems)]
    missing = [p for p in [*block_paths, *map(Path, extra_block_paths)] if not Path(p).is_dir()]
    problems += [f"{where}: block_paths: block folder {str(p)!r} does not exist" for p in missing]
    registry = Registry([*block_paths, *extra_block_paths])
    problems += [f"{where}: {c}" for c in registry.conflicts]
    blocks = data.get("blocks")
    if not isinstance(blocks, dict) or not blocks:
        problems.append(f"{where}: blocks: a [blocks] table with at least one node is required")
        blocks = {}
    graph_params = {k: v for k, v in data.items() if k not in TOP_KEYS}
    run_set = [o for o in overrides if o.startswith("run.")]      # `--set run.cycles=100`: the [run] table
    overrides = [o for o in overrides if o not in run_set]
    if run_set:
        run_table = data.get("run", {})
        data = {**data, "run": {**(run_table if isinstance(run_table, dict) else {}),
                                **{o[4:].partition("=")[0].strip(): parse_value(o.partition("=")[2].strip())
                                   for o in run_set}}}
    run = _table(data, "run", where, problems, RUN_DEFAULTS)
    restart_default = _restart(data.get("restart", {}), f"{where}: restart", problems)
    hosts = _hosts(data.get("hosts", {}), where, problems)
    nodes: dict[str, Node] = {}
    for name, spec in blocks.items():
        node = _node(name, spec, where, hosts, restart_default, problems)
        if node:
            nodes[name] = node
    from_file = {n: dict(node.params) for n, node in nodes.items()}
    graph_from_file = dict(graph_params)
    _apply_overrides(nodes, graph_params, overrides, problems)
    classes: dict[str, type[Block]] = {}
    for node in nodes.values():
        try:
            classes[node.name] = registry.get(node.type).cls
        except RegistryError as exc:
            problems.append(f"{where}: blocks.{node.name}.type: {exc}")
    _resolve_files(source, nodes, classes, graph_params, from_file, graph_from_file)
    if len(classes) == len(nodes):   # with an unknown block type, an unused key may be that block's
        declared = {p.name for cls in classes.values() for p in cls.params}
        problems += [f"{where}: {key}: no block of this graph takes a parameter {key!r} (top-level keys are "
                     f"graph-wide parameters, or one of {sorted(TOP_KEYS)})"
                     for key in graph_params if key not in declared]
    for n, cls in classes.items():
        nodes[n].params = with_graph_params(cls, graph_params, nodes[n].params)
    bad_wide = _check_graph_wide(nodes, classes, where, problems)
    left_open = _template(data.get("template", []), nodes, classes, where, problems)
    warnings: dict[str, None] = {}     # ordered, each text once (a scene shared by several blocks warns once)
    for node in nodes.values():
        if node.name in classes:
            warnings.update(dict.fromkeys(_check_params(node, classes[node.name], bad_wide, where, problems,
                                                        left_open.get(node.name, set()), open_ok)))
        if node.name in classes and classes[node.name].not_restartable and node.restart.policy != "never":
            problems.append(f"{where}: blocks.{node.name}.restart: a {node.type} cannot be restarted "
                            f"({classes[node.name].not_restartable}); give it restart = \"never\"")
    edges = _edges(data.get("connections", []), nodes, classes, where, problems)
    _check_inputs(nodes, classes, edges, where, problems)
    _check_cycles(nodes, edges, where, problems)
    security = _security(data.get("security", {}), where, problems)
    if problems:
        raise GraphError(problems)
    still_open = [f"{n}.{p}" for n, params in left_open.items() for p in sorted(params) if p not in nodes[n].params]
    return Graph(path, str(data.get("description", "")), nodes, edges, run, hosts, security, block_paths, registry,
                 graph_params, list(warnings), still_open)


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
            continue
        p = Param(k, type(defaults[k]), choices=CHOICES[k]) if k in CHOICES else Param(k, type(defaults[k]), low=0)
        v, problem = p.check(v)
        if problem:
            problems.append(f"{where}: {key}.{k}: {problem}")
        else:
            result[k] = v
    return result


def _restart(spec: Any, where: str, problems: list[str], default: Restart | None = None) -> Restart:
    default = default or Restart()
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
            problems.append(f"{where}: hosts.{name}.port_base: must be an integer port in 1024..65000, "
                            f"got {port_base!r}")
        address = h.get("address", "127.0.0.1")
        # Loopback unless the graph says otherwise: bind defaults to the loopback address, not to `address`.
        hosts[name] = Host(name, str(address), str(h.get("bind", "127.0.0.1")),
                           port_base if isinstance(port_base, int) else 0)
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


def _apply_overrides(nodes: dict[str, Node], graph_params: dict[str, Any], overrides: list[str],
                     problems: list[str]) -> None:
    """`--set node.param=value` sets a node's parameter, `--set param=value` a graph-wide one (`run.KEY=value`
    was taken into the [run] table before)."""
    for item in overrides:
        key, sep, value = item.partition("=")
        node, dot, param = key.strip().partition(".")
        if not sep or not node or (dot and not param):
            problems.append(f"--set {item!r}: expected node.param=value or param=value (graph-wide)")
        elif not dot:
            if node in TOP_KEYS:
                problems.append(f"--set {item!r}: {node!r} is not a parameter; --set sets node.param or a "
                                "graph-wide parameter")
            else:
                graph_params[node] = parse_value(value.strip())
        elif node not in nodes:
            problems.append(f"--set {item!r}: unknown node {node!r}; nodes are {sorted(nodes)}")
        else:
            nodes[node].params[param] = parse_value(value.strip())


def _resolve_files(source: Source, nodes: dict[str, Node], classes: dict[str, type[Block]],
                   graph_params: dict[str, Any], from_file: dict[str, dict[str, Any]],
                   graph_from_file: dict[str, Any]) -> None:
    """Values of file parameters written in a graph file (not `--set`) that name a file in the folder of the file
    that wrote them become absolute paths to it."""
    def resolve(value: Any, folder: Path | None) -> Any:
        if (isinstance(value, str) and value and folder is not None and not Path(value).is_absolute()
                and (folder / value).is_file()):
            return str((folder / value).resolve())
        return value

    file_params = {n: {p.name for p in cls.params if p.file} for n, cls in classes.items()}
    for key in set().union(*file_params.values()) & graph_params.keys():
        if key in graph_from_file and graph_params[key] is graph_from_file[key]:
            graph_params[key] = resolve(graph_params[key], source.folders.get(f"top:{key}"))
    for n, names in file_params.items():
        params, written = nodes[n].params, from_file[n]
        for key in names & written.keys():
            if params.get(key) is written[key]:          # still the graph file's value, not a --set override
                params[key] = resolve(params[key], source.folders.get(f"node:{n}:{key}"))


def _check_graph_wide(nodes: dict[str, Node], classes: dict[str, type[Block]], where: str,
                      problems: list[str]) -> set[str]:
    """Graph-wide parameters (Param.graph_wide): every block that declares one must use the same value, which is
    checked once. Returns the names whose value failed (blocks using them are not built)."""
    users: dict[str, list[tuple[str, Param]]] = {}
    for n, cls in classes.items():
        for p in cls.params:
            if p.graph_wide:
                users.setdefault(p.name, []).append((n, p))
    bad: set[str] = set()
    for name, used in users.items():
        values = {n: nodes[n].params.get(name, p.default) for n, p in used}
        distinct = []
        for v in values.values():
            if not any(v == d and type(v) is type(d) for d in distinct):
                distinct.append(v)
        if len(distinct) > 1:
            listing = ", ".join(f"{n} {'(not set)' if v is REQUIRED else repr(v)}"
                                for n, v in values.items())
            problems.append(f"{where}: {name}: a graph-wide parameter has one value for the whole graph, but the "
                            f"blocks use different ones: {listing}; set it once at the top of the graph file")
            bad.add(name)
            continue
        value, p = distinct[0], used[0][1]
        if value is REQUIRED:
            problems.append(f"{where}: {name}: missing; blocks {sorted(values)} need it ({p.doc}): set it at "
                            "the top of the graph file")
            bad.add(name)
            continue
        value, problem = p.check(value)
        if problem is None and p.validate is not None:
            try:
                p.validate(value)
            except ValueError as exc:
                found = getattr(exc, "problems", None) or [str(exc)]
                problems += [f"{where}: {name}: {text}" for text in found]
                bad.add(name)
                continue
        if problem:
            problems.append(f"{where}: {name}: {problem}")
            bad.add(name)
    return bad


def _template(spec: Any, nodes: dict[str, Node], classes: dict[str, type[Block]], where: str,
              problems: list[str]) -> dict[str, set[str]]:
    """The parameters a template leaves open, by node (`template = ["source.path"]`); {} for a graph that is not one."""
    if spec == []:
        return {}
    entries = _list_of_str(spec, where, "template", problems)
    left_open: dict[str, set[str]] = {}
    for item in entries:
        node, _, param = item.partition(".")
        if node not in nodes or not param:
            problems.append(f"{where}: template: {item!r}: expected NODE.PARAM with one of the nodes {sorted(nodes)}")
        elif node in classes and param not in {p.name for p in classes[node].params}:
            problems.append(f"{where}: template: {item!r}: block type {nodes[node].type!r} has no parameter "
                            f"{param!r}; its parameters are {sorted(p.name for p in classes[node].params)}")
        else:
            left_open.setdefault(node, set()).add(param)
    return left_open


def _check_params(node: Node, cls: type[Block], bad_wide: set[str], where: str, problems: list[str],
                  left_open: set[str] = frozenset(), open_ok: bool = False) -> list[str]:
    """Adds the node's parameter problems to `problems`; returns its warnings.

    `left_open`: the node's parameters its template leaves open; with `open_ok` they may stay without a value."""
    wide = {p.name for p in cls.params if p.graph_wide}
    unset = {p for p in left_open if p not in node.params}
    found = [(p, t) for p, t in cls.param_problems(node.params) if p not in wide and not (open_ok and p in unset)]
    problems += [f"{where}: blocks.{node.name}.{p}: {text}" + (f"; the graph is a template that leaves it open: give "
                                                               f"it with --set {node.name}.{p}=VALUE" if p in unset
                                                               else "")
                 for p, text in found]
    if unset and open_ok:
        return []       # the block's cross-parameter checks need the values still to come
    for p in cls.params:
        value = node.params.get(p.name)
        if p.output and isinstance(value, str) and value != "-" and (text := _output_problem(Path(value))):
            found.append((p.name, text))
            problems.append(f"{where}: blocks.{node.name}.{p.name}: {text}")
    if not found and not wide & bad_wide:
        try:
            return cls(**node.params).param_warnings()   # cross-parameter checks; __init__ does no I/O by contract
        except (BlockError, ValueError, TypeError) as exc:
            problems.append(f"{where}: blocks.{node.name}: {exc}")
    return []


def _output_problem(path: Path) -> str | None:
    """Why a block could not write `path` (relative to the working folder), or None."""
    if path.is_dir():
        return f"{str(path)!r} is a folder, not a file"
    folder = path.parent
    if not folder.is_dir():
        return f"cannot write {str(path)!r}: folder {str(folder)!r} does not exist"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"cannot write {str(path)!r}: folder {str(folder)!r} is not writable"
    return None


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
    predecessors: dict[str, set[str]] = {n: set() for n in nodes}
    for e in edges:
        predecessors.setdefault(e.dst, set()).add(e.src)
    try:
        TopologicalSorter(predecessors).prepare()
    except CycleError as exc:
        problems.append(f"{where}: connections form a cycle: {' -> '.join(exc.args[1])}")


def _security(spec: Any, where: str, problems: list[str]) -> dict[str, Path]:
    keys = ("curve_server_cert", "curve_client_cert", "curve_authorized")
    if not isinstance(spec, dict):
        problems.append(f"{where}: security: must be a table")
        return {}
    result: dict[str, Path] = {}
    for k, v in spec.items():
        if k not in keys:
            problems.append(f"{where}: security.{k}: unknown key; expected {list(keys)}")
        elif not isinstance(v, str) or not Path(v).exists():
            problems.append(f"{where}: security.{k}: key file or folder {v!r} not found")
        else:
            result[k] = Path(v).resolve()
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
        except (BlockError, ValueError, TypeError) as exc:
            problems.append(f"{block_type}: {exc}")
    return problems
