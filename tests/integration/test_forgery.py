"""Well-formed forged messages pushed into a running graph's inputs from another process, on both data planes:
each is refused with its reason and counted rejected on its input, the graph keeps running, and it stops
cleanly with nothing lost. Forged clean verdicts never let an attacked cycle reach ranging."""
import json
import re
from pathlib import Path

import msgpack
import numpy as np
import pytest
import zmq

from carav_stream.runtime.frames import Frame, encode
from carav_stream.runtime.graph import TRANSPORTS
from tests.integration.conftest import PACED, read_jsonl, wait_until

pytestmark = pytest.mark.integration

TAPS = Path(__file__).resolve().parent / "graphs"

CHAIN = """
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[blocks]
src = { type = "counter_source", rows = 64, n_values = 64 }
# 50 frames a second: a forged message waits behind the frames queued for t (about 90 on shared memory, 45 over
# ZeroMQ), so this rate sets the test's length
t = { type = "tagger", delay_s = 0.02 }
log = { type = "jsonl_sink", path = "out.jsonl", max_values = 0 }
"""


def push(carav, port: str, messages: list[list]) -> None:
    """Send `messages` into the running graph's input `port` ("node.port") from this process."""
    (endpoint,) = carav.run_root.glob(f"carav-*/*/{port}")
    ctx = zmq.Context()
    rogue = ctx.socket(zmq.PUSH)
    rogue.linger = 120_000   # a full queue (a slow graph) takes the messages as the node reads them
    rogue.connect(f"ipc://{endpoint}")
    for parts in messages:
        rogue.send_multipart(parts)
    rogue.close()
    ctx.term()


def advancing(carav, path: Path, what: str, more: int = 20) -> None:
    """Wait until `path` (a jsonl sink's file) holds `more` lines more than now; the deadline restarts while
    it grows (a busy machine slows the graph, a stalled graph stops it)."""
    goal = len(read_jsonl(path)) + more
    while (n := len(read_jsonl(path))) < goal:
        wait_until(lambda: len(read_jsonl(path)) > n, f"{what} ({path.name} stuck at {n} lines)", *carav.started)


def cycles_of(record: dict) -> list[int]:
    per = record.get("per_cycle") or {}
    return per.get("cycle_index", list(range(record["cycle"], record["cycle"] + record.get("cycles", 1))))


def last_seq_taken(carav, node: str) -> int:
    """The last seq `node` took on its input, from its last heartbeat (`carav status`)."""
    def state():
        st = carav.cli("status", "--json")
        if st.returncode != 0 or not st.stdout.strip().startswith("["):
            return None
        (run,) = json.loads(st.stdout)
        found = re.search(r"last seq (\d+)", run["nodes"][node]["counters"].get("state", ""))
        return found and int(found.group(1))
    return wait_until(state, f"{node}'s last seq in carav status", *carav.started)


