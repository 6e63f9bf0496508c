"""The in-process node harness: a real NodeRunner on real ZeroMQ sockets, driven by the test."""
import os
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
from carav_stream.runtime.protocol import NodeSpec, OutEdge, Report, pack, unpack
from carav_stream.runtime.senders import start_ticks
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
                    queue_frames=2, drain_timeout_s=1.0,
                    producers={p: [[os.getpid(), start_ticks(os.getpid())]] for p in ("a", "b")})   # the test feeds
    runners = [NodeRunner(spec)]
    runner = runners[0]
    runner.driver.block.start()
    runner.link.tell(Report.READY)
    assert router.poll(5000), "the node's control connection did not come up"
    route, hello = router.recv_multipart()         # the node says hello at once: where messages to it go
    assert unpack(hello)["type"] == Report.HELLO
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
        def send_raw(port, parts):
            transport.send_message(feeds[port], parts)

        @staticmethod
        def run_until(n_processed, until=lambda: True, what="the expected counts"):
            """Receive and pump until the node handed `n_processed` frame sets to its block in all (and `until()`
            holds)."""
            deadline = time.monotonic() + DEADLINE_S
            while runner.driver.processed < n_processed or not until():
                assert time.monotonic() < deadline, (f"{runner.driver.processed} of {n_processed} frame sets "
                                                     f"processed; waiting for {what}")
                for p in ("a", "b"):
                    runner.ports.receive(p)
                runner.driver.pump()

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
            router.send_multipart([route, pack(kind, **msg)])
            assert runner.link.sock.poll(DEADLINE_S * 1000), "control message did not arrive"
            runner.link.serve()

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


