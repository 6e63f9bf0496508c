"""[security]: how the graph's tcp edges are protected, checked against its hosts and edges.

    [security]
    curve_server_cert = "keys/server.key_secret"    # ZeroMQ CURVE with the graph's own keys: `carav keys DIR`
    curve_client_cert = "keys/client.key_secret"    # makes them and prints this table
    curve_authorized = "keys/authorized"
    tcp = "plain"                                   # or: the tcp edges in the clear, said in so many words

A tcp edge (between nodes placed on different hosts) is authenticated and encrypted with CURVE unless the graph
says `tcp = "plain"`, which validation and the run's summary flag as a warning. Without key files the supervisor
makes keys for the run (runtime/curve_keys.py), which serves when every host is this machine (each host's address
is a loopback address: 127.0.0.0/8, ::1, localhost); an edge to a host on another machine needs the graph's own
keys, and validation refuses it, naming the edge and how to make keys.
"""
from __future__ import annotations

import ipaddress
from pathlib import Path
from typing import Any

from carav_stream.runtime.graph import Edge, Host, Node

KEY_FILES = ("curve_server_cert", "curve_client_cert", "curve_authorized")
TCP_MODES = ("curve", "plain")
MAKE_KEYS = ("make them with `carav keys DIR` and add the [security] table it prints (or write "
             "[security] tcp = \"plain\" to send in the clear)")


def table(spec: Any, where: str, problems: list[str]) -> dict[str, Any]:
    """The [security] table: its key files (resolved paths) and `tcp` (curve or plain), each checked."""
    if not isinstance(spec, dict):
        problems.append(f"{where}: security: must be a table")
        return {}
    result: dict[str, Any] = {}
    for k, v in spec.items():
        if k == "tcp":
            if v in TCP_MODES:
                result[k] = v
            else:
                problems.append(f"{where}: security.tcp: must be one of {list(TCP_MODES)}, got {v!r}")
        elif k not in KEY_FILES:
            problems.append(f"{where}: security.{k}: unknown key; expected {[*KEY_FILES, 'tcp']}")
        elif not isinstance(v, str) or not Path(v).exists():
            problems.append(f"{where}: security.{k}: key file or folder {v!r} not found")
        else:
            result[k] = Path(v).resolve()
    keys = set(result) & set(KEY_FILES)
    if keys and keys != set(KEY_FILES):
        problems.append(f"{where}: security: CURVE needs all of {list(KEY_FILES)}; missing "
                        f"{sorted(set(KEY_FILES) - keys)}")
    if keys and result.get("tcp") == "plain":
        problems.append(f"{where}: security.tcp: \"plain\" sends the tcp edges in the clear, yet CURVE key files "
                        "are given; keep one of the two")
    return result


def tcp_edges(nodes: dict[str, Node], edges: list[Edge]) -> list[Edge]:
    """The edges between nodes placed on different hosts (carried over tcp)."""
    return [e for e in edges if e.src in nodes and e.dst in nodes and nodes[e.src].host != nodes[e.dst].host]


def on_this_machine(host: Host) -> bool:
    """Whether `host`'s address is a loopback address (the host is the machine the graph runs on)."""
    if host.address.lower().rstrip(".") == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.address).is_loopback
    except ValueError:
        return False


def plain_warning(edges: list[Edge]) -> str:
    named = ", ".join(f"'{e}'" for e in edges[:3]) + (f" and {len(edges) - 3} more" if len(edges) > 3 else "")
    return (f"security.tcp = \"plain\": {len(edges)} tcp edge(s) ({named}) carry frames unauthenticated and in "
            "the clear: any process that reaches their ports can send into them and read them")


def check_tcp(sec: dict[str, Any], nodes: dict[str, Node], edges: list[Edge], hosts: dict[str, Host], where: str,
              problems: list[str], warnings: list[str]) -> None:
    """A warning for tcp edges sent in the clear; a problem for each tcp edge to another machine without keys."""
    crossing = tcp_edges(nodes, edges)
    if not crossing or any(k in sec for k in KEY_FILES):
        return
    if sec.get("tcp") == "plain":
        warnings.append(plain_warning(crossing))
        return
    for e in crossing:
        far = next((h for h in (nodes[e.dst].host, nodes[e.src].host) if not on_this_machine(hosts[h])), None)
        if far is not None:
            problems.append(f"{where}: connections: edge '{e}' joins host {far} ({hosts[far].address}), another "
                            f"machine: its tcp edges need the graph's CURVE keys; {MAKE_KEYS}")