def header(seq: int, **fields) -> dict:
    return {"v": 1, "stream": "src.out", "seq": seq, "cycle": seq, "eos": False, "arrays": [], "node": "src",
            "block": "counter_source", **fields}


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_forged_seq_end_of_stream_cycles_and_resume_are_refused_and_the_graph_runs_on(carav):
    out = carav.workdir / "out.jsonl"
    run = carav.run(carav.graph(CHAIN), "--cycles", "0")
    advancing(carav, out, "frames to flow", more=5)
    # Every forgery comes from this test's process, so the node refuses it for its sender before it reads a field
    # (tests/runtime/test_forged_headers.py checks each field's own reason, as a producer's message would meet it).
    forgeries = [   # (what, the message)
        ("a seq 1e6 ahead", lambda s: encode(Frame.of(np.zeros((64, 64), np.complex64)), **header(s + 10**6))),
        ("an end of stream whose count is not a number", lambda s: [msgpack.packb(header(s, eos=True, count="many"))]),
        ("an end of stream announcing fewer frames than came", lambda s: [msgpack.packb(header(s, eos=True, count=1))]),
        ("a 200-byte header stating 1e8 cycles", lambda s: [msgpack.packb(header(s + 1, cycles=100_000_000))]),
        ("a resume marker 1e6 ahead", lambda s: [msgpack.packb(header(s + 10**6, resume=True))]),
        ("a well-formed frame ahead of the stream", lambda s: encode(Frame.of(np.zeros((64, 64), np.complex64)),
                                                                     **header(s + 50))),
    ]
    reason = "not by this input's producer"
    for i, (what, build) in enumerate(forgeries, 1):
        last = last_seq_taken(carav, "t")
        push(carav, "t.inp", [build(last)])
        wait_until(lambda: f"rejected frame #{i}: " in run.stderr(), f"{what} to be refused", *carav.started)
        line = next(l for l in run.stderr().splitlines() if f"rejected frame #{i}: " in l)
        assert reason in line, (what, line)
        advancing(carav, out, f"the graph to keep running after {what}", more=5)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["lost"] == 0 and not s["failures"], (s["lost_by_edge"], s["failures"])
    assert s["rejected"] == len(forgeries) and s["per_node"]["t"]["rejected"] == {"inp": len(forgeries)}
    assert s["per_node"]["t"]["in"]["inp"] == s["per_node"]["src"]["sent"]["src.out -> t.inp"]
    assert [l["seq"] for l in read_jsonl(out)] == list(range(s["per_node"]["src"]["processed"]))


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_forged_clean_verdicts_never_let_an_attacked_cycle_reach_ranging(carav):
    """The smart attacker is on from cycle 0 (the detector alarms on nearly every cycle); 20 clean verdicts
    naming the next seqs are pushed into gate.verdict, each well formed and ahead of the detector's own. Each is
    refused (it does not come from the detector), the gate judges every cycle on the detector's verdict, and
    no cycle the detector alarmed on reaches ranging."""
    verdicts = carav.workdir / "verdicts.jsonl"
    run = carav.run(TAPS / "radar_taps.toml", "--cycles", "0", "--set", "attacker.model='smart'",
                    "--set", "attacker.rarms=3.0", "--set", "attacker.start_cycle=0", "--set", "batch=16", *PACED)
    wait_until(lambda: read_jsonl(verdicts), "the radar graph to start (14 processes importing numpy)", *carav.started)
    advancing(carav, verdicts, "verdicts to flow", more=3)
    real = read_jsonl(verdicts)[-1]
    n, n_chirps = real["cycles"], len(real["data"][0])
    forged = [encode(Frame.of(np.ones((n, n_chirps), bool), eta=1.5, per_cycle={
                  "alarm": [False] * n, "invalid": [False] * n, "q": [0.0] * n, "c": [0] * n}),
                  **header(real["seq"] + k, cycle=n * (real["seq"] + k), cycles=n, stream="detector.verdict",
                           node="detector", block="rms_detector"))
              for k in range(10, 30)]
    push(carav, "gate.verdict", forged)        # returns once the gate's input holds them (linger)
    # the gate reads its verdict input from both senders: 40 frames more out of the gate (alarms and the cycles it
    # passed, both in judged.jsonl) before the stop
    advancing(carav, carav.workdir / "judged.jsonl", "the gate to keep judging after the forged verdicts", more=40)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()                          # a node prints its first refusals; its counters count them all
    refusals = [l for l in run.stderr().splitlines() if "node 'gate' input 'verdict': rejected frame #" in l]
    assert refusals and all("not by this input's producer" in l for l in refusals), refusals
    # every forged verdict the gate read was refused for its sender (how many it read before the stop is not
    # pinned down here: all 20 in most runs, fewer in some); none of them let a cycle through
    rejected = s["per_node"]["gate"]["rejected"].get("verdict", 0)
    assert s["lost"] == 0 and not s["failures"] and s["rejected"] == rejected and 1 <= rejected <= 20, \
        (s["lost_by_edge"], s["failures"], s["per_node"]["gate"]["rejected"])
    alarmed = {c for v in read_jsonl(verdicts) for c, a in zip(cycles_of(v), v["per_cycle"]["alarm"]) if a}
    ranged = {c for e in read_jsonl(carav.workdir / "judged.jsonl") if e["port"] == "inp" for c in cycles_of(e)}
    assert len(alarmed) > 100 and not alarmed & ranged, sorted(alarmed & ranged)[:10]
