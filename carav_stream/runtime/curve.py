"""ZeroMQ CURVE on a node's tcp edges: its keys, the ZAP handler that admits only authorized client keys, and the
watch over every handshake.

An input bound on tcp is a CURVE server: its ZAP handler (a thread of the node, answering ZeroMQ's requests on
inproc://zeromq.zap.01) admits a connection only if the client's public key is in `curve_authorized`, and notes
every key it refuses. An output edge on tcp is a CURVE client that also checks the server's key, so a peer
without the right keys gets nothing in and nothing out.

Every tcp socket is watched through a ZeroMQ socket monitor (read between frames, like control):
- on an input, each connection refused at the handshake (a key not authorized, a peer without CURVE, a handshake
  that cannot be decrypted) is a refusal with its reason: the node counts it on the port and the graph runs on;
- on an output edge, a handshake the consumer refused is a fault of this graph's keys, which a restart would meet
  again: the node fails at once, with one line naming the edge and the key (`HandshakeWatch.failure`).
"""
from __future__ import annotations

import collections
import itertools
import shutil
import threading
from pathlib import Path
from typing import Any

import zmq
import zmq.auth
from zmq.utils import z85
from zmq.utils.monitor import parse_monitor_message

ZAP_ENDPOINT = "inproc://zeromq.zap.01"
WATCHED = (zmq.EVENT_HANDSHAKE_SUCCEEDED | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
           | zmq.EVENT_HANDSHAKE_FAILED_AUTH)
NO_DETAIL_FAILURES = 3   # handshakes failed without detail in a row on an output edge before the node fails
PROTOCOL_ERRORS = {
    zmq.PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH: "the peer does not use CURVE",
    zmq.PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC: "the handshake could not be decrypted: the peer does not hold the keys "
                                           "of this edge",
}
_ids = itertools.count()


def public(key: bytes) -> str:
    return key.decode() if isinstance(key, bytes) else str(key)


class Curve:
    """The CURVE keys of one node, from the certificate files `security` names (zmq.auth format):
    curve_server_cert, curve_client_cert (secret-key files) and curve_authorized (a folder of public keys)."""

    def __init__(self, security: dict[str, str]) -> None:
        self.files = security
        self.server_public, self.server_secret = zmq.auth.load_certificate(security["curve_server_cert"])
        self.client_public, self.client_secret = zmq.auth.load_certificate(security["curve_client_cert"])
        if not self.server_secret or not self.client_secret:
            raise ValueError(f"CURVE certificates {security['curve_server_cert']} and "
                             f"{security['curve_client_cert']} must be secret-key files")
        self.authorized = set(zmq.auth.load_certificates(security["curve_authorized"]))
        self.zap: ZapHandler | None = None
        self.watch = HandshakeWatch(self)

    def serve(self, ctx: zmq.Context, sock: zmq.Socket, port: str) -> None:
        """Make `sock` (an input about to bind) a CURVE server whose ZAP handler admits the authorized keys."""
        if self.zap is None:
            self.zap = ZapHandler(ctx, self.authorized, self.files["curve_authorized"], self.watch.refused)
        sock.curve_secretkey = self.server_secret
        sock.curve_publickey = self.server_public
        sock.curve_server = True
        sock.zap_domain = port.encode()
        self.watch.add(sock, port, server=True)

    def connect_as_client(self, sock: zmq.Socket, edge: str) -> None:
        """Make `sock` (an output edge about to connect) a CURVE client that checks the server's key."""
        sock.curve_secretkey = self.client_secret
        sock.curve_publickey = self.client_public
        sock.curve_serverkey = self.server_public
        self.watch.add(sock, edge, server=False)

    def close(self) -> None:
        self.watch.close()
        if self.zap is not None:
            self.zap.stop()
            self.zap = None


class ZapHandler(threading.Thread):
    """ZeroMQ's authentication handler for the node's CURVE servers: admits a client whose public key is in
    `authorized`; for each one refused, puts (input port, reason) in `refused`. Bound when made, so no server
    socket can take a connection before it answers."""

    def __init__(self, ctx: zmq.Context, authorized: set[bytes], folder: str,
                 refused: collections.deque) -> None:
        super().__init__(name="carav-zap", daemon=True)
        self.authorized, self.folder, self.refused = authorized, folder, refused
        self.sock = ctx.socket(zmq.REP)
        self.sock.linger = 0
        self.sock.bind(ZAP_ENDPOINT)
        stop = f"inproc://carav-zap-stop-{next(_ids)}"
        self.stop_in = ctx.socket(zmq.PAIR)
        self.stop_in.bind(stop)
        self.stop_out = ctx.socket(zmq.PAIR)
        self.stop_out.linger = 0
        self.stop_out.connect(stop)
        self.start()

    def run(self) -> None:
        poller = zmq.Poller()
        poller.register(self.sock, zmq.POLLIN)
        poller.register(self.stop_in, zmq.POLLIN)
        try:
            while self.stop_in not in dict(poller.poll()):
                self.sock.send_multipart(self.answer(self.sock.recv_multipart()))
        finally:
            self.sock.close(linger=0)
            self.stop_in.close(linger=0)

    def answer(self, request: list[bytes]) -> list[bytes]:
        """The reply to one ZAP request (version, id, domain, address, identity, mechanism, credentials...)."""
        if len(request) < 6:
            return [b"1.0", request[1] if len(request) > 1 else b"", b"500", b"malformed request", b"", b""]
        version, request_id, domain, address, _, mechanism, *credentials = request
        key = z85.encode(credentials[0]) if mechanism == b"CURVE" and credentials else None
        if key is not None and key in self.authorized:
            return [version, request_id, b"200", b"OK", key, b""]
        what = (f"its CURVE key {public(key)} is not in curve_authorized ({self.folder})" if key is not None
                else f"it uses {mechanism.decode(errors='replace')}, not CURVE")
        self.refused.append((domain.decode(errors="replace"),
                             f"refused a tcp connection from {address.decode(errors='replace')}: {what}"))
        return [version, request_id, b"400", b"key not authorized", b"", b""]

    def stop(self) -> None:
        self.stop_out.send(b"")
        self.join(5.0)
        self.stop_out.close(linger=0)


