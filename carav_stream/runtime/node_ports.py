"""A node's data ports: its inputs (one bound PULL socket each, the data plane's readers, and admission: decode,
the checks of pairing.py, counting), its outputs (outputs.Outputs over one connected PUSH socket per edge, and
the data plane's writers) and the port taps an observer asked for (port_tap.py). Which plane carries the arrays is
the spec's (runtime/planes/); a port the plane gave no resources to carries them inline, in the ZeroMQ message.

A bad message is rejected with its reason, counted on its port and reported (the first MAX_REPORTED_REJECTS),
and the node keeps running. On a local (ipc) input a message is taken only from an incarnation of that input's
producer (the kernel's SO_PEERCRED, read from ZeroMQ's Peer-Address, with the start time of that pid: senders.py).
"""
from __future__ import annotations

import collections
from collections.abc import Callable
from typing import Any

import zmq

from carav_stream.runtime import planes, transport
from carav_stream.runtime.block import BlockError
from carav_stream.runtime.curve import Curve, key_files
from carav_stream.runtime.frames import PLANE_REF, Frame, FrameError, decode, encode_with_header, header_packer
from carav_stream.runtime.node_link import ControlLink
from carav_stream.runtime.outputs import Outputs
from carav_stream.runtime.pairing import Pairing
from carav_stream.runtime.port_tap import PortTaps
from carav_stream.runtime.protocol import NodeSpec, Report
from carav_stream.runtime.senders import sender_pid

MAX_REPORTED_REJECTS = 20
RECEIVE_BURST = 64       # messages taken from one input before looking at the others


