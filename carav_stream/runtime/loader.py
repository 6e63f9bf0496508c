"""Graph files: read a declarative TOML graph, compose it with the graphs it includes, validate all of it.

    include = "radar_chain.toml"      # optional: a graph this one builds on (relative to this file)
    description = "..."
    seed = 7                          # any other top-level value is a graph-wide parameter, given to every
    scene = "table1"                  # block that declares a parameter of that name and does not set it
    block_paths = ["./my_blocks"]     # extra folders of block files, relative to the graph file
    template = ["source.path"]        # optional: parameters left for whoever runs the graph (validate/)
    connections = ["source.out -> sink.in", ...]

    [blocks]
    source = { type = "counter_source", rate_hz = 0.0 }
    sink   = { type = "jsonl_sink", path = "out.jsonl", restart = "on-failure", host = "b" }

    [run]      cycles, queue_frames, heartbeat_timeout_s, drain_timeout_s, ready_timeout_s,
               transport = "zmq" | "shm" | a plane of CARAV_PLANE_PATH (the data plane of same-host arrays: in
               ZeroMQ messages, in shared memory, ...: runtime/planes/),
               zygote = true | false (nodes forked from a warm process, or each a fresh interpreter: launcher.py)
    [restart]  policy = "never" | "on-failure", max_restarts
    [hosts.b]  address = "127.0.0.1", bind = "127.0.0.1", port_base = 47000
    [security] curve_server_cert, curve_client_cert, curve_authorized, tcp = "plain"   (tcp edges: ZeroMQ CURVE
               with the graph's keys, or keys made for the run, or in the clear: validate/security.py)

Composition: a graph that includes another states only what differs. Its top-level values replace the included
ones; its `[run]`, `[restart]`, `[hosts]` and `[security]` tables are merged key by key; its `connections` are
added to the included ones, after removing those it lists in `remove_connections` (each must be one of them), so
a block goes between two nodes of an included chain in three lines; a node it writes with a `type` replaces the
included node, a node it writes without one changes only the parameters it names (`attacker = { rarms = 3.0 }`),
unless it changes the block's variant (Block.variant, e.g. the attacker's `model`): a node of another model starts
from that model's own defaults, with only the parameters written beside the new model. `carav validate` names what
composition replaced.

Overrides (`carav run --set`): `node.param=value`, a graph-wide `param=value`, or `run.KEY=value` for the `[run]`
table, each checked like the file's own values. Every problem is reported at once, each located:
`demo.toml: blocks.detector.eta: must be > 0, got -1.5`
(validation: carav_stream.runtime.validate).

Relative file names: `block_paths` and `[security]` key files are relative to the graph file that writes them.
A parameter that names a file a block reads (`Param(file=True)`, e.g. `scene = "my_scene.toml"`) is taken
relative to the folder of the graph file that writes it when the file exists there, so a graph and its scene file
travel together; otherwise (preset names, files elsewhere) the value is left as written, and relative paths are
then relative to the working directory, as are `--set` values and output files (`path` of the sinks).
"""
from __future__ import annotations

import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from carav_stream.runtime.graph import Graph, GraphError, Source
from carav_stream.runtime.validate import build_graph
from carav_stream.runtime.validate.security import KEY_FILES

MERGED_TABLES = ("run", "restart", "hosts", "security")   # tables an including graph merges key by key
MAX_INCLUDE_DEPTH = 8


def read_graph_file(path: Path, problems: list[str], seen: tuple[Path, ...] = ()) -> Source | None:
    """The composed data of `path` (its includes resolved) or None, with every problem added to `problems`."""
    where = path.name
    if path.is_dir():
        problems.append(f"{path}: is a folder, not a graph file")
        return None
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        problems.append(f"{path}: graph file not found")
        return None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        problems.append(f"{where}: not valid TOML: {exc}")
        return None
    except OSError as exc:
        problems.append(f"{path}: cannot be read: {exc.strerror or exc}")
        return None
    folder = path.resolve().parent
    _absolute_names(data, folder)
    own = Source(data, _written_where(data, folder), [path])
    include = data.pop("include", None)
    if include is None:
        if "remove_connections" in data:
            problems.append(f"{where}: remove_connections: only a graph that includes another can remove its "
                            "connections")
        return own
    if not isinstance(include, str) or not include:
        problems.append(f"{where}: include: must be the name of a graph file, got {include!r}")
        return own
    target = (folder / include).resolve()
    if target in (*seen, path.resolve()):
        chain = " -> ".join(p.name for p in (*seen, path.resolve(), target))
        problems.append(f"{where}: include: graph files include each other: {chain}")
        return own
    if len(seen) >= MAX_INCLUDE_DEPTH:
        problems.append(f"{where}: include: more than {MAX_INCLUDE_DEPTH} levels of includes")
        return own
    base = read_graph_file(target, problems, (*seen, path.resolve()))
    if base is None:
        problems.append(f"{where}: include: {include!r} could not be read (above)")
        return own
    return _compose(base, own, where, problems)


