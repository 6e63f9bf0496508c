"""The admin client: ask a running graph's supervisor (protocol.Admin: status, stop, swap) from any process on the
same machine and user, the way `carav status | stop | swap` do. A run is found by its `run.json` in the run
folder (rundir.run_info); the supervisor answers through admin_server.AdminServer.
"""
from __future__ import annotations

from typing import Any

import zmq

from carav_stream.runtime.protocol import pack, unpack


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
