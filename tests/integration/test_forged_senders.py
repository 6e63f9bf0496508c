"""Senders that are not who they say, on real sockets: a process that speaks for a node on the control socket
right after that node died, and a process holding the pid a killed producer had. Each is refused with its reason
and counted; the graph runs on, and `carav stop` ends it with nothing lost.

To lose nothing when a node is killed, no frame may be on its way to it or inside it, and its last heartbeat must
count all it did (tests/integration/test_restart_accounting.py covers kills mid-flow). So the source is held first,
and every node downstream has drained and reported it twice before the kill: the first test stops its source
(SIGSTOP), which feeds the killed node only through a running node; the second holds its source up by a sink that
it stopped (the source blocks on that edge, its ZeroMQ thread running), because the source feeds the killed node
directly: a stopped source may still hold a frame it handed to ZeroMQ, or hand one to the dead node's connection
on SIGCONT before it reads that the node was restarted, and either dies with that connection."""
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import zmq

from carav_stream.runtime.frames import Frame, encode
from carav_stream.runtime.protocol import Report, pack
from carav_stream.testing.graphs import node_pids
from tests.integration.conftest import PACED, read_jsonl, wait_until
from tests.integration.test_forgery import TAPS, advancing, cycles_of, header

pytestmark = pytest.mark.integration

CHAIN = """
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[blocks]
src = { type = "counter_source" }
t = { type = "tagger", delay_s = 0.01 }
log = { type = "jsonl_sink", path = "out.jsonl", max_values = 0, restart = "on-failure" }
[run]
heartbeat_timeout_s = 120.0     # src is paused while log restarts
"""
PID_MAX = Path("/proc/sys/kernel/pid_max")
LAST_PID = Path("/proc/sys/kernel/ns_last_pid")


def status(carav) -> dict | None:
    st = carav.cli("status", "--json")
    if st.returncode != 0 or not st.stdout.strip().startswith("["):
        return None
    (run,) = json.loads(st.stdout)
    return run


def idle(run: dict, node: str) -> bool:
    """`node`'s last heartbeat says it waits for input and holds nothing it took."""
    c = run["nodes"][node]["counters"]
    return "waiting for input" in c.get("state", "") and sum(c["in"].values()) == c["consumed"]


def sleeping(pid: int) -> bool:
    """Process `pid`'s main thread is asleep (waiting: on a socket, for its next frame's time)."""
    stat = Path(f"/proc/{pid}/stat").read_bytes()
    return stat[stat.rfind(b")") + 2:].split()[0] == b"S"


def settle(carav, run, drained: list[str], watched: list[str]) -> None:
    """Wait until the nodes `drained` are idle, every edge into them from a `watched` node is empty, and so they
    stay, with the same counts of every watched node, from one status read to a later one that has a heartbeat
    of each of them sent after the first (its cpu_s moved on): counts read twice from one late heartbeat prove
    nothing."""
    ref = [None]

    def settled():
        st = status(carav)
        if st is None or not all(st["nodes"][n]["counters"] for n in watched):
            return False
        nodes = {n: st["nodes"][n]["counters"] for n in watched}
        edges = [q for e, q in st["edges"].items() if e.split("->")[0].strip().split(".")[0] in watched
                 and e.split("->")[1].strip().split(".")[0] in drained]
        calm = all(idle(st, n) for n in drained) and all(q["in_flight"] == 0 for q in edges)
        counts = {n: (c["in"], c.get("out"), c.get("sent")) for n, c in nodes.items()}
        cpu = {n: c.get("cpu_s") for n, c in nodes.items()}
        if not calm or ref[0] is None or ref[0][0] != counts:
            ref[0] = (counts, cpu) if calm else None
            return False
        return all(ref[0][1][n] != cpu[n] for n in watched)
    wait_until(settled, f"{drained} to drain", run, interval_s=0.3)


def pause(carav, run, source: str, drained: list[str]) -> int:
    """SIGSTOP `source` while it waits and settle the nodes `drained` below it (settle); the source's pid. What
    the source had handed to ZeroMQ and not yet sent reaches its consumers after SIGCONT: none of them may be
    killed meanwhile (hold_by for a node the source feeds)."""
    (pid,) = wait_until(lambda: node_pids(carav.run_root, source), f"{source}'s pid", run)
    # stopped while it waits (its main thread asleep), never halfway through a frame
    wait_until(lambda: sleeping(pid) and not os.kill(pid, signal.SIGSTOP), f"{source} to wait", run, interval_s=0.001)
    settle(carav, run, drained, drained)
    return pid


