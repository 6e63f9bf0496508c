"""The supervisor: start every node of a graph in its own process, watch them, stop them in order.

Each run has a folder of its own (rundir.py), holding the ipc endpoints, the node specs, each node's log and
`run.json` (how `carav status|stop|swap` find the run). It is removed when the run ends, whatever the way it ends.

Stop order: sources are told to stop, end of stream flows down the graph behind the last frames, and each
node exits once it has drained; the sinks end last. A second Ctrl-C (or the drain deadline) kills what is left.
"""
from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import zmq

from carav_stream.runtime import shm, transport
from carav_stream.runtime.graph import LOCAL_HOST, Graph
from carav_stream.runtime.protocol import LEASE_FRAMES, Admin, Control, NodeSpec, OutEdge, Report, pack, unpack
from carav_stream.runtime.rundir import RUN_ID_ENV, remove_stale_runs, run_root
from carav_stream.runtime.validate import swap_problems

# The environment of node processes (settings in the user's environment win):
# - glibc malloc keeps freed buffers for reuse rather than handing them back to the OS after every frame.
#   Large frames would otherwise be mmap'ed and unmapped each time, and every page of every new buffer faulted
#   in again (measured on an 8-node radar graph with 4.5 MB frames: 70-80 page faults and about 200 us of
#   kernel time per cycle fewer). Other C libraries ignore these variables.
# - BLAS libraries run one thread: a graph's parallelism is its processes, and a threaded BLAS call in one
#   node competing with the other nodes for the cores can stall for milliseconds.
NODE_ENV = {"MALLOC_MMAP_THRESHOLD_": str(256 << 20), "MALLOC_TRIM_THRESHOLD_": str(512 << 20),
            "MALLOC_TOP_PAD_": str(64 << 20), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
            "MKL_NUM_THREADS": "1"}
# dicts: port or edge -> n
PER_PORT_COUNTERS = ("in", "out", "sent", "rejected", "unpaired", "undeliverable", "skipped")


@dataclass
class NodeState:
    name: str
    spec: NodeSpec
    proc: subprocess.Popen | None = None
    ready: bool = False
    done: bool = False
    failed: bool = False
    last_seen: float = 0.0
    counters: dict[str, Any] = field(default_factory=dict)
    dead_counters: list[dict[str, Any]] = field(default_factory=list)   # of crashed incarnations
    restarts: int = 0
    unreported: int = 0        # incarnations that died without a final report (SIGKILL, hang)
    history: list[dict[str, Any]] = field(default_factory=list)
    lost: dict[str, int] = field(default_factory=dict)
    rejects: list[str] = field(default_factory=list)
    error: str | None = None
    grace: bool = False        # exited; its last report may still be on the way

    def total(self, key: str) -> Any:
        """A counter summed over every incarnation of the node (crashed ones and the current one): a number,
        or for per-port and per-edge counters a dict of numbers."""
        incarnations = [*self.dead_counters, self.counters]
        if key in PER_PORT_COUNTERS:
            out: dict[str, Any] = {}
            for c in incarnations:
                for k, v in c.get(key, {}).items():
                    out[k] = out.get(k, 0) + v
            return out
        return sum(c.get(key, 0) for c in incarnations)


