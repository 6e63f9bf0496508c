"""The data-plane helpers: lean multipart send and receive, each waiting at most one tick inside ZeroMQ."""
import time

import pytest
import zmq

from carav_stream.runtime import transport


@pytest.fixture
def pair(tmp_path):
    """A connected PUSH -> PULL edge with HWM 1, set up as nodes set up theirs."""
    ctx = zmq.Context()
    endpoint = transport.ipc_endpoint(tmp_path, "edge")
    pull = transport.bind_input(ctx, endpoint, hwm=1)
    push = transport.connect_output(ctx, endpoint, hwm=1, linger_ms=0)
    yield push, pull
    push.close(linger=0)
    pull.close(linger=0)
    ctx.term()


def test_sockets_wait_at_most_one_tick_inside_zeromq(pair):
    push, pull = pair
    assert push.sndtimeo == pull.rcvtimeo == int(transport.TICK_S * 1000)
    t0 = time.monotonic()
    with pytest.raises(zmq.Again):
        transport.recv_message(pull)
    assert transport.TICK_S * 0.5 <= time.monotonic() - t0 < 5
    t0 = time.monotonic()
    with pytest.raises(zmq.Again):
        transport.recv_message(pull, zmq.NOBLOCK)
    assert time.monotonic() - t0 < transport.TICK_S * 0.5


def test_multipart_messages_arrive_whole_and_frames_are_forwarded_without_copies(pair):
    push, pull = pair
    payload = bytes(range(256)) * 1024
    transport.send_message(push, [b"head", memoryview(payload), b"tail"])
    parts = transport.recv_message(pull)
    assert [bytes(p) for p in parts] == [b"head", payload, b"tail"]
    transport.send_message(push, [b"again", parts[1]])     # a received zmq.Frame goes out as it is
    again = transport.recv_message(pull)
    assert bytes(again[0]) == b"again" and bytes(again[1]) == payload and not again[1].more
