"""A node's pairing of inputs by seq and its restart protocol, driven in-process on real ZeroMQ sockets.

When a consumer is restarted, each producer connects afresh and first sends a `resume` marker: the frames its
old connection held are gone, so the new consumer must not wait for them to pair its other inputs (waiting
deadlocks a graph whose producers are blocked behind that consumer). A partner that comes after its seq was
handled without it is refused, never handed to the block: a second, out-of-order output would follow.
"""
import shutil
import tempfile
import time
from pathlib import Path

import msgpack
import numpy as np
import pytest
import zmq

from carav_stream import node as node_mod
from carav_stream import transport
from carav_stream.frames import Frame, decode, encode
from carav_stream.node import NodeRunner
from tests.integration.conftest import TOYS

EDGE = "p.out -> sink.inp"
QUIET_S = 0.5     # in-process ipc messages arrive within milliseconds: this long a silence means nothing is coming


@pytest.fixture
def harness():
    """A `pairer` node (inputs a and b, output out) with the test holding its control ROUTER, a PUSH socket into
    each input and the PULL socket its output edge connects to."""
    ctx = zmq.Context()
    run_dir = Path(tempfile.mkdtemp(prefix="np", dir="/tmp"))     # ipc paths must stay short
    ep = {k: transport.ipc_endpoint(run_dir, k) for k in ("ctl", "a", "b", "out")}
    router = ctx.socket(zmq.ROUTER)
    router.bind(ep["ctl"])
    sink = transport.bind_input(ctx, ep["out"], hwm=100)
    spec = {"name": "p", "type": "pairer", "params": {}, "control": ep["ctl"], "block_paths": [str(TOYS)],
            "inputs": {"a": ep["a"], "b": ep["b"]}, "outputs": {"out": [{"edge": EDGE, "connect": ep["out"]}]},
            "queue_frames": 2, "drain_timeout_s": 1.0, "security": {}}
    runner = NodeRunner(spec)
    runner.block.start()
    runner.tell("ready")                  # the ROUTER drops messages to a peer it has not heard from yet
    assert router.poll(5000), "the node's control connection did not come up"
    router.recv_multipart()
    feeds = {p: transport.connect_output(ctx, ep[p], hwm=100, linger_ms=0) for p in ("a", "b")}

    class H:
        node = runner

        @staticmethod
        def feed(port, *seqs, resume=None, marker=None):
            """Frames with `seqs` into `port`, then a resume marker at seq `resume` (or the header `marker`)."""
            for seq in seqs:
                f = Frame({}, {"data": np.full(2, float(seq))})
                transport.send_message(feeds[port], encode(f, stream=f"up.{port}", seq=seq))
            if resume is not None:
                marker = {"seq": resume, "resume": True}
            if marker is not None:
                transport.send_message(feeds[port], encode(Frame(marker), stream=f"up.{port}"))

        @staticmethod
        def settle():
            """Receive and pump until the inputs have been quiet for QUIET_S (10 s at most)."""
            poller = zmq.Poller()
            for sock in runner.inputs.values():
                poller.register(sock, zmq.POLLIN)
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                for p in ("a", "b"):
                    runner.receive(p)
                runner.pump()
                if not poller.poll(QUIET_S * 1000):
                    return

        @staticmethod
        def outputs():
            out = []
            while sink.poll(QUIET_S * 1000):
                out.append(decode(transport.recv_message(sink)).header)
            return [(h["seq"], h.get("handled"), h.get("port"), h.get("resume") or ("eos" if h["eos"] else None))
                    for h in out]

        @staticmethod
        def control(**msg):
            """Send a control message to the node and have it served (waits for it to arrive, 5 s at most)."""
            router.send_multipart([b"p", msgpack.packb(msg)])
            assert runner.control.poll(5000), "control message did not arrive"
            runner.serve_control()

    yield H
    for s in (*feeds.values(), sink, router, runner.control, *runner.inputs.values(),
              *(s for edges in runner.outputs.values() for _, s in edges)):
        s.close(linger=0)
    ctx.term()
    shutil.rmtree(run_dir, ignore_errors=True)


def test_frames_pair_by_seq_and_a_skipped_seq_goes_alone_once_the_other_input_is_past_it(harness):
    harness.feed("a", 0, 1, 2, 3)
    harness.feed("b", 0, 2, 3)
    harness.settle()
    assert harness.outputs() == [(0, "paired", None, None), (1, "alone", "a", None), (2, "paired", None, None),
                                 (3, "paired", None, None)]


