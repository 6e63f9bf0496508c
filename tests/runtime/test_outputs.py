"""Output delivery: back-pressure keeps serving the node, cut edges count what they could not take, a restarted
consumer gets a fresh connection whose first message says where the stream resumes."""
import time

import pytest
import zmq

from carav_stream.runtime import transport
from carav_stream.runtime.outputs import Outputs
from carav_stream.runtime.protocol import OutEdge

EDGES = {"out": (OutEdge("p.out -> a.inp", "A"), OutEdge("p.out -> b.inp", "B"))}


class Sock:
    """A stand-in socket: what was sent on it, and how many sends it refuses first (a full queue)."""

    def __init__(self, endpoint: str, full: int = 0) -> None:
        self.endpoint, self.full, self.sent, self.closed = endpoint, full, [], False

    def close(self, linger=None) -> None:
        self.closed = True


def outputs(full: dict[str, int] | None = None, idle=lambda: None, edges=EDGES) -> tuple[Outputs, list[Sock]]:
    made: list[Sock] = []

    def connect(endpoint):
        made.append(Sock(endpoint, (full or {}).get(endpoint, 0)))
        return made[-1]

    def send(sock, parts, flags=0):
        if sock.full:
            sock.full -= 1
            raise zmq.Again()
        sock.sent.append(parts)

    return Outputs(edges, connect, idle, send, tick_s=0.0), made


TAPPED = {"out": (OutEdge("p.out -> a.inp", "A"), OutEdge("p.out -> view.inp", "V", tap=True))}


def test_a_full_tap_skips_the_frame_at_once_and_counts_it_skipped_never_lost():
    idles = []
    out, socks = outputs({"V": 2}, idle=lambda: idles.append(1), edges=TAPPED)
    for seq in range(4):
        out.send("out", [f"h{seq}"], seq)
    assert idles == []                                               # never waited
    assert socks[0].sent == [["h0"], ["h1"], ["h2"], ["h3"]]         # the processing edge got every frame
    assert socks[1].sent == [["h2"], ["h3"]]                         # the tap: what it had room for, in order
    assert out.c_skipped == {"p.out -> view.inp": 2} and out.c_undeliverable == {}
    assert out.c_sent == {"p.out -> a.inp": 4, "p.out -> view.inp": 2}


def test_a_tap_alone_on_its_port_and_a_tap_being_reconnected_skip_too():
    out, socks = outputs({"V": 1}, edges={"out": (OutEdge("p.out -> view.inp", "V", tap=True),)})
    out.send("out", ["h0"], 0)
    out.reconnect.add("p.out -> view.inp")
    out.send("out", ["h1"], 1)                                       # its consumer is restarting: skipped at once
    out.reconnect.clear()
    out.send("out", ["h2"], 2)
    assert socks[0].sent == [["h2"]] and out.c_skipped == {"p.out -> view.inp": 2}


def test_a_frame_goes_to_every_edge_of_its_port_in_order_and_is_counted_per_edge():
    out, socks = outputs()
    out.send("out", ["h0"], 0)
    out.send("out", ["h1"], 1)
    assert [s.sent for s in socks] == [[["h0"], ["h1"]], [["h0"], ["h1"]]]
    assert out.c_sent == {"p.out -> a.inp": 2, "p.out -> b.inp": 2} and out.sent_seq["p.out -> b.inp"] == 1


def test_a_full_consumer_blocks_the_send_while_the_node_keeps_serving_control():
    idles = []
    out, socks = outputs({"B": 3}, idle=lambda: idles.append(1))
    out.send("out", ["h"], 0)
    assert len(idles) == 3 and socks[1].sent == [["h"]] and out.c_undeliverable == {}


def test_an_edge_cut_while_blocked_gives_up_and_counts_the_frame_undeliverable():
    out, socks = outputs({"B": 10 ** 6}, idle=lambda: out.cut.add("p.out -> b.inp"))
    out.send("out", ["h"], 0)
    assert socks[0].sent == [["h"]] and socks[1].sent == []
    assert out.c_sent == {"p.out -> a.inp": 1} and out.c_undeliverable == {"p.out -> b.inp": 1}


def test_a_restarted_consumer_gets_a_fresh_connection_that_first_says_where_the_stream_resumes():
    out, socks = outputs()
    out.send("out", ["h0"], 0)
    out.reconnect.add("p.out -> b.inp")
    out.resume_all(lambda port, edge: [["resume", out.resume_seq(edge, 1)]])
    assert socks[1].closed and len(socks) == 3 and socks[2].endpoint == "B"
    out.send("out", ["h1"], 1)
    assert socks[2].sent == [["resume", 1], ["h1"]] and out.reconnect == set()


def test_a_fresh_connection_without_room_yet_is_kept_and_the_next_call_sends_only_what_is_left():
    out, socks = outputs()
    first_fresh = {"B": True}

    def connect(endpoint):            # the fresh connection to B takes one message, then has no room for a while
        socks.append(Sock(endpoint))
        if first_fresh.pop(endpoint, False):
            socks[-1].refuse_after = 1
        return socks[-1]

    def send(sock, parts, flags=0):
        if getattr(sock, "refuse_after", None) == len(sock.sent):
            del sock.refuse_after
            raise zmq.Again()
        sock.sent.append(parts)

    out._connect, out._send = connect, send
    out.reconnect.add("p.out -> b.inp")
    marker = lambda port, edge: [["resume", 0], ["eos", 0]]   # noqa: E731
    out.resume_all(marker)
    assert out.reconnect == {"p.out -> b.inp"} and socks[2].sent == [["resume", 0]]
    out.resume_all(marker)
    assert out.reconnect == set() and not socks[2].closed and len(socks) == 3
    assert socks[2].sent == [["resume", 0], ["eos", 0]]         # each message once, on the one fresh connection