def _absolute_names(data: dict[str, Any], folder: Path) -> None:
    """`block_paths` and `[security]` key files written in a graph file are relative to its folder: made absolute
    before composition, so that an including graph in another folder keeps them."""
    paths = data.get("block_paths")
    if isinstance(paths, list):
        data["block_paths"] = [str(folder / p) if isinstance(p, str) else p for p in paths]
    sec = data.get("security")
    if isinstance(sec, dict):
        data["security"] = {k: str(folder / v) if isinstance(v, str) and k in KEY_FILES else v
                            for k, v in sec.items()}


def _written_where(data: dict[str, Any], folder: Path) -> dict[str, Path]:
    """The folder every value of a graph file is relative to: its own."""
    out = {f"top:{k}": folder for k in data}
    blocks = data.get("blocks")
    if isinstance(blocks, dict):
        for name, spec in blocks.items():
            if isinstance(spec, dict):
                out.update({f"node:{name}:{k}": folder for k in spec})
    return out


def _merge(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """`new` over `old`, key by key, tables within tables too (`[hosts.front]` changes only what it names)."""
    out = dict(old)
    for k, v in new.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _connection(text: Any) -> str | None:
    """A connection written `src.port -> dst.port`, spaced as the graph files write it; None for anything else."""
    if not isinstance(text, str) or "->" not in text:
        return None
    src, _, dst = text.partition("->")
    return f"{src.strip()} -> {dst.strip()}"


def _remove_connections(base: Source, own: Source, where: str, problems: list[str]) -> list[Any]:
    """The included graph's connections less those `own` removes (each must be one of them); the words for
    what was removed go into own.composed."""
    old = base.data.get("connections", [])
    removed = own.data.get("remove_connections", [])
    if not isinstance(removed, list) or not isinstance(old, list):
        problems.append(f"{where}: remove_connections: must be a list of connections 'src.port -> dst.port'")
        return old
    written = {_connection(c): c for c in old}
    drop = set()
    for text in removed:
        conn = _connection(text)
        if conn not in written:
            problems.append(f"{where}: remove_connections: {text!r} is not a connection of the included graph "
                            f"({base.files[0].name}); its connections are {sorted(c for c in written if c)}")
            continue
        drop.add(conn)
        own.composed.append(f"removes the connection {conn} of {base.files[0].name}")
    return [c for c in old if _connection(c) not in drop]


def _compose(base: Source, own: Source, where: str, problems: list[str]) -> Source:
    """`own` on top of the graph it includes (module docstring: what replaces, what merges)."""
    data = dict(base.data)
    folders = dict(base.folders)
    bases, restated = dict(base.bases), dict(base.restated)
    if "remove_connections" in own.data:
        data["connections"] = _remove_connections(base, own, where, problems)
    for key, value in own.data.items():
        old = data.get(key)
        if key == "remove_connections":
            continue
        if key in MERGED_TABLES and isinstance(value, dict) and isinstance(old, dict):
            data[key] = _merge(old, value)
        elif key in ("connections", "block_paths") and isinstance(value, list) and isinstance(old, list):
            data[key] = [*old, *value]
        elif key == "blocks" and isinstance(value, dict) and isinstance(old, dict):
            blocks = dict(old)
            for name, spec in value.items():
                if isinstance(spec, dict) and "type" not in spec:
                    if not isinstance(blocks.get(name), dict):
                        problems.append(f"{where}: blocks.{name}: changes a node the included graph does not have; "
                                        "give it a type")
                        continue
                    bases[name], restated[name] = blocks[name], set(spec)
                    blocks[name] = {**blocks[name], **spec}
                else:
                    blocks[name] = spec
                    bases.pop(name, None)
                    restated.pop(name, None)
                    folders = {k: v for k, v in folders.items() if not k.startswith(f"node:{name}:")}
            data[key] = blocks
        else:
            data[key] = value
    folders.update(own.folders)
    return Source(data, folders, [*own.files, *base.files], bases, restated, [*base.composed, *own.composed])


def load_graph(path: str | Path, overrides: list[str] = (), extra_block_paths: list[str | Path] = (),
               open_ok: bool = False, on_types: Callable[[list[str]], None] | None = None,
               checks_later: bool = False) -> Graph:
    """Read, compose and fully validate a graph file; raises GraphError listing every problem.

    `overrides`: `node.param=value` sets one node's parameter, `param=value` a graph-wide one (both are checked
    like the file's own values). `open_ok`: check a template as one, its listed parameters allowed to stay open
    (Graph.open_params names those still without a value); a graph to run leaves none open. `on_types(types)`:
    told the nodes' block types once they are read, before any block is imported (a run's zygote imports them
    meanwhile). `checks_later`: the blocks' param_warnings() (which may import much: a detector's design laws) are
    not called but left to Graph.run_later_checks; a run calls it while its nodes start, before any frame flows."""
    path = Path(path)
    problems: list[str] = []
    source = read_graph_file(path, problems)
    if source is None:
        raise GraphError(problems)
    return build_graph(path, source, list(overrides), list(extra_block_paths), problems, open_ok, on_types,
                       checks_later)