class NodePorts:
    """The ports of node `spec.name` whose block has the inputs `in_ports` connected; `link` serves control while
    a send blocks and judges anew a message refused before a control message that may change the verdict."""

    def __init__(self, ctx: zmq.Context, spec: NodeSpec, in_ports: list[str], link: ControlLink) -> None:
        self.ctx, self.spec, self.link = ctx, spec, link
        plane = planes.get(spec.plane) if spec.plane_out or spec.plane_in else None
        self.plane_name = spec.plane
        taps = {e.edge for edges in spec.outputs.values() for e in edges if e.tap}
        self.writers = {port: plane.writer(res, taps) for port, res in spec.plane_out.items()}
        header_only = plane is not None and plane.header_only
        keys = key_files(spec.security)
        self.curve = Curve(keys) if keys else None
        self.inputs = {p: transport.bind_input(ctx, spec.inputs[p], spec.queue_frames, self.curve,
                                               header_only=header_only and p in spec.plane_in, name=p)
                       for p in in_ports}
        self.edge_at = {e.connect: e.edge for edges in spec.outputs.values() for e in edges}
        self.ipc_inputs = {p for p in in_ports if spec.inputs[p].startswith("ipc://")}
        self.header_only_endpoints = {e.connect for port in spec.plane_out for e in spec.outputs.get(port, ())
                                      if header_only}
        self.outputs = Outputs(spec.outputs, self.connect, link.idle, wait_room=transport.wait_room)
        self.taps = PortTaps(ctx, spec.name, spec.incarnation)
        self.readers = {port: plane.reader(res) for port, res in spec.plane_in.items() if port in self.inputs}
        ctl = link.ctl
        self.pairing = Pairing(in_ports, max(4, 4 * spec.queue_frames), recovering=spec.recovering,
                               bounds=ctl.input_bounds, producers=ctl.producers)
        self.packer = header_packer()
        self.c_in = collections.Counter()
        self.frame_bytes: dict[str, int] = {}     # port -> the largest message taken from it, in bytes
        self.c_out = collections.Counter()
        self.c_rejected = collections.Counter()
        self.c_refused = collections.Counter()      # per tcp input: connections refused at the CURVE handshake
        self.n_reports = 0

    def connect(self, endpoint: str) -> zmq.Socket:
        return transport.connect_output(self.ctx, endpoint, self.spec.queue_frames, self.curve,
                                        int(self.spec.drain_timeout_s * 1000), endpoint in self.header_only_endpoints,
                                        name=self.edge_at[endpoint])

    def watch_handshakes(self) -> None:
        """Count and report the tcp connections the node's inputs refused since the last call (curve.py); raise
        BlockError(retry=False), naming the edge and the key, when an output edge's consumer refused this node's
        CURVE handshake."""
        if self.curve is None:
            return
        for port, reason in self.curve.watch.poll():
            self.c_refused[port] += 1
            if self.n_reports < MAX_REPORTED_REJECTS:
                self.n_reports += 1
                self.link.tell(Report.REJECT, port=port, reason=reason, count=self.c_refused[port], what="connection")
        if self.curve.watch.failure is not None:
            raise BlockError(self.curve.watch.failure, retry=False)

    # -- inputs --------------------------------------------------------------------------------------------
    def reject(self, port: str, reason: str) -> None:
        self.c_rejected[port] += 1
        if self.n_reports < MAX_REPORTED_REJECTS:
            self.n_reports += 1
            self.link.tell(Report.REJECT, port=port, reason=reason, count=self.c_rejected[port])

    def receive(self, port: str) -> None:
        """Take what is queued on `port`, up to RECEIVE_BURST messages, without waiting. Each is validated and
        buffered for pairing, or rejected and counted."""
        sock = self.inputs[port]
        for _ in range(RECEIVE_BURST):
            try:
                parts = transport.recv_message(sock, zmq.NOBLOCK)
            except zmq.Again:
                return
            frame = self.admit(port, parts)
            if frame is not None:
                self.pairing.push(port, frame)
            elif port in self.pairing.eos:
                return

    def admit(self, port: str, parts: list[Any]) -> Frame | None:
        """Decode and check one message from `port`: the data frame to hand on, or None for a message that was
        rejected (counted and reported), the end of stream or a resume marker."""
        reader = self.readers.get(port)
        try:
            frame = decode(parts, reader=reader)
        except FrameError as exc:
            self.reject(port, str(exc))
            return None
        sender = sender_pid(parts[0]) if port in self.ipc_inputs else None
        reason = self.pairing.check(port, frame, sender)
        if reason is not None:
            # a producer's pid or lease the supervisor sent may still be queued on the control socket: take it
            # and judge again before refusing
            self.link.serve()
            reason = self.pairing.check(port, frame, sender)
        if reason is not None:
            self.reject(port, reason)
            return None
        if reader is not None and frame.header.get("resume") is True:
            reader.resume(frame.header)
        if not self.pairing.accept(port, frame, sender):
            return None
        self.c_in[port] += 1
        nbytes = sum(part.nbytes if isinstance(part, memoryview) else len(part) for part in parts)
        if nbytes > self.frame_bytes.get(port, 0):
            self.frame_bytes[port] = nbytes
        return frame

    # -- outputs -------------------------------------------------------------------------------------------
    def deliver(self, port: str, header: dict[str, Any], frame: Frame, seq: int) -> None:
        """Send `frame` with its stamped `header` on every edge of `port`: its arrays on the port's data plane,
        or inline."""
        self.c_out[port] += 1
        if self.taps.ports and port in self.taps.ports:   # before the send, which packs the header
            self.taps.offer(port, header, frame)
        writer = self.writers.get(port)
        if writer is None:
            self.outputs.send(port, encode_with_header(header, frame, self.packer), seq)
            return
        cut, idle = self.outputs.cut, self.link.idle
        parts = encode_with_header(header, frame, self.packer, lambda buffers: writer.place(buffers, cut, idle))
        missed: list[str] = []
        try:
            missed = self.outputs.send(port, parts, seq)
        finally:
            writer.delivered(header.get(PLANE_REF), missed)

    def allocate(self, port: str, shape: tuple[int, ...], dtype: Any) -> Any:
        """Block.output_buffer on the data plane: a writable array on `port`'s plane, or None."""
        writer = self.writers.get(port)
        if writer is None:
            return None
        return writer.reserve(shape, dtype, self.outputs.cut, self.link.idle)

    def resume_fields(self, port: str) -> dict[str, Any]:
        """What the data plane adds to a resume marker on `port`."""
        writer = self.writers.get(port)
        return writer.resume_fields() if writer is not None else {}

    def apply_control(self, resume: Callable[[str, str], list[list[Any]]]) -> None:
        """Act on what the supervisor said (node_link.py): inputs ended, edges cut, consumers restarted (connected
        afresh at once, `resume(port, edge)` sent first)."""
        ctl, out = self.link.ctl, self.outputs
        for msg in ctl.taps:
            self.taps.apply(msg)
        ctl.taps.clear()
        for port in ctl.ended_ports:                     # an upstream node died for good: its input ends here
            self.pairing.eos.setdefault(port, None)
        out.cut |= ctl.cut_edges
        out.restart(ctl.reconnect_edges)
        ctl.reconnect_edges.clear()
        self.pairing.recovering = ctl.recovering
        if out.reconnect:
            out.resume_all(resume)

    def plane_counters(self) -> dict[str, Any]:
        """The data plane's counters of each output port it carries, under the plane's name."""
        return {self.plane_name: {p: w.counters() for p, w in self.writers.items()}} if self.writers else {}

    def waiting(self) -> str | None:
        """What the node waits for on its data plane, naming the ports; None when it does not."""
        ports = [p for p, w in self.writers.items() if w.waiting]
        return f"waiting for {self.writers[ports[0]].waits_for} on {', '.join(ports)}" if ports else None

    def close(self, crashed: bool = False) -> None:
        self.outputs.close(crashed)
        self.taps.close()
        for sock in self.inputs.values():
            sock.close(linger=0)
        for end in [*self.writers.values(), *self.readers.values()]:
            end.close()
        if self.curve:
            self.curve.close()