def test_a_consumer_restarted_again_while_its_marker_waits_gets_another_fresh_connection():
    out, socks = outputs()
    fresh = iter([10 ** 6, 0])        # the first fresh connection never has room (its consumer died again)

    def connect(endpoint):
        socks.append(Sock(endpoint, next(fresh)))
        return socks[-1]

    out._connect = connect
    out.restart({"p.out -> b.inp", "x.out -> elsewhere"})      # an edge this node does not have is ignored
    out.resume_all(lambda port, edge: [["resume", 0]])
    assert out.reconnect == {"p.out -> b.inp"} and socks[2].sent == []
    out.restart({"p.out -> b.inp"})
    out.resume_all(lambda port, edge: [["resume", 0]])
    assert socks[2].closed and socks[3].sent == [["resume", 0]] and out.reconnect == set()


def test_end_of_stream_reaches_every_edge_with_the_count_sent_on_it():
    out, socks = outputs()
    out.send("out", ["h0"], 0)
    out.send_eos(lambda port, edge: ["eos", out.c_sent[edge]])
    assert [s.sent[-1] for s in socks] == [["eos", 1], ["eos", 1]] and out.eos_sent


@pytest.fixture
def pair(tmp_path):
    """A connected PUSH -> PULL edge with HWM 1, set up as nodes set up theirs."""
    ctx = zmq.Context()
    endpoint = transport.ipc_endpoint(tmp_path, "edge")
    pull = transport.bind_input(ctx, endpoint, hwm=1)
    yield ctx, endpoint, pull
    ctx.destroy(linger=0)         # closes whatever a failed test left open, so teardown cannot hang


def test_over_zeromq_a_blocked_send_waits_inside_zeromq_tick_by_tick_and_sends_nothing_when_cut(pair):
    ctx, endpoint, pull = pair
    calls = []
    edges = {"out": (OutEdge("p.out -> s.inp", endpoint),)}
    out = Outputs(edges, lambda ep: transport.connect_output(ctx, ep, hwm=1, linger_ms=0),
                  lambda: calls.append(time.monotonic()) if len(calls) < 3 else out.cut.add("p.out -> s.inp"))
    big = b"x" * (1 << 20)                                 # more than a Unix socket buffer holds
    sock = out.sockets["out"][0][1]
    filled = 0
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:                     # fill every queue of the edge
        try:
            transport.send_message(sock, [b"h", big])     # refused only after a whole tick without room
            filled += 1
        except zmq.Again:
            break
    assert filled >= 1 and not calls
    t0 = time.monotonic()
    out.send("out", [b"h", b"y" * 1000], filled)
    assert len(calls) >= 3 and out.c_undeliverable == {"p.out -> s.inp": 1}
    assert transport.TICK_S * 2 <= time.monotonic() - t0 < 10    # it waited inside ZeroMQ, tick by tick
    received = []
    for _ in range(filled):                                # every frame ZeroMQ took arrives whole ...
        assert pull.poll(5000), f"only {len(received)} of {filled} frames arrived"
        received.append(bytes(transport.recv_message(pull)[1]))
    assert received == [big] * filled
    assert not pull.poll(300)                              # ... and the cut one was never half sent
    out.close(crashed=True)


def test_over_zeromq_frames_queued_towards_a_consumer_that_died_never_reach_its_restarted_incarnation(tmp_path):
    """The restarted incarnation binds the same address; the old connection reconnects to it by itself before its
    producer hears of the restart. What it held for the dead one must be gone, not delivered ahead of (or after)
    the resume marker."""
    ctx = zmq.Context()
    try:
        endpoint = transport.ipc_endpoint(tmp_path, "edge")
        pull = transport.bind_input(ctx, endpoint, hwm=1)
        push = transport.connect_output(ctx, endpoint, hwm=4, linger_ms=0)
        transport.send_message(push, [b"old", b"0"])
        assert pull.poll(5000)
        sent = 1
        big = b"x" * (1 << 20)                      # more than a Unix socket buffer holds
        for _ in range(64):                         # fill every queue of the connection towards it
            try:
                transport.send_message(push, [b"old", big], zmq.NOBLOCK)
                sent += 1
            except zmq.Again:
                break
        assert sent > 2
        pull.close(linger=0)                        # the consumer dies with frames queued towards it
        pull = transport.bind_input(ctx, endpoint, hwm=1)      # its restarted incarnation, same address
        deadline = time.monotonic() + 10
        while not pull.poll(50):                    # the old connection reaches it again by itself; a frame sent
            assert time.monotonic() < deadline, "the old connection never reached the new incarnation"
            try:                                    # before the break was noticed is dropped with the rest
                transport.send_message(push, [b"new", b"0"], zmq.NOBLOCK)
            except zmq.Again:
                pass
        received = []
        while pull.poll(300):
            received.append(bytes(transport.recv_message(pull)[0]))
        assert received and set(received) == {b"new"}, received
    finally:
        ctx.destroy(linger=0)
