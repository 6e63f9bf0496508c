"""Graph files run as real processes, for integration tests: `carav run` in a process group of its own, waits that
follow progress, per-cycle records, swapping and killing a node, and teardown.

    graphs = Graphs(tmp_path)                        # the pytest fixture `carav` gives one, torn down after the test
    run = graphs.run("my_graph.toml", "--cycles", "200", sets={"seed": 3})
    wait_for(lambda: len(read_jsonl(tmp_path / "verdicts.jsonl")) >= 5, "verdicts", run)
    graphs.kill_node("detector")                     # SIGKILL its process (a restart policy brings it back)
    graphs.swap("attacker", "attacker", model="random", rarms=4.0)
    assert run.wait() == 0 and run.summary()["lost"] == 0

A wait never depends on the machine's speed alone: it follows the CPU time of the runs it waits on
(carav_stream.testing.waiting), so a loaded machine slows a test and does not fail it, while a graph that stands
still fails it in about a minute.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from carav_stream.node_start import parent_death_signal
from carav_stream.testing.waiting import group_cpu_s, wait_until

__all__ = ["GraphRun", "Graphs", "wait_for", "read_jsonl", "by_cycle", "node_pids"]



def wait_for(predicate: Callable[[], Any], what: str, *runs: GraphRun, interval_s: float = 0.05) -> Any:
    """The predicate's first true value, waiting while `runs` make progress (their processes' CPU time)."""
    return wait_until(predicate, what, lambda: sum(r.progress() for r in runs), interval_s=interval_s)


def read_jsonl(path: str | Path) -> list[dict]:
    """The complete lines of a jsonl_sink's file (a last line still being written is left out)."""
    path = Path(path)
    if not path.exists():
        return []
    out = []
    for line in path.read_text().splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            break
    return out


def by_cycle(records: list[dict]) -> dict[int, dict]:
    """{cycle: that cycle's record} from jsonl_sink records: the frame's header with its per_cycle columns taken at
    the cycle. A cycle recorded twice is an error."""
    out = {}
    for r in records:
        per = r.get("per_cycle") or {}
        index = per.get("cycle_index", list(range(r["cycle"], r["cycle"] + r.get("cycles", 1))))
        for i, c in enumerate(index):
            assert c not in out, f"cycle {c} recorded twice"
            out[c] = {**{k: v for k, v in r.items() if k != "per_cycle"}, **{k: v[i] for k, v in per.items()}}
    return out


