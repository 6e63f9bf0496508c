"""One node of a graph, in its own OS process: `python -m carav_stream.runtime.node SPEC_FILE` (the supervisor starts
it through carav_stream/node_start.py, which makes it die with the supervisor before any import).

The node opens its sockets inside its own process, builds its block, says "ready" to the supervisor, and then
receives, validates, pairs by seq (pairing.Pairing), processes and sends frames (outputs.Outputs) until every
input delivered end of stream (or, for a source, until it generated its cycles or was told to stop). Control
messages (protocol.Control: go, stop, swap, eos, ...) and reports (protocol.Report: heartbeats, rejects, errors)
travel on a DEALER socket to the supervisor's ROUTER (control.ControlState keeps what it was told). A block
exception ends the process with the block's traceback reported to the supervisor; a bad message is rejected,
counted and reported, and the node keeps running.

Sequence leases: a source generates a seq only below the lease its supervisor granted and asks for more ahead of
time, so a restarted source resumes beyond every seq its killed incarnation may have sent (from the lease, not
from counters that a SIGKILL leaves stale): no consumer ever sees one seq with two contents.

Start: a node that is not told to go (Control.GO) within its spec's start_timeout_s exits (status 1): its
supervisor is gone or cannot run the graph, and nobody else could stop it.

Restarts: when a node's consumer is restarted, the node connects afresh at once and first sends a resume marker
(outputs.py); a pairing node releases a frame without its partner as soon as another input shows the partner can
never come (pairing.py).
"""
from __future__ import annotations

import collections
import os
import signal
import sys
import time
import traceback
from typing import Any

import zmq

from carav_stream import node_start
from carav_stream.runtime import shm, transport
from carav_stream.runtime.block import Block, BlockError
from carav_stream.runtime.control import ControlState
from carav_stream.runtime.frames import Frame, FrameError, decode, encode_with_header, header_packer
from carav_stream.runtime.outputs import Outputs, runtime_message
from carav_stream.runtime.pairing import Pairing
from carav_stream.runtime.protocol import LEASE_FRAMES, NodeSpec, Report, pack, unpack
from carav_stream.runtime.registry import Registry

HEARTBEAT_S = 0.5
CONTROL_S = 0.01         # while frames flow, the control socket is looked at no more often than this
CRASH_FLUSH_S = 1.0      # after a crash: how long frames already sent get to leave before the process exits
MAX_REPORTED_REJECTS = 20
RECEIVE_BURST = 64       # messages taken from one input before looking at the others


def _sender(part: Any) -> int | None:
    """The pid of the process that sent a message received over ipc: ZeroMQ's Peer-Address of a Unix socket
    ends in ":uid:gid:pid", taken by the kernel (SO_PEERCRED) when that process connected. None over tcp or for
    a part that is not a received zmq.Frame."""
    try:
        address = part.get("Peer-Address")
    except (AttributeError, zmq.ZMQError):
        return None
    fields = address.rsplit(":", 3)
    if len(fields) != 4 or not fields[3].isdigit():
        return None
    return int(fields[3])


