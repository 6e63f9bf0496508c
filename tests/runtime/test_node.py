"""A node's runner driven in-process on real ZeroMQ sockets: frames in, frames out, restarts and swaps.

Pairing itself is tested without sockets (test_pairing.py) and output delivery with stand-in sockets
(test_outputs.py); this file checks that the runner wires them to real sockets and to its control channel. Every
wait is for an expected number of messages, with a deadline: no test relies on a quiet spell.
"""
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import zmq

from carav_stream.runtime import transport
from carav_stream.runtime.frames import Frame, decode, encode
from carav_stream.runtime.node import NodeRunner
from carav_stream.runtime.protocol import Control, NodeSpec, OutEdge, Report, pack, unpack
from tests.integration.conftest import TOYS

EDGE = "p.out -> sink.inp"
DEADLINE_S = 10.0


@pytest.fixture
def harness():
    """A `pairer` node (inputs a and b, output out) with the test holding its control ROUTER, a PUSH socket into
    each input and the PULL socket its output edge connects to."""
    ctx = zmq.Context()
    run_dir = Path(tempfile.mkdtemp(prefix="nd", dir="/tmp"))     # ipc paths must stay short
    ep = {k: transport.ipc_endpoint(run_dir, k) for k in ("ctl", "a", "b", "out")}
    router = ctx.socket(zmq.ROUTER)
    router.bind(ep["ctl"])
    sink = transport.bind_input(ctx, ep["out"], hwm=100)
    spec = NodeSpec(name="p", type="pairer", params={}, control=ep["ctl"], block_paths=(str(TOYS),),
                    inputs={"a": ep["a"], "b": ep["b"]}, outputs={"out": (OutEdge(EDGE, ep["out"]),)},
                    queue_frames=2, drain_timeout_s=1.0)
    runners = [NodeRunner(spec)]
    runner = runners[0]
    runner.block.start()
    runner.tell(Report.READY)                 # the ROUTER drops messages to a peer it has not heard from yet
    assert router.poll(5000), "the node's control connection did not come up"
    assert unpack(router.recv_multipart()[1])["type"] == Report.READY
    feeds = {p: transport.connect_output(ctx, ep[p], hwm=100, linger_ms=0) for p in ("a", "b")}

    class H:
        node = runner

        @staticmethod
        def feed(port, *seqs):
            for seq in seqs:
                f = Frame({}, {"data": np.full(2, float(seq))})
                transport.send_message(feeds[port], encode(f, stream=f"up.{port}", seq=seq))

        @staticmethod
        def run_until(n_processed):
            """Receive and pump until the node handed `n_processed` frame sets to its block in all."""
            deadline = time.monotonic() + DEADLINE_S
            while runner.processed < n_processed:
                assert time.monotonic() < deadline, f"only {runner.processed} of {n_processed} frame sets processed"
                for p in ("a", "b"):
                    runner.receive(p)
                runner.pump()

        @staticmethod
        def outputs(n):
            """The next `n` messages on the output edge, as (seq, handled, resume-or-eos)."""
            out = []
            for _ in range(n):
                assert sink.poll(DEADLINE_S * 1000), f"only {len(out)} of {n} messages arrived"
                h = decode(transport.recv_message(sink)).header
                out.append((h["seq"], h.get("handled"), h.get("resume") or ("eos" if h["eos"] else None)))
            return out

        @staticmethod
        def control(kind, **msg):
            """Send a control message to the node and have it served (waits for it to arrive)."""
            router.send_multipart([b"p", pack(kind, **msg)])
            assert runner.control.poll(DEADLINE_S * 1000), "control message did not arrive"
            runner.serve_control()

        @staticmethod
        def restarted(**changes):
            r = NodeRunner(spec.with_(**changes))
            runners.append(r)
            return r

    yield H
    for r in runners:
        r.close(crashed=True)
    for s in (*feeds.values(), sink, router):
        s.close(linger=0)
    ctx.term()
    shutil.rmtree(run_dir, ignore_errors=True)


def test_frames_on_real_sockets_pair_by_seq_and_leave_in_order(harness):
    harness.feed("a", 0, 1, 2, 3)
    harness.feed("b", 0, 2, 3)
    harness.run_until(4)
    assert harness.outputs(4) == [(0, "paired", None), (1, "alone", None), (2, "paired", None),
                                  (3, "paired", None)]
    assert harness.node.c_in == {"a": 4, "b": 3} and harness.node.c_unpaired == {"a": 1}


def test_a_producer_reconnects_at_once_and_tells_the_restarted_consumer_where_it_resumes(harness):
    node = harness.node
    for seq in range(3):
        node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": seq}))
    assert [s for s, *_ in harness.outputs(3)] == [0, 1, 2]
    node.seq = 3
    harness.control(Control.RECONNECT, edges=[EDGE, "not.an -> edge.of_this_node"])
    assert node.outputs.reconnect == set()                    # reconnected at once, with no frame to send
    node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": 3}))
    assert harness.outputs(2) == [(3, None, True), (3, None, None)]   # the marker comes first
    assert node.outputs.c_sent[EDGE] == 4                             # a marker is not a frame


def test_a_finished_producer_also_repeats_its_end_of_stream_to_the_restarted_consumer(harness):
    node = harness.node
    node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": 0}))
    node.seq = 1
    node.outputs.send_eos(node.eos_message)
    assert [(s, r) for s, _, r in harness.outputs(2)] == [(0, None), (1, "eos")]
    harness.control(Control.RECONNECT, edges=[EDGE])
    assert [(s, r) for s, _, r in harness.outputs(2)] == [(1, True), (1, "eos")]   # resume at 1, then eos again


def test_the_runtime_tells_each_block_which_instance_it_is(harness):
    node = harness.node
    assert node.block.instance == (0, 0)
    harness.control(Control.SWAP, block="pairer", params={}, id=1)
    node.apply_swap()
    assert node.generation == 1 and node.block.instance == (0, 1)          # swapped in: a new generation
    assert [h["generation"] for h in node.history] == [0]                   # the old block's record was kept
    restarted = harness.restarted(incarnation=2, generation=1)
    assert restarted.block.instance == (2, 1)                              # a restarted process: a new incarnation


def test_a_swap_to_an_unknown_block_is_reported_and_the_old_block_runs_on(harness):
    node = harness.node
    harness.control(Control.SWAP, block="no_such_block", params={}, id=7)
    node.apply_swap()
    assert node.generation == 0 and node.block_type == "pairer"
    harness.feed("a", 0)
    harness.feed("b", 0)
    harness.run_until(1)
    assert harness.outputs(1) == [(0, "paired", None)]
