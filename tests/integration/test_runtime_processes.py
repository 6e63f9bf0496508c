"""Real graphs of real processes: counts, order, back-pressure, swap, crash and restart, clean shutdown."""
import json
import re
import signal

import msgpack
import numpy as np
import pytest
import zmq

from carav_stream.runtime.frames import Frame, encode
from carav_stream.runtime.graph import TRANSPORTS
from tests.integration.conftest import read_jsonl, wait_until

pytestmark = pytest.mark.integration

CHAIN = """
connections = ["src.out -> t.inp", "t.out -> add.a", "src.out -> add.b", "add.out -> log.inp"]
[run]
cycles = {cycles}
[blocks]
src = {{ type = "counter_source" }}
t = {{ type = "tagger", tag = "x", offset = 1.0, delay_s = {delay} }}
add = {{ type = "adder" }}
log = {{ type = "jsonl_sink", path = "out.jsonl" }}
"""


# a chain moving 64 x 1100 frames through queues of 2 frames, its tagger taking `delay` per frame
LARGE_FRAME_CHAIN = """
connections = ["src.out -> t.inp", "t.out -> log.inp"{edges}]
[run]
queue_frames = 2
{run}
[blocks]
src = {{ type = "counter_source", rows = 64, n_values = 1100 }}
t = {{ type = "tagger", delay_s = {delay} }}
log = {{ type = "jsonl_sink", path = "out.jsonl", max_values = 0 }}
{blocks}"""


def test_fan_out_and_pairing_deliver_every_frame_once_in_order(carav):
    n = 3000
    run = carav.run(carav.graph(CHAIN.format(cycles=n, delay=0.0)))
    assert run.wait() == 0, run.stderr()
    lines = read_jsonl(carav.workdir / "out.jsonl")
    assert [l["seq"] for l in lines] == list(range(n))
    assert all(l["data"] == [2.0 * l["seq"] + 1.0] * 4 for l in lines)
    assert lines[5]["trail"] == ["src:counter_source@1#0", "t:tagger@1#0", "add:adder@1#0"]
    s = run.summary()
    assert s["cycles"] == n and s["lost"] == 0 and s["rejected"] == 0 and s["unpaired"] == 0
    assert s["per_node"]["add"]["in"] == {"a": n, "b": n} and s["per_node"]["log"]["in"] == {"inp": n}
    assert s["per_node"]["src"]["sent"] == {"src.out -> t.inp": n, "src.out -> add.b": n}
    assert s["throughput_cycles_per_s"] > 0 and s["per_node"]["log"]["history"][0]["summary"] == {"lines": n}
    assert all(p["busy_s"] > 0 and p["cpu_s"] > 0 for p in s["per_node"].values())   # time in blocks, process CPU
    # CPU from the first frame on holds the block's time and leaves the start-up (imports) out
    assert all(p["busy_s"] <= p["cpu_working_s"] < p["cpu_s"] for p in s["per_node"].values()), s["per_node"]


