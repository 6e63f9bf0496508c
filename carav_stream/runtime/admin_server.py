"""The supervisor's side of the admin requests (protocol.Admin) that `carav status | stop | swap` and the live
view send (admin.request), on a REP socket: one answer for every request, a bad one included.

    status   the run, its nodes (pid, alive, restarts, counters, rates, block and parameters), its edges' queues,
             the swaps so far and the swaps refused
    stop     the supervisor stops the run in order (its request_stop), answered at once
    swap     checked like the graph file (validate.swap_problems), sent to the node once the node is ready, and
             answered when the node confirms or refuses it, after SWAP_TIMEOUT_S, as soon as the node has ended
             (its stream over, or failed), or when the run ends; one swap at a time
    ports    the output ports of this host's nodes (kind, dtypes, private, edges): what may be tapped
    tap      a port tap started, renewed or stopped (port_tap.py: checked here, answered at once with where its
             copies come from; the node starts it when it gets the message, from its first control connection on)
"""
from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zmq

from carav_stream.runtime.graph import Graph
from carav_stream.runtime.node_state import NodeState
from carav_stream.runtime.port_tap import output_ports, tap_request
from carav_stream.runtime.protocol import Admin, Control, Report, pack, unpack
from carav_stream.runtime.report import RunReport
from carav_stream.runtime.validate import swap_problems

SWAP_TIMEOUT_S = 30


