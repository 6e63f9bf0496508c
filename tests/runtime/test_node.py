"""A node's runner driven in-process on real ZeroMQ sockets: frames in, frames out, restarts and swaps.

Pairing itself is tested without sockets (test_pairing.py) and output delivery with stand-in sockets
(test_outputs.py); this file checks that the runner wires them to real sockets and to its control channel. Every
wait is for an expected number of messages, with a deadline: no test relies on a quiet spell.
"""
import os
import time

import numpy as np
import zmq

from carav_stream.runtime import transport
from carav_stream.runtime.frames import Frame
from carav_stream.runtime.node import NodeRunner
from carav_stream.runtime.protocol import LEASE_FRAMES, Control, NodeSpec, Report, pack, unpack
from tests.runtime.conftest import EDGE, TOYS


def test_frames_on_real_sockets_pair_by_seq_and_leave_in_order(harness):
    harness.feed("a", 0, 1, 2, 3)
    harness.feed("b", 0, 2, 3)
    harness.run_until(4)
    assert harness.outputs(4) == [(0, "paired", None), (1, "alone", None), (2, "paired", None),
                                  (3, "paired", None)]
    assert harness.node.ports.c_in == {"a": 4, "b": 3} and harness.node.driver.c_unpaired == {"a": 1}


def test_a_producer_reconnects_at_once_and_tells_the_restarted_consumer_where_it_resumes(harness):
    node, outputs = harness.node.driver, harness.node.ports.outputs
    for seq in range(3):
        node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": seq}))
    assert [s for s, *_ in harness.outputs(3)] == [0, 1, 2]
    node.seq = 3
    harness.control(Control.RECONNECT, edges=[EDGE, "not.an -> edge.of_this_node"])
    assert outputs.reconnect == set()                         # reconnected at once, with no frame to send
    node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": 3}))
    assert harness.outputs(2) == [(3, None, True), (3, None, None)]   # the marker comes first
    assert outputs.c_sent[EDGE] == 4                                  # a marker is not a frame


def test_a_finished_producer_also_repeats_its_end_of_stream_to_the_restarted_consumer(harness):
    node = harness.node.driver
    node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": 0}))
    node.seq = 1
    harness.node.ports.outputs.send_eos(node.eos_message)
    assert [(s, r) for s, _, r in harness.outputs(2)] == [(0, None), (1, "eos")]
    harness.control(Control.RECONNECT, edges=[EDGE])
    assert [(s, r) for s, _, r in harness.outputs(2)] == [(1, True), (1, "eos")]   # resume at 1, then eos again


def test_the_runtime_tells_each_block_which_instance_it_is(harness):
    node = harness.node.driver
    assert node.block.instance == (0, 0)
    harness.control(Control.SWAP, block="pairer", params={}, id=1)
    node.apply_swap()
    assert node.generation == 1 and node.block.instance == (0, 1)          # swapped in: a new generation
    assert [h["generation"] for h in node.history] == [0]                   # the old block's record was kept
    restarted = harness.restarted(incarnation=2, generation=1)
    assert restarted.driver.block.instance == (2, 1)                       # a restarted process: a new incarnation


def test_a_swap_to_an_unknown_block_is_reported_and_the_old_block_runs_on(harness):
    node = harness.node.driver
    harness.control(Control.SWAP, block="no_such_block", params={}, id=7)
    node.apply_swap()
    assert node.generation == 0 and node.block_type == "pairer"
    harness.feed("a", 0)
    harness.feed("b", 0)
    harness.run_until(1)
    assert harness.outputs(1) == [(0, "paired", None)]


def test_a_source_generates_only_within_its_lease_and_asks_for_more_ahead_of_time(tmp_path):
    """Sequence leases: what a restarted source resumes beyond. Below half a lease from its end the source asks for
    more; at its end it waits for the grant instead of generating."""
    ctx = zmq.Context()
    router = ctx.socket(zmq.ROUTER)
    ctl = transport.ipc_endpoint(tmp_path, "ctl")
    router.bind(ctl)
    spec = NodeSpec(name="src", type="counter_source", params={}, control=ctl, inputs={}, outputs={},
                    block_paths=(str(TOYS),), seq_lease=LEASE_FRAMES)
    node = NodeRunner(spec)
    link = node.link
    try:
        link.tell(Report.READY)
        assert router.poll(5000) and unpack(router.recv_multipart()[1])["type"] == Report.HELLO
        assert router.poll(5000) and unpack(router.recv_multipart()[1])["type"] == Report.READY
        assert link.within_lease(LEASE_FRAMES // 2 - 1) and not router.poll(200)   # far from the end: no request
        assert link.within_lease(LEASE_FRAMES // 2)
        assert router.poll(5000)
        ident, raw = router.recv_multipart()
        assert unpack(raw) == {"type": "lease", "node": "src", "pid": os.getpid(), "upto": 3 * LEASE_FRAMES // 2}
        assert not link.within_lease(LEASE_FRAMES)                        # at the end: waits, generates nothing
        router.send_multipart([ident, pack(Control.LEASE, upto=3 * LEASE_FRAMES // 2)])
        assert wait_for(lambda: link.within_lease(LEASE_FRAMES))
    finally:
        node.close(crashed=True)
        router.close(linger=0)
        ctx.term()


def wait_for(predicate, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
    return False
