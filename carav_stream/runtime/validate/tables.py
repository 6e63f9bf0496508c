"""The graph file's own tables, checked before any block is looked at: [run], [restart], [hosts], the nodes of
[blocks] (names, types, hosts, restart policies), `--set` overrides, file parameters resolved against the file
that wrote them ([security]: security.py)."""
from __future__ import annotations

import ipaddress
import re
from pathlib import Path
from typing import Any

from carav_stream.core.params import Param
from carav_stream.runtime.block import Block
from carav_stream.runtime.graph import (
    LOCAL_HOST,
    NODE_KEYS,
    RESTART_POLICIES,
    TOP_KEYS,
    TRANSPORTS,
    Host,
    Node,
    Restart,
    Source,
    parse_value,
)

NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
HOSTNAME_RE = re.compile(r"^(?=.{1,253}$)([A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?)(\.[A-Za-z0-9]([A-Za-z0-9-]{0,61}"
                         r"[A-Za-z0-9])?)*\.?$")        # RFC 1123 host names: labels of letters, digits and -
CHOICES = {"transport": TRANSPORTS}      # settings of [run] with a fixed set of values
# The numeric settings of [run]: (low, high, strict low). A queue of 0 frames would be ZeroMQ's "no limit"; a
# deeper queue than 1024 frames holds that many frames in memory on every edge, and a timeout of 0 fails at once.
RUN_RANGES = {"cycles": (0, None, False), "queue_frames": (1, 1024, False),
              "heartbeat_timeout_s": (0, 3600, True), "drain_timeout_s": (0, 86400, True),
              "ready_timeout_s": (0, 3600, True)}


def list_of_str(value: Any, where: str, key: str, problems: list[str]) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        problems.append(f"{where}: {key}: must be a list of strings, got {value!r}")
        return []
    return value


def take_run_settings(data: dict, overrides: list[str]) -> tuple[dict, list[str]]:
    """`--set run.cycles=100` sets the [run] table: the data with those settings in it, and the other overrides."""
    run_set = [o for o in overrides if o.startswith("run.")]
    overrides = [o for o in overrides if o not in run_set]
    if run_set:
        run_table = data.get("run", {})
        data = {**data, "run": {**(run_table if isinstance(run_table, dict) else {}),
                                **{o[4:].partition("=")[0].strip(): parse_value(o.partition("=")[2].strip())
                                   for o in run_set}}}
    return data, overrides


def table(data: dict, key: str, where: str, problems: list[str], defaults: dict[str, Any]) -> dict[str, Any]:
    table = data.get(key, {})
    if not isinstance(table, dict):
        problems.append(f"{where}: {key}: must be a table, got {type(table).__name__}")
        return dict(defaults)
    result = dict(defaults)
    for k, v in table.items():
        if k not in defaults:
            problems.append(f"{where}: {key}.{k}: unknown setting; expected one of {sorted(defaults)}")
            continue
        low, high, strict = RUN_RANGES.get(k, (0, None, False))
        p = (Param(k, type(defaults[k]), choices=CHOICES[k]) if k in CHOICES
             else Param(k, type(defaults[k]), low=low, high=high, strict=strict))
        v, problem = p.check(v)
        if problem:
            problems.append(f"{where}: {key}.{k}: {problem}")
        else:
            result[k] = v
    return result


def restart(spec: Any, where: str, problems: list[str], default: Restart | None = None) -> Restart:
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


def hosts(spec: Any, where: str, problems: list[str]) -> dict[str, Host]:
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
        address, bind = h.get("address", "127.0.0.1"), h.get("bind", "127.0.0.1")
        for key, value, wildcard in (("address", address, False), ("bind", bind, True)):
            problem = network_address(value, wildcard)
            if problem:
                problems.append(f"{where}: hosts.{name}.{key}: {problem}")
        # Loopback unless the graph says otherwise: bind defaults to the loopback address, not to `address`.
        hosts[name] = Host(name, str(address), str(bind), port_base if isinstance(port_base, int) else 0)
    return hosts


def network_address(value: Any, wildcard: bool) -> str | None:
    """None for an IP address or a host name (and, where a socket binds, the wildcard * or 0.0.0.0), else why not."""
    if isinstance(value, str):
        if wildcard and value == "*":
            return None
        try:
            ipaddress.ip_address(value)
            return None
        except ValueError:
            if HOSTNAME_RE.match(value) and not value.replace(".", "").isdigit():
                return None
    expected = "an IP address or a host name" + (" (or * for every interface)" if wildcard else "")
    return f"must be {expected}, got {value!r:.60}"


def node(name: str, spec: Any, where: str, hosts: dict[str, Host], restart_default: Restart,
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
    node_restart = (restart(spec["restart"], f"{loc}.restart", problems, restart_default) if "restart" in spec
                    else restart_default)
    params = {k: v for k, v in spec.items() if k not in NODE_KEYS}
    return Node(name, spec["type"], params, host, node_restart)


def apply_overrides(nodes: dict[str, Node], graph_params: dict[str, Any], overrides: list[str],
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


def restart_variants(nodes: dict[str, Node], classes: dict[str, type[Block]], source: Source,
                     from_file: dict[str, dict[str, Any]], overrides: list[str]) -> list[str]:
    """A node whose variant (Block.variant: the attacker's `model`) an including graph or a `--set` changed starts
    from the new variant's own defaults: the parameters it kept from below that change are dropped (the node's
    `host` and `restart` stay). Returns what was dropped, in words."""
    set_keys: dict[str, set[str]] = {}
    for item in overrides:
        node, dot, param = item.partition("=")[0].strip().partition(".")
        if dot:
            set_keys.setdefault(node, set()).add(param)
    notes = []
    for name, node in nodes.items():
        variant = getattr(classes.get(name), "variant", None)
        if not variant:
            continue
        if variant in set_keys.get(name, ()) and node.params.get(variant) != from_file[name].get(variant):
            kept, below = set_keys[name], f"{source.files[0].name}"
        elif name in source.bases and variant in source.restated[name] \
                and source.bases[name].get(variant) != from_file[name].get(variant):
            kept = source.restated[name] | set_keys.get(name, set())
            below = ", ".join(p.name for p in source.files[1:])
        else:
            continue
        dropped = sorted(k for k in node.params if k not in kept)
        for k in dropped:
            del node.params[k]
        if dropped:
            notes.append(f"blocks.{name}: {variant} {node.params.get(variant)!r} starts from its own defaults: "
                         f"{', '.join(dropped)} of {below} not inherited")
    return notes


def resolve_files(source: Source, nodes: dict[str, Node], classes: dict[str, type[Block]],
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