def test_frames_carrying_several_cycles_are_counted_as_cycles_and_the_last_is_sized_to_the_budget(carav):
    body = """
connections = ["src.out -> log.inp"]
[blocks]
src = { type = "counter_source", batch = 4, n_values = 2 }
log = { type = "jsonl_sink", path = "out.jsonl" }
"""
    run = carav.run(carav.graph(body), "--cycles", "10")
    assert run.wait() == 0, run.stderr()
    lines = read_jsonl(carav.workdir / "out.jsonl")
    assert [(l["seq"], l["cycle"], l["cycles"]) for l in lines] == [(0, 0, 4), (1, 4, 4), (2, 8, 2)]
    assert [row[0] for l in lines for row in l["data"]] == list(range(10))
    s = run.summary()
    assert s["cycles"] == 10 and s["lost"] == 0
    assert s["per_node"]["src"]["processed"] == 3 and s["per_node"]["log"]["cycles"] == 10


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_slow_consumer_slows_the_producer_and_nothing_is_dropped(carav):
    n = 300
    body = LARGE_FRAME_CHAIN.format(edges="", run=f"cycles = {n}", delay=0.01, blocks="")
    run = carav.run(carav.graph(body))
    gaps = []

    def sample():
        st = carav.cli("status", "--json")
        if st.returncode == 0 and st.stdout.strip().startswith("["):
            for s in json.loads(st.stdout):
                nodes = s["nodes"]
                made = sum(nodes["src"]["counters"].get("out", {}).values())
                done = sum(nodes["log"]["counters"].get("in", {}).values())
                # the two counts come from two heartbeats: by how much the source's is newer than the sink's
                apart = sum(s["edges"][e]["counters_apart_s"] for e in ("src.out -> t.inp", "t.out -> log.inp"))
                if 0 < made < n:       # while the source still produces (its last report is final)
                    gaps.append((made - done, max(0.0, apart)))
        return run.proc.poll() is not None or len(gaps) >= 5
    wait_until(sample, "status samples", run)
    assert run.wait() == 0, run.stderr()
    assert len(read_jsonl(carav.workdir / "out.jsonl")) == n and run.summary()["lost"] == 0
    # 300 frames at >= 10 ms each take >= 3 s; a producer without back-pressure would be done at once.
    # With queues of 2 frames the source stays within a bounded distance of the sink. The sink's count may be
    # older than the source's (a loaded machine delays heartbeats): the sink took at most one frame per 10 ms (the
    # tagger's delay) meanwhile, so those frames are not counted as distance.
    assert gaps and max(gap - apart / 0.01 for gap, apart in gaps) < 60, gaps


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_a_slow_tap_never_slows_the_chain_and_what_it_skips_is_counted_skipped_not_lost(carav):
    """The same slow consumer as above, but on a tap input beside a fast chain: the producer does not wait for
    it; the tap sees an increasing subset of the frames and every other frame is counted skipped on its edge."""
    n = 400
    body = LARGE_FRAME_CHAIN.format(edges=', "src.out -> view.inp"', run=f"cycles = {n}", delay=0.0,
                                    blocks='view = { type = "slow_tap", delay_s = 0.02, path = "seen.txt" }')
    run = carav.run(carav.graph(body))
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    seen = [int(x) for x in (carav.workdir / "seen.txt").read_text().split()]
    assert len(read_jsonl(carav.workdir / "out.jsonl")) == n and s["lost"] == 0 and s["rejected"] == 0
    assert seen == sorted(set(seen)) and len(seen) < n / 2          # at 20 ms a frame it could not keep up
    edge = "src.out -> view.inp"
    assert s["skipped_by_taps"] == {edge: n - len(seen)}
    assert s["per_node"]["src"]["sent"][edge] == len(seen) == s["per_node"]["view"]["in"]["inp"]
    assert f"frames skipped for a busy observer (a tap, not lost): {n - len(seen)} on {edge}" in run.stdout()