class Supervisor:
    def __init__(self, graph: Graph, *, host: str | None = None, cycles: int | None = None,
                 progress: bool | None = None, log: Callable[[str], None] | None = None) -> None:
        self.graph = graph
        self.host = host
        self.cycles = graph.run["cycles"] if cycles is None else cycles
        self.progress = sys.stderr.isatty() if progress is None else progress
        self.log = log or (lambda text: print(text, file=sys.stderr, flush=True))
        self.run_id = f"{graph.path.stem[:24]}-{secrets.token_hex(3)}"
        self.run_dir = run_root() / self.run_id
        self.nodes: dict[str, NodeState] = {}
        self.failures: list[str] = []
        self.swaps: list[dict[str, Any]] = []
        self.signals = 0
        self.pending_admin: dict[str, Any] | None = None
        self.stop_requested: str | None = None
        self.stop_deadline = 0.0
        self.pending_go: set[str] = set()
        self.t_go = self.t_end = 0.0
        self.segments: list[int] = []       # file descriptors of the shared-memory segments (transport "shm")

    # -- planning ------------------------------------------------------------------------------------------
    def local_nodes(self) -> list[str]:
        if self.host is None:
            return list(self.graph.nodes)
        return [n for n, node in self.graph.nodes.items() if node.host == self.host]

    def plan(self) -> None:
        g = self.graph
        endpoints: dict[tuple[str, str], tuple[str, str]] = {}   # input -> (bind, connect)
        cross_ports: dict[str, int] = {}
        for e in sorted(g.edges, key=lambda e: (e.dst, e.dst_port)):
            dst_host = g.hosts[g.nodes[e.dst].host]
            if g.nodes[e.src].host == g.nodes[e.dst].host:
                ep = transport.ipc_endpoint(self.run_dir, f"{e.dst}.{e.dst_port}")
                endpoints[(e.dst, e.dst_port)] = (ep, ep)
            else:
                if not dst_host.port_base:
                    raise ValueError(f"{g.path.name}: edge '{e}' crosses hosts; set hosts.{dst_host.name}.port_base")
                port = dst_host.port_base + cross_ports.setdefault(dst_host.name, 0)
                cross_ports[dst_host.name] += 1
                endpoints[(e.dst, e.dst_port)] = (f"tcp://{dst_host.bind}:{port}", f"tcp://{dst_host.address}:{port}")
        control = transport.ipc_endpoint(self.run_dir, "control")
        shm_out, shm_in = self.plan_segments()
        for name in self.local_nodes():
            node = g.nodes[name]
            outputs: dict[str, list[OutEdge]] = {}
            for e in g.edges_from(name):
                tap = any(p.name == e.dst_port and p.tap for p in g.block_class(e.dst).inputs)
                outputs.setdefault(e.src_port, []).append(OutEdge(str(e), endpoints[(e.dst, e.dst_port)][1], tap))
            spec = NodeSpec(
                shm_out={port: seg for (n, port), seg in shm_out.items() if n == name},
                shm_in={port: ref for (n, port), ref in shm_in.items() if n == name},
                name=name, type=node.type, params=node.params, control=control,
                inputs={e.dst_port: endpoints[(e.dst, e.dst_port)][0] for e in g.edges_into(name)},
                outputs={port: tuple(edges) for port, edges in outputs.items()},
                queue_frames=int(g.run["queue_frames"]), drain_timeout_s=float(g.run["drain_timeout_s"]),
                max_cycles=int(self.cycles or 0) if not g.edges_into(name) else 0,
                seq_lease=0 if g.edges_into(name) else LEASE_FRAMES,
                block_paths=tuple(str(p) for p in g.registry.paths[1:]),
                security={k: str(v) for k, v in g.security.items()})
            self.nodes[name] = NodeState(name, spec)

    def plan_segments(self) -> tuple[dict[tuple[str, str], dict[str, Any]], dict[tuple[str, str], list[int]]]:
        """With run.transport = "shm": a shared-memory segment (runtime/shm.py) for every output port of a local
        node whose edges all stay on this host; {(node, port): {fd, edges}} for producers and
        {(node, port): [fd, edge index]} for consumers. A port with an edge to another host stays inline."""
        g = self.graph
        shm_out: dict[tuple[str, str], dict[str, Any]] = {}
        shm_in: dict[tuple[str, str], list[int]] = {}
        if g.run["transport"] != "shm":
            return shm_out, shm_in
        local = set(self.local_nodes())
        ports: dict[tuple[str, str], list] = {}
        for e in g.edges:
            if e.src in local:
                ports.setdefault((e.src, e.src_port), []).append(e)
        n_slots = min(shm.MAX_SLOTS, 6 * int(g.run["queue_frames"]) + 4)   # ZeroMQ queues, pairing, in hand
        for (src, port), edges in ports.items():
            if any(e.dst not in local for e in edges) or len(edges) > shm.MAX_EDGES:
                continue
            fd = shm.create_segment(n_slots, len(edges), f"carav-{src}.{port}")
            self.segments.append(fd)
            shm_out[(src, port)] = {"fd": fd, "edges": [str(e) for e in edges]}
            for i, e in enumerate(edges):
                shm_in[(e.dst, e.dst_port)] = [fd, i]
        return shm_out, shm_in

    # -- process management --------------------------------------------------------------------------------
    def spawn(self, st: NodeState) -> None:
        spec_path = self.run_dir / f"{st.name}.spec"
        spec_path.write_bytes(st.spec.to_wire())
        logf = open(self.run_dir / f"{st.name}.log", "ab")
        fds = [s["fd"] for s in st.spec.shm_out.values()] + [fd for fd, _ in st.spec.shm_in.values()]
        st.proc = subprocess.Popen([sys.executable, "-m", "carav_stream.runtime.node", str(spec_path)],
                                   stdin=subprocess.DEVNULL, stdout=logf, stderr=logf, pass_fds=fds,
                                   env={**NODE_ENV, **os.environ, RUN_ID_ENV: self.run_id})
        logf.close()
        st.ready = st.done = st.failed = False
        st.last_seen = time.monotonic()

    def send(self, name: str, kind: Control, **fields: Any) -> None:
        self.router.send_multipart([name.encode(), pack(kind, **fields)])

    def log_tail(self, name: str, n: int = 25) -> str:
        try:
            lines = (self.run_dir / f"{name}.log").read_text(errors="replace").splitlines()
        except OSError:
            return ""
        return "\n".join(lines[-n:])

    # -- messages ------------------------------------------------------------------------------------------
    def drain_router(self) -> None:
        while True:
            try:
                ident, body = self.router.recv_multipart(flags=zmq.NOBLOCK)
            except zmq.Again:
                return
            try:
                msg = unpack(body)
            except ValueError as exc:
                self.log(f"carav: a message on the control socket from {ident!r} was refused: {exc}")
                continue
            self.on_node_message(ident.decode(errors="replace"), msg)

    def on_node_message(self, name: str, msg: dict[str, Any]) -> None:
        st = self.nodes.get(name)
        if st is None:
            return
        if st.proc is not None and msg.get("pid") not in (None, st.proc.pid):
            return        # a message from a dead incarnation
        st.last_seen = time.monotonic()
        kind = msg.get("type")
        if "counters" in msg:
            st.counters = msg["counters"]
        if kind == Report.READY:
            st.ready = True
        elif kind == Report.DONE:
            st.done = True
            st.history = msg.get("history", [])
            st.lost = msg.get("lost", {})
        elif kind == Report.ERROR:
            st.error = msg.get("traceback") or msg.get("error")
        elif kind == Report.REJECT:
            text = f"node {name!r} input {msg['port']!r}: rejected frame #{msg['count']}: {msg['reason']}"
            st.rejects.append(text)
            self.log(f"carav: {text}")
        elif kind == Report.LEASE and isinstance(msg.get("upto"), int):
            st.spec = st.spec.with_(seq_lease=max(st.spec.seq_lease, msg["upto"]))   # granted: remembered first
            self.send(name, Control.LEASE, upto=st.spec.seq_lease)
        elif kind in (Report.SWAPPED, Report.SWAP_FAILED):
            if kind == Report.SWAPPED:
                st.spec = st.spec.with_(type=msg["block"], generation=msg["generation"],
                                        params=(self.pending_admin or {}).get("params", st.spec.params))
                self.swaps.append({"node": name, "block": msg["block"], "version": msg["version"],
                                   "generation": msg["generation"], "first_seq": msg["next_seq"]})
                self.log(f"carav: swapped {name} to {msg['block']} from seq {msg['next_seq']}")
            self.reply_admin({"ok": kind == Report.SWAPPED, **{k: v for k, v in msg.items() if k != "type"}})

    def on_admin(self, req: dict[str, Any]) -> None:
        cmd = req.get("type")
        if cmd == Admin.STATUS:
            self.admin.send(pack("status", ok=True, **self.status()))
        elif cmd == Admin.STOP:
            self.request_stop("carav stop")
            self.admin.send(pack("stop", ok=True))
        elif cmd == Admin.SWAP and self.pending_admin is None:
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
            if problems:
                self.admin.send(pack("swap", ok=False, error="; ".join(problems)))
                return
            self.pending_admin = {**req, "params": params, "deadline": time.monotonic() + 30, "sent": False}
            self.deliver_swap()
        else:
            self.admin.send(pack(str(cmd), ok=False, error=f"unknown or busy command {cmd!r}"))

    def deliver_swap(self) -> None:
        """Send the pending swap to its node once the node is ready: a node still starting (or restarting) has no
        control connection yet, and the router would drop the request unseen."""
        req = self.pending_admin
        if req is not None and not req["sent"] and self.nodes[req["node"]].ready:
            req["sent"] = True
            self.send(req["node"], Control.SWAP, block=req["block"], params=req["params"], id=1)

    def reply_admin(self, reply: dict[str, Any]) -> None:
        if self.pending_admin is not None:
            self.pending_admin = None
            self.admin.send(pack("swap", **reply))

    def status(self) -> dict[str, Any]:
        elapsed = max(time.monotonic() - self.t_go, 1e-9) if self.t_go else 0.0
        return {"run": self.run_id, "graph": str(self.graph.path), "pid": os.getpid(), "elapsed_s": elapsed,
                "cycles": self.cycles_done(),
                "nodes": {n: {"pid": st.proc.pid if st.proc else None,
                              "alive": bool(st.proc and st.proc.poll() is None),
                              "restarts": st.restarts, "counters": st.counters,
                              "rate_per_s": st.counters.get("processed", 0) / elapsed if elapsed else 0.0,
                              "cycles_per_s": st.counters.get("cycles", 0) / elapsed if elapsed else 0.0,
                              "block": st.spec.type, "params": st.spec.params}
                          for n, st in self.nodes.items()},
                "edges": self.edge_queues(), "swaps": self.swaps}

    def edge_queues(self) -> dict[str, dict[str, Any]]:
        """Per edge between local nodes, from the last heartbeats (up to HEARTBEAT_S old): frames in flight (sent
        by the producer, not yet taken by the consumer), the queue capacity (ZeroMQ's send and receive high-water
        marks; the socket buffers of the kernel can hold a little more), and skipped frames of a tap edge."""
        capacity = 2 * int(self.graph.run["queue_frames"])
        out = {}
        for e in self.graph.edges:
            src, dst = self.nodes.get(e.src), self.nodes.get(e.dst)
            if src is None or dst is None:
                continue
            sent = src.total("sent").get(str(e), 0)
            taken = dst.total("in").get(e.dst_port, 0) + dst.total("rejected").get(e.dst_port, 0)
            out[str(e)] = {"in_flight": max(0, sent - taken), "capacity": capacity,
                           "skipped": src.total("skipped").get(str(e), 0)}
        return out

    def shared_memory(self) -> dict[str, dict[str, int]]:
        """Per output port with a segment ("node.port"), from its producer's last report: segment_bytes (slots
        touched x slot size: the memory the segment holds), slots, stride, frames_in_slots, frames_inline (too
        small, too large, or no slot free: no_free_slot) and held (slots not given back yet)."""
        out = {}
        for n, st in self.nodes.items():
            last = st.counters or (st.dead_counters[-1] if st.dead_counters else {})
            for port, c in last.get("shm", {}).items():
                out[f"{n}.{port}"] = c
        return out

    def cycles_done(self) -> int:
        """Cycles the local sources generated (a frame may carry several, header `cycles`); on a host without
        sources, cycles processed by the nodes fed from other hosts."""
        sources = [n for n in self.nodes if not self.graph.edges_into(n)]
        if sources:
            return max(self.nodes[n].total("cycles") for n in sources)
        remote = {e.dst for e in self.graph.edges if e.dst in self.nodes and e.src not in self.nodes}
        return max((self.nodes[n].total("cycles") for n in remote), default=0)

    # -- failure handling ----------------------------------------------------------------------------------
    def check_processes(self) -> None:
        self.drain_router()   # a dead node's last words (its error and final counters) come first
        now = time.monotonic()
        for st in self.nodes.values():
            if st.proc is None or st.done or st.failed:
                continue
            code = st.proc.poll()
            hung = code is None and st.ready and now - st.last_seen > self.graph.run["heartbeat_timeout_s"]
            if code is None and not hung:
                continue
            if code is not None and st.error is None and now - st.last_seen < 1.0 and not st.grace:
                st.grace = True      # look again next round
                continue
            if code == 0:   # a node exits 0 only after "done", which may still be in flight
                if now - st.last_seen > 5:
                    st.done = True
                continue
            if hung:
                st.proc.kill()
                st.proc.wait()
                reason = f"no heartbeat for {self.graph.run['heartbeat_timeout_s']:.0f} s (hung); killed"
            else:
                reason = f"exited with {'signal ' + signal.Signals(-code).name if code < 0 else 'status ' + str(code)}"
            self.node_failed(st, reason)

    def node_failed(self, st: NodeState, reason: str) -> None:
        detail = st.error or self.log_tail(st.name)
        self.log(f"carav: node {st.name!r} ({st.spec.type}) failed: {reason}\n{_indent(detail)}")
        st.grace = False
        st.unreported += st.error is None     # no last words: its counters are those of its last heartbeat
        st.dead_counters.append(st.counters)
        st.counters = {}
        policy = self.graph.nodes[st.name].restart
        if policy.policy == "on-failure" and st.restarts < policy.max_restarts and not self.signals:
            st.restarts += 1
            st.error = None
            if not self.graph.edges_into(st.name):   # a source resumes beyond every seq it was allowed to send
                start = max(st.spec.seq_lease, st.total("processed"))
                st.spec = st.spec.with_(start_seq=start, seq_lease=start + LEASE_FRAMES,
                                        start_cycles=st.total("cycles"))
            # its blocks' seeded streams must not replay the last ones: a new incarnation
            st.spec = st.spec.with_(recovering=True, incarnation=st.restarts)
            self.log(f"carav: restarting {st.name!r} ({st.restarts}/{policy.max_restarts})")
            self.spawn(st)
            self.pending_go.add(st.name)
            for e in self.graph.edges_into(st.name):   # producers connect afresh to the new incarnation
                if e.src in self.nodes:
                    self.send(e.src, Control.RECONNECT, edges=[str(e)])
            for e in self.graph.edges_from(st.name):   # consumers: what it held is lost, do not wait for it
                if e.dst in self.nodes:
                    self.send(e.dst, Control.RECOVER)
            return
        st.failed = True
        self.failures.append(f"node {st.name!r} ({st.spec.type}) failed: {reason}")
        # its consumers will get no end of stream from it: tell them their inputs end here; its producers
        # must stop waiting on it (what they cannot deliver is counted lost, edge by edge)
        for e in self.graph.edges_from(st.name):
            if e.dst in self.nodes:
                self.send(e.dst, Control.EOS, ports=[e.dst_port])
        for e in self.graph.edges_into(st.name):
            if e.src in self.nodes:
                self.send(e.src, Control.CUT, edges=[str(e)])
        self.request_stop(f"node {st.name!r} failed")

    def request_stop(self, why: str) -> None:
        if not self.stop_requested:
            self.stop_requested = why
            self.stop_deadline = time.monotonic() + self.graph.run["drain_timeout_s"]
            for n in self.nodes:
                if not self.graph.edges_into(n):
                    self.send(n, Control.STOP)

    def on_signal(self, signum, frame) -> None:
        self.signals += 1
        if self.signals >= 2:
            self.kill_all()

    def kill_all(self) -> None:
        for st in self.nodes.values():
            if st.proc and st.proc.poll() is None:
                st.proc.kill()

    # -- main ----------------------------------------------------------------------------------------------
    def run(self) -> dict[str, Any]:
        remove_stale_runs(self.run_dir.parent)
        self.run_dir.mkdir(mode=0o700)
        (self.run_dir / "pid").write_text(str(os.getpid()))     # how a later run knows this one is gone
        old = {s: signal.signal(s, self.on_signal) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
        self.ctx = zmq.Context()
        try:
            self.router = self.ctx.socket(zmq.ROUTER)
            self.router.linger = 0
            self.router.bind(transport.ipc_endpoint(self.run_dir, "control"))
            self.admin = self.ctx.socket(zmq.REP)
            self.admin.linger = 0
            self.admin.bind(transport.ipc_endpoint(self.run_dir, "admin"))
            self.plan()
            (self.run_dir / "run.json").write_text(json.dumps({
                "run": self.run_id, "pid": os.getpid(), "graph": str(self.graph.path.resolve()),
                "host": self.host or LOCAL_HOST, "started": time.time(),
                "admin": transport.ipc_endpoint(self.run_dir, "admin")}))
            for st in self.nodes.values():
                self.spawn(st)
            self.loop()
        finally:
            deadline = time.monotonic() + 10
            for st in self.nodes.values():   # released nodes exit by themselves; kill what does not
                if st.proc and st.done:
                    try:
                        st.proc.wait(max(0.0, deadline - time.monotonic()))
                    except subprocess.TimeoutExpired:
                        pass
            self.kill_all()
            for st in self.nodes.values():
                if st.proc:
                    st.proc.wait()
            self.ctx.destroy(linger=0)
            for fd in self.segments:        # the kernel frees a segment when its last holder closes it
                os.close(fd)
            self.segments.clear()
            for s, h in old.items():
                signal.signal(s, h)
            if not os.environ.get("CARAV_KEEP_RUN_DIR"):   # debugging aid: keep node logs and specs
                shutil.rmtree(self.run_dir, ignore_errors=True)
        return self.summary()

    def loop(self) -> None:
        poller = zmq.Poller()
        poller.register(self.router, zmq.POLLIN)
        poller.register(self.admin, zmq.POLLIN)
        ready_deadline = time.monotonic() + self.graph.run["ready_timeout_s"]
        started = False
        next_progress = 0.0
        while True:
            for sock, _ in poller.poll(100):
                if sock is self.router:
                    self.drain_router()
                else:
                    raw = self.admin.recv()
                    try:
                        req = unpack(raw)
                    except ValueError as exc:   # answer, never crash
                        self.admin.send(pack("error", ok=False, error=f"bad admin request: {exc}"))
                        continue
                    self.on_admin(req)
            if self.signals and not self.stop_requested:
                self.request_stop("signal")
            self.check_processes()
            if not started:
                if all(st.ready or st.failed for st in self.nodes.values()):
                    started = True
                    self.t_go = time.monotonic()
                    for n in self.nodes:
                        self.send(n, Control.GO)
                elif time.monotonic() > ready_deadline:
                    late = [n for n, st in self.nodes.items() if not st.ready]
                    self.failures.append(f"nodes not ready after {self.graph.run['ready_timeout_s']:.0f} s: {late}")
                    for n in late:
                        self.log(f"carav: node {n!r} not ready; its log:\n{_indent(self.log_tail(n))}")
                    break
            for n in list(self.pending_go):
                if self.nodes[n].ready:
                    self.send(n, Control.GO)
                    if self.stop_requested and not self.graph.edges_into(n):
                        self.send(n, Control.STOP)
                    self.pending_go.discard(n)
            self.deliver_swap()
            if self.pending_admin and time.monotonic() > self.pending_admin["deadline"]:
                up = "did not confirm the swap" if self.pending_admin["sent"] else "was not ready for the swap"
                self.reply_admin({"ok": False, "error": f"the node {up} within 30 s"})
            if all(st.done or st.failed for st in self.nodes.values()):
                for n, st in self.nodes.items():
                    if st.done:
                        self.send(n, Control.EXIT)
                break
            if not self.stop_requested and started and all(
                    self.nodes[n].done or self.nodes[n].failed for n in self.nodes if not self.graph.edges_into(n)):
                # the sources have finished: what is still in flight must drain within the deadline
                self.stop_requested = "end of stream"
                self.stop_deadline = time.monotonic() + self.graph.run["drain_timeout_s"]
            if self.stop_requested and time.monotonic() > self.stop_deadline:
                late = [n for n, st in self.nodes.items() if not (st.done or st.failed)]
                # what each was doing at its last heartbeat: which edge it was blocked on, which seqs it held
                states = "".join(f"\n  {n}: {self.nodes[n].counters.get('state', 'no heartbeat yet')}" for n in late)
                self.failures.append(f"drain deadline of {self.graph.run['drain_timeout_s']:.0f} s passed; "
                                     f"killed {late}; their last reported state:{states}")
                break
            if self.signals >= 2:
                self.failures.append("killed by a second interrupt")
                break
            if self.progress and time.monotonic() >= next_progress and started:
                next_progress = time.monotonic() + 0.5
                self.draw_progress()
        self.t_end = time.monotonic()
        if self.progress:
            print(file=sys.stderr)

    def draw_progress(self) -> None:
        elapsed = max(time.monotonic() - self.t_go, 1e-9)
        n = self.cycles_done()
        total = f"/{self.cycles}" if self.cycles else ""
        rejected = sum(sum(st.counters.get("rejected", {}).values()) for st in self.nodes.values())
        print(f"\r[carav] {n}{total} cycles  {n / elapsed:8.1f} cycles/s  frames rejected {rejected}  "
              f"node restarts {sum(st.restarts for st in self.nodes.values())}   ", end="", file=sys.stderr, flush=True)

    # -- summary -------------------------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        wall = max(self.t_end - self.t_go, 1e-9) if self.t_go else 0.0
        per_node: dict[str, Any] = {}
        for n, st in self.nodes.items():
            per_node[n] = {"block": st.spec.type,
                           **{k: st.total(k) for k in (*PER_PORT_COUNTERS, "processed", "cycles", "busy_s", "cpu_s",
                                                           "cpu_working_s")},
                           "restarts": st.restarts, "failed": st.failed, "history": st.history}
        lost = 0
        edge_loss = {}
        for e in self.graph.edges:
            if e.src in per_node and e.dst in per_node:
                sent = per_node[e.src]["sent"].get(str(e), 0)
                got = per_node[e.dst]["in"].get(e.dst_port, 0) + per_node[e.dst]["rejected"].get(e.dst_port, 0)
                missed = sent - got + per_node[e.src]["undeliverable"].get(str(e), 0)
                if missed:
                    edge_loss[str(e)] = missed
                    lost += max(0, missed)
        # frames a crashed incarnation had received but not finished died with it
        for n, st in self.nodes.items():
            if self.graph.edges_into(n):
                for c in st.dead_counters:
                    died = sum(c.get("in", {}).values()) - c.get("consumed", 0)
                    if died > 0:
                        edge_loss[f"inside {n} (crashed)"] = edge_loss.get(f"inside {n} (crashed)", 0) + died
                        lost += died
        cycles = self.cycles_done()
        result: dict[str, Any] = {
            "graph": str(self.graph.path), "run": self.run_id, "host": self.host or LOCAL_HOST,
            "cycles": cycles, "lost": lost, "lost_by_edge": edge_loss,
            # nodes that died without a final report: the counts on their edges (and so `lost`) are estimates,
            # off by what they did after their last heartbeat
            "estimated_counts": sorted(n for n, st in self.nodes.items() if st.unreported),
            "rejected": sum(sum(p["rejected"].values()) for p in per_node.values()),
            "unpaired": sum(sum(p["unpaired"].values()) for p in per_node.values()),
            # frames a tap edge skipped because its observer was busy (block.In.tap): by design, not lost
            "skipped_by_taps": {e: n for p in per_node.values() for e, n in p["skipped"].items() if n},
            "restarts": sum(st.restarts for st in self.nodes.values()),
            "failures": self.failures, "swaps": self.swaps, "stopped_by": self.stop_requested,
            "wall_s": wall, "throughput_cycles_per_s": cycles / wall if wall else 0.0, "per_node": per_node,
            "transport": self.graph.run["transport"], "shared_memory": self.shared_memory(),
        }
        # Blocks may contribute run-level figures: a summary() key "run" is merged into the top level.
        for st in self.nodes.values():
            for h in st.history:
                for k, v in (h.get("summary") or {}).get("run", {}).items():
                    result.setdefault(k, v)
        return result


def _indent(text: str) -> str:
    return "\n".join("    " + line for line in text.splitlines())
