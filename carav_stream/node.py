"""One node of a graph, in its own OS process: `python -m carav_stream.node SPEC_FILE`.

The node opens its sockets inside its own process, builds its block, says "ready" to the supervisor, and then
receives, validates, pairs by seq, processes and sends frames until every input delivered end of stream (or,
for a source, until it generated its cycles or was told to stop). Control messages (go, stop, swap, eos) and
heartbeats travel on a DEALER socket to the supervisor's ROUTER. A block exception ends the process with the
block's traceback reported to the supervisor; a bad message is rejected, counted and reported, and the node
keeps running.

Restarts: when a node's consumer is restarted, the node connects afresh at once (what the old connection held
is lost and counted) and first sends a header-only frame {resume: true, seq: X}: nothing before X comes on that
stream. A pairing node releases a frame without its partner as soon as another input shows the partner can never
come (it holds a later seq, received or resumed past it, or ended); a partner arriving after its seq was handled
is rejected, so the block sees every seq once and outputs stay in order.
"""
from __future__ import annotations

import collections
import os
import signal
import sys
import time
import traceback
from typing import Any

import msgpack
import zmq

from carav_stream import transport
from carav_stream.block import Block
from carav_stream.frames import Frame, FrameError, decode, encode, encode_with_header, header_packer
from carav_stream.registry import Registry

HEARTBEAT_S = 0.5
CONTROL_S = 0.01         # while frames flow, the control socket is looked at no more often than this
CRASH_FLUSH_S = 1.0      # after a crash: how long frames already sent get to leave before the process exits
RECOVERY_STALL_S = 2.0   # after a crash: how long a full input buffer waits for a partner before giving up
MAX_REPORTED_REJECTS = 20


def _set_parent_death_signal() -> None:
    """Die with the supervisor even if it is SIGKILLed (Linux prctl PR_SET_PDEATHSIG); no orphans."""
    try:
        import ctypes
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)   # PR_SET_PDEATHSIG = 1
    except (OSError, AttributeError):
        pass