def hold_by(carav, run, source: str, sink: str, drained: list[str]) -> int:
    """Hold `source` up by its edge into `sink` (a sink fed by the source alone): SIGSTOP the sink, and wait until
    the source blocks on that edge (its queue full) and the nodes `drained` (those that take what the source sends
    on its other edges, directly or not) have taken, processed and reported everything the source sent; the
    sink's pid. The source is never stopped: its counts are exact and its ZeroMQ thread runs on, so it learns at
    once that a consumer died and connects afresh to its successor (a stopped one could hand a frame to the dead
    consumer's connection before it learned), and it sends nothing until the sink is continued."""
    (pid,) = wait_until(lambda: node_pids(carav.run_root, sink), f"{sink}'s pid", run)
    os.kill(pid, signal.SIGSTOP)

    def blocked():
        st = status(carav)
        state = st["nodes"][source]["counters"].get("state", "") if st else ""
        return state.startswith(("sending on", "waiting for"))
    wait_until(blocked, f"{source} to block on its edge into the stopped {sink}", run, interval_s=0.3)
    settle(carav, run, drained, [source, *drained])
    return pid


def restarted(carav, run, node: str, old: int) -> int:
    """The pid of `node`'s new process, once it has sent a heartbeat (it is up and serving its control link)."""
    def new_pid():
        st = status(carav)
        n = st and st["nodes"][node]
        return n and n["pid"] != old and n["alive"] and "state" in n["counters"] and n["pid"]
    return wait_until(new_pid, f"{node} to be restarted", run)


def test_a_process_speaking_for_a_dead_node_on_the_control_socket_is_refused_and_hears_nothing(carav):
    """Right after `log` died (restart on failure), a process connects to the run's control socket with log's
    name as its identity, says it is ready and sends heartbeats counting 10^12 cycles. It never hears log's go,
    its reports are refused and counted, and the new `log` runs on."""
    out = carav.workdir / "out.jsonl"
    run = carav.run(carav.graph(CHAIN), "--cycles", "0")
    advancing(carav, out, "frames to flow", more=5)
    src = pause(carav, run, "src", ["t", "log"])
    (old,) = node_pids(carav.run_root, "log")
    (control,) = carav.run_root.glob("carav-*/*/control")
    os.kill(old, signal.SIGKILL)
    wait_until(lambda: "restarting 'log'" in run.stderr(), "the supervisor to restart log", run)
    ctx = zmq.Context()
    rogue = ctx.socket(zmq.DEALER)
    rogue.identity, rogue.linger = b"log", 0
    rogue.connect(f"ipc://{control}")
    huge = {"cycles": 10 ** 12, "processed": 10 ** 12, "in": {"inp": 10 ** 12}, "consumed": 10 ** 12}
    heard = []

    def heard_or_up():
        while rogue.poll(0):
            heard.append(rogue.recv())
        if heard:
            return True
        st = status(carav)
        n = st["nodes"]["log"] if st else None
        return n and n["pid"] != old and n["alive"] and "state" in n["counters"] and n["pid"]
    try:
        rogue.send(pack("hello", node="log"))
        rogue.send(pack(Report.READY, node="log", block="jsonl_sink", version="1"))
        rogue.send(pack(Report.HEARTBEAT, node="log", counters=huge))
        new = wait_until(heard_or_up, "the new log to come up (or the rogue to hear from the supervisor)", run)
        assert heard == [], heard                       # no go, nothing meant for log
        rogue.send(pack(Report.HEARTBEAT, node="log", pid=new, counters=huge))
        while rogue.poll(500):
            heard.append(rogue.recv())
        assert heard == [], heard
        live = status(carav)
        assert live["cycles"] < 10 ** 9 and live["nodes"]["log"]["processed"] < 10 ** 9, live["cycles"]
    finally:
        os.kill(src, signal.SIGCONT)
        ctx.destroy(linger=0)
    advancing(carav, out, "the new log to write what src sends", more=20)
    assert carav.cli("stop").returncode == 0
    code = run.wait()
    s = run.summary()
    assert code == 0, run.stderr()
    assert s["lost"] == 0 and not s["failures"] and s["rejected"] == 0, (s["lost_by_edge"], s["failures"])
    refused = s["security"]["refused_control"]
    assert sum(refused.values()) == 4, refused
    reason = f"sent by process {os.getpid()}, which is no process of this run's nodes (it says it is node 'log')"
    assert set(refused) == {reason}, refused
    assert f"carav: control message #1 refused: {reason}" in run.stderr()
    assert s["per_node"]["log"]["restarts"] == 1 and s["cycles"] == s["per_node"]["src"]["processed"]
    assert s["per_node"]["log"]["in"]["inp"] == s["per_node"]["t"]["sent"]["t.out -> log.inp"] == len(read_jsonl(out))


# sends its messages, then stays connected until its stdin closes: ZeroMQ drops what a consumer has not read yet
# from a connection whose sender is gone
FORGER = """
import sys, zmq
ctx = zmq.Context()
sock = ctx.socket(zmq.PUSH)
sock.connect(sys.argv[1])
for path in sys.argv[2:]:
    sock.send_multipart(open(path, "rb").read().split(b"\\0PART\\0"))
sys.stdin.read()
sock.close(linger=0)
ctx.term()
"""


