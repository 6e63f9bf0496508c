"""The supervisor: start every node of a graph in its own process, watch them, restart or fail them, stop them
in order.

Each run has a folder of its own (rundir.py), holding the ipc endpoints, the node specs, each node's log and
`run.json` (how `carav status|stop|swap` find the run). It is removed when the run ends, whatever the way it ends.
The supervisor plans the nodes (plan.py) and the keys of their tcp edges (curve_keys.py), hears and tells them
through control_router.ControlRouter (a node's word only from its own processes), answers admin requests through
admin_server.AdminServer, starts the node processes through launcher.Launcher (forked from a zygote, or fresh
interpreters), keeps what it knows of each node in node_state.NodeState (none of its processes reaped
before the run ends) and reports the run through report.RunReport.

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
import threading
import time
from collections.abc import Callable
from typing import Any

import zmq

from carav_stream.runtime import planes, transport
from carav_stream.runtime.admin_server import AdminServer
from carav_stream.runtime.control_router import ControlRouter
from carav_stream.runtime.curve_keys import plan_keys
from carav_stream.runtime.graph import LOCAL_HOST, Graph
from carav_stream.runtime.launcher import NODE_ENV, Launcher, node_env
from carav_stream.runtime.node_state import NodeState
from carav_stream.runtime.plan import input_bounds, input_sources, plan_specs
from carav_stream.runtime.protocol import LEASE_FRAMES, Control, Report, pack
from carav_stream.runtime.report import RunReport
from carav_stream.runtime.rundir import remove_stale_runs, run_root
from carav_stream.runtime.senders import start_ticks

__all__ = ["NODE_ENV", "Supervisor"]        # NODE_ENV: the nodes' environment (launcher.py), named here by documents


class Supervisor:
    """Runs the nodes of `graph` on `host` (every node when None) until they finish, `cycles` cycles from each
    source (the graph's run.cycles when None); run() returns the summary (report.RunReport.summary). `progress`: the
    terminal's line (default: on a terminal); on_progress(cycles done, expected_cycles or cycles) twice a second."""

    def __init__(self, graph: Graph, *, host: str | None = None, cycles: int | None = None,
                 progress: bool | None = None, log: Callable[[str], None] | None = None,
                 on_progress: Callable[[int, int], None] | None = None, expected_cycles: int | None = None,
                 launcher: Launcher | None = None, on_warnings: Callable[[list[str]], None] | None = None) -> None:
        self.graph = graph
        self.host = host
        self.cycles = graph.run["cycles"] if cycles is None else cycles
        self.progress = sys.stderr.isatty() if progress is None else progress
        self.on_progress, self.expected_cycles = on_progress, expected_cycles or self.cycles   # report.draw_progress
        self.log = log or (lambda text: print(text, file=sys.stderr, flush=True))
        self.run_id = f"{graph.path.stem[:24]}-{secrets.token_hex(3)}"
        self.run_dir = run_root() / self.run_id
        self.nodes: dict[str, NodeState] = {}
        self.failures: list[str] = []
        self.signals = 0
        self.stop_requested: str | None = None
        self.stop_deadline = 0.0
        self.pending_go: set[str] = set()
        self.plane: planes.Plane | None = None      # the run's data plane (run.transport), made by plan()
        self.security: dict[str, Any] = {}          # how the run's tcp edges are protected (plan)
        self.control: ControlRouter | None = None   # the control socket's end (run)
        self.launcher = launcher                    # starts the node processes (run makes one if not given)
        self.later: LaterChecks | None = None       # the graph's checks left for later, while the nodes start
        self.on_warnings = on_warnings or (lambda found: [self.log(f"carav: warning: {w}") for w in found])
        self.invalid: list[str] = []                # what those checks found wrong: the graph was not started
        self.report = RunReport(graph, self.nodes, run_id=self.run_id, host=host, cycles=self.cycles)
        self.admin = AdminServer(graph, self.nodes, self.report, send=self.send, request_stop=self.request_stop,
                                 log=self.log, run_dir=self.run_dir)

    # -- planning ------------------------------------------------------------------------------------------
    def plan(self) -> None:
        self.plane = planes.get(self.graph.run["transport"])(self.graph.run, self.run_dir)
        keys, self.security = plan_keys(self.graph, self.host, self.run_dir / "keys")
        specs = plan_specs(self.graph, self.host, self.run_dir, self.cycles, self.plane, keys)
        for name, spec in specs.items():
            self.nodes[name] = NodeState(name, spec)
        self.input_sources = input_sources(self.graph, self.nodes)
        for st in self.nodes.values():
            st.spec = st.spec.with_(input_bounds=self.input_bounds(st.name), supervisor_pid=os.getpid())

    def input_bounds(self, name: str) -> dict[str, int]:
        """The highest seq each input of node `name` can carry now (plan.input_bounds)."""
        return input_bounds(self.graph, self.input_sources, name, lambda src: self.nodes[src].spec.seq_lease)

    def raise_bounds(self, source: str) -> None:
        """After a lease of `source` grew: every consumer its seqs reach learns its new bound first."""
        for dst in {d for (d, _), srcs in self.input_sources.items() if srcs and source in srcs}:
            st = self.nodes[dst]
            st.spec = st.spec.with_(input_bounds=self.input_bounds(dst))
            if st.proc is not None:
                self.send(dst, Control.LEASE, inputs=st.spec.input_bounds)

    def tell_peers(self, name: str) -> None:
        """Tell node `name` the pid and start time of the process feeding each of its local inputs, and their seq
        bounds."""
        st = self.nodes[name]
        pids = {e.dst_port: self.nodes[e.src].peer() for e in self.graph.edges_into(name)
                if e.src in self.nodes and self.nodes[e.src].proc is not None}
        if pids:
            self.send(name, Control.PEERS, inputs=pids)
        if st.spec.input_bounds:
            self.send(name, Control.LEASE, inputs=st.spec.input_bounds)

    # -- process management --------------------------------------------------------------------------------
    def spawn(self, st: NodeState) -> None:
        spec_path = self.run_dir / f"{st.name}.spec"
        spec_path.write_bytes(st.spec.to_wire())
        st.proc = self.launcher.launch(spec_path, self.run_dir / f"{st.name}.log", st.spec.inherit_fds,
                                       node_env(self.run_id), self.graph.run["ready_timeout_s"], block=st.spec.type)
        st.procs.append(st.proc)            # kept, not reaped, until the run ends: its pid stays its own
        st.start_ticks = start_ticks(st.proc.pid)
        self.control.started(st.name, st.proc.pid)
        for e in self.graph.edges_from(st.name):   # its consumers accept frames from this process from now on
            if e.dst in self.nodes:
                dst = self.nodes[e.dst]
                pids = [*dst.spec.producers.get(e.dst_port, ()), st.peer()]
                dst.spec = dst.spec.with_(producers={**dst.spec.producers, e.dst_port: pids})
                if dst.proc is not None:
                    self.send(e.dst, Control.PEERS, inputs={e.dst_port: st.peer()})
        st.ready = st.done = st.failed = False
        st.last_seen = time.monotonic()

    def send(self, name: str, kind: Control, **fields: Any) -> None:
        self.control.send(name, pack(kind, **fields))

    def log_tail(self, name: str, n: int = 25) -> str:
        try:
            lines = (self.run_dir / f"{name}.log").read_text(errors="replace").splitlines()
        except OSError:
            return ""
        return "\n".join(lines[-n:])

    # -- messages ------------------------------------------------------------------------------------------
    def drain_router(self) -> None:
        """Act on every queued message of a node's current process (control_router.py refuses the others)."""
        for name, msg in self.control.receive():
            self.on_node_message(name, msg)

    def on_node_message(self, name: str, msg: dict[str, Any]) -> None:
        st = self.nodes[name]
        st.last_seen = time.monotonic()
        kind = msg.get("type")
        if "counters" in msg:
            st.counters = msg["counters"]
        if kind == Report.READY:
            st.ready = True
            self.tell_peers(name)   # before GO, on the same connection: known before any frame comes
        elif kind == Report.DONE:
            st.done = True
            st.history = msg.get("history", [])
            st.lost = msg.get("lost", {})
        elif kind == Report.ERROR:
            st.error = msg.get("traceback") or msg.get("error")
            st.retry = msg.get("retry") is not False
        elif kind == Report.REJECT:
            what = "refused connection" if msg.get("what") == "connection" else "rejected frame"
            text = f"node {name!r} input {msg['port']!r}: {what} #{msg['count']}: {msg['reason']}"
            st.rejects.append(text)
            self.log(f"carav: {text}")
        elif kind == Report.LEASE and isinstance(msg.get("upto"), int):
            st.spec = st.spec.with_(seq_lease=max(st.spec.seq_lease, msg["upto"]))   # granted: remembered first
            self.raise_bounds(name)                                                   # consumers know it before
            self.send(name, Control.LEASE, upto=st.spec.seq_lease)                   # the source may use it
        elif kind in (Report.SWAPPED, Report.SWAP_FAILED):
            self.admin.on_swap_report(st, msg)

    # -- failure handling ----------------------------------------------------------------------------------
    def check_processes(self) -> None:
        self.drain_router()   # a dead node's last words (its error and final counters) come first
        now = time.monotonic()
        for st in self.nodes.values():
            if st.proc is None or st.done or st.failed:
                continue
            code = st.exit_code()        # an ended process is not reaped: its pid stays its own
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
                st.kill()
                reason = f"no heartbeat for {self.graph.run['heartbeat_timeout_s']:.0f} s (hung); killed"
            else:
                reason = f"exited with {'signal ' + signal.Signals(-code).name if code < 0 else 'status ' + str(code)}"
            self.node_failed(st, reason)

    def node_failed(self, st: NodeState, reason: str) -> None:
        detail = st.error or self.log_tail(st.name)
        if st.error and "\n" not in st.error.strip():   # the block's own one-line statement: it is the reason
            reason, detail = f"{reason}: {st.error.strip()}", ""
        policy = self.graph.nodes[st.name].restart
        may_restart = policy.policy == "on-failure" and st.restarts < policy.max_restarts and not self.signals
        if may_restart and not st.retry:
            reason += " (not restarted: a new process would meet the same fault)"
        self.log(f"carav: node {st.name!r} ({st.spec.type}) failed: {reason}" + (f"\n{_indent(detail)}" * bool(detail)))
        st.grace = False
        st.unreported += st.error is None     # no last words: its counters are those of its last heartbeat
        st.dead_counters.append(st.counters)
        st.counters = {}
        if may_restart and st.retry:
            st.restarts += 1
            st.error = None
            if not self.graph.edges_into(st.name):   # a source resumes beyond every seq it was allowed to send
                start = max(st.spec.seq_lease, st.total("processed"))
                st.spec = st.spec.with_(start_seq=start, seq_lease=start + LEASE_FRAMES,
                                        start_cycles=st.total("cycles"))
                self.raise_bounds(st.name)
            # its blocks' seeded streams must not replay the last ones: a new incarnation
            st.spec = st.spec.with_(recovering=True, incarnation=st.restarts)
            self.log(f"carav: restarting {st.name!r} ({st.restarts}/{policy.max_restarts})")
            self.spawn(st)
            self.pending_go.add(st.name)
            for e in self.graph.edges_into(st.name):   # producers connect afresh to the new incarnation
                if e.src in self.nodes:
                    self.send(e.src, Control.RECONNECT, edges=[str(e)])
            # every node downstream, not only its consumers: what it held is lost, and a node further down that
            # pairs a stream through it with another (the detector's frames with the source's rho) must not wait
            # for it either, or a full buffer backs the other stream up to its source and the graph stalls
            for name in self.downstream_of(st.name):
                self.send(name, Control.RECOVER)
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

    def downstream_of(self, name: str) -> list[str]:
        """Every running node a frame from `name` can reach, in breadth-first order."""
        seen, order, todo = {name}, [], [name]
        while todo:
            for e in self.graph.edges_from(todo.pop(0)):
                if e.dst not in seen:
                    seen.add(e.dst)
                    todo.append(e.dst)
                    if e.dst in self.nodes:
                        order.append(e.dst)
        return order

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
            st.kill(wait=False)         # also from a signal handler: reaped when the run ends

    # -- main ----------------------------------------------------------------------------------------------
    def run(self) -> dict[str, Any]:
        remove_stale_runs(self.run_dir.parent)
        self.run_dir.mkdir(mode=0o700)
        (self.run_dir / "pid").write_text(str(os.getpid()))     # how a later run knows this one is gone
        old = {s: signal.signal(s, self.on_signal) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
        self.ctx = zmq.Context()
        if self.graph.later_checks:     # a loader left the blocks' own checks: they run while the nodes start
            self.later = LaterChecks(self.graph)
        if self.launcher is None:       # the zygote's imports run while the run is set up
            self.launcher = Launcher(zygote=self.graph.run["zygote"], log=self.log)
            self.launcher.import_blocks(sorted({node.type for node in self.graph.nodes.values()}))
        elif not self.graph.run["zygote"]:
            self.launcher.close()
        try:
            self.router = self.ctx.socket(zmq.ROUTER)
            self.router.linger = 0
            self.router.bind(transport.ipc_endpoint(self.run_dir, "control"))
            self.control = ControlRouter(self.router, self.log)
            self.admin.bind(self.ctx, transport.ipc_endpoint(self.run_dir, "admin"))
            self.plan()
            (self.run_dir / "run.json").write_text(json.dumps({
                "run": self.run_id, "pid": os.getpid(), "graph": str(self.graph.path.resolve()),
                "host": self.host or LOCAL_HOST, "started": time.time(),
                "admin": transport.ipc_endpoint(self.run_dir, "admin")}))
            for name in self.graph.topological_order():   # producers first: each consumer's spec names them
                if name in self.nodes:
                    self.spawn(self.nodes[name])
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
                st.reap_all()
            self.launcher.close()
            if self.later is not None:
                self.later.close()
            self.ctx.destroy(linger=0)
            if self.plane is not None:
                self.plane.close()
            for s, h in old.items():
                signal.signal(s, h)
            if not os.environ.get("CARAV_KEEP_RUN_DIR"):   # debugging aid: keep node logs and specs
                shutil.rmtree(self.run_dir, ignore_errors=True)
        return self.summary()

    def summary(self) -> dict[str, Any]:
        refused = dict(self.control.refused) if self.control is not None else {}
        return self.report.summary(failures=self.failures, swaps=self.admin.swaps, stopped_by=self.stop_requested,
                                   refused_swaps=self.admin.refused_swaps,
                                   node_starts=self.launcher.counts() if self.launcher else {},
                                   security={**self.security, "refused_control": refused})

    def checked_later(self) -> bool:
        """The graph's later checks are done: their warnings told; False (and the graph not started) when they
        found it invalid (`invalid`)."""
        later, self.later = self.later, None
        later.close()
        warnings, self.invalid = later.result
        if warnings:
            self.on_warnings(warnings)
        return not self.invalid

    def loop(self) -> None:
        poller = zmq.Poller()
        poller.register(self.router, zmq.POLLIN)
        poller.register(self.admin.sock, zmq.POLLIN)
        if self.later is not None:
            poller.register(self.later.done_fd, zmq.POLLIN)
        ready_deadline = time.monotonic() + self.graph.run["ready_timeout_s"]
        started = False
        next_progress = 0.0
        while True:
            for sock, _ in poller.poll(100):
                if sock is self.router:
                    self.drain_router()
                elif sock is self.admin.sock:
                    self.admin.receive()
            if self.signals and not self.stop_requested:
                self.request_stop("signal")
            self.check_processes()
            if self.later is not None and self.later.done():
                poller.unregister(self.later.done_fd)
                if not self.checked_later():
                    break
            if not started:
                if self.later is None and all(st.ready or st.failed for st in self.nodes.values()):
                    started = True
                    self.report.t_go = time.monotonic()
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
            self.admin.deliver_swap()
            self.admin.expire_swap()
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
            if time.monotonic() >= next_progress and started:
                next_progress = time.monotonic() + 0.5
                self.report.draw_progress(self.progress, self.on_progress, self.expected_cycles)
        self.report.t_end = time.monotonic()
        self.admin.run_ended()
        if started:
            self.report.draw_progress(False, self.on_progress, self.expected_cycles)
        if self.progress:
            print(file=sys.stderr)


class LaterChecks:
    """Graph.run_later_checks in a thread of its own, beside the nodes' start: `done_fd` is readable once it is
    done; `result` is then (the warnings it added, the problems it found)."""

    def __init__(self, graph: Graph) -> None:
        self.done_fd, self._done_w = os.pipe()
        self.result: tuple[list[str], list[str]] | None = None
        self.thread = threading.Thread(target=self._run, args=(graph,), name="later-checks", daemon=True)
        self.thread.start()

    def _run(self, graph: Graph) -> None:
        known = len(graph.warnings)
        try:
            problems = graph.run_later_checks()
        except Exception as exc:            # a check's own bug: the graph is not started, and the user told why
            problems = [f"{graph.path.name}: the blocks' parameter checks failed: {type(exc).__name__}: {exc}"]
        self.result = (graph.warnings[known:], problems)
        os.write(self._done_w, b".")

    def done(self) -> bool:
        return self.result is not None

    def close(self) -> None:
        """Wait for the thread (a run that ends before the checks do), then close the pipe."""
        self.thread.join()
        for fd in (self.done_fd, self._done_w):
            try:
                os.close(fd)
            except OSError:
                pass


def _indent(text: str) -> str:
    return "\n".join("    " + line for line in text.splitlines())
