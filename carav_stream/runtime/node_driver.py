"""A node's block driver: the block it runs, its swaps, and the loops that feed it.

A filter's frames are paired by seq (pairing.Pairing, through the node's ports) and handed to the block's
process(); a frame whose partner can never come goes to unpaired(). A source generates a frame per seq within its
lease (node_link.py), when its block says the frame is due. What a block returns is stamped (stream, seq, cycle,
trail, provenance) and sent on by the ports (node_ports.py), on the run's data plane.

Swaps: a swap the supervisor asked (Control.SWAP) is taken between two frames only: the new block is built and
started, and the old one keeps running if that fails (the supervisor is told why). `history` records every
block this node ran (version, generation, the seqs it handled, its summary), for provenance and the summary.
"""
from __future__ import annotations

import collections
import time
from typing import Any

import zmq

from carav_stream.runtime import transport
from carav_stream.runtime.block import Block
from carav_stream.runtime.frames import Frame
from carav_stream.runtime.node_link import ControlLink
from carav_stream.runtime.node_ports import NodePorts
from carav_stream.runtime.outputs import runtime_message
from carav_stream.runtime.protocol import NodeSpec, Report
from carav_stream.runtime.registry import Registry


def new_block(registry: Registry, block_type: str, params: dict[str, Any], instance: tuple[int, int]) -> Block:
    """A block of `block_type`, told which instance (incarnation, generation) of its node's blocks it is."""
    block = registry.get(block_type).cls(**params)
    block.instance = instance
    return block


