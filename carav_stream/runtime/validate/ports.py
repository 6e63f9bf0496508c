"""Connections and ports: every `src.port -> dst.port` names known nodes and ports whose kinds and dtypes agree,
every required input is connected once, and the connections form no cycle (naming its blocks)."""
from __future__ import annotations

import re
from graphlib import CycleError, TopologicalSorter
from typing import Any

from carav_stream.runtime.block import Block
from carav_stream.runtime.graph import Edge, Node
from carav_stream.runtime.validate.tables import list_of_str

EDGE_RE = re.compile(r"^\s*([A-Za-z_][\w]*)\.([A-Za-z_]\w*)\s*->\s*([A-Za-z_][\w]*)\.([A-Za-z_]\w*)\s*$")


def edges(spec: Any, nodes: dict[str, Node], classes: dict[str, type[Block]], where: str,
          problems: list[str]) -> list[Edge]:
    found: list[Edge] = []
    for i, text in enumerate(list_of_str(spec, where, "connections", problems)):
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
            found.append(edge)
    return found


def port_mismatch(out, inp) -> str | None:
    """Why output port `out` cannot feed input port `inp`, or None when it can."""
    if inp.kind != "any" and out.kind != "any" and inp.kind != out.kind:
        return f"port kinds differ: {out.name} carries {out.kind!r}, {inp.name} expects {inp.kind!r}"
    if inp.dtypes and out.dtypes and not set(inp.dtypes) & set(out.dtypes):
        return f"dtypes differ: {out.name} sends {list(out.dtypes)}, {inp.name} accepts {list(inp.dtypes)}"
    return None


def check_inputs(nodes: dict[str, Node], classes: dict[str, type[Block]], edges: list[Edge], where: str,
                 problems: list[str]) -> None:
    seen: dict[tuple[str, str], Edge] = {}
    for e in edges:
        key = (e.dst, e.dst_port)
        if key in seen:
            problems.append(f"{where}: input {e.dst}.{e.dst_port} is connected twice: '{seen[key]}' and '{e}' (a "
                            "graph that includes another replaces an included connection by listing it in "
                            "remove_connections)")
        seen[key] = e
    for name, cls in classes.items():
        for p in cls.inputs:
            if p.required and (name, p.name) not in seen:
                problems.append(f"{where}: input {name}.{p.name} ({nodes[name].type}) is not connected")


def check_cycles(nodes: dict[str, Node], edges: list[Edge], where: str, problems: list[str]) -> None:
    predecessors: dict[str, set[str]] = {n: set() for n in nodes}
    for e in edges:
        predecessors.setdefault(e.dst, set()).add(e.src)
    try:
        TopologicalSorter(predecessors).prepare()
    except CycleError as exc:
        problems.append(f"{where}: connections form a cycle: {' -> '.join(exc.args[1])}")


def unused_outputs(nodes: dict[str, Node], classes: dict[str, type[Block]], edges: list[Edge]) -> list[str]:
    """A warning for each node that has outputs and none of them connected: it runs, and nothing takes what it
    computes (an attacker left unconnected leaves the graph without an attack, which is easy to miss)."""
    used = {e.src for e in edges}
    return [f"blocks.{name} ({nodes[name].type}): none of its outputs ({', '.join(p.name for p in cls.outputs)}) is "
            "connected: it runs, and nothing takes what it computes"
            for name, cls in classes.items() if cls.outputs and name not in used]