def test_live_swaps_lose_duplicate_and_reorder_nothing(carav):
    body = """
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[blocks]
src = { type = "counter_source", n_values = 1 }
t = { type = "tagger", tag = "first", offset = 0.5, delay_s = 0.001 }
log = { type = "jsonl_sink", path = "out.jsonl" }
"""
    run = carav.run(carav.graph(body))   # runs until stopped: the swaps happen mid-stream whatever the load
    out = carav.workdir / "out.jsonl"
    swaps = [("tagger_b", ["factor=3.0", "delay_s=0.001"]), ("tagger", ["tag=again", "offset=7", "delay_s=0.001"]),
             ("tagger_b", ["factor=-1"])]
    for i, (block, sets) in enumerate(swaps):
        wait_until(lambda: len(read_jsonl(out)) > (i + 1) * 500, f"frames before swap {i}", run)
        res = carav.cli("swap", "t", block, *sum((["--set", s] for s in sets), []))
        assert res.returncode == 0, res.stderr
        assert f"now {block}" in res.stdout
    refused = carav.cli("swap", "t", "adder")
    assert refused.returncode == 3 and "has no input 'inp'" in refused.stderr
    wait_until(lambda: len(read_jsonl(out)) > 2500, "frames after the last swap", run)
    status = carav.cli("status").stdout                            # the swaps in words, not @1#1
    assert re.search(r"swap: node t runs block tagger \(version 1\)( \([^)]*\))? from (cycle \d+ \()?frame seq",
                     status), status
    assert "its swap number 2" in status
    assert "frames/s" in status and "cycles/s" in status
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    lines = read_jsonl(out)
    n = run.summary()["cycles"]
    assert [l["seq"] for l in lines] == list(range(n))          # none lost, duplicated or reordered
    gens = [int(l["trail"][1].rsplit("#", 1)[1]) for l in lines]
    assert gens == sorted(gens) and set(gens) == {0, 1, 2, 3}
    expected = {0: lambda v: v + 0.5, 1: lambda v: v * 3.0, 2: lambda v: v + 7.0, 3: lambda v: -v}
    for l, g in zip(lines, gens):
        assert l["data"] == [expected[g](float(l["seq"]))], l   # each frame handled by the block its trail names
    blocks = [l["trail"][1].split("@")[0] for l in lines]
    assert {blocks[gens.index(g)] for g in (1, 3)} == {"t:tagger_b"}
    s = run.summary()
    assert [sw["block"] for sw in s["swaps"]] == ["tagger_b", "tagger", "tagger_b"]
    assert [sw["first_seq"] for sw in s["swaps"]] == [gens.index(1), gens.index(2), gens.index(3)]
    assert s["lost"] == 0


def test_a_swap_asked_while_the_node_is_still_starting_waits_for_it_instead_of_being_dropped(carav):
    # the swap goes out as soon as the run exists, the swapped node listed last so it starts last: a request sent
    # before its control connection is up must wait for it, not vanish (the swap would be refused after 30 s).
    # The run lasts until stopped, so that however slow the swap command, the stream has not ended before it.
    body = """
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[blocks]
src = { type = "counter_source", n_values = 1 }
log = { type = "jsonl_sink", path = "out.jsonl" }
t = { type = "tagger", tag = "first", offset = 0.5 }
"""
    run = carav.run(carav.graph(body))
    res = None
    for _ in range(200):
        res = carav.cli("swap", "t", "tagger_b", "--set", "factor=3.0")
        if "no running graph" not in res.stderr:
            break
    assert res.returncode == 0 and "now tagger_b" in res.stdout, res.stderr
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert [sw["block"] for sw in s["swaps"]] == ["tagger_b"] and s["lost"] == 0



def test_a_swap_of_a_node_whose_stream_has_ended_is_refused_at_once_and_the_run_goes_on(carav):
    # one branch ends after 3 frames, the other runs until stopped: the ended node can take no swap, and the
    # request is answered with why at once (not left to the 30 s deadline, and not hung when the run ends)
    body = """
connections = ["a.out -> t.inp", "t.out -> log.inp", "b.out -> u.inp", "u.out -> log2.inp"]
[blocks]
a = { type = "counter_source", n_values = 1, frames = 3 }
t = { type = "tagger", tag = "ends" }
log = { type = "jsonl_sink", path = "out.jsonl" }
b = { type = "counter_source", n_values = 1 }
u = { type = "tagger", tag = "goes on", delay_s = 0.001 }
log2 = { type = "jsonl_sink", path = "out2.jsonl" }
"""
    run = carav.run(carav.graph(body))

    def t_state():
        st = carav.cli("status", "--json")
        runs = json.loads(st.stdout) if st.returncode == 0 and st.stdout.strip().startswith("[") else []
        return runs[0]["nodes"]["t"]["counters"].get("state", "") if runs else ""

    wait_until(lambda: t_state().startswith("finished"), "node t to finish its 3 frames", run)
    refused = carav.cli("swap", "t", "tagger_b", "--set", "factor=3.0")
    assert refused.returncode == 3 and "node 't' has ended its stream" in refused.stderr, refused.stderr
    before = len(read_jsonl(carav.workdir / "out2.jsonl"))
    wait_until(lambda: len(read_jsonl(carav.workdir / "out2.jsonl")) > before + 50, "the other branch", run)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["swaps"] == [] and [r["node"] for r in s["refused_swaps"]] == ["t"] and s["lost"] == 0
    assert len(read_jsonl(carav.workdir / "out.jsonl")) == 3