class BlockDriver:
    """Runs `block` (built by new_block for `spec`) on a node's `link` and `ports`."""

    def __init__(self, spec: NodeSpec, registry: Registry, block: Block, link: ControlLink, ports: NodePorts) -> None:
        self.spec, self.registry, self.link, self.ports = spec, registry, link, ports
        self.name = spec.name
        self.generation = spec.generation
        self.in_ports = list(ports.inputs)
        self.use_block(block, spec.type)
        self.c_unpaired = collections.Counter()
        self.processed = 0
        self.consumed = 0                                # input frames handed to the block
        self.cycles = 0                                  # cycles those frames carried (header `cycles`), this process's
        self.cycles_before = spec.start_cycles           # sources: cycles earlier incarnations generated (the budget's)
        self.next_cycle: int | None = None               # the cycle after the last one handled (frames' headers)
        self.busy_s = 0.0                                # CPU time spent inside the block's own code
        self.cpu_at_first_s: float | None = None          # the process's CPU time when the first frame came
        self.first_frame_at: float | None = None          # and time.monotonic() then (the host's one clock)
        self.history: list[dict[str, Any]] = []         # blocks this node ran, for provenance and summary
        self.first_seq_of_block = None
        self.seq = spec.start_seq

    def use_block(self, block: Block, block_type: str) -> None:
        """Run `block` from now on; the per-frame stamps of this node and block are prepared here once."""
        self.block, self.cls, self.block_type = block, type(block), block_type
        if self.ports.writers:
            block.allocate = self.ports.allocate
        self.out_names = {p.name for p in self.cls.outputs}
        self.single_out = self.cls.outputs[0].name if len(self.cls.outputs) == 1 else None
        self.arg_names = [p.name for p in self.cls.inputs]             # process() arguments, in order
        # every input connected: process() takes the frame set as it is, in port order
        self.direct = self.arg_names == self.in_ports and not self.cls.merge_inputs
        version = f"{self.cls.version}#{self.generation}"
        self.hop = f"{self.name}:{block_type}@{version}"              # this node's entry in a frame's trail
        self.stamp = {"node": self.name, "block": block_type, "block_version": version}
        self.streams = {p.name: f"{self.name}.{p.name}" for p in self.cls.outputs}

    def apply_swap(self) -> None:
        msg = self.link.ctl.take_swap()
        try:
            new = new_block(self.registry, msg["block"], msg.get("params", {}),
                            (self.spec.incarnation, self.generation + 1))
            new.start()
        except Exception as exc:   # the old block keeps running; the supervisor tells the user why
            self.link.tell(Report.SWAP_FAILED, id=msg.get("id"), error=f"{type(exc).__name__}: {exc}")
            return
        self.close_block(next_seq=self.seq)
        self.generation += 1
        self.use_block(new, msg["block"])
        self.first_seq_of_block = None
        self.link.tell(Report.SWAPPED, id=msg.get("id"), block=self.block_type, version=self.cls.version,
                       generation=self.generation, next_seq=self.seq, next_cycle=self.next_cycle)

    def passed(self, frame: Frame | None) -> None:
        """Note the cycle after `frame`'s last (its header's cycle + cycles), where a swap now would start."""
        cycle = frame.header.get("cycle") if frame is not None else None
        if isinstance(cycle, int) and not isinstance(cycle, bool):
            self.next_cycle = cycle + int(frame.header.get("cycles", 1))

    def close_block(self, next_seq: int) -> None:
        self.history.append({"block": self.block_type, "version": self.cls.version, "generation": self.generation,
                             "first_seq": self.first_seq_of_block, "next_seq": next_seq,
                             "summary": self.block.summary()})

    # -- what the block returns ----------------------------------------------------------------------------
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
        """Stamp `frame` (from the block, for the frame set `context`, or generated when None) and send it."""
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
        self.ports.deliver(port, header, frame, seq)

    def runtime_message(self, port: str, **header: Any) -> list[Any]:
        return runtime_message(self.name, self.block_type, port, **header)

    def eos_message(self, port: str, edge: str) -> list[Any]:
        """End of stream on `edge`, with the count of frames sent on it for the consumer to check."""
        return self.runtime_message(port, seq=self.seq, eos=True, count=self.ports.outputs.c_sent[edge])

    def resume_messages(self, port: str, edge: str) -> list[list[Any]]:
        """The first messages on a fresh connection to a restarted consumer: where the stream resumes (with what
        the data plane adds), and the end of stream if this node had finished."""
        out = self.ports.outputs
        msgs = [self.runtime_message(port, seq=out.resume_seq(edge, self.seq), resume=True,
                                     **self.ports.resume_fields(port))]
        if out.eos_sent:
            msgs.append(self.eos_message(port, edge))
        return msgs

    def first_frame(self) -> None:
        """Note when this process's block takes its first frame: CPU time, and the monotonic clock (CLOCK_MONOTONIC,
        one clock for every process of the host: the supervisor times a restart to its successor's first frame)."""
        self.cpu_at_first_s = time.process_time()
        self.first_frame_at = time.monotonic()

    # -- filters -------------------------------------------------------------------------------------------
    def pump(self) -> None:
        """Hand the block every frame set that is complete (all inputs at the same seq) or can never complete."""
        while True:
            if self.link.ctl.pending_swap:
                self.apply_swap()
            nxt = self.ports.pairing.next_set(self.cls.merge_inputs)
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
            self.first_frame()
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
        self.passed(context)
        self.emit(result, context)
        self.seq = seq + 1
        self.link.idle()

    def run_filter(self) -> None:
        poller = zmq.Poller()
        poller.register(self.link.sock, zmq.POLLIN)
        if len(self.in_ports) == 1 and not self.cls.merge_inputs:
            self.run_single(self.in_ports[0])
        inputs, pairing = self.ports.inputs, self.ports.pairing
        while True:
            self.pump()
            # several inputs, or none wanted (end of stream, full buffer): wait for any, or for control
            wanted = pairing.wanted()
            if pairing.finished():
                return
            for p, sock in inputs.items():
                if p in wanted and sock not in poller:
                    poller.register(sock, zmq.POLLIN)
                elif p not in wanted and sock in poller:
                    poller.unregister(sock)
            events = dict(poller.poll(transport.TICK_S * 1000))
            if self.link.sock in events:
                self.link.serve()
            for p in wanted:
                if inputs[p] in events:
                    self.ports.receive(p)
            self.link.idle()

    def run_single(self, port: str) -> None:
        """The loop of a node with one input that does not merge inputs (most nodes): every frame is complete
        as it arrives, so each message is received, checked, processed and sent on in one pass, waiting inside
        ZeroMQ's receive. Returns at the end of the stream, or when a swapped-in block merges inputs (the
        general loop of run_filter takes over)."""
        sock = self.ports.inputs[port]
        eos = self.ports.pairing.eos
        while port not in eos:
            if self.link.ctl.pending_swap:         # a swap between two frames
                self.apply_swap()
                if self.cls.merge_inputs:
                    return
            try:
                parts = transport.recv_message(sock, 0)
            except zmq.Again:                 # nothing for TICK_S: serve control and wait again
                self.link.idle()
                continue
            frame = self.ports.admit(port, parts)
            if frame is None:
                self.link.idle()
            else:
                self.run_block("process", [frame])   # it serves control after the block, as idle() does

    # -- sources -------------------------------------------------------------------------------------------
    def run_source(self) -> None:
        max_cycles, ctl = self.spec.max_cycles, self.link.ctl
        while not ctl.go:
            self.link.wait(0.1)
        while not ctl.stopping and (not max_cycles or self.cycles_before + self.cycles < max_cycles):
            if ctl.pending_swap:
                self.apply_swap()
            if not self.link.within_lease(self.seq) or not self.release_due():
                continue
            self.block.cycle_budget = max_cycles - self.cycles_before - self.cycles if max_cycles else None
            if self.cpu_at_first_s is None:
                self.first_frame()
            t0 = time.thread_time()
            result = self.block.generate(self.seq)
            self.busy_s += time.thread_time() - t0
            if result is None:
                break
            self.processed += 1
            first = result if isinstance(result, Frame) else next((f for f in result.values() if f is not None), None)
            self.cycles += first.header.get("cycles", 1) if first is not None else 1
            self.passed(first)
            self.emit(result, None)
            self.seq += 1
            self.link.idle()

    def release_due(self) -> bool:
        """Whether the block's frame `self.seq` may be generated now; if not, wait on control for up to a tick."""
        wait = self.block.ready_in(self.seq)
        if wait <= 0:
            return True
        self.link.wait(min(wait, transport.TICK_S))
        return False

    def finish(self) -> None:
        """After the last frame: the block's final frames, the end of stream on every edge, the block's record."""
        self.emit(self.block.finish(), None if not self.in_ports else Frame({"seq": self.seq}))
        self.ports.outputs.send_eos(self.eos_message)
        self.close_block(next_seq=self.seq)
