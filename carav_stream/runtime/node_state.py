"""What the supervisor knows of one node: its spec, its process, how far it got, and the counters its reports
carried, kept for every incarnation (a restarted node starts its counters afresh; the crashed ones' are kept).

The processes of every incarnation are kept and none is reaped before the run ends: an ended one stays a zombie
that holds its pid, so no other process can take a pid that a consumer or the control plane trusts (senders.py).
"""
from __future__ import annotations

import os
import signal
import subprocess
from dataclasses import dataclass, field
from typing import Any

from carav_stream.runtime.launcher import Forked
from carav_stream.runtime.protocol import NodeSpec

# dicts: port or edge -> n
PER_PORT_COUNTERS = ("in", "out", "sent", "rejected", "unpaired", "undeliverable", "skipped", "refused")


@dataclass
class NodeState:
    name: str
    spec: NodeSpec
    proc: subprocess.Popen | Forked | None = None
    procs: list[subprocess.Popen | Forked] = field(default_factory=list)   # every incarnation's, the current last
    start_ticks: int | None = None     # when the current process started (senders.start_ticks)
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

    def peer(self) -> list[int]:
        """[pid, start time] of the current process, as a consumer checks its messages against (-1: unknown)."""
        assert self.proc is not None
        return [self.proc.pid, -1 if self.start_ticks is None else self.start_ticks]

    def exit_code(self) -> int | None:
        """The current process's exit status (minus the signal that ended it), or None while it runs; without
        reaping it: an ended process stays a zombie and keeps its pid until the run ends (reap_all)."""
        proc = self.proc
        if proc is None or proc.returncode is not None:
            return None if proc is None else proc.returncode
        try:
            info = os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except ChildProcessError:        # reaped already
            return proc.poll()
        if info is None:
            return None
        return info.si_status if info.si_code == os.CLD_EXITED else -info.si_status

    def kill(self, wait: bool = True) -> None:
        """SIGKILL the current process and (`wait`) wait until it has ended, without reaping it."""
        if self.proc is not None and self.exit_code() is None:
            os.kill(self.proc.pid, signal.SIGKILL)
            if wait:
                os.waitid(os.P_PID, self.proc.pid, os.WEXITED | os.WNOWAIT)

    def reap_all(self) -> None:
        """Wait for every incarnation's process (the run is over: their pids may be given to others now)."""
        for proc in self.procs:
            proc.wait()