class NodeRunner:
    def __init__(self, spec: NodeSpec) -> None:
        self.spec = spec
        self.name = spec.name
        self.ctx = zmq.Context()
        self.control = self.ctx.socket(zmq.DEALER)
        self.control.identity = self.name.encode()
        self.control.linger = 2000
        self.control.connect(spec.control)
        self.registry = Registry(list(spec.block_paths))
        self.generation = spec.generation
        self.incarnation = spec.incarnation
        # shared-memory data plane (run.transport = "shm"): this node's output segments (its producers': readers)
        taps = {e.edge for edges in spec.outputs.values() for e in edges if e.tap}
        self.writers = {port: shm.SlotWriter(seg["fd"], seg["edges"], taps) for port, seg in spec.shm_out.items()}
        self.sending: str | None = None      # the port whose frame in a slot is being delivered
        block = self.new_block(spec.type, spec.params, self.generation)
        self.in_ports: list[str] = [p.name for p in type(block).inputs if p.name in spec.inputs]
        self.use_block(block, spec.type)
        sec = spec.security
        self.curve = transport.Curve(sec["curve_server_cert"], sec["curve_client_cert"],
                                     sec["curve_authorized"]) if sec else None
        self.inputs = {p: transport.bind_input(self.ctx, spec.inputs[p], spec.queue_frames, self.curve,
                                               header_only=p in spec.shm_in)
                       for p in self.in_ports}
        self.ipc_inputs = {p for p in self.in_ports if spec.inputs[p].startswith("ipc://")}
        self.shm_endpoints = {e.connect for port in spec.shm_out for e in spec.outputs.get(port, ())}
        self.outputs = Outputs(spec.outputs, self.connect, self.idle)
        self.readers = {port: shm.SlotReader(fd, edge) for port, (fd, edge) in spec.shm_in.items()
                        if port in self.inputs}
        self.ctl = ControlState(go=not self.cls.is_source(), recovering=spec.recovering, seq_lease=spec.seq_lease,
                                input_bounds=spec.input_bounds, producers=spec.producers)
        self.pairing = Pairing(self.in_ports, max(4, 4 * spec.queue_frames), recovering=spec.recovering,
                               bounds=self.ctl.input_bounds, producers=self.ctl.producers)
        self.lease_asked = 0
        self.c_in = collections.Counter()
        self.c_out = collections.Counter()
        self.c_rejected = collections.Counter()
        self.c_unpaired = collections.Counter()
        self.n_reports = 0
        self.processed = 0
        self.consumed = 0                                # input frames handed to the block
        self.cycles = 0                                  # cycles those frames carried (header `cycles`), this process's
        self.cycles_before = spec.start_cycles           # sources: cycles earlier incarnations generated (the budget's)
        self.busy_s = 0.0                                # CPU time spent inside the block's own code
        self.cpu_at_first_s: float | None = None          # the process's CPU time when the first frame came
        self.history: list[dict[str, Any]] = []         # blocks this node ran, for provenance and summary
        self.first_seq_of_block = None
        self.next_hb = 0.0
        self.next_control = 0.0
        self.go_by = time.monotonic() + spec.start_timeout_s if spec.start_timeout_s else None
        self.seq = spec.start_seq
        self.packer = header_packer()

    def new_block(self, block_type: str, params: dict[str, Any], generation: int) -> Block:
        """A block of `block_type`, told which instance of this node's blocks it is (Block.instance)."""
        block = self.registry.get(block_type).cls(**params)
        block.instance = (self.incarnation, generation)
        return block

    def use_block(self, block: Block, block_type: str) -> None:
        """Run `block` from now on; the per-frame stamps of this node and block are prepared here once."""
        self.block, self.cls, self.block_type = block, type(block), block_type
        if self.writers:
            block.allocate = self.allocate
        self.out_names = {p.name for p in self.cls.outputs}
        self.single_out = self.cls.outputs[0].name if len(self.cls.outputs) == 1 else None
        self.arg_names = [p.name for p in self.cls.inputs]             # process() arguments, in order
        # every input connected: process() takes the frame set as it is, in port order
        self.direct = self.arg_names == self.in_ports and not self.cls.merge_inputs
        version = f"{self.cls.version}#{self.generation}"
        self.hop = f"{self.name}:{block_type}@{version}"              # this node's entry in a frame's trail
        self.stamp = {"node": self.name, "block": block_type, "block_version": version}
        self.streams = {p.name: f"{self.name}.{p.name}" for p in self.cls.outputs}

    def allocate(self, port: str, shape: tuple[int, ...], dtype: Any) -> Any:
        """Block.output_buffer over shared memory: an array in a free slot of `port`'s segment, or None."""
        writer = self.writers.get(port)
        if writer is None:
            return None
        cut = writer.mask(self.outputs.cut) if self.outputs.cut else 0
        return writer.reserve(shape, dtype, cut, transport.TICK_S, self.idle)

    def connect(self, endpoint: str) -> zmq.Socket:
        return transport.connect_output(self.ctx, endpoint, self.spec.queue_frames, self.curve,
                                        int(self.spec.drain_timeout_s * 1000), endpoint in self.shm_endpoints)

    # -- control plane -------------------------------------------------------------------------------------
    def tell(self, kind: Report, **fields: Any) -> None:
        self.control.send(pack(kind, node=self.name, pid=os.getpid(), **fields))

    def counters(self) -> dict[str, Any]:
        return {"in": dict(self.c_in), "out": dict(self.c_out), "sent": dict(self.outputs.c_sent),
                "rejected": dict(self.c_rejected), "unpaired": dict(self.c_unpaired),
                "undeliverable": dict(self.outputs.c_undeliverable), "skipped": dict(self.outputs.c_skipped),
                "processed": self.processed, "consumed": self.consumed, "cycles": self.cycles, "busy_s": self.busy_s,
                "cpu_s": time.process_time(),           # the whole node process, ZeroMQ I/O thread included
                # the same from the first frame on: start-up left out, so working - busy is what the node spends
                # outside its block (decoding, pairing, sending, shared-memory slots, control)
                "cpu_working_s": 0.0 if self.cpu_at_first_s is None else time.process_time() - self.cpu_at_first_s,
                "block": self.block_type, "generation": self.generation, "state": self.state(),
                **({"shm": {p: w.counters() for p, w in self.writers.items()}} if self.writers else {})}

    def state(self) -> str:
        """What the node is doing, in one line: for the supervisor's report on a run that does not drain."""
        waiting = [p for p, w in self.writers.items() if w.waiting]
        if self.outputs.blocked_on:
            what = f"sending on {self.outputs.blocked_on}"
        elif waiting:
            what = f"waiting for a free shared-memory slot on {', '.join(waiting)}"
        elif self.outputs.eos_sent:
            what = "finished, waiting to be released"
        elif self.cls.is_source():
            what = "stopping" if self.ctl.stopping else f"generating (seq lease up to {self.ctl.seq_lease})"
        else:
            what = "waiting for input"
        inputs = f"; inputs {self.pairing.describe()}" if self.in_ports else ""
        return f"{what}; seq {self.seq}{inputs}"

    def idle(self) -> None:
        """Serve control messages and heartbeats at most every CONTROL_S; called between frames and every
        transport.TICK_S while blocked in ZeroMQ."""
        now = time.monotonic()
        if now >= self.next_control:
            self.next_control = now + CONTROL_S
            self.serve_control()

    def serve_control(self) -> None:
        """Send a heartbeat if one is due, take every queued control message, and act on what they said."""
        now = time.monotonic()
        if now >= self.next_hb:
            self.tell(Report.HEARTBEAT, counters=self.counters())
            self.next_hb = now + HEARTBEAT_S
        while self.control.get(zmq.EVENTS) & zmq.POLLIN:
            self.ctl.apply(unpack(self.control.recv()))
        if self.go_by is not None and not self.ctl.told_go and now > self.go_by:
            # no supervisor to report to or to be stopped by: leave at once, saying why in the node's log
            print(f"{self.name}: not told to go within {self.spec.start_timeout_s:.0f} s of starting; its "
                  "supervisor is gone or cannot start the graph; exiting", file=sys.stderr, flush=True)
            os._exit(1)
        ctl, out = self.ctl, self.outputs
        for port in ctl.ended_ports:                     # an upstream node died for good: its input ends here
            self.pairing.eos.setdefault(port, None)
        out.cut |= ctl.cut_edges
        out.reconnect |= ctl.reconnect_edges & out.edge_of.keys()
        ctl.reconnect_edges.clear()
        self.pairing.recovering = ctl.recovering
        if out.reconnect:
            out.resume_all(self.resume_messages)

    def resume_messages(self, port: str, edge: str) -> list[list[Any]]:
        """The first messages on a fresh connection to a restarted consumer: where the stream resumes, and the
        end of stream if this node had finished."""
        writer = self.writers.get(port)
        # what the consumer may give back (shm.py): every generation issued before, except a frame this node is
        # still delivering (it goes on the fresh connection after the marker)
        at = {"shm_gen": writer.generation - (self.sending == port)} if writer else {}
        msgs = [self.runtime_message(port, seq=self.outputs.resume_seq(edge, self.seq), resume=True, **at)]
        if self.outputs.eos_sent:
            msgs.append(self.eos_message(port, edge))
        return msgs

    def apply_swap(self) -> None:
        msg = self.ctl.take_swap()
        try:
            new = self.new_block(msg["block"], msg.get("params", {}), self.generation + 1)
            new.start()
        except Exception as exc:   # the old block keeps running; the supervisor tells the user why
            self.tell(Report.SWAP_FAILED, id=msg.get("id"), error=f"{type(exc).__name__}: {exc}")
            return
        self.close_block(next_seq=self.seq)
        self.generation += 1
        self.use_block(new, msg["block"])
        self.first_seq_of_block = None
        self.tell(Report.SWAPPED, id=msg.get("id"), block=self.block_type, version=self.cls.version,
                  generation=self.generation, next_seq=self.seq)

    def close_block(self, next_seq: int) -> None:
        self.history.append({"block": self.block_type, "version": self.cls.version, "generation": self.generation,
                             "first_seq": self.first_seq_of_block, "next_seq": next_seq,
                             "summary": self.block.summary()})

    # -- data plane ----------------------------------------------------------------------------------------
    def reject(self, port: str, reason: str) -> None:
        self.c_rejected[port] += 1
        if self.n_reports < MAX_REPORTED_REJECTS:
            self.n_reports += 1
            self.tell(Report.REJECT, port=port, reason=reason, count=self.c_rejected[port])

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
            frame = decode(parts, slots=reader)
        except FrameError as exc:
            self.reject(port, str(exc))
            return None
        sender = _sender(parts[0]) if port in self.ipc_inputs else None
        reason = self.pairing.check(port, frame, sender)
        if reason is not None:
            # a producer's pid or lease the supervisor sent may still be queued on the control socket: take it
            # and judge again before refusing
            self.serve_control()
            reason = self.pairing.check(port, frame, sender)
        if reason is not None:
            self.reject(port, reason)
            return None
        if reader is not None and frame.header.get("resume") is True:
            gen = frame.header.get("shm_gen")
            if type(gen) is int:
                reader.resume(gen)
        if not self.pairing.accept(port, frame, sender):
            return None
        self.c_in[port] += 1
        return frame

    def emit(self, result: Any, context: Frame | None) -> None:
        if type(result) is Frame and self.single_out is not None:   # the usual result: one frame, one output
            self.send(self.single_out, result, context)
            return
        if result is None:
            return
        if isinstance(result, Frame):
            if len(self.cls.outputs) != 1:
                raise TypeError(f"{self.cls.__name__}.process returned one Frame but the block has "
                                f"{len(self.cls.outputs)} outputs; return a dict {{port: Frame}}")
            self.send(self.cls.outputs[0].name, result, context)
            return
        for port, frame in result.items():
            if frame is None:
                continue
            if port not in self.out_names:
                raise KeyError(f"{self.cls.__name__} returned a frame for unknown output {port!r}")
            self.send(port, frame, context)

    def send(self, port: str, frame: Frame, context: Frame | None) -> None:
        h = frame.header
        if context is not None:
            ch = context.header
            seq = ch["seq"]
            cycle = ch.get("cycle", seq)
            trail = [*h.get("trail", ch.get("trail", ())), self.hop]
            t_created = h.get("t_created_s", ch.get("t_created_s", time.time()))
        else:
            seq, cycle, trail = self.seq, h.get("cycle", self.seq), [self.hop]
            t_created = h.get("t_created_s", time.time())
        if self.first_seq_of_block is None:
            self.first_seq_of_block = seq
        header = {**h, "stream": self.streams[port], "seq": seq, "cycle": cycle, "t_created_s": t_created,
                  "t_sent_s": time.time(), "trail": trail, **self.stamp}
        self.c_out[port] += 1
        writer = self.writers.get(port)
        if writer is None:
            self.outputs.send(port, encode_with_header(header, frame, self.packer), seq)
            return
        cut = writer.mask(self.outputs.cut) if self.outputs.cut else 0
        parts = encode_with_header(header, frame, self.packer,
                                   lambda buffers: writer.place(buffers, cut, transport.TICK_S, self.idle))
        self.sending = port if "shm" in header else None
        try:
            missed = self.outputs.send(port, parts, seq)
        finally:
            self.sending = None
        if missed and "shm" in header:
            writer.unsend(header["shm"], missed)

    def runtime_message(self, port: str, **header: Any) -> list[Any]:
        return runtime_message(self.name, self.block_type, port, **header)

    def eos_message(self, port: str, edge: str) -> list[Any]:
        """End of stream on `edge`, with the count of frames sent on it for the consumer to check."""
        return self.runtime_message(port, seq=self.seq, eos=True, count=self.outputs.c_sent[edge])

    def pump(self) -> None:
        """Hand the block every frame set that is complete (all inputs at the same seq) or can never complete."""
        while True:
            if self.ctl.pending_swap:
                self.apply_swap()
            nxt = self.pairing.next_set(self.cls.merge_inputs)
            if nxt is None:
                return
            what, frames, port = nxt
            if what == "unpaired":
                self.c_unpaired[port] += 1
            self.run_block(what, frames, port)

    def run_block(self, what: str, frames: list[Frame], port: str | None = None) -> None:
        context = frames[0]
        self.seq = seq = context.header["seq"]
        if self.first_seq_of_block is None:
            self.first_seq_of_block = seq
        if self.cpu_at_first_s is None:
            self.cpu_at_first_s = time.process_time()
        t0 = time.thread_time()
        if what == "process":
            if self.direct:
                result = self.block.process(*frames)
            else:
                full = {port: context} if self.cls.merge_inputs else dict(zip(self.in_ports, frames))
                result = self.block.process(*map(full.get, self.arg_names))
        else:
            result = self.block.unpaired(port, context)
        self.busy_s += time.thread_time() - t0
        self.processed += 1
        self.consumed += len(frames)
        self.cycles += context.header.get("cycles", 1)
        self.emit(result, context)
        self.seq = seq + 1
        self.idle()

    # -- main loops ----------------------------------------------------------------------------------------
    def run_source(self) -> None:
        max_cycles = self.spec.max_cycles
        while not self.ctl.go:
            self.control.poll(100)
            self.serve_control()
        while not self.ctl.stopping and (not max_cycles or self.cycles_before + self.cycles < max_cycles):
            if self.ctl.pending_swap:
                self.apply_swap()
            if not self.within_lease() or not self.release_due():
                continue
            self.block.cycle_budget = max_cycles - self.cycles_before - self.cycles if max_cycles else None
            if self.cpu_at_first_s is None:
                self.cpu_at_first_s = time.process_time()
            t0 = time.thread_time()
            result = self.block.generate(self.seq)
            self.busy_s += time.thread_time() - t0
            if result is None:
                break
            self.processed += 1
            first = result if isinstance(result, Frame) else next((f for f in result.values() if f is not None), None)
            self.cycles += first.header.get("cycles", 1) if first is not None else 1
            self.emit(result, None)
            self.seq += 1
            self.idle()

    def release_due(self) -> bool:
        """Whether the block's frame `self.seq` may be generated now; if not, wait on control for up to a tick."""
        wait = self.block.ready_in(self.seq)
        if wait <= 0:
            return True
        self.control.poll(min(wait, transport.TICK_S) * 1000)
        self.serve_control()
        return False

    def within_lease(self) -> bool:
        """Ask for more seqs half a lease ahead; False (after waiting on control) while `self.seq` is beyond it."""
        if self.seq + LEASE_FRAMES // 2 >= self.ctl.seq_lease and self.lease_asked < self.seq + LEASE_FRAMES:
            self.lease_asked = self.seq + LEASE_FRAMES
            self.tell(Report.LEASE, upto=self.lease_asked)
        if self.seq < self.ctl.seq_lease:
            return True
        self.control.poll(transport.TICK_S * 1000)
        self.serve_control()
        return False

    def run_filter(self) -> None:
        poller = zmq.Poller()
        poller.register(self.control, zmq.POLLIN)
        if len(self.in_ports) == 1 and not self.cls.merge_inputs:
            self.run_single(self.in_ports[0])
        while True:
            self.pump()
            # several inputs, or none wanted (end of stream, full buffer): wait for any, or for control
            wanted = self.pairing.wanted()
            if self.pairing.finished():
                return
            for p, sock in self.inputs.items():
                if p in wanted and sock not in poller:
                    poller.register(sock, zmq.POLLIN)
                elif p not in wanted and sock in poller:
                    poller.unregister(sock)
            events = dict(poller.poll(transport.TICK_S * 1000))
            if self.control in events:
                self.serve_control()
            for p in wanted:
                if self.inputs[p] in events:
                    self.receive(p)
            self.idle()

    def run_single(self, port: str) -> None:
        """The loop of a node with one input that does not merge inputs (most nodes): every frame is complete
        as it arrives, so each message is received, checked, processed and sent on in one pass, waiting inside
        ZeroMQ's receive. Returns at the end of the stream, or when a swapped-in block merges inputs (the
        general loop of run_filter takes over)."""
        sock = self.inputs[port]
        eos = self.pairing.eos
        while port not in eos:
            if self.ctl.pending_swap:         # a swap between two frames
                self.apply_swap()
                if self.cls.merge_inputs:
                    return
            try:
                parts = transport.recv_message(sock, 0)
            except zmq.Again:                 # nothing for TICK_S: serve control and wait again
                self.idle()
                continue
            frame = self.admit(port, parts)
            if frame is None:
                self.idle()
            else:
                self.run_block("process", [frame])   # it serves control after the block, as idle() does

    def run(self) -> int:
        self.block.start()
        self.tell(Report.READY, block=self.block_type, version=self.cls.version)
        if self.cls.is_source():
            self.run_source()
        else:
            self.run_filter()
        self.emit(self.block.finish(), None if not self.in_ports else Frame({"seq": self.seq}))
        self.outputs.send_eos(self.eos_message)
        self.close_block(next_seq=self.seq)
        eos = self.pairing.eos
        lost = {p: n - self.c_in[p] for p, n in eos.items() if n is not None and n != self.c_in[p]}
        self.tell(Report.DONE, counters=self.counters(), history=self.history, lost=lost,
                  upstream_gone=sorted(p for p, n in eos.items() if n is None))
        # Stay alive until the supervisor releases every node: ZeroMQ drops the frames still buffered in a
        # connection when the sending process exits while its consumer's queue is full (linger does not help).
        deadline = time.monotonic() + self.spec.drain_timeout_s
        while not self.ctl.released and time.monotonic() < deadline:
            self.control.poll(HEARTBEAT_S * 1000)
            self.serve_control()
        return 0

    def close(self, crashed: bool = False) -> None:
        self.outputs.close(crashed)
        for sock in self.inputs.values():
            sock.close(linger=0)
        for end in [*self.writers.values(), *self.readers.values()]:
            end.close()
        self.control.close(linger=2000)
        if self.curve:
            self.curve.close()
        self.ctx.term()                     # flushes the last reports to the supervisor


