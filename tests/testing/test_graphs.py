"""The kit's graph helpers on a real graph, through the plugin's own `carav` fixture: a node killed mid-run comes
back under its restart policy and the stream goes on in order (what died with it is counted lost); a node swapped
mid-run carries on from where the old block stopped."""
import os
import shutil
import signal
import subprocess
import sys

import pytest

from carav_stream.testing.graphs import by_cycle, node_pids, read_jsonl, wait_for
from carav_stream.testing.waiting import group_cpu_s, wait_until
from tests.integration.conftest import TOYS, exit_code_after_a_kill

pytestmark = pytest.mark.integration

CHAIN = """
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[run]
cycles = 0
[restart]
policy = "on-failure"
[blocks]
src = { type = "counter_source" }
t = { type = "tagger", tag = "a", delay_s = 0.002 }
log = { type = "jsonl_sink", path = "out.jsonl" }
"""


def test_kill_node_and_swap_steer_a_running_graph_and_nothing_is_lost(carav):
    out = carav.workdir / "out.jsonl"
    run = carav.run(carav.graph(CHAIN, block_paths=[TOYS]))     # the plugin's fixture, as a user has it
    wait_for(lambda: len(read_jsonl(out)) > 30, "frames before the kill", run)
    killed = carav.kill_node("t")
    wait_for(lambda: "restarting 't'" in run.stderr(), "the supervisor to restart t", run)
    wait_for(lambda: node_pids(carav.run_root, "t") and killed not in node_pids(carav.run_root, "t"),
             "t's new process", run)
    seen = len(read_jsonl(out))
    wait_for(lambda: len(read_jsonl(out)) > seen + 30, "frames after the restart", run)
    reply = carav.swap("t", "tagger_b", factor=2.0)
    assert "now t" in reply.stdout + reply.stderr
    wait_for(lambda: any(r.get("tag") == "b2" for r in read_jsonl(out)), "frames of the swapped-in block", run)
    assert carav.cli("stop").returncode == 0
    code = run.wait()
    s = run.summary()
    assert s["restarts"] == 1 and s["estimated_counts"] == ["t"] and not s["failures"], s["failures"]
    assert code == exit_code_after_a_kill(s, "t"), run.stderr()
    assert len(s["swaps"]) == 1 and s["swaps"][0]["block"] == "tagger_b"
    records = read_jsonl(out)
    seqs = [r["seq"] for r in records]
    assert seqs == sorted(set(seqs)), "a frame judged twice or out of order"
    tags = [r["tag"] for r in records]
    assert tags[0] == "a" and tags[-1] == "b2" and "a" not in tags[tags.index("b2"):]
    assert sorted(by_cycle(records)) == sorted(r["cycle"] for r in records)


def test_a_test_process_killed_mid_run_takes_its_graph_along(tmp_path):
    """The kit's runs die with the process that started them (a test killed by a CI timeout leaves no graph
    running on): the test process here is a child SIGKILLed while its endless graph runs."""
    graph = tmp_path / "g.toml"
    graph.write_text(f"block_paths = [{str(TOYS)!r}]\n" + CHAIN)
    script = ("import time; from carav_stream.testing.graphs import Graphs; "
              f"g = Graphs({str(tmp_path)!r}); r = g.run({str(graph)!r}); print(g.run_root, r.pgid, flush=True); "
              "time.sleep(3600)")
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    run_root, pgid = child.stdout.readline().split()
    progress = lambda: group_cpu_s(int(pgid))  # noqa: E731
    wait_until(lambda: len(read_jsonl(tmp_path / "out.jsonl")) > 5, "the graph to run", progress)
    assert node_pids(run_root)
    os.kill(child.pid, signal.SIGKILL)
    child.wait()
    wait_until(lambda: not node_pids(run_root), "the graph's nodes to go with the test process", progress)
    shutil.rmtree(run_root, ignore_errors=True)