CRASH = """
connections = ["src.out -> c.inp", "c.out -> log.inp"]
[run]
cycles = 400
[blocks]
src = { type = "counter_source", n_values = 1 }
c = { type = "crasher", at_seq = 50, marker = "%s" %s }
log = { type = "jsonl_sink", path = "out.jsonl" }
"""


def test_crashed_block_is_named_with_its_traceback_and_the_run_fails(carav):
    run = carav.run(carav.graph(CRASH % ("", "")))
    assert run.wait() == 1
    err = run.stderr()
    assert "node 'c' (crasher) failed" in err and "Traceback" in err
    assert "RuntimeError: deliberate crash at seq 50" in err
    s = run.summary()
    assert s["failures"] and "node 'c' (crasher) failed" in s["failures"][0]
    got = [l["seq"] for l in read_jsonl(carav.workdir / "out.jsonl")]
    assert got == list(range(len(got))) and len(got) <= 50
    # c sent seq 0..49 before it raised; whatever did not reach the sink is counted lost on that edge
    assert s["lost_by_edge"].get("c.out -> log.inp", 0) == 50 - len(got)
    wait_until(lambda: not run.group_alive() or run.proc.poll() is not None, "process group to end", run)


def test_crashed_block_restarts_by_policy_and_the_loss_is_accounted(carav):
    # An endless source, so that the restarted c has frames to take whatever the machine's speed: tiny frames fit by
    # the hundred in the sockets' buffers, and a 400-cycle source could have sent them all (and lost them with c)
    # before c came back. Stopped once frames well past the crash have reached the sink.
    marker = carav.workdir / "crashed-once"
    run = carav.run(carav.graph(CRASH.replace("cycles = 400", "cycles = 0") % (marker, ', restart = "on-failure"')))
    wait_until(lambda: any(l["seq"] > 150 for l in read_jsonl(carav.workdir / "out.jsonl")),
               "frames after the restart", run)
    run.proc.send_signal(signal.SIGINT)
    code = run.wait()
    err = run.stderr()
    assert "node 'c' (crasher) failed" in err and "restarting 'c' (1/3)" in err
    s = run.summary()
    got = [l["seq"] for l in read_jsonl(carav.workdir / "out.jsonl")]
    assert s["restarts"] == 1 and got == sorted(set(got)) and got[-1] > 150
    assert s["estimated_counts"] == []      # the crash was reported with final counters: the counts are exact
    assert got[:50] == list(range(50))
    # every cycle the source made is either delivered or counted lost: none vanishes silently
    assert len(got) + s["lost"] == s["cycles"], (len(got), s["lost"], s["cycles"], s["lost_by_edge"])
    # frames lost with the crashed incarnation outrank the interruption in the exit code
    assert s["stopped_by"] == "signal" and code == (1 if s["lost"] else 130)


def test_sigint_drains_in_order_and_leaves_no_process_or_endpoint(carav):
    run = carav.run(carav.graph(CHAIN.format(cycles=0, delay=0.0)))
    wait_until(lambda: len(read_jsonl(carav.workdir / "out.jsonl")) > 200, "frames to flow", run)
    run_dirs = list(carav.run_root.glob("carav-*/*"))
    assert len(run_dirs) == 1 and oct(run_dirs[0].stat().st_mode & 0o777) == "0o700"
    run.proc.send_signal(signal.SIGINT)
    assert run.wait() == 130, run.stderr()                        # interrupted: drained, but not finished
    s = run.summary()
    lines = read_jsonl(carav.workdir / "out.jsonl")
    assert s["lost"] == 0 and s["stopped_by"] == "signal"
    assert [l["seq"] for l in lines] == list(range(s["cycles"]))   # sources stopped first, all drained
    assert not run_dirs[0].exists()
    wait_until(lambda: not run.group_alive(), "no orphan in the process group", run)