class AdminServer:
    """Answers admin requests for the nodes `nodes` (the supervisor's own dict) of a run of `graph`. `send(node,
    kind, **fields)` sends a control message to a node, `request_stop(why)` stops the run, `log(text)` tells the
    user. `swaps` lists every swap a node confirmed (with the parameters it applied), `refused_swaps` every swap
    refused (by the checks, the node or the deadline) with its reason; both say when, in seconds from go (`at_s`)."""

    def __init__(self, graph: Graph, nodes: dict[str, NodeState], report: RunReport, *,
                 send: Callable[..., None], request_stop: Callable[[str], None], log: Callable[[str], None],
                 run_dir: Path | None = None) -> None:
        self.graph = graph
        self.run_dir = run_dir                           # where the nodes bind their port taps
        self.nodes = nodes
        self.report = report
        self.send = send
        self.request_stop = request_stop
        self.log = log
        self.sock: zmq.Socket | None = None
        self.pending: dict[str, Any] | None = None      # the swap under way: its request, deadline, sent or not
        self.swaps: list[dict[str, Any]] = []
        self.refused_swaps: list[dict[str, Any]] = []

    def bind(self, ctx: zmq.Context, endpoint: str) -> zmq.Socket:
        self.sock = ctx.socket(zmq.REP)
        self.sock.linger = 0
        self.sock.bind(endpoint)
        return self.sock

    def receive(self) -> None:
        """Take one request from the socket (it has one waiting) and answer it, or leave the answer to a swap."""
        raw = self.sock.recv()
        try:
            req = unpack(raw)
        except ValueError as exc:   # answer, never crash
            self.sock.send(pack("error", ok=False, error=f"bad admin request: {exc}"))
            return
        self.on_admin(req)

    def on_admin(self, req: dict[str, Any]) -> None:
        cmd = req.get("type")
        if cmd == Admin.STATUS:
            self.sock.send(pack("status", ok=True, **self.status()))
        elif cmd == Admin.STOP:
            self.request_stop("carav stop")
            self.sock.send(pack("stop", ok=True))
        elif cmd == Admin.SWAP and self.pending is None:
            node, block = req.get("node"), req.get("block")
            try:
                params = self.graph.params_for(block, req.get("params", {}))
            except LookupError as exc:
                params = {}
                problems = [str(exc)]
            else:
                problems = swap_problems(self.graph, node, block, params)
            if not problems and node not in self.nodes:
                problems = [f"node {node!r} does not run on this host"]
            if not problems and (why := self.ended(node)):
                problems = [why]
            if problems:
                self.refuse(req, "; ".join(problems))
                self.sock.send(pack("swap", ok=False, error="; ".join(problems)))
                return
            self.pending = {**req, "params": params, "asked": req.get("params", {}),
                            "deadline": time.monotonic() + SWAP_TIMEOUT_S, "sent": False}
            self.deliver_swap()
        elif cmd == Admin.PORTS:
            self.sock.send(pack("ports", ok=True, ports=output_ports(self.graph, self.nodes)))
        elif cmd == Admin.TAP:
            reply, control = tap_request(self.graph, self.nodes, self.run_dir, req)
            if control is not None:
                self.send(req["node"], Control.TAP, **control)
            self.sock.send(pack("tap", **reply))
        elif cmd == Admin.SWAP:
            error = f"another swap (of {self.pending['node']}) is under way"
            self.refuse(req, error)
            self.sock.send(pack("swap", ok=False, error=error))
        else:
            self.sock.send(pack(str(cmd), ok=False, error=f"unknown command {cmd!r}"))

    def ended(self, node: str) -> str | None:
        """Why `node` can take no swap any more (its stream ended, or it failed for good), or None."""
        st = self.nodes[node]
        if st.done:
            return f"node {node!r} has ended its stream"
        return f"node {node!r} has failed" if st.failed else None

    def deliver_swap(self) -> None:
        """Send the pending swap to its node once the node is ready: a node still starting (or restarting) has no
        control connection yet, and the router would drop the request unseen. A node that ended before it took
        the swap (its stream over, or failed) refuses it: the request is answered at once, not at the deadline."""
        req = self.pending
        if req is None:
            return
        if why := self.ended(req["node"]):
            self.reply_admin({"ok": False, "error": f"{why} without taking the swap"})
        elif not req["sent"] and self.nodes[req["node"]].ready:
            req["sent"] = True
            self.send(req["node"], Control.SWAP, block=req["block"], params=req["params"], id=1)

    def expire_swap(self) -> None:
        """Refuse the pending swap once its deadline has passed."""
        if self.pending and time.monotonic() > self.pending["deadline"]:
            up = "did not confirm the swap" if self.pending["sent"] else "was not ready for the swap"
            self.reply_admin({"ok": False, "error": f"the node {up} within {SWAP_TIMEOUT_S} s"})

    def run_ended(self) -> None:
        """The run is over: a swap still pending is refused, not left without an answer, and the socket closed
        with a second to deliver that answer (the run's context is then destroyed without waiting)."""
        if self.pending:
            node = self.pending["node"]
            self.reply_admin({"ok": False, "error": f"the run ended before node {node!r} took the swap"})
            self.sock.close(linger=1000)

    def on_swap_report(self, st: NodeState, msg: dict[str, Any]) -> None:
        """A node's answer to the swap (Report.SWAPPED or SWAP_FAILED): a confirmed swap becomes the node's spec
        (restarts run the new block) and is listed; either way the request is answered."""
        kind = msg.get("type")
        if kind == Report.SWAPPED:
            st.spec = st.spec.with_(type=msg["block"], generation=msg["generation"],
                                    params=(self.pending or {}).get("params", st.spec.params))
            self.swaps.append({"node": st.name, "block": msg["block"], "version": msg["version"],
                               "generation": msg["generation"], "first_seq": msg["next_seq"],
                               "first_cycle": msg.get("next_cycle"),
                               "params": st.spec.params, "asked": (self.pending or {}).get("asked", {}),
                               "at_s": self.since_go()})
            self.log(f"carav: swapped {st.name} to {msg['block']} {_from(msg.get('next_cycle'), msg['next_seq'])}")
        self.reply_admin({"ok": kind == Report.SWAPPED, **{k: v for k, v in msg.items() if k != "type"},
                          **({"params": st.spec.params} if kind == Report.SWAPPED else {})})

    def reply_admin(self, reply: dict[str, Any]) -> None:
        if self.pending is not None:
            if not reply.get("ok"):
                self.refuse(self.pending, str(reply.get("error")))
            self.pending = None
            self.sock.send(pack("swap", **reply))

    def refuse(self, req: dict[str, Any], error: str) -> None:
        """Keep a refused swap (node, block, the parameters asked, the reason) for the summary and the status."""
        asked = req.get("asked", req.get("params"))
        self.refused_swaps.append({"node": req.get("node"), "block": req.get("block"),
                                   "asked": asked if isinstance(asked, dict) else {}, "error": error,
                                   "at_s": self.since_go()})
        self.log(f"carav: swap of {req.get('node')} to {req.get('block')} refused: {error}")

    def since_go(self) -> float | None:
        """Seconds since every node was told to go (None before)."""
        return time.monotonic() - self.report.t_go if self.report.t_go else None

    def status(self) -> dict[str, Any]:
        t_go = self.report.t_go
        elapsed = max(time.monotonic() - t_go, 1e-9) if t_go else 0.0
        return {"run": self.report.run_id, "graph": str(self.graph.path), "pid": os.getpid(), "elapsed_s": elapsed,
                "cycles": self.report.cycles_done(),
                "nodes": {n: {"pid": st.proc.pid if st.proc else None,
                              "alive": st.proc is not None and st.exit_code() is None,
                              "restarts": st.restarts, "counters": st.counters,
                              # over every incarnation: each counts only what it did itself (NodeState.total)
                              "processed": st.total("processed"), "cycles_total": st.total("cycles"),
                              "rate_per_s": st.total("processed") / elapsed if elapsed else 0.0,
                              "cycles_per_s": st.total("cycles") / elapsed if elapsed else 0.0,
                              "block": st.spec.type, "params": st.spec.params}
                          for n, st in self.nodes.items()},
                "edges": self.edge_queues(), "swaps": self.swaps, "refused_swaps": self.refused_swaps}

    def edge_queues(self) -> dict[str, dict[str, Any]]:
        """Per edge between local nodes, from the last heartbeats (up to HEARTBEAT_S old): frames in flight (sent
        by the producer, not yet taken by the consumer), the queue capacity (ZeroMQ's send and receive high-water
        marks), how far apart the two counts were read, and skipped frames of a tap edge.

        In flight can exceed the capacity, and then `beyond_capacity` says why: the two counters come from two
        heartbeats, and when the producer's is the newer one the frames it sent since the consumer's count look
        in flight; and the kernel's socket buffers hold frames beyond ZeroMQ's marks (many small header-only
        frames fit there)."""
        capacity = 2 * int(self.graph.run["queue_frames"])
        out = {}
        for e in self.graph.edges:
            src, dst = self.nodes.get(e.src), self.nodes.get(e.dst)
            if src is None or dst is None:
                continue
            sent = src.total("sent").get(str(e), 0)
            taken = dst.total("in").get(e.dst_port, 0) + dst.total("rejected").get(e.dst_port, 0)
            apart = src.last_seen - dst.last_seen
            entry = {"in_flight": max(0, sent - taken), "capacity": capacity, "counters_apart_s": round(apart, 3),
                     "skipped": src.total("skipped").get(str(e), 0)}
            if entry["in_flight"] > capacity:
                entry["beyond_capacity"] = (
                    (f"the producer's count is {apart:.1f} s newer than the consumer's; " if apart > 0 else "")
                    + "the kernel's socket buffers hold frames beyond ZeroMQ's high-water marks")
            out[str(e)] = entry
        return out


def _from(cycle: int | None, seq: int) -> str:
    """Where a swap takes over, in cycles when the frames carry them: "from cycle 1200 (frame seq 75)"."""
    return f"from cycle {cycle} (frame seq {seq})" if cycle is not None else f"from frame seq {seq}"