class NodeRunner:
    def __init__(self, spec: dict[str, Any]) -> None:
        self.spec = spec
        self.name: str = spec["name"]
        self.ctx = zmq.Context()
        self.control = self.ctx.socket(zmq.DEALER)
        self.control.identity = self.name.encode()
        self.control.linger = 2000
        self.control.connect(spec["control"])
        self.registry = Registry(spec.get("block_paths", []))
        self.generation = spec.get("generation", 0)
        self.incarnation = spec.get("incarnation", 0)     # restarts of this node before this process
        block = self.new_block(spec["type"], spec["params"], self.generation)
        self.in_ports: list[str] = [p.name for p in type(block).inputs if p.name in spec["inputs"]]
        self.use_block(block, spec["type"])
        sec = spec.get("security") or {}
        self.curve = transport.Curve(sec["curve_server_cert"], sec["curve_client_cert"],
                                     sec["curve_authorized"]) if sec else None
        hwm = spec["queue_frames"]
        self.inputs = {p: transport.bind_input(self.ctx, spec["inputs"][p], hwm, self.curve) for p in self.in_ports}
        self.endpoints = {e["edge"]: e["connect"] for edges in spec["outputs"].values() for e in edges}
        self.outputs: dict[str, list[tuple[str, zmq.Socket]]] = {
            port: [(e["edge"], self.connect(e["edge"])) for e in edges] for port, edges in spec["outputs"].items()}
        self.edge_of = {edge: (port, i) for port, edges in self.outputs.items() for i, (edge, _) in enumerate(edges)}
        self.reconnect: set[str] = set()                 # edges whose consumer was restarted, not yet resumed
        self.sent_seq: dict[str, int] = {}               # per edge: seq of the last frame ZeroMQ took
        self.eos_sent = False
        self.limit = max(4, 4 * spec["queue_frames"])    # frames buffered per input while pairing
        # After a crash, partners lost with the dead node can never arrive: a node restarted, or fed by a
        # restarted node, must not hold frames for them forever (its full buffer would stall the graph).
        self.recovering = bool(spec.get("recovering"))
        self.stalled_since: float | None = None
        self.buffers = {p: collections.deque() for p in self.in_ports}
        self.eos: dict[str, int | None] = {}          # port -> announced count (None: upstream gone)
        self.last_seq: dict[str, int] = {}
        self.handled = -1            # pairing inputs: last seq handed to the block (a later partner is late)
        self.c_in = collections.Counter()
        self.c_out = collections.Counter()
        self.c_sent = collections.Counter()              # per edge
        self.c_rejected = collections.Counter()
        self.c_unpaired = collections.Counter()
        self.c_undeliverable = collections.Counter()     # per edge cut because its consumer died for good
        self.cut: set[str] = set()
        self.n_reports = 0
        self.processed = 0
        self.consumed = 0                                # input frames handed to the block
        self.cycles = spec.get("start_cycles", 0)        # cycles those frames carried (header `cycles`)
        self.busy_s = 0.0                                # CPU time spent inside the block's own code
        self.history: list[dict[str, Any]] = []         # blocks this node ran, for provenance and summary
        self.first_seq_of_block = None
        self.go = not self.cls.is_source()
        self.released = False
        self.stopping = False
        self.pending_swap: dict[str, Any] | None = None
        self.next_hb = 0.0
        self.next_control = 0.0
        self.seq = spec.get("start_seq", 0)
        self.packer = header_packer()

    def new_block(self, block_type: str, params: dict[str, Any], generation: int) -> Block:
        """A block of `block_type`, told which instance of this node's blocks it is (Block.instance)."""
        block = self.registry.get(block_type).cls(**params)
        block.instance = (self.incarnation, generation)
        return block

    def use_block(self, block: Block, block_type: str) -> None:
        """Run `block` from now on; the per-frame stamps of this node and block are prepared here once."""
        self.block, self.cls, self.block_type = block, type(block), block_type
        self.out_names = {p.name for p in self.cls.outputs}
        self.single_out = self.cls.outputs[0].name if len(self.cls.outputs) == 1 else None
        self.arg_names = [p.name for p in self.cls.inputs]             # process() arguments, in order
        # every input connected: process() takes the frame set as it is, in port order
        self.direct = self.arg_names == self.in_ports and not self.cls.merge_inputs
        version = f"{self.cls.version}#{self.generation}"
        self.hop = f"{self.name}:{block_type}@{version}"              # this node's entry in a frame's trail
        self.stamp = {"node": self.name, "block": block_type, "block_version": version}
        self.streams = {p.name: f"{self.name}.{p.name}" for p in self.cls.outputs}

    def connect(self, edge: str) -> zmq.Socket:
        return transport.connect_output(self.ctx, self.endpoints[edge], self.spec["queue_frames"], self.curve,
                                        int(self.spec["drain_timeout_s"] * 1000))

    def resume(self, edge: str) -> None:
        """Connect afresh to the restarted consumer of `edge` (a connection to a consumer that died may never
        recover) and tell it first where the stream resumes: the frames the old connection still held are lost
        with it (the counters show them as lost on that edge), and the new consumer must not wait for them to
        pair its other inputs. Done at once, even while this node is blocked elsewhere, because that consumer
        may be what it is blocked on."""
        port, i = self.edge_of[edge]
        self.outputs[port][i][1].close(linger=0)
        sock = self.connect(edge)
        self.outputs[port][i] = (edge, sock)
        parts = [self.runtime_message(port, seq=max(self.sent_seq.get(edge, -1) + 1, self.seq), resume=True)]
        if self.eos_sent:   # this node had finished: the new consumer needs the end of stream too
            parts.append(self.eos_message(port, edge))
        try:
            for msg in parts:             # a fresh connection has room: ZeroMQ queues them at once
                transport.send_message(sock, msg)
        except zmq.Again:                 # it had not: the next serve_control connects afresh and tries again
            return
        self.reconnect.discard(edge)

    # -- control plane -------------------------------------------------------------------------------------
    def tell(self, kind: str, **fields: Any) -> None:
        self.control.send(msgpack.packb({"type": kind, "node": self.name, "pid": os.getpid(), **fields},
                                        use_bin_type=True))

    def counters(self) -> dict[str, Any]:
        return {"in": dict(self.c_in), "out": dict(self.c_out), "sent": dict(self.c_sent),
                "rejected": dict(self.c_rejected), "unpaired": dict(self.c_unpaired),
                "undeliverable": dict(self.c_undeliverable),
                "processed": self.processed, "consumed": self.consumed, "cycles": self.cycles, "busy_s": self.busy_s,
                "cpu_s": time.process_time(),           # the whole node process, ZeroMQ I/O thread included
                "block": self.block_type, "generation": self.generation}

    def idle(self) -> None:
        """Serve control messages and heartbeats at most every CONTROL_S; called between frames and every
        transport.TICK_S while blocked in ZeroMQ."""
        now = time.monotonic()
        if now >= self.next_control:
            self.next_control = now + CONTROL_S
            self.serve_control()

    def serve_control(self) -> None:
        """Send a heartbeat if one is due and handle every queued control message."""
        now = time.monotonic()
        if now >= self.next_hb:
            self.tell("hb", counters=self.counters())
            self.next_hb = now + HEARTBEAT_S
        while self.control.get(zmq.EVENTS) & zmq.POLLIN:
            msg = msgpack.unpackb(self.control.recv(), raw=False, strict_map_key=True)
            kind = msg.get("type")
            if kind == "go":
                self.go = True
            elif kind == "stop":
                self.stopping = True
            elif kind == "exit":
                self.released = True
            elif kind == "swap":
                self.pending_swap = msg
            elif kind == "eos":                 # an upstream node died for good: its input ends here
                for port in msg.get("ports", []):
                    self.eos.setdefault(port, None)
            elif kind == "cut":                 # a downstream node died for good: stop feeding it
                self.cut.update(msg.get("edges", []))
            elif kind == "reconnect":           # a downstream node was restarted: connect afresh
                self.reconnect.update(e for e in msg.get("edges", []) if e in self.edge_of)
            elif kind == "recover":             # an upstream node was restarted: partners may be lost
                self.recovering = True
        for edge in [*self.reconnect]:
            self.resume(edge)

    def apply_swap(self) -> None:
        msg, self.pending_swap = self.pending_swap, None
        try:
            new = self.new_block(msg["block"], msg.get("params", {}), self.generation + 1)
            new.start()
        except Exception as exc:   # the old block keeps running; the supervisor tells the user why
            self.tell("swap_failed", id=msg.get("id"), error=f"{type(exc).__name__}: {exc}")
            return
        self.close_block(next_seq=self.seq)
        self.generation += 1
        self.use_block(new, msg["block"])
        self.first_seq_of_block = None
        self.tell("swapped", id=msg.get("id"), block=self.block_type, version=self.cls.version,
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
            self.tell("reject", port=port, reason=reason, count=self.c_rejected[port])

    def receive(self, port: str) -> None:
        """Take what is queued on `port`, up to a burst of 64 messages, without waiting. Each is validated and
        buffered for pairing, or rejected and counted."""
        sock = self.inputs[port]
        for _ in range(64):
            try:
                parts = transport.recv_message(sock, zmq.NOBLOCK)
            except zmq.Again:
                return
            frame = self.admit(port, parts)
            if frame is not None:
                self.buffers[port].append(frame)
            elif port in self.eos:
                return

    def admit(self, port: str, parts: list[Any]) -> Frame | None:
        """Decode and check one message from `port`: the data frame to hand on, or None for a message that was
        rejected (counted and reported), the end of stream (noted in self.eos) or a resume marker (noted)."""
        try:
            frame = decode(parts)
        except FrameError as exc:
            self.reject(port, str(exc))
            return None
        h = frame.header
        seq = h["seq"]
        if h["eos"]:                            # decode guarantees the key
            self.eos[port] = h.get("count")
            return None
        last = self.last_seq.get(port)
        if "resume" in h:                       # a producer's fresh connection: nothing before seq comes
            if h["resume"] is not True or h["arrays"]:
                self.reject(port, "a resume marker must say resume = true and carry no arrays")
            elif last is None or seq - 1 > last:
                self.last_seq[port] = seq - 1
            return None
        if last is not None and seq <= last:
            self.reject(port, f"seq {seq} after {last}: duplicate or out of order")
            return None
        if seq <= self.handled:
            self.reject(port, f"seq {seq} came after the node handled seq {self.handled} without it "
                              "(its partner was given up)")
            return None
        self.last_seq[port] = seq
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
        parts = encode_with_header({**h, "stream": self.streams[port], "seq": seq, "cycle": cycle,
                                    "t_created_s": t_created, "t_sent_s": time.time(), "trail": trail, **self.stamp},
                                   frame, self.packer)
        self.c_out[port] += 1
        edges = self.outputs.get(port, ())
        if len(edges) == 1 and not (self.cut or self.reconnect):   # the usual case: one consumer, room in its
            edge, sock = edges[0]                                  # queue, and ZeroMQ takes the message at once
            try:
                transport.send_message(sock, parts)
                self.c_sent[edge] += 1
                self.sent_seq[edge] = seq
                return
            except zmq.Again:
                pass
        for i, (edge, _) in enumerate(edges):
            if self.deliver(port, i, parts):
                self.c_sent[edge] += 1
                self.sent_seq[edge] = seq
            else:
                self.c_undeliverable[edge] += 1

    def deliver(self, port: str, i: int, parts: list[Any]) -> bool:
        """Send on edge i of `port`, blocking under back-pressure; on the fresh connection if its consumer was
        restarted meanwhile. False only if the edge was cut (its consumer died for good)."""
        edges = self.outputs[port]
        while True:
            edge, sock = edges[i]
            if edge in self.cut:
                return False
            if edge in self.reconnect:          # not resumed yet (no room for the marker): serve_control retries
                time.sleep(transport.TICK_S)
                self.idle()
                continue
            if transport.send_blocking(sock, parts, self.idle, lambda: edge in self.cut or edges[i][1] is not sock):
                return True

    def runtime_message(self, port: str, **header: Any) -> list[Any]:
        """A header-only message of the runtime's own (end of stream, resume marker) on output `port`."""
        return encode(Frame(header), stream=f"{self.name}.{port}", node=self.name, block=self.block_type)

    def eos_message(self, port: str, edge: str) -> list[Any]:
        """End of stream on `edge`, with the count of frames sent on it for the consumer to check."""
        return self.runtime_message(port, seq=self.seq, eos=True, count=self.c_sent[edge])

    def send_eos(self) -> None:
        for port, edges in self.outputs.items():
            for i, (edge, _) in enumerate(edges):
                self.deliver(port, i, self.eos_message(port, edge))
        self.eos_sent = True

    def pump(self) -> None:
        """Process every frame set that is complete (all inputs at the same seq) or can never complete."""
        ports = self.in_ports
        while True:
            if self.pending_swap:
                self.apply_swap()
            heads = {p: b[0] for p, b in self.buffers.items() if b}
            if not heads:
                return
            if self.cls.merge_inputs:
                port = next(iter(heads))
                self.run_block("process", [self.buffers[port].popleft()], port)
                continue
            seq = min(f.seq for f in heads.values())
            group = [p for p in ports if p in heads and heads[p].seq == seq]
            if len(group) == len(ports):
                frames = [self.buffers[p].popleft() for p in ports]
                self.stalled_since = None
                self.handled = seq
                self.run_block("process", frames)
                continue
            if not any(self.lacks(p, seq) for p in ports) and not self.given_up():
                return                          # a partner may still come
            self.handled = seq                  # a partner that comes after this is late (receive refuses it)
            for p in group:
                self.c_unpaired[p] += 1
                self.run_block("unpaired", [self.buffers[p].popleft()], p)

    def lacks(self, port: str, seq: int) -> bool:
        """Input `port` can never supply a frame with `seq`: it holds a later one, it received one past `seq`
        (or its producer said it resumed past it), or its stream has ended."""
        buf = self.buffers[port]
        if buf:
            return buf[0].seq > seq
        return port in self.eos or self.last_seq.get(port, -1) >= seq

    def given_up(self) -> bool:
        """In recovery only: a full buffer has waited RECOVERY_STALL_S for an empty partner input, which in a
        graph that lost frames with a crashed node means the partner is gone (and the graph is stalled)."""
        if not (self.recovering and any(len(b) >= self.limit for b in self.buffers.values())):
            self.stalled_since = None
            return False
        now = time.monotonic()
        if self.stalled_since is None:
            self.stalled_since = now
        return now - self.stalled_since >= RECOVERY_STALL_S

    def run_block(self, what: str, frames: list[Frame], port: str | None = None) -> None:
        context = frames[0]
        self.seq = seq = context.header["seq"]
        if self.first_seq_of_block is None:
            self.first_seq_of_block = seq
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
        max_cycles = self.spec.get("max_cycles", 0)
        while not self.go:
            self.control.poll(100)
            self.serve_control()
        while not self.stopping and (not max_cycles or self.cycles < max_cycles):
            if self.pending_swap:
                self.apply_swap()
            self.block.cycle_budget = max_cycles - self.cycles if max_cycles else None
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

    def run_filter(self) -> None:
        poller = zmq.Poller()
        poller.register(self.control, zmq.POLLIN)
        if len(self.in_ports) == 1 and not self.cls.merge_inputs:
            self.run_single(self.in_ports[0])
        while True:
            self.pump()
            # several inputs, or none wanted (end of stream, full buffer): wait for any, or for control
            wanted = [p for p, b in self.buffers.items() if p not in self.eos and len(b) < self.limit]
            if all(p in self.eos for p in self.in_ports) and not any(self.buffers.values()):
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
        while port not in self.eos:
            if self.pending_swap:             # a swap between two frames
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
        self.tell("ready", block=self.block_type, version=self.cls.version)
        if self.cls.is_source():
            self.run_source()
        else:
            self.run_filter()
        self.emit(self.block.finish(), None if not self.in_ports else Frame({"seq": self.seq}))
        self.send_eos()
        self.close_block(next_seq=self.seq)
        lost = {p: n - self.c_in[p] for p, n in self.eos.items() if n is not None and n != self.c_in[p]}
        self.tell("done", counters=self.counters(), history=self.history, lost=lost,
                  upstream_gone=sorted(p for p, n in self.eos.items() if n is None))
        # Stay alive until the supervisor releases every node: ZeroMQ drops the frames still buffered in a
        # connection when the sending process exits while its consumer's queue is full (linger does not help).
        deadline = time.monotonic() + self.spec["drain_timeout_s"]
        while not self.released and time.monotonic() < deadline:
            self.control.poll(HEARTBEAT_S * 1000)
            self.serve_control()
        return 0


def main(argv: list[str]) -> int:
    _set_parent_death_signal()
    # Ctrl-C and a group-wide SIGTERM go to the supervisor too, which stops the nodes in order; a node dies
    # with its supervisor through the parent-death signal, and the supervisor kills with SIGKILL.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    with open(argv[0], "rb") as fh:
        spec = msgpack.unpackb(fh.read(), raw=False, strict_map_key=True)
    runner = None
    try:
        runner = NodeRunner(spec)
        code = runner.run()
    except BaseException as exc:  # report, with the traceback, then fail: the supervisor decides what next
        tb = traceback.format_exc()
        print(tb, file=sys.stderr, flush=True)
        try:
            ctx = runner.ctx if runner else zmq.Context()
            if runner:
                for sock in runner.inputs.values():
                    sock.close(linger=0)
                ctl = runner.control
            else:
                ctl = ctx.socket(zmq.DEALER)
                ctl.identity = spec["name"].encode()
                ctl.connect(spec["control"])
            ctl.send(msgpack.packb({"type": "error", "node": spec["name"], "pid": os.getpid(),
                                    "error": f"{type(exc).__name__}: {exc}", "traceback": tb,
                                    "counters": runner.counters() if runner else {}}, use_bin_type=True))
            if runner:
                # What it already sent is valid and must leave, but ZeroMQ drops what is still queued towards a
                # full consumer once the socket closes (linger does not help): the process stays up for
                # CRASH_FLUSH_S with its outputs open (the supervisor restarts it only after it exits), then
                # drops the rest, which the supervisor counts as lost.
                if runner.outputs:
                    time.sleep(CRASH_FLUSH_S)
                for edges in runner.outputs.values():
                    for _, sock in edges:
                        sock.close(linger=0)
                if runner.curve:
                    runner.curve.close()
            ctl.close(linger=2000)
            ctx.term()                     # flushes the report to the supervisor
        except Exception:
            pass
        os._exit(1)
    if runner is not None:
        for edges in runner.outputs.values():
            for edge, sock in edges:   # linger: queued frames still leave, except towards a dead consumer
                sock.close(linger=0 if edge in runner.cut else None)
        for sock in runner.inputs.values():
            sock.close(linger=0)
        runner.control.close(linger=2000)
        if runner.curve:
            runner.curve.close()
        runner.ctx.term()
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