class HandshakeWatch:
    """The socket monitors of a node's tcp sockets: refused connections on its inputs, and the first failed
    handshake of an output edge."""

    def __init__(self, curve: Curve) -> None:
        self.curve = curve
        self.refused: collections.deque[tuple[str, str]] = collections.deque()   # (port, reason), also ZAP's
        self.monitors: dict[str, tuple[zmq.Socket, bool]] = {}    # port or edge -> (its monitor, server side)
        self.endpoints: dict[str, str] = {}
        self.no_detail: collections.Counter[str] = collections.Counter()
        self.failure: str | None = None

    def add(self, sock: zmq.Socket, name: str, *, server: bool) -> None:
        """Watch `sock`, an input (server) or an output edge (client) named `name`; a new socket for the same
        name (a connection made afresh) replaces the old one's watch."""
        old = self.monitors.pop(name, None)
        if old is not None:
            old[0].close(linger=0)
        self.monitors[name] = (sock.get_monitor_socket(WATCHED), server)

    def poll(self) -> list[tuple[str, str]]:
        """The (port, reason) of every connection refused on an input since the last call; sets `failure` on the
        first output edge whose handshake the consumer refused."""
        for name, (monitor, server) in list(self.monitors.items()):
            while monitor.get(zmq.EVENTS) & zmq.POLLIN:
                event = parse_monitor_message(monitor.recv_multipart())
                self.endpoints[name] = event["endpoint"].decode(errors="replace")
                (self.on_input if server else self.on_output)(name, event["event"], event["value"])
        out = list(self.refused)
        self.refused.clear()
        return out

    def on_input(self, port: str, event: int, value: int) -> None:
        if event == zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL:
            why = PROTOCOL_ERRORS.get(value, f"it broke ZeroMQ's protocol (error {value:#x})")
            self.refused.append((port, f"refused a tcp connection: {why}"))
        elif event == zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL:
            self.refused.append((port, "refused a tcp connection: its handshake failed"))
        # EVENT_HANDSHAKE_FAILED_AUTH: the ZAP handler refused it and said why (with the key)

    def on_output(self, edge: str, event: int, value: int) -> None:
        c, where = self.curve, f"edge '{edge}' ({self.endpoints[edge]})"
        if event == zmq.EVENT_HANDSHAKE_SUCCEEDED:
            self.no_detail[edge] = 0
        elif event == zmq.EVENT_HANDSHAKE_FAILED_AUTH and self.failure is None:
            self.failure = (f"{where}: the consumer refused this node's CURVE key {public(c.client_public)} "
                            f"(curve_client_cert {c.files['curve_client_cert']}): it is not in the consumer's "
                            "curve_authorized")
        elif event in (zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL, zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL):
            # a protocol error is the consumer's answer; a failure without detail may be a connection that broke
            # mid-handshake, and only a run of them says the keys are wrong
            protocol = event == zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
            self.no_detail[edge] += not protocol
            if self.failure is None and (protocol or self.no_detail[edge] >= NO_DETAIL_FAILURES):
                why = PROTOCOL_ERRORS.get(value, "the handshake failed") if protocol else "the handshake failed"
                self.failure = (f"{where}: CURVE with the consumer failed ({why}): it does not hold the secret key "
                                f"of server key {public(c.server_public)} (curve_server_cert "
                                f"{c.files['curve_server_cert']}), or does not use CURVE")

    def close(self) -> None:
        for monitor, _ in self.monitors.values():
            monitor.close(linger=0)
        self.monitors.clear()


def key_files(security: dict[str, Any]) -> dict[str, str]:
    """The CURVE certificate files of a [security] table (or of a spec), as strings; {} when it names none."""
    names = ("curve_server_cert", "curve_client_cert", "curve_authorized")
    return {k: str(security[k]) for k in names if k in security}


def write_keys(folder: Path) -> dict[str, str]:
    """New CURVE certificates (zmq.curve_keypair) in `folder`, made private (mode 0700, secret files 0600):
    server and client key pairs, and `authorized/` holding the client's public key. Returns the [security] key
    files {curve_server_cert, curve_client_cert, curve_authorized}."""
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    folder.chmod(0o700)
    _, server_secret = zmq.auth.create_certificates(folder, "server")
    client_public, client_secret = zmq.auth.create_certificates(folder, "client")
    authorized = folder / "authorized"
    authorized.mkdir(mode=0o700, exist_ok=True)
    shutil.copy(client_public, authorized / Path(client_public).name)
    for secret in (server_secret, client_secret):
        Path(secret).chmod(0o600)
    return {"curve_server_cert": str(server_secret), "curve_client_cert": str(client_secret),
            "curve_authorized": str(authorized)}
