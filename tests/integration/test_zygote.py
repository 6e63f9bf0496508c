"""Nodes forked from the supervisor's zygote (runtime/launcher.py) are the supervisor's own children, die with it,
are restarted through the same zygote, and start as fresh interpreters, with one line saying why, when the zygote
is gone or the graph says not to use one. tests/runtime/test_zygote.py holds what a forked process holds."""
import os
import signal
from pathlib import Path

import pytest

from carav_stream.testing.graphs import node_pids
from tests.integration.conftest import exit_code_after_a_kill, read_jsonl, wait_until
from tests.integration.test_forged_senders import restarted
from tests.integration.test_supervisor_death import CHAIN  # a restarting three-node chain, paced by its tagger

pytestmark = pytest.mark.integration


def _stat(pid: int) -> list[str] | None:
    """Fields 3 on of /proc/PID/stat (state first, then the parent's pid), or None when no such process runs."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None


def alive(pid: int) -> bool:
    fields = _stat(pid)
    return fields is not None and fields[0] != "Z"


def zygotes_of(supervisor: int) -> list[int]:
    """The live zygotes among the supervisor's children."""
    found = []
    for proc in Path("/proc").iterdir():
        fields = _stat(int(proc.name)) if proc.name.isdigit() else None
        try:
            forks = fields is not None and b"--zygote" in (proc / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if forks and fields[0] != "Z" and int(fields[1]) == supervisor:
            found.append(int(proc.name))
    return found


def forked(pid: int) -> bool:
    """A forked node's command line was written over its zygote's longer one: the rest is NUL bytes."""
    return Path(f"/proc/{pid}/cmdline").read_bytes().endswith(b"\0\0")


def frames_beyond(carav, n: int, run) -> int:
    return wait_until(lambda: len(read_jsonl(carav.workdir / "out.jsonl")) > n and
                      len(read_jsonl(carav.workdir / "out.jsonl")), f"more than {n} frames", run)


def test_forked_nodes_are_the_supervisors_children_and_die_with_it_as_does_the_zygote(carav):
    run = carav.run(carav.graph(CHAIN))
    frames_beyond(carav, 5, run)
    nodes = node_pids(carav.run_root)
    assert len(nodes) == 3
    assert all(forked(pid) and int(_stat(pid)[1]) == run.proc.pid for pid in nodes)
    [zygote] = zygotes_of(run.proc.pid)
    os.kill(run.proc.pid, signal.SIGKILL)
    run.proc.wait()
    wait_until(lambda: not any(alive(pid) for pid in [*nodes, zygote]),
               "every node and the zygote to die with the supervisor", run)


def test_a_node_restarts_forked_and_fresh_once_the_zygote_is_gone_saying_so_once(carav):
    run = carav.run(carav.graph(CHAIN))
    n = frames_beyond(carav, 5, run)
    (old,) = node_pids(carav.run_root, "t")
    carav.kill_node("t")
    wait_until(lambda: "restarting 't' (1/3)" in run.stderr(), "the supervisor to restart t", run)
    # the successor up and reporting (frames t sent before it died may still reach the log): the zygote is killed
    # below only once it has answered for this restart
    new = restarted(carav, run, "t", old)
    n = frames_beyond(carav, n, run)
    assert forked(new)
    [zygote] = zygotes_of(run.proc.pid)
    os.kill(zygote, signal.SIGKILL)
    carav.kill_node("t")
    wait_until(lambda: "restarting 't' (2/3)" in run.stderr(), "the supervisor to restart t again", run)
    n = frames_beyond(carav, n, run)
    assert not any(forked(pid) for pid in node_pids(carav.run_root, "t"))
    assert carav.cli("stop").returncode == 0
    code = run.wait()
    s = run.summary()
    assert code == exit_code_after_a_kill(s, "t"), run.stderr()
    said = [line for line in run.stderr().splitlines() if "zygote" in line]
    assert said == [f"carav: the zygote (pid {zygote}) ended with signal SIGKILL; every node starts as a fresh "
                    "interpreter from now on"], run.stderr()
    assert s["node_starts"] == {"forked": 4, "fresh": 1} and s["restarts"] == 2, (s["node_starts"], s["restarts"],
                                                                                 run.stderr())


def test_a_graph_can_start_its_nodes_as_fresh_interpreters(carav):
    run = carav.run(carav.graph(CHAIN), "--cycles", "20", "--set", "run.zygote=false")
    assert run.wait() == 0, run.stderr()
    assert run.summary()["node_starts"] == {"forked": 0, "fresh": 3}