def test_status_and_stop_commands_reach_the_running_graph(carav):
    run = carav.run(carav.graph(CHAIN.format(cycles=0, delay=0.0)))
    wait_until(lambda: len(read_jsonl(carav.workdir / "out.jsonl")) > 50, "frames to flow", run)
    st = carav.cli("status")
    assert st.returncode == 0 and "add" in st.stdout and "tagger" in st.stdout and "/s" in st.stdout
    (admin,) = carav.run_root.glob("carav-*/*/admin")
    ctx = zmq.Context()
    req = ctx.socket(zmq.REQ)
    req.linger = 0
    req.connect(f"ipc://{admin}")
    for garbage in (b"\xc1", msgpack.packb([1, 2])):          # a garbled request gets an answer, not a crash
        req.send(garbage)
        assert req.poll(10_000), "the supervisor did not answer a bad request"
        reply = msgpack.unpackb(req.recv())
        assert reply["ok"] is False and "bad admin request" in reply["error"]
    req.close()
    ctx.term()
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0
    assert run.summary()["lost"] == 0 and run.summary()["stopped_by"] == "carav stop"
    assert "no running graphs" in carav.cli("status").stdout


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_a_run_that_cannot_drain_is_killed_at_its_deadline_and_says_where_each_node_stood(carav):
    """A consumer that takes 3 s a frame keeps the source blocked on a full queue after `carav stop`: at the
    drain deadline the supervisor kills what is left, fails the run and names, for each node it killed, what
    that node was doing at its last heartbeat (the edge it was blocked on, the seqs it held)."""
    body = LARGE_FRAME_CHAIN.format(edges="", run="drain_timeout_s = 2.0", delay=3.0, blocks="")
    run = carav.run(carav.graph(body))

    def blocked():
        st = carav.cli("status", "--json")
        if st.returncode != 0 or not st.stdout.strip().startswith("["):
            return False
        # the source blocked on t's full queue, and t heard from once (a node reports between frames: t, in its
        # first 3 s frame from the start, would otherwise be killed having said nothing)
        return any("queue full" in s["nodes"]["src"]["counters"].get("state", "")
                   and "inp: " in s["nodes"]["t"]["counters"].get("state", "") for s in json.loads(st.stdout))
    wait_until(blocked, "the source to block on t's full queue and t to report", run)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 1, run.stderr()
    (failure,) = [f for f in run.summary()["failures"] if "drain deadline" in f]
    assert failure.startswith("drain deadline of 2 s passed; killed ['src', 't', 'log']"), failure
    states = dict(line.strip().split(": ", 1) for line in failure.splitlines()[1:])
    assert states["src"].startswith("sending on src.out -> t.inp (queue full); seq "), failure
    # log had taken t's first frame or not at its last heartbeat, as the machine's load had it: 0 or 1 buffered
    assert states["log"].startswith("waiting for input; seq ") and re.search(r"inp: [01] buffered", states["log"]), \
        failure
    assert "inp: " in states["t"] and "last seq " in states["t"], failure


def inject_into_t_then_stop(carav, run, bad: list[list]) -> str:
    """Push the messages `bad` into the running graph's t.inp from outside; once every one is reported rejected and
    100 more frames went through, stop the graph (it must end cleanly); its stderr."""
    (endpoint,) = carav.run_root.glob("carav-*/*/t.inp")
    ctx = zmq.Context()
    rogue = ctx.socket(zmq.PUSH)
    rogue.linger = 2000
    rogue.connect(f"ipc://{endpoint}")
    for parts in bad:
        rogue.send_multipart(parts)
    rogue.close()
    ctx.term()
    wait_until(lambda: f"rejected frame #{len(bad)}" in run.stderr(), f"{len(bad)} rejections reported", run)
    n_before = len(read_jsonl(carav.workdir / "out.jsonl"))
    wait_until(lambda: len(read_jsonl(carav.workdir / "out.jsonl")) > n_before + 100, "graph still running", run)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0
    return run.stderr()


