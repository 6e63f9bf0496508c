"""The figures of a run, from its nodes' reports: the run's clock, cycles done, the progress line, the use of the
shared-memory segments, and the summary `carav run` prints (and writes with --json).

A node's counters are summed over its incarnations (NodeState.total). Frames lost are counted edge by edge (sent
minus taken, plus what the producer could not deliver) and inside crashed consumers (received, not finished). A
refused message is rejected, never taken; an edge on which a consumer took more than its producer sent is a
failure of the run (unless the producer died without a final report, when its counts are estimates).
"""
from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

from carav_stream.runtime.graph import LOCAL_HOST, Graph
from carav_stream.runtime.node_state import PER_PORT_COUNTERS, NodeState


class RunReport:
    """The figures of the nodes `nodes` (the supervisor's own dict, filled as it plans) of a run of `graph`.
    t_go: when every node was told to go (0 until then); t_end: when the supervisor stopped watching."""

    def __init__(self, graph: Graph, nodes: dict[str, NodeState], *, run_id: str, host: str | None,
                 cycles: int | None) -> None:
        self.graph = graph
        self.nodes = nodes
        self.run_id = run_id
        self.host = host
        self.cycles = cycles
        self.t_go = self.t_end = 0.0

    def cycles_done(self) -> int:
        """Cycles the local sources generated (a frame may carry several, header `cycles`); on a host without
        sources, cycles processed by the nodes fed from other hosts."""
        sources = [n for n in self.nodes if not self.graph.edges_into(n)]
        if sources:
            return max(self.nodes[n].total("cycles") for n in sources)
        remote = {e.dst for e in self.graph.edges if e.dst in self.nodes and e.src not in self.nodes}
        return max((self.nodes[n].total("cycles") for n in remote), default=0)

    def draw_progress(self, line: bool, on_progress: Callable[[int, int], None] | None = None,
                      expected: int = 0) -> None:
        """The terminal's progress line (if `line`); on_progress(cycles done, `expected`) when the run has an end
        to count towards (expected > 0)."""
        n = self.cycles_done()
        if on_progress is not None and expected:
            on_progress(min(n, expected), expected)
        if not line:
            return
        elapsed = max(time.monotonic() - self.t_go, 1e-9)
        total = f"/{self.cycles}" if self.cycles else ""
        rejected = sum(sum(st.counters.get("rejected", {}).values()) for st in self.nodes.values())
        print(f"\r[carav] {n}{total} cycles  {n / elapsed:8.1f} cycles/s  frames rejected {rejected}  "
              f"node restarts {sum(st.restarts for st in self.nodes.values())}   ", end="", file=sys.stderr, flush=True)

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

    def summary(self, *, failures: list[str], swaps: list[dict[str, Any]], stopped_by: str | None,
                refused_swaps: list[dict[str, Any]] = (), security: dict[str, Any] | None = None,
                node_starts: dict[str, int] | None = None) -> dict[str, Any]:
        """The run's summary: counts per node and for the whole run, frames lost (by edge), restarts, failures,
        swaps applied and refused, why it stopped, wall time and throughput from go to the end, who was refused
        (`security`: the supervisor's part, completed here with the tcp connections each input refused); blocks'
        "run" figures merged in."""
        wall = max(self.t_end - self.t_go, 1e-9) if self.t_go else 0.0
        per_node: dict[str, Any] = {}
        for n, st in self.nodes.items():
            per_node[n] = {"block": st.spec.type,
                           **{k: st.total(k) for k in (*PER_PORT_COUNTERS, "processed", "cycles", "busy_s", "cpu_s",
                                                           "cpu_working_s")},
                           "restarts": st.restarts, "failed": st.failed, "history": st.history}
        lost = 0
        edge_loss = {}
        failures = list(failures)
        for e in self.graph.edges:
            if e.src in per_node and e.dst in per_node:
                sent = per_node[e.src]["sent"].get(str(e), 0)
                # taken: frames the consumer accepted; a refused message is counted rejected, never taken, so
                # messages from elsewhere cannot hide a real loss
                got = per_node[e.dst]["in"].get(e.dst_port, 0)
                missed = sent - got + per_node[e.src]["undeliverable"].get(str(e), 0)
                if missed:
                    edge_loss[str(e)] = missed
                    lost += max(0, missed)
                if got > sent and not self.nodes[e.src].unreported:
                    failures.append(f"edge '{e}': {e.dst} took {got} frames but {e.src} sent {sent}: frames "
                                    "that its producer never sent were accepted")
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
            # node processes started, restarts included: forked from the zygote, or fresh interpreters
            "node_starts": dict(node_starts or {}),
            "failures": failures, "swaps": swaps, "refused_swaps": list(refused_swaps), "stopped_by": stopped_by,
            "wall_s": wall, "throughput_cycles_per_s": cycles / wall if wall else 0.0, "per_node": per_node,
            "transport": self.graph.run["transport"], "shared_memory": self.shared_memory(),
            "security": {**(security or {}), "refused_connections": {
                f"{n}.{port}": k for n, p in per_node.items() for port, k in p["refused"].items() if k}},
        }
        # Blocks may contribute run-level figures: a summary() key "run" is merged into the top level.
        for st in self.nodes.values():
            for h in st.history:
                for k, v in (h.get("summary") or {}).get("run", {}).items():
                    result.setdefault(k, v)
        return result
