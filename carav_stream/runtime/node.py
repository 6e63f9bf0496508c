"""One node of a graph, in its own OS process: `python -m carav_stream.runtime.node SPEC_FILE` (the supervisor starts
it through carav_stream/node_start.py, which makes it die with the supervisor before any import).

The node builds its block, opens its sockets inside its own process, says "ready" to the supervisor, and then
receives, validates, pairs by seq, processes and sends frames until every input delivered end of stream (or, for
a source, until it generated its cycles or was told to stop). A block exception ends the process with the block's
traceback reported to the supervisor; a bad message is rejected, counted and reported, and the node keeps running.

NodeRunner puts together three parts, one job each:

    node_link.ControlLink     the control socket: what the supervisor says (go, stop, swap, eos, ...), reports,
                              heartbeats, leases; served between frames and from inside every blocking wait
    node_ports.NodePorts      the data ports: inputs (admission, pairing.Pairing) and outputs (outputs.Outputs),
                              with the ends of the run's data plane (runtime/planes/)
    node_driver.BlockDriver   the block: its loops, what it returns stamped and sent on, swaps between frames

Restarts: when a node's consumer is restarted, the node connects afresh at once and first sends a resume marker
(outputs.py); a pairing node releases a frame without its partner as soon as another input shows the partner can
never come (pairing.py).
"""
from __future__ import annotations

import os
import signal
import sys
import time
import traceback
from typing import Any

import zmq

from carav_stream import node_start
from carav_stream.runtime.block import BlockError
from carav_stream.runtime.node_driver import BlockDriver, new_block
from carav_stream.runtime.node_link import ControlLink, connection_id
from carav_stream.runtime.node_ports import NodePorts
from carav_stream.runtime.protocol import NodeSpec, Report, pack
from carav_stream.runtime.registry import Registry

CRASH_FLUSH_S = 1.0      # after a crash: how long frames already sent get to leave before the process exits


class NodeRunner:
    def __init__(self, spec: NodeSpec) -> None:
        self.spec = spec
        self.name = spec.name
        self.ctx = zmq.Context()
        registry = Registry(list(spec.block_paths))
        block = new_block(registry, spec.type, spec.params, (spec.incarnation, spec.generation))
        cls = type(block)
        self.link = ControlLink(self.ctx, spec, source=cls.is_source(), counters=self.counters,
                                on_control=self.apply_control)
        self.ports = NodePorts(self.ctx, spec, [p.name for p in cls.inputs if p.name in spec.inputs], self.link)
        self.driver = BlockDriver(spec, registry, block, self.link, self.ports)

    def apply_control(self) -> None:
        """What the served control messages say, done on the ports at once (node_link.py: re-entrancy)."""
        self.ports.apply_control(self.driver.resume_messages)
        self.ports.watch_handshakes()

    def counters(self) -> dict[str, Any]:
        d, p = self.driver, self.ports
        out = p.outputs
        return {"in": dict(p.c_in), "out": dict(p.c_out), "sent": dict(out.c_sent),
                "rejected": dict(p.c_rejected), "refused": dict(p.c_refused), "unpaired": dict(d.c_unpaired),
                "undeliverable": dict(out.c_undeliverable), "skipped": dict(out.c_skipped),
                "processed": d.processed, "consumed": d.consumed, "cycles": d.cycles, "busy_s": d.busy_s,
                "cpu_s": time.process_time(),           # the whole node process, ZeroMQ I/O thread included
                # the same from the first frame on: start-up left out, so working - busy is what the node spends
                # outside its block (decoding, pairing, sending, the data plane, control)
                "cpu_working_s": 0.0 if d.cpu_at_first_s is None else time.process_time() - d.cpu_at_first_s,
                "first_frame_at": d.first_frame_at,     # time.monotonic() at its first frame (None before)
                "block": d.block_type, "generation": d.generation, "state": self.state(),
                # what the node can hold: per input, its largest message and the most frames its pairing buffer
                # held at once (up to pairing.limit), beside ZeroMQ's queue of queue_frames
                "frame_bytes": dict(p.frame_bytes), "most_buffered": dict(p.pairing.most_buffered),
                "buffer_limit": p.pairing.limit, **p.plane_counters(),
                **({"taps": p.taps.counters()} if p.taps.totals else {})}   # only once a port was tapped

    def state(self) -> str:
        """What the node is doing, in one line: for the supervisor's report on a run that does not drain."""
        d, p, ctl = self.driver, self.ports, self.link.ctl
        waiting = p.waiting()
        if p.outputs.blocked_on:
            what = f"sending on {p.outputs.blocked_on}"
        elif waiting:
            what = waiting
        elif p.outputs.eos_sent:
            what = "finished, waiting to be released"
        elif d.cls.is_source():
            what = "stopping" if ctl.stopping else f"generating (seq lease up to {ctl.seq_lease})"
        else:
            what = "waiting for input"
        inputs = f"; inputs {p.pairing.describe()}" if d.in_ports else ""
        return f"{what}; seq {d.seq}{inputs}"

    def run(self) -> int:
        d, link = self.driver, self.link
        d.block.start()
        link.tell(Report.READY, block=d.block_type, version=d.cls.version)
        if d.cls.is_source():
            d.run_source()
        else:
            d.run_filter()
        d.finish()
        self.ports.watch_handshakes()       # what its tcp inputs refused to the end, in its final counters
        eos, c_in = self.ports.pairing.eos, self.ports.c_in
        lost = {p: n - c_in[p] for p, n in eos.items() if n is not None and n != c_in[p]}
        link.tell(Report.DONE, counters=self.counters(), history=d.history, lost=lost,
                  upstream_gone=sorted(p for p, n in eos.items() if n is None))
        # Stay alive until the supervisor releases every node: ZeroMQ drops the frames still buffered in a
        # connection when the sending process exits while its consumer's queue is full (linger does not help).
        link.until_released(self.spec.drain_timeout_s)
        return 0

    def close(self, crashed: bool = False) -> None:
        self.ports.close(crashed)
        self.link.close()
        self.ctx.term()                     # flushes the last reports to the supervisor


def _report_crash(spec: NodeSpec, runner: NodeRunner | None, exc: BaseException) -> None:
    """Tell the supervisor why this node failed, with the traceback (none for a BlockError: the block's own
    one-line statement that its input cannot go on, e.g. a truncated file); let what it already sent leave."""
    tb = None if isinstance(exc, BlockError) else traceback.format_exc()
    print(tb or f"{spec.name}: {exc}", file=sys.stderr, flush=True)
    msg = pack(Report.ERROR, node=spec.name, pid=os.getpid(), error=f"{type(exc).__name__}: {exc}", traceback=tb,
               counters=runner.counters() if runner else {}, retry=getattr(exc, "retry", True))
    if runner is None:
        ctx = zmq.Context()
        ctl = ctx.socket(zmq.DEALER)
        ctl.identity = connection_id()
        ctl.connect(spec.control)
        ctl.send(msg)
        ctl.close(linger=2000)
        ctx.term()
        return
    for sock in runner.ports.inputs.values():
        sock.close(linger=0)
    runner.link.sock.send(msg)
    # What it already sent is valid and must leave, but ZeroMQ drops what is still queued towards a full
    # consumer once the socket closes (linger does not help): the process stays up for CRASH_FLUSH_S with its
    # outputs open (the supervisor restarts it only after it exits), then drops the rest, which the supervisor
    # counts as lost.
    if runner.ports.outputs.sockets:
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