def test_bad_messages_are_rejected_counted_and_named_while_the_graph_runs_on(carav):
    run = carav.run(carav.graph(CHAIN.format(cycles=0, delay=0.0)))
    wait_until(lambda: len(read_jsonl(carav.workdir / "out.jsonl")) > 50, "frames to flow", run)
    bad = [
        [b"\xc1not msgpack"],
        [msgpack.packb({"v": 1, "stream": "x.y", "seq": 10**9, "cycle": 0, "eos": False,
                        "arrays": [["data", "float64", [1000]]]}), b"\x00" * 16],      # truncated payload
        [msgpack.packb({"v": 1, "stream": "x.y", "seq": 10**9, "cycle": 0, "eos": False,
                        "arrays": [["data", "object", [1]]]}), b"\x00" * 8],           # forbidden dtype
        encode(Frame.of(np.zeros(4)), seq=0, stream="x.y"),                            # well formed, not its producer
    ]
    err = inject_into_t_then_stop(carav, run, bad)
    assert "node 't' input 'inp': rejected frame #1: header is not valid msgpack" in err
    assert "needs 8000 bytes, buffer has 16" in err and "dtype 'object' is not allowed" in err
    assert "not by this input's producer" in err          # well formed: refused for who sent it
    s = run.summary()
    assert s["rejected"] == 4 and s["per_node"]["t"]["rejected"] == {"inp": 4}
    lines = read_jsonl(carav.workdir / "out.jsonl")
    assert [l["seq"] for l in lines] == list(range(s["cycles"]))


BIG_CHAIN = """
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[blocks]
src = { type = "counter_source", rows = 64, n_values = 1100 }
t = { type = "tagger" }
log = { type = "jsonl_sink", path = "out.jsonl", max_values = 0 }
"""


@pytest.mark.parametrize("carav", ["shm"], indirect=True)
def test_bad_slot_references_are_rejected_counted_and_named_while_the_graph_runs_on(carav):
    """Over shared memory: headers naming a slot outside the segment, more bytes than a slot holds, a generation
    the slot does not hold, or carrying buffer parts besides are refused with the reason; the graph runs on."""
    run = carav.run(carav.graph(BIG_CHAIN))
    wait_until(lambda: len(read_jsonl(carav.workdir / "out.jsonl")) > 50, "frames to flow", run)
    head = {"v": 1, "stream": "x.y", "seq": 10**9, "cycle": 0, "eos": False}
    data = [["data", "float64", [64, 1100]]]
    bad = [
        [msgpack.packb({**head, "arrays": data, "shm": [999, 1]})],                  # outside the segment
        [msgpack.packb({**head, "arrays": [["data", "float64", [1 << 24]]], "shm": [0, 1]})],   # too large
        [msgpack.packb({**head, "arrays": data, "shm": [0, 10**12]})],               # stale generation
        [msgpack.packb({**head, "arrays": data, "shm": [0, 1]}), b"\x00" * 8],       # buffer parts besides
        [msgpack.packb({**head, "arrays": data, "shm": "slot 0"})],                  # not a reference
    ]
    err = inject_into_t_then_stop(carav, run, bad)
    assert "slot 999 is outside the segment's" in err and "a slot holds" in err
    assert "stale generation 1000000000000" in err and "the header alone" in err
    assert "header key 'shm' must be list" in err
    s = run.summary()
    assert s["rejected"] == 5 and s["per_node"]["t"]["rejected"] == {"inp": 5} and s["lost"] == 0
    assert [l["seq"] for l in read_jsonl(carav.workdir / "out.jsonl")] == list(range(s["cycles"]))
    src = s["shared_memory"]["src.out"]
    assert src["frames_in_slots"] + src["frames_inline"] == s["cycles"], src
    assert src["frames_in_slots"] > s["cycles"] // 2, src


def test_invalid_graph_starts_nothing_and_names_the_problem(carav):
    run = carav.run(carav.graph(CHAIN.format(cycles=5, delay=0.0).replace('"adder"', '"addr"')))
    assert run.wait() == 3
    assert "blocks.add.type: unknown block type 'addr'" in run.stderr()
    assert not list(carav.run_root.glob("carav-*/*"))
