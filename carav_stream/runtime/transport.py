"""ZeroMQ plumbing: one PULL socket bound per input port, one PUSH socket per edge connected to it.

Every input port binds its own endpoint (`ipc://RUNDIR/node.port`, or `tcp://bind:port` for an edge that
crosses hosts), so a producer with several edges on one output port sends each frame to each edge in order.
High-water marks bound every queue and sends block when a queue is full: a slow consumer slows its
producers and nothing is dropped. Nodes block inside ZeroMQ (no Python polling loop per frame): every data
socket has a send and receive timeout of TICK_S, after which the node serves heartbeats and control and waits
again. On tcp edges ZeroMQ's CURVE mechanism authenticates and encrypts (curve.py): the binding side is the
CURVE server, the connecting side a client that also checks the server's key.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import zmq

MAX_MESSAGE_BYTES = (1 << 30) + (1 << 21)   # arrays limit plus header room: zmq drops the peer beyond this
TICK_S = 0.1            # longest a node waits inside one ZeroMQ send or receive before serving heartbeats and control
RECONNECT_MS, RECONNECT_MAX_MS = 5, 100   # an output's tries to reach its consumer: after 5 ms, doubling up to 100

# pyzmq's compiled send: the Python wrapper around it only adds routing_id/group options and, with
# send_multipart, a type check per part and enum arithmetic per frame, a cost per message that the compiled
# send skips (measured: docs/bench/transport.md).
_send = zmq.backend.Socket.send
_SNDMORE = int(zmq.SNDMORE)


# Socket buffers of the kernel for edges whose messages are headers alone (arrays in shared memory): the default
# (about 200 kB) would queue hundreds of such messages beyond the high-water marks, each holding a slot.
HEADER_ONLY_BUFFER_BYTES = 8192


def bind_input(ctx: zmq.Context, endpoint: str, hwm: int, curve: Any = None, header_only: bool = False,
               name: str = "") -> zmq.Socket:
    """The PULL socket of input `name` bound at `endpoint`; a CURVE server (curve.Curve.serve) on tcp when `curve`
    is given."""
    sock = ctx.socket(zmq.PULL)
    if header_only:
        sock.rcvbuf = HEADER_ONLY_BUFFER_BYTES
    sock.rcvhwm = hwm
    sock.maxmsgsize = MAX_MESSAGE_BYTES
    sock.rcvtimeo = int(TICK_S * 1000)
    sock.linger = 0
    if curve is not None and endpoint.startswith("tcp://"):
        curve.serve(ctx, sock, name)
    sock.bind(endpoint)
    return sock


def connect_output(ctx: zmq.Context, endpoint: str, hwm: int, curve: Any = None, linger_ms: int = 30_000,
                   header_only: bool = False, name: str = "") -> zmq.Socket:
    """The PUSH socket of output edge `name` connected to `endpoint`; a CURVE client (curve.Curve.connect_as_client)
    on tcp when `curve` is given."""
    sock = ctx.socket(zmq.PUSH)
    if header_only:
        sock.sndbuf = HEADER_ONLY_BUFFER_BYTES
    sock.sndhwm = hwm
    sock.sndtimeo = int(TICK_S * 1000)
    sock.linger = linger_ms          # a clean exit waits for queued frames to leave
    # queue only towards a consumer reached: a connection to one that died drops what it held when it breaks,
    # so a restarted consumer bound at the same address never gets frames meant for its dead incarnation
    sock.immediate = True
    # a restarted consumer binds its endpoint anew: tried again soon, then less and less often (ZeroMQ's default
    # is one try every RECONNECT_MAX_MS, a tenth of a second of every restart spent waiting for the next try)
    sock.reconnect_ivl, sock.reconnect_ivl_max = RECONNECT_MS, RECONNECT_MAX_MS
    if curve is not None and endpoint.startswith("tcp://"):
        curve.connect_as_client(sock, name)
    sock.connect(endpoint)
    return sock


def wait_room(sock: zmq.Socket, timeout_s: float) -> None:
    """Wait until `sock` can take a message (an `immediate` PUSH socket: it reached its consumer and has room), for
    `timeout_s` at most."""
    sock.poll(int(timeout_s * 1000), zmq.POLLOUT)


def send_message(sock: zmq.Socket, parts: list[Any], flags: int = 0) -> None:
    """Send a multipart message without copying buffers (zmq.Frames, bytes, buffer objects); waits at most
    the socket's send timeout (not at all with flags zmq.NOBLOCK), then raises zmq.Again. ZeroMQ queues a
    multipart message whole or not at all, so a timed-out attempt sent nothing."""
    last = len(parts) - 1
    for i, part in enumerate(parts):
        _send(sock, part, (_SNDMORE if i < last else 0) | flags, copy=False)


def recv_message(sock: zmq.Socket, flags: int = 0) -> list[zmq.Frame]:
    """Receive one multipart message as zmq.Frames (no copy); waits at most the socket's receive timeout
    (not at all with zmq.NOBLOCK), then raises zmq.Again. The parts of a message arrive together."""
    part = sock.recv(flags, copy=False)
    parts = [part]
    while part.more:
        part = sock.recv(copy=False)
        parts.append(part)
    return parts


def ipc_endpoint(run_dir: Path, name: str) -> str:
    path = run_dir / name
    if len(str(path)) > 100:   # sockaddr_un holds 107 bytes
        raise ValueError(f"ipc endpoint path {path} is too long for a Unix socket; set CARAV_RUN_DIR to a "
                         "shorter folder")
    return f"ipc://{path}"
