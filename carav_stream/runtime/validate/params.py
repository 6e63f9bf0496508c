"""Block parameters: graph-wide ones (one value for the whole graph, checked once), the parameters a template
leaves open, every node's parameters (type, range, required values, output files it could not write, the block's
cross-parameter checks) and whether the block may be restarted as its policy asks."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from carav_stream.core.params import REQUIRED, Param
from carav_stream.runtime.block import PARAM_ERRORS, Block
from carav_stream.runtime.graph import Node
from carav_stream.runtime.validate.tables import list_of_str


def check_graph_wide(nodes: dict[str, Node], classes: dict[str, type[Block]], where: str,
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


def template(spec: Any, nodes: dict[str, Node], classes: dict[str, type[Block]], where: str,
             problems: list[str]) -> dict[str, set[str]]:
    """The parameters a template leaves open, by node (`template = ["source.path"]`); {} for a graph that is not one."""
    if spec == []:
        return {}
    entries = list_of_str(spec, where, "template", problems)
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


def check_nodes(nodes: dict[str, Node], classes: dict[str, type[Block]], bad_wide: set[str],
                left_open: dict[str, set[str]], open_ok: bool, where: str, problems: list[str],
                later: list | None = None) -> list[str]:
    """Adds every node's parameter and restart problems to `problems`; returns the warnings, each text once (a
    scene shared by several blocks warns once), in the nodes' order. `later`: see check_params."""
    warnings: dict[str, None] = {}
    for node in nodes.values():
        if node.name in classes:
            warnings.update(dict.fromkeys(check_params(node, classes[node.name], bad_wide, where, problems,
                                                       left_open.get(node.name, set()), open_ok, later)))
        if node.name in classes and classes[node.name].not_restartable and node.restart.policy != "never":
            problems.append(f"{where}: blocks.{node.name}.restart: a {node.type} cannot be restarted "
                            f"({classes[node.name].not_restartable}); give it restart = \"never\"")
    return list(warnings)


def check_params(node: Node, cls: type[Block], bad_wide: set[str], where: str, problems: list[str],
                 left_open: set[str] = frozenset(), open_ok: bool = False, later: list | None = None) -> list[str]:
    """Adds the node's parameter problems to `problems`; returns its warnings.

    `left_open`: the node's parameters its template leaves open; with `open_ok` they may stay without a value.
    `later`: the block is made (its cross-parameter checks run) but its param_warnings() is not called: it is
    appended to `later` with its place, for Graph.run_later_checks."""
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
            block = cls(**node.params)          # cross-parameter checks; __init__ does no I/O by contract
            if later is None:
                return block.param_warnings()
            later.append((f"{where}: blocks.{node.name}", block.param_warnings))
        except PARAM_ERRORS as exc:
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