def spawn_as(pid: int, argv: list[str]) -> tuple[int, int]:
    """Run `argv` in a process whose pid is `pid` if the kernel will give that pid out: the next pid is set
    through ns_last_pid where that is allowed, else processes are forked until the pids come round to it (or go
    past it: someone holds it). Returns the pid the process got and the end of a pipe that is its stdin."""
    stdin, feed = os.pipe()
    try:
        LAST_PID.write_text(str(pid - 1))
        proc = subprocess.Popen(argv, stdin=stdin)
        os.close(stdin)
        return proc.pid, feed
    except OSError:
        pass
    pid_max, below = int(PID_MAX.read_text()), False
    for _ in range(2 * pid_max):
        child = os.fork()
        if child == 0:
            if os.getpid() == pid:
                os.dup2(stdin, 0)
                os.execv(argv[0], argv)
            os._exit(0)
        if child == pid:
            os.close(stdin)
            return child, feed
        os.waitpid(child, 0)
        below = below or 0 < (pid - child) % pid_max < 64
        if below and 0 < (child - pid) % pid_max < 64:
            break
    proc = subprocess.Popen(argv, stdin=stdin)
    os.close(stdin)
    return proc.pid, feed


def verdicts_read(carav, extra: int) -> bool:
    """The gate has read (taken or refused) `extra` messages on its verdict input beyond what the detector sent
    it, from their last heartbeats."""
    st = status(carav)
    if st is None:
        return False
    gate = st["nodes"]["gate"]["counters"]
    read = gate["in"].get("verdict", 0) + gate["rejected"].get("verdict", 0)
    sent = st["nodes"]["detector"]["counters"]["sent"].get("detector.verdict -> gate.verdict", 0)
    return read >= sent + extra


def test_a_process_given_a_killed_producers_pid_cannot_send_into_its_consumer(carav):
    """The detector is SIGKILLed (restart on failure); a process is then started with the killed detector's pid
    if the kernel gives it out, and sends clean verdicts for the next seqs into gate.verdict. Each is refused
    for its sender; no cycle the detector alarmed on reaches ranging."""
    verdicts, judged = carav.workdir / "verdicts.jsonl", carav.workdir / "judged.jsonl"
    run = carav.run(TAPS / "radar_taps_detector_restarts.toml", "--cycles", "0", "--set", "attacker.model='smart'",
                    "--set", "attacker.rarms=3.0", "--set", "attacker.start_cycle=0", "--set", "batch=16",
                    "--set", "run.heartbeat_timeout_s=120", *PACED)
    wait_until(lambda: read_jsonl(verdicts), "the radar graph to start (14 processes importing numpy)", run)
    advancing(carav, verdicts, "verdicts to flow", more=3)
    rlog = hold_by(carav, run, "source", "rlog", ["channel", "attacker", "adc", "detector", "gate", "vlog"])
    real = read_jsonl(verdicts)[-1]
    n, n_chirps = real["cycles"], len(real["data"][0])
    (old,) = node_pids(carav.run_root, "detector")
    (endpoint,) = carav.run_root.glob("carav-*/*/gate.verdict")
    parts = []
    for k in range(1, 21):
        msg = encode(Frame.of(np.ones((n, n_chirps), bool), eta=1.5, per_cycle={
            "alarm": [False] * n, "invalid": [False] * n, "q": [0.0] * n, "c": [0] * n}),
            **header(real["seq"] + k, cycle=n * (real["seq"] + k), cycles=n, stream="detector.verdict",
                     node="detector", block="rms_detector"))
        path = carav.workdir / f"forged{k}"
        path.write_bytes(b"\0PART\0".join(bytes(memoryview(p)) for p in msg))
        parts.append(str(path))
    os.kill(old, signal.SIGKILL)
    try:
        wait_until(lambda: "restarting 'detector'" in run.stderr(), "the supervisor to restart the detector", run)
        got, feed = spawn_as(old, [sys.executable, "-c", FORGER, f"ipc://{endpoint}", *parts])
        restarted(carav, run, "detector", old)
    finally:
        os.kill(rlog, signal.SIGCONT)
    try:
        advancing(carav, judged, "the gate to judge past the forged seqs", more=40)
        wait_until(lambda: verdicts_read(carav, 20), "the gate to read the 20 forged verdicts", run)
    finally:
        os.close(feed)                  # the forger exits
        os.waitpid(got, 0)
    assert carav.cli("stop").returncode == 0
    code = run.wait()
    s = run.summary()
    assert code == 0, run.stderr()
    refusals = [l for l in run.stderr().splitlines() if "node 'gate' input 'verdict': rejected frame #" in l]
    assert refusals and all(f"sent by process {got}, not by this input's producer" in l for l in refusals), \
        (got, old, refusals)
    assert s["per_node"]["gate"]["rejected"] == {"verdict": 20} and s["rejected"] == 20, s["per_node"]["gate"]
    assert s["lost"] == 0 and not s["failures"] and s["missed"] == 0, (s["lost_by_edge"], s["failures"])
    alarmed = {c for v in read_jsonl(verdicts) for c, a in zip(cycles_of(v), v["per_cycle"]["alarm"]) if a}
    ranged = {c for e in read_jsonl(judged) if e["port"] == "inp" for c in cycles_of(e)}
    assert len(alarmed) > 100 and not alarmed & ranged, sorted(alarmed & ranged)[:10]
    assert s["per_node"]["detector"]["restarts"] == 1
