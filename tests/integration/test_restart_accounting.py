"""Restarts never rewrite history: a SIGKILLed node restarted by policy is counted once, and a restarted sink keeps
what it wrote. Real processes, SIGKILL of a node's own pid (found in /proc), restart policy on-failure."""
import csv
import json
import os
import signal
from pathlib import Path

import pytest

from carav_stream.testing.graphs import node_pids
from tests.integration.conftest import read_jsonl, wait_until

pytestmark = pytest.mark.integration

# a chain slowed by its tagger (5 ms a frame, queues of 2 frames): the source's counters at its last heartbeat
# are at most about 0.5 s x 200 frames/s behind what it really did when it is killed
CHAIN = """
connections = ["src.out -> t.inp", "t.out -> log.inp", "t.out -> csv.estimates"]
[run]
cycles = 0
queue_frames = 2
[restart]
policy = "on-failure"
max_restarts = 5
[blocks]
src = { type = "counter_source" }
t = { type = "tagger", delay_s = 0.005 }
log = { type = "jsonl_sink", path = "out.jsonl" }
csv = { type = "csv_sink", path = "out.csv", columns = ["value"] }
"""
STALE_FRAMES = 120     # what a killed node may have done after its last heartbeat, with a margin


def node_pid(carav, node: str) -> int | None:
    """The pid of the one live process of `node`."""
    pids = node_pids(carav.run_root, node)
    return pids[0] if len(pids) == 1 else None


def kill_and_wait_for_restart(carav, run, node: str, n: int) -> None:
    os.kill(int(wait_until(lambda: node_pid(carav, node), f"{node}'s pid", run)), signal.SIGKILL)
    wait_until(lambda: f"restarting {node!r} ({n}/5)" in run.stderr(), f"the supervisor to restart {node}", run)


def grow(run, path: Path, more_than: int, what: str) -> int:
    """Wait while the sink's file grows (a deadline that restarts with every new line) until it has more lines."""
    last, n = -1, 0
    while n <= more_than:
        n = wait_until(lambda: (k := len(read_jsonl(path))) > last and k, what, run)
        last = n
    return n


def test_a_restarted_source_counts_each_cycle_once_in_the_summary_and_status(carav):
    run = carav.run(carav.graph(CHAIN))
    out = carav.workdir / "out.jsonl"
    for i in (1, 2):
        n = grow(run, out, 300 * i, "frames before killing the source")
        kill_and_wait_for_restart(carav, run, "src", i)
    grow(run, out, n + 200, "frames after the restarts")
    status = carav.cli("status", "--json")
    assert status.returncode == 0, status.stderr
    [live] = json.loads(status.stdout)
    assert carav.cli("stop").returncode == 0
    run.wait()
    s = run.summary()
    lines = read_jsonl(out)
    seqs = [line["seq"] for line in lines]
    assert seqs == sorted(set(seqs))                          # none judged twice or out of order
    assert s["per_node"]["src"]["restarts"] == 2
    # the source's cycles: what it generated, each once (not its dead incarnations' counters again): within what
    # the killed incarnations did after their last heartbeats of the frames that reached the sink
    assert abs(s["cycles"] - len(lines)) <= 2 * STALE_FRAMES + s["lost"], (s["cycles"], len(lines), s["lost"])
    assert s["throughput_cycles_per_s"] == pytest.approx(s["cycles"] / s["wall_s"])
    # carav status, asked while it ran: its count of cycles is no larger than what the run generated in all
    assert live["cycles"] <= len(lines) + 2 * STALE_FRAMES + s["lost"], (live["cycles"], len(lines))
    assert live["nodes"]["src"]["cycles_per_s"] * live["elapsed_s"] == pytest.approx(live["cycles"], rel=0.01)


def test_restarted_jsonl_and_csv_sinks_append_and_keep_every_line_they_wrote(carav):
    run = carav.run(carav.graph(CHAIN))
    out, table = carav.workdir / "out.jsonl", carav.workdir / "out.csv"
    grow(run, out, 150, "frames before killing the sinks")
    before = read_jsonl(out)
    rows_before = list(csv.reader(table.open()))
    kill_and_wait_for_restart(carav, run, "log", 1)
    kill_and_wait_for_restart(carav, run, "csv", 1)
    grow(run, out, len(before) + 150, "frames after the sinks' restarts")
    assert carav.cli("stop").returncode == 0
    run.wait()
    s = run.summary()
    lines = read_jsonl(out)
    rows = list(csv.reader(table.open()))
    assert lines[:len(before)] == before                       # nothing it wrote before the kill is gone
    assert rows[:len(rows_before)] == rows_before
    assert rows[0] == ["cycle", "port", "value"] and rows.count(rows[0]) == 1
    seqs = [line["seq"] for line in lines]
    assert seqs == sorted(set(seqs)) and seqs[0] == 0
    cycles = [int(r[0]) for r in rows[1:]]
    assert cycles == sorted(set(cycles)) and cycles[0] == 0
    assert s["per_node"]["log"]["restarts"] == 1 and s["per_node"]["csv"]["restarts"] == 1


def test_a_sink_on_a_full_disk_fails_once_in_one_line_and_is_not_restarted(carav):
    # /dev/full takes the open and refuses every write with ENOSPC: a restarted sink would meet the same disk
    graph = CHAIN.replace('path = "out.jsonl"', 'path = "/dev/full"')
    run = carav.run(carav.graph(graph), "--cycles", "40")
    assert run.wait() == 1, run.stderr()
    err = run.stderr()
    assert "Traceback" not in err and "restarting 'log'" not in err, err
    line = ("carav: node 'log' (jsonl_sink) failed: exited with status 1: BlockError: /dev/full: cannot write: "
            "No space left on device (not restarted: a new process would meet the same fault)")
    assert line in err.splitlines(), err
    summary = run.summary()
    assert summary["per_node"]["log"]["restarts"] == 0 and len(summary["failures"]) == 1
