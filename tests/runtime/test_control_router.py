"""The control plane's senders, on real ipc sockets in one process: the supervisor's ROUTER takes a message as a
node's only when the kernel names a process of that node, and a node takes control only from its supervisor.

The test process plays both ends, so the pid the kernel reports is its own: it is the node's when the router was
told so (`started`), and no node's otherwise."""
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import zmq

from carav_stream.runtime import transport
from carav_stream.runtime.control_router import MAX_REASONS, OTHER, ControlRouter
from carav_stream.runtime.node_state import NodeState
from carav_stream.runtime.protocol import Control, NodeSpec, Report, pack, unpack
from carav_stream.runtime.senders import sender_pid, start_ticks

ME = os.getpid()


@pytest.fixture
def sockets():
    ctx = zmq.Context()
    folder = Path(tempfile.mkdtemp(prefix="cr", dir="/tmp"))
    endpoint = transport.ipc_endpoint(folder, "control")
    router = ctx.socket(zmq.ROUTER)
    router.bind(endpoint)
    lines: list[str] = []
    dealers = []

    def dealer(identity: bytes | None = None) -> zmq.Socket:
        sock = ctx.socket(zmq.DEALER)
        if identity is not None:
            sock.identity = identity
        sock.connect(endpoint)
        dealers.append(sock)
        return sock
    yield ControlRouter(router, lines.append), dealer, lines
    for sock in (*dealers, router):
        sock.close(linger=0)
    ctx.term()
    shutil.rmtree(folder, ignore_errors=True)


def received(control: ControlRouter, n: int) -> list[tuple[str, dict]]:
    """The next messages the router takes as a node's, after `n` messages arrived in all (taken or not)."""
    got, deadline = [], time.monotonic() + 10
    while control.n_refused + len(got) < n:
        assert time.monotonic() < deadline, (got, control.refused)
        control.sock.poll(100)
        got += list(control.receive())
    return got


def test_a_message_from_a_process_of_no_node_is_refused_whatever_name_it_gives(sockets):
    control, dealer, lines = sockets
    rogue = dealer(b"det")                       # the node's name as its identity changes nothing
    rogue.send(pack(Report.READY, node="det"))
    rogue.send(pack(Report.HEARTBEAT, node="det", pid=1234, counters={"cycles": 10 ** 12}))
    assert received(control, 2) == []
    reason = f"sent by process {ME}, which is no process of this run's nodes (it says it is node 'det')"
    assert control.refused == {reason: 2}
    assert lines == [f"carav: control message #1 refused: {reason}", f"carav: control message #2 refused: {reason}"]


def test_a_nodes_process_is_heard_and_messages_to_it_wait_for_its_hello(sockets):
    control, dealer, _ = sockets
    control.started("det", ME)
    control.send("det", pack(Control.PEERS, inputs={"frames": [7, 8]}))
    control.send("det", pack(Control.GO))
    node = dealer()
    assert not node.poll(200)                      # nothing went anywhere before the node spoke
    node.send(pack(Report.HELLO, node="det"))
    assert received(control, 1) == [("det", {"type": "hello", "node": "det"})]
    assert [unpack(node.recv())["type"] for _ in range(2)] == ["peers", "go"]      # in the order sent
    control.send("det", pack(Control.STOP))
    assert node.poll(5000) and unpack(node.recv())["type"] == "stop"


def test_a_message_naming_another_node_or_malformed_is_refused(sockets):
    control, dealer, _ = sockets
    control.started("det", ME)
    node = dealer()
    node.send(pack(Report.HEARTBEAT, node="gate", counters={}))
    node.send(b"\xc1 not msgpack")
    node.send_multipart([b"a", b"b"])
    assert received(control, 3) == []
    reasons = sorted(control.refused)
    assert len(reasons) == 3 and sum(control.refused.values()) == 3, control.refused
    assert reasons[0].startswith(f"a message from node 'det''s process {ME} that is not valid msgpack: ")
    assert reasons[1:] == [f"a message of 3 parts from node 'det''s process {ME}",
                           f"sent by node 'det''s process {ME}, naming node 'gate'"]


def test_the_last_words_of_an_ended_incarnation_are_left_aside_not_refused(sockets):
    control, dealer, _ = sockets
    control.started("det", ME)
    control.started("det", ME + 10 ** 6)           # restarted: the new process has another pid
    dealer().send(pack(Report.HEARTBEAT, node="det", counters={"cycles": 5}))
    deadline = time.monotonic() + 10
    while control.sock.poll(100) == 0:
        assert time.monotonic() < deadline
    assert list(control.receive()) == [] and not control.refused


def test_refusal_reasons_are_kept_up_to_a_bound_and_all_counted(sockets):
    control, _, lines = sockets
    for i in range(MAX_REASONS + 5):
        control.refuse(f"reason {i}")
    assert len(control.refused) == MAX_REASONS + 1 and control.refused[OTHER] == 5
    assert sum(control.refused.values()) == MAX_REASONS + 5 and len(lines) == 20


def test_a_node_takes_control_only_from_its_supervisors_process(harness, capfd):
    """The node harness's node, told that its supervisor is another process: a message the test sends is refused
    and named in the node's log; the same message applied when the node knows no supervisor pid."""
    link = harness.node.link
    link.supervisor_pid = ME + 1
    harness.control(Control.RECOVER)
    assert link.ctl.recovering is False and link.n_refused == 1
    assert (f"p: control message #1 refused: sent by process {ME}, not by the supervisor (process {ME + 1})"
            in capfd.readouterr().err)
    link.supervisor_pid = ME
    harness.control(Control.RECOVER)
    assert link.ctl.recovering is True


@pytest.mark.integration
def test_an_ended_node_process_keeps_its_pid_until_the_run_reaps_it():
    """A node's process that ended is seen ended without being reaped: it stays a zombie, so its pid (and start
    time) can be given to no other process while the run lasts."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    st = NodeState("n", NodeSpec(name="n", type="t", params={}, control="", inputs={}, outputs={}), proc=proc,
                   procs=[proc], start_ticks=start_ticks(proc.pid))
    deadline = time.monotonic() + 30
    while st.exit_code() is None:
        assert time.monotonic() < deadline
        time.sleep(0.01)
    assert st.exit_code() == 0 and proc.returncode is None
    assert start_ticks(proc.pid) == st.start_ticks          # still there (a zombie), still the same process
    st.kill()                                                # a no-op on an ended process
    st.reap_all()
    assert proc.returncode == 0 and start_ticks(proc.pid) != st.start_ticks     # gone, or another process


def test_sender_pid_reads_the_kernels_pid_and_nothing_else():
    assert sender_pid(b"bytes") is None
    assert start_ticks(ME) == start_ticks(ME) and start_ticks(ME) > 0
