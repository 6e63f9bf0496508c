"""The admin client: ask a running graph's supervisor (protocol.Admin: status, stop, swap) from any process on the
same machine and user, the way `carav status | stop | swap` do. A run is found by its `run.json` in the run
folder (supervisor.run_root); a node finds its own run through CARAV_RUN_ID, which the supervisor sets for it.
"""
from __future__ import annotations

import json
import os
from typing import Any

import zmq

from carav_stream.runtime.protocol import pack, unpack

RUN_ID_ENV = "CARAV_RUN_ID"


def run_info(run_id: str) -> dict[str, Any]:
    """The run.json of run `run_id`; LookupError if no such run is running under this user."""
    from carav_stream.runtime.supervisor import run_root
    path = run_root() / run_id / "run.json"
    try:
        info = json.loads(path.read_text())
        os.kill(info["pid"], 0)
    except (OSError, ValueError, KeyError):
        raise LookupError(f"no running graph with run id {run_id!r} (no readable {path})") from None
    return info


def request(run: dict[str, Any], kind: str, timeout_s: float, **fields: Any) -> dict[str, Any]:
    """One admin request to the run's supervisor and its answer; TimeoutError if none within timeout_s."""
    ctx = zmq.Context.instance()
    sock = ctx.socket(zmq.REQ)
    sock.linger = 0
    try:
        sock.connect(run["admin"])
        sock.send(pack(kind, **fields))
        if not sock.poll(timeout_s * 1000):
            raise TimeoutError(f"run {run['run']} did not answer within {timeout_s:.0f} s")
        return unpack(sock.recv())
    finally:
        sock.close()
