"""A node dies with its supervisor whenever the supervisor dies: while the nodes start (still importing), and while
a killed node is restarted. SIGKILL of the supervisor at 20 random moments; no process of the run is left."""
import os
import random
import signal
import time
from pathlib import Path

import pytest

from tests.integration.conftest import read_jsonl, wait_until

pytestmark = pytest.mark.integration

CHAIN = """
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[run]
cycles = 0
queue_frames = 2
[restart]
policy = "on-failure"
[blocks]
src = { type = "counter_source" }
t = { type = "tagger", delay_s = 0.005 }
log = { type = "jsonl_sink", path = "out.jsonl" }
"""


def run_processes(root: Path) -> dict[int, str]:
    """Live processes (zombies left out) whose command line names a file under the run root: the run's nodes."""
    found = {}
    for proc in Path("/proc").iterdir():
        try:
            argv = (proc / "cmdline").read_bytes().decode(errors="replace").split("\0")
            if (proc / "stat").read_text().rsplit(")", 1)[1].split()[0] == "Z":
                continue
        except (OSError, IndexError):       # not a process, or it ended meanwhile
            continue
        if any(a.startswith(str(root)) for a in argv):
            found[int(proc.name)] = " ".join(argv)
    return found


def node_pid(root: Path, node: str) -> int | None:
    pids = [pid for pid, cmd in run_processes(root).items() if cmd.split()[-1].endswith(f"/{node}.spec")]
    return pids[0] if len(pids) == 1 else None


@pytest.mark.parametrize("moment", ["start-up", "restart"])
def test_no_node_outlives_a_supervisor_killed_while_nodes_start_or_restart(carav, moment):
    rng = random.Random(f"supervisor-death-{moment}")
    graph = carav.graph(CHAIN)
    for i in range(10):
        run = carav.run(graph)
        if moment == "start-up":
            # from the first spawn (its spec written) to about when every node has imported and said ready
            wait_until(lambda: list(carav.run_root.glob("carav-*/*/*.spec")), "the first node to be spawned", run)
        else:
            wait_until(lambda: len(read_jsonl(carav.workdir / "out.jsonl")) > 5 * (i + 1), "frames to flow", run)
            os.kill(int(wait_until(lambda: node_pid(carav.run_root, "t"), "t's pid", run)), signal.SIGKILL)
            wait_until(lambda: "restarting 't'" in run.stderr(), "the supervisor to restart t", run)
        # the moment of the kill, drawn at random (not a wait for work): before, during or after the imports of
        # the nodes being started
        time.sleep(rng.uniform(0.0, 1.2))
        os.kill(run.proc.pid, signal.SIGKILL)
        run.proc.wait(10)
        try:
            wait_until(lambda: not run_processes(carav.run_root),
                       f"every node to die with its supervisor (kill {i + 1} at {moment})", run)
        except AssertionError as exc:
            raise AssertionError(f"{exc}; still alive: {run_processes(carav.run_root)}") from None
        run.kill()