def node_pids(run_root: Path, node: str = "*") -> list[int]:
    """The pids of the live node processes under a run folder (or of one node), from /proc: a node's command line
    names its spec file in the run folder (no `carav status` process to start, which is slow on a loaded machine).
    Zombies (ended, not yet reaped) are left out."""
    specs = {str(p) for p in Path(run_root).glob(f"carav-*/*/{node}.spec")}
    pids = []
    for proc in Path("/proc").iterdir():
        try:
            argv = (proc / "cmdline").read_bytes().decode(errors="replace").split("\0")[:-1]
            zombie = (proc / "stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
        except (OSError, IndexError):       # not a process, or it ended meanwhile
            continue
        if not zombie and argv[1:2] == ["-m"] and argv[2:3] in (["carav_stream.node_start"],
                                                                 ["carav_stream.runtime.node"]) \
                and argv[3:] and argv[3] in specs:
            pids.append(int(proc.name))
    return pids


def _not_json(word: str):
    raise ValueError(f"the summary holds {word}, which is not JSON")


class GraphRun:
    """One `carav run GRAPH --json SUMMARY` in its own session (process group), with stdout and stderr in files."""

    def __init__(self, workdir: Path, env: dict[str, str], graph: str | Path, args: list[str]) -> None:
        tag = time.monotonic_ns()
        self.workdir = workdir
        self.summary_path = workdir / f"summary-{tag}.json"
        self.out = open(workdir / f"stdout-{tag}.txt", "w+")
        self.err = open(workdir / f"stderr-{tag}.txt", "w+")
        self.proc = subprocess.Popen([sys.executable, "-m", "carav_stream.cli", "run", str(graph),
                                      "--json", str(self.summary_path), "--no-progress", *args],
                                     cwd=workdir, env=env, stdout=self.out, stderr=self.err,
                                     stdin=subprocess.DEVNULL, start_new_session=True,
                                     preexec_fn=parent_death_signal)   # a test process killed takes its graph along
        self.pgid = self.proc.pid

    def progress(self) -> float:
        """CPU seconds used by the run's process group: it rises while the graph works."""
        return group_cpu_s(self.pgid)

    def wait(self) -> int:
        """The exit code, once the run ends; fails when the run stops making progress."""
        wait_until(lambda: self.proc.poll() is not None, "the run to end", self.progress)
        return self.proc.returncode

    def stderr(self) -> str:
        self.err.flush()
        return Path(self.err.name).read_text()

    def stdout(self) -> str:
        return Path(self.out.name).read_text()

    def summary(self) -> dict:
        """The run's --json summary, read as strict JSON (a bare NaN or Infinity, which no JSON reader but Python's
        accepts, fails the test)."""
        return json.loads(self.summary_path.read_text(), parse_constant=_not_json)

    def group_alive(self) -> bool:
        try:
            os.killpg(self.pgid, 0)
        except ProcessLookupError:
            return False
        return True

    def kill(self) -> None:
        """SIGKILL the whole process group (teardown)."""
        _kill_group(self.pgid)
        self.proc.wait()          # SIGKILL cannot be refused: the direct child ends and is reaped
        self.out.close()
        self.err.close()


class Graphs:
    """Runs graphs in a working folder with a private run folder, and tears every one down in `close()`.

    transport   "zmq" or "shm": every run carries its arrays over that data plane (run.transport), else the
                graph's own
    env         extra environment for the processes (CARAV_BLOCK_PATH for your block folders, say)
    """

    def __init__(self, workdir: str | Path, *, transport: str | None = None, env: dict[str, str] | None = None):
        self.workdir = Path(workdir)
        self.transport = transport or "zmq"
        self._plane = transport
        # ipc paths must stay short (Unix sockets hold 107 bytes): a short private run folder
        self.run_root = Path(tempfile.mkdtemp(prefix="cr", dir="/tmp"))
        self.env = {**os.environ, "CARAV_RUN_DIR": str(self.run_root), **(env or {})}
        self.started: list[GraphRun] = []

    def run(self, graph: str | Path, *args: str, sets: dict[str, Any] | None = None) -> GraphRun:
        """Start `carav run GRAPH ARGS` (sets: --set key=value each); returns at once."""
        plane = ["--set", f"run.transport={self._plane}"] if self._plane else []
        more = [a for k, v in (sets or {}).items() for a in ("--set", f"{k}={_toml(v)}")]
        p = GraphRun(self.workdir, self.env, graph, [*args, *more, *plane])
        self.started.append(p)
        return p

    def cli(self, *args: str) -> subprocess.CompletedProcess:
        """A short carav command (status, stop, swap, validate ...) in its own process group, waited on by progress
        (a command that waits on a running graph, swap or stop, has that graph's work as its progress too)."""
        with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
            proc = subprocess.Popen([sys.executable, "-m", "carav_stream.cli", *args], env=self.env, cwd=self.workdir,
                                    stdout=out, stderr=err, stdin=subprocess.DEVNULL, text=True,
                                    start_new_session=True)
            try:
                wait_until(lambda: proc.poll() is not None, f"carav {' '.join(args)}",
                           lambda: group_cpu_s(proc.pid, *(p.pgid for p in self.started)))
            finally:
                _kill_group(proc.pid)
                proc.wait()
            out.seek(0)
            err.seek(0)
            return subprocess.CompletedProcess(proc.args, proc.returncode, out.read(), err.read())

    def graph(self, body: str, name: str = "g.toml", block_paths: list[str | Path] = ()) -> Path:
        """Write a graph file into the working folder (with `block_paths` to find your blocks)."""
        path = self.workdir / name
        head = f"block_paths = {json.dumps([str(p) for p in block_paths])}\n" if block_paths else ""
        path.write_text(head + body)
        return path

    def swap(self, node: str, block: str, **params: Any) -> subprocess.CompletedProcess:
        """`carav swap NODE BLOCK --set k=v ...` on the running graph; asserts it was applied."""
        res = self.cli("swap", node, block, *[a for k, v in params.items() for a in ("--set", f"{k}={_toml(v)}")])
        assert res.returncode == 0, f"swap of {node} to {block} refused: {res.stderr.strip()}"
        return res

    def kill_node(self, node: str, sig: int = signal.SIGKILL) -> int:
        """Send `sig` to the process of one node of the running graph; returns its pid."""
        pids = wait_for(lambda: node_pids(self.run_root, node), f"the process of node {node}", *self.started)
        assert len(pids) == 1, f"node {node}: {len(pids)} processes {pids}"
        os.kill(pids[0], sig)
        return pids[0]

    def close(self) -> None:
        for p in self.started:
            p.kill()
        shutil.rmtree(self.run_root, ignore_errors=True)


def _kill_group(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _toml(value: Any) -> str:
    """A --set value as TOML writes it (strings quoted, booleans lower case)."""
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)
