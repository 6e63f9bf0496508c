"""Who sent a message over ipc, in the kernel's words, and for how long those words name one process.

ZeroMQ reports with every message received over a Unix socket the credentials the kernel took (SO_PEERCRED) when
the sending process connected: its Peer-Address ends in ":uid:gid:pid". A pid names one process while that process
exists, ended but not yet reaped (a zombie) included; the kernel hands it to another process only after the
parent has reaped it. The supervisor is the parent of every node and reaps none before the run ends
(node_state.NodeState.exit_code looks at a child without reaping it), so a pid it names, of a running node or of
an incarnation that ended, belongs to that incarnation for the whole run.

A pid also travels with its process's start time (`start_ticks`: /proc/PID/stat field 22, clock ticks after boot),
read by the supervisor when it starts the process. A receiver reads a sender's start time once, the first time
that pid sends, and takes its messages only if the two agree: a pid held by any other process is refused.
"""
from __future__ import annotations

from typing import Any

import zmq


def sender_pid(part: Any) -> int | None:
    """The pid of the process that sent a message received over ipc, from one of its parts (a received zmq.Frame):
    ZeroMQ's Peer-Address of a Unix socket ends in ":uid:gid:pid". None over tcp or for anything but a received
    zmq.Frame."""
    try:
        address = part.get("Peer-Address")
    except (AttributeError, zmq.ZMQError):
        return None
    fields = address.rsplit(":", 3)
    if len(fields) != 4 or not fields[3].isdigit():
        return None
    return int(fields[3])


def start_ticks(pid: int) -> int | None:
    """When process `pid` started, in clock ticks after boot (field 22 of /proc/PID/stat); None when no process
    has that pid. The process's name (field 2) may hold spaces and parentheses: the fields are counted after its
    last ')'."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            stat = fh.read()
    except OSError:
        return None
    fields = stat[stat.rfind(b")") + 2:].split()
    try:
        return int(fields[19])       # field 22; fields[0] is field 3
    except (IndexError, ValueError):
        return None
