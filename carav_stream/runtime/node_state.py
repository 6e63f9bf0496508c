"""What the supervisor knows of one node: its spec, its process, how far it got, and the counters its reports
carried, kept for every incarnation (a restarted node starts its counters afresh; the crashed ones' are kept)."""
from __future__ import annotations

import subprocess
from dataclasses import dataclass, field
from typing import Any

from carav_stream.runtime.protocol import NodeSpec

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
    retry: bool = True         # False: its last error said a restart would meet the same fault
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