def test_an_unmatched_frame_waits_for_its_partner_while_one_may_still_come(harness):
    harness.feed("a", 0, 1)
    harness.settle()
    assert harness.outputs() == [] and harness.node.c_unpaired == {}
    harness.feed("b", 0, 1)
    harness.settle()
    assert harness.outputs() == [(0, "paired", None, None), (1, "paired", None, None)]


def test_a_resume_marker_releases_the_frames_whose_partners_went_with_the_old_connection(harness):
    # a restarted consumer: input b's producer resumed at seq 3, so frames 0-2 on a can never pair
    harness.feed("a", 0, 1, 2, 3, 4)
    harness.feed("b", resume=3)
    harness.settle()
    assert harness.node.recovering is False                      # no timer: the marker says so at once
    assert harness.outputs() == [(0, "alone", "a", None), (1, "alone", "a", None), (2, "alone", "a", None)]
    harness.feed("b", 3, 4)
    harness.settle()
    assert harness.outputs() == [(3, "paired", None, None), (4, "paired", None, None)]
    assert harness.node.c_in == {"a": 5, "b": 2} and harness.node.c_rejected == {}


def test_a_malformed_resume_marker_is_rejected_and_releases_nothing(harness):
    harness.feed("a", 0, 1)
    harness.feed("b", marker={"seq": 5, "resume": False})
    harness.settle()
    assert harness.outputs() == [] and harness.node.c_rejected == {"b": 1}


def test_a_partner_arriving_after_its_seq_was_given_up_is_refused_not_processed(harness, monkeypatch):
    monkeypatch.setattr(node_mod, "RECOVERY_STALL_S", 0.0)
    harness.node.recovering = True                             # fed by a restarted node: partners may be lost
    harness.feed("a", *range(harness.node.limit))              # a full buffer with no partner in sight
    harness.settle()
    first = harness.outputs()
    assert first and first[0] == (0, "alone", "a", None)
    gone = first[-1][0]
    harness.feed("b", *range(gone + 1))                        # the partners, too late
    harness.feed("b", gone + 1)                                # and the first one in time
    harness.settle()
    assert harness.node.c_rejected == {"b": gone + 1}          # refused, counted, never handed to the block
    assert harness.outputs() == [(gone + 1, "paired", None, None)]


def test_a_producer_reconnects_at_once_and_tells_the_restarted_consumer_where_it_resumes(harness):
    node = harness.node
    for seq in range(3):
        node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": seq}))
    assert [s for s, *_ in harness.outputs()] == [0, 1, 2]
    node.seq = 3
    harness.control(type="reconnect", edges=[EDGE, "not.an -> edge.of_this_node"])
    assert node.reconnect == set()                             # reconnected at once, with no frame to send
    node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": 3}))
    assert harness.outputs() == [(3, None, None, True), (3, None, None, None)]   # the marker comes first
    assert node.c_sent[EDGE] == 4                                                # a marker is not a frame


def test_a_finished_producer_also_repeats_its_end_of_stream_to_the_restarted_consumer(harness):
    node = harness.node
    node.send("out", Frame({}, {"data": np.zeros(2)}), Frame({"seq": 0}))
    node.seq = 1
    node.send_eos()
    assert [(s, r) for s, _, _, r in harness.outputs()] == [(0, None), (1, "eos")]
    harness.control(type="reconnect", edges=[EDGE])
    assert [(s, r) for s, _, _, r in harness.outputs()] == [(1, True), (1, "eos")]   # resume at 1, then the end of stream again


def test_the_runtime_tells_each_block_which_instance_it_is(harness):
    node = harness.node
    assert node.block.instance == (0, 0)
    harness.control(type="swap", block="pairer", params={}, id=1)
    node.apply_swap()
    assert node.generation == 1 and node.block.instance == (0, 1)          # swapped in: a new generation
    restarted = NodeRunner({**node.spec, "incarnation": 2, "generation": 1})
    try:
        assert restarted.block.instance == (2, 1)                          # a restarted process: a new incarnation
    finally:
        restarted.control.close(linger=0)
        for s in (*restarted.inputs.values(), *(s for e in restarted.outputs.values() for _, s in e)):
            s.close(linger=0)
        restarted.ctx.term()