def _report_crash(spec: NodeSpec, runner: NodeRunner | None, exc: BaseException) -> None:
    """Tell the supervisor why this node failed, with the traceback (none for a BlockError: the block's own
    one-line statement that its input cannot go on, e.g. a truncated file); let what it already sent leave."""
    tb = None if isinstance(exc, BlockError) else traceback.format_exc()
    print(tb or f"{spec.name}: {exc}", file=sys.stderr, flush=True)
    msg = pack(Report.ERROR, node=spec.name, pid=os.getpid(), error=f"{type(exc).__name__}: {exc}", traceback=tb,
               counters=runner.counters() if runner else {})
    if runner is None:
        ctx = zmq.Context()
        ctl = ctx.socket(zmq.DEALER)
        ctl.identity = spec.name.encode()
        ctl.connect(spec.control)
        ctl.send(msg)
        ctl.close(linger=2000)
        ctx.term()
        return
    for sock in runner.inputs.values():
        sock.close(linger=0)
    runner.control.send(msg)
    # What it already sent is valid and must leave, but ZeroMQ drops what is still queued towards a full
    # consumer once the socket closes (linger does not help): the process stays up for CRASH_FLUSH_S with its
    # outputs open (the supervisor restarts it only after it exits), then drops the rest, which the supervisor
    # counts as lost.
    if runner.outputs.sockets:
        time.sleep(CRASH_FLUSH_S)
    runner.close(crashed=True)


def main(argv: list[str]) -> int:
    node_start.die_with_parent()     # already done by the launcher; here for `python -m carav_stream.runtime.node`
    # Ctrl-C and a group-wide SIGTERM go to the supervisor too, which stops the nodes in order; a node dies
    # with its supervisor through the parent-death signal, and the supervisor kills with SIGKILL.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    with open(argv[0], "rb") as fh:
        spec = NodeSpec.from_wire(fh.read())
    runner = None
    try:
        runner = NodeRunner(spec)
        code = runner.run()
    except BaseException as exc:  # report, with the traceback, then fail: the supervisor decides what next
        try:
            _report_crash(spec, runner, exc)
        except Exception:
            pass
        os._exit(1)
    runner.close()
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
