"""build_graph: the stages of validation in order, every problem of every stage collected before one GraphError.

1. the file's tables (tables.py): block folders, [blocks], [run], [restart], [hosts], the nodes, `--set`
2. block types from the registry, file parameters resolved, top-level keys no block takes
3. block parameters (params.py): graph-wide ones, the template, every node's
4. connections and ports (ports.py), then [security] and the tcp edges it protects (security.py)
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from carav_stream.runtime.block import Block
from carav_stream.runtime.graph import RUN_DEFAULTS, TOP_KEYS, Graph, GraphError, Node, Source, with_graph_params
from carav_stream.runtime.registry import Registry, RegistryError
from carav_stream.runtime.validate import params, ports, tables
from carav_stream.runtime.validate import security as secure


def build_graph(path: Path, source: Source, overrides: list[str], extra_block_paths: list[str | Path],
                problems: list[str], open_ok: bool = False,
                on_types: Callable[[list[str]], None] | None = None, checks_later: bool = False) -> Graph:
    """The validated Graph of a composed graph file; raises GraphError listing every problem.

    `open_ok`: a template's listed parameters may stay without a value (the package docstring). `on_types`: told
    the nodes' block types before the blocks are imported; `checks_later`: the blocks' param_warnings() left to
    Graph.run_later_checks (both: loader.load_graph)."""
    data, where = source.data, path.name
    block_paths, registry = _block_folders(data, extra_block_paths, where, problems)
    blocks = data.get("blocks")
    if not isinstance(blocks, dict) or not blocks:
        problems.append(f"{where}: blocks: a [blocks] table with at least one node is required")
        blocks = {}
    graph_params = {k: v for k, v in data.items() if k not in TOP_KEYS}
    data, overrides = tables.take_run_settings(data, overrides)
    run = tables.table(data, "run", where, problems, RUN_DEFAULTS)
    restart_default = tables.restart(data.get("restart", {}), f"{where}: restart", problems)
    hosts = tables.hosts(data.get("hosts", {}), where, problems)
    nodes: dict[str, Node] = {}
    for name, spec in blocks.items():
        node = tables.node(name, spec, where, hosts, restart_default, problems)
        if node:
            nodes[name] = node
    from_file = {n: dict(node.params) for n, node in nodes.items()}
    graph_from_file = dict(graph_params)
    tables.apply_overrides(nodes, graph_params, overrides, problems)
    if on_types is not None:
        on_types(sorted({node.type for node in nodes.values()}))
    classes = _block_classes(nodes, registry, where, problems)
    composed = [*source.composed, *tables.restart_variants(nodes, classes, source, from_file, overrides)]
    tables.resolve_files(source, nodes, classes, graph_params, from_file, graph_from_file)
    _apply_graph_params(nodes, classes, graph_params, where, problems)
    bad_wide = params.check_graph_wide(nodes, classes, where, problems)
    left_open = params.template(data.get("template", []), nodes, classes, where, problems)
    later: list | None = [] if checks_later else None
    warnings = params.check_nodes(nodes, classes, bad_wide, left_open, open_ok, where, problems, later)
    edges = ports.edges(data.get("connections", []), nodes, classes, where, problems)
    ports.check_inputs(nodes, classes, edges, where, problems)
    ports.check_cycles(nodes, edges, where, problems)
    warnings += ports.unused_outputs(nodes, classes, edges)
    security = secure.table(data.get("security", {}), where, problems)
    secure.check_tcp(security, nodes, edges, hosts, where, problems, warnings)
    if problems:
        raise GraphError(problems)
    still_open = [f"{n}.{p}" for n, names in left_open.items() for p in sorted(names) if p not in nodes[n].params]
    return Graph(path, str(data.get("description", "")), nodes, edges, run, hosts, security, block_paths, registry,
                 graph_params, warnings, still_open, composed, later or [])


def _block_folders(data: dict, extra_block_paths: list[str | Path], where: str,
                   problems: list[str]) -> tuple[list[Path], Registry]:
    """The graph's block folders (`block_paths`), resolved, and the registry of block types they and the extra
    folders hold."""
    block_paths = [Path(p).resolve() for p in tables.list_of_str(data.get("block_paths", []), where, "block_paths",
                                                                 problems)]
    missing = [p for p in [*block_paths, *map(Path, extra_block_paths)] if not Path(p).is_dir()]
    problems += [f"{where}: block_paths: block folder {str(p)!r} does not exist" for p in missing]
    registry = Registry([*block_paths, *extra_block_paths])
    problems += [f"{where}: {c}" for c in registry.conflicts]
    return block_paths, registry


def _block_classes(nodes: dict[str, Node], registry: Registry, where: str,
                   problems: list[str]) -> dict[str, type[Block]]:
    """{node name: its block class} for the nodes whose type the registry knows; the others are problems."""
    classes: dict[str, type[Block]] = {}
    for node in nodes.values():
        try:
            classes[node.name] = registry.get(node.type).cls
        except RegistryError as exc:
            problems.append(f"{where}: blocks.{node.name}.type: {exc}")
    return classes


def _apply_graph_params(nodes: dict[str, Node], classes: dict[str, type[Block]], graph_params: dict[str, Any],
                        where: str, problems: list[str]) -> None:
    """Every node's parameters with the graph-wide values its block takes; a top-level key no block takes is a
    problem (unless a block type is unknown: the key may be that block's)."""
    if len(classes) == len(nodes):
        declared = {p.name for cls in classes.values() for p in cls.params}
        problems += [f"{where}: {key}: no block of this graph takes a parameter {key!r} (top-level keys are "
                     f"graph-wide parameters, or one of {sorted(TOP_KEYS)})"
                     for key in graph_params if key not in declared]
    for n, cls in classes.items():
        nodes[n].params = with_graph_params(cls, graph_params, nodes[n].params)
