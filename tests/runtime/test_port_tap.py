"""Port taps (runtime/port_tap.py): started over the control plane, a sampled copy of a port's frames (its header
and the last rows of its payload, never its other arrays) at most rate_hz a second, ended by their lease or on
request; a tap nobody reads, or a reader that does not read, never holds the producer back; the supervisor refuses
a private port, another host's node and a port the block does not have, every problem named."""
import shutil
import tempfile
import threading
from pathlib import Path
from types import SimpleNamespace

import msgpack
import numpy as np
import pytest
import zmq

from carav_graphs import graph_file
from carav_stream.runtime import transport
from carav_stream.runtime.admin_server import AdminServer
from carav_stream.runtime.frames import Frame, decode
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.node_state import NodeState
from carav_stream.runtime.port_tap import MAX_RATE_HZ, PortTaps, output_ports, tap_request
from carav_stream.runtime.protocol import Admin, Control, unpack
from tests.runtime.conftest import EDGE

DEADLINE_S = 10.0


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def tapdir():
    d = Path(tempfile.mkdtemp(prefix="tp", dir="/tmp"))        # ipc paths must stay short
    yield d
    shutil.rmtree(d, ignore_errors=True)


def frame(seq: int, n_cycles: int = 3) -> tuple[dict, Frame]:
    data = np.arange(n_cycles * 4 * 6, dtype=np.int16).reshape(n_cycles, 4, 6) + seq
    header = {"stream": "p.out", "seq": seq, "cycle": seq * n_cycles, "cycles": n_cycles,
              "per_cycle": {"q": [0.5] * n_cycles}, "node": "p", "block": "toy", "block_version": "1#0"}
    return header, Frame({}, {"data": data, "secret": np.ones((n_cycles, 4), bool)})


def receive(sub: zmq.Socket) -> tuple[bytes, dict, Frame]:
    assert sub.poll(DEADLINE_S * 1000), "no tap message arrived"
    topic, info, *parts = sub.recv_multipart()
    return topic, msgpack.unpackb(info), decode(parts)


def subscriber(ctx: zmq.Context, endpoint: str, topic: bytes = b"") -> zmq.Socket:
    sub = ctx.socket(zmq.SUB)
    sub.rcvhwm = 2         # a reader that does not read is full after two messages
    sub.linger = 0
    sub.subscribe(topic)
    sub.connect(endpoint)
    return sub


def test_a_started_tap_copies_the_header_and_the_last_rows_of_the_payload_and_nothing_else(tapdir):
    ctx, clock = zmq.Context(), Clock()
    ep = transport.ipc_endpoint(tapdir, "tap-p")
    taps = PortTaps(ctx, "p", incarnation=2, clock=clock)
    taps.apply({"port": "out", "rate_hz": 4.0, "rows": 1, "for_s": 5.0, "endpoint": ep})
    sub = subscriber(ctx, ep, b"p.out")
    header, f = frame(0)
    # a PUB drops what it sends before the subscription reached it: offer until a copy arrives
    for k in range(200):
        clock.t += 1.0
        taps.offer("out", dict(header, seq=k), f)
        if sub.poll(20):
            break
    topic, info, got = receive(sub)
    assert topic == b"p.out"
    assert info["port"] == "out" and info["rows"] == [2, 3] and info["incarnation"] == 2 and info["rate_hz"] == 4.0
    assert info["frames"] == info["sent"] == k + 1
    assert list(got.arrays) == ["data"]                                   # never the frame's other arrays
    np.testing.assert_array_equal(got.payload, f.payload[2:])              # the last row only
    assert got.header["seq"] == k and got.header["per_cycle"] == {"q": [0.5] * 3} and got.header["cycles"] == 3
    assert taps.counters() == {"out": {"frames": k + 1, "sent": k + 1}}
    taps.close()
    sub.close()
    ctx.term()


def test_a_tap_copies_at_most_rate_hz_frames_a_second_and_counts_every_frame_the_port_sent():
    sent, clock = [], Clock()
    taps = PortTaps(None, "p", clock=clock, send=lambda sock, parts, flags=0: sent.append((parts, flags)))
    taps.sock, taps.endpoint = object(), "ipc://x"                          # bound already: a stand-in
    taps.apply({"port": "out", "rate_hz": 4.0, "rows": 2, "for_s": 30.0, "endpoint": "ipc://x"})
    header, f = frame(0)
    for k in range(100):                                                   # 100 frames in one second
        taps.offer("out", dict(header, seq=k), f)
        clock.t += 0.01
    infos = [msgpack.unpackb(parts[1]) for parts, _ in sent]
    assert len(sent) == 4 and [i["frames"] for i in infos] == [1, 26, 51, 76]   # every 0.25 s
    assert all(flags == zmq.NOBLOCK for _, flags in sent)                       # never a waiting send
    assert taps.ports["out"].frames == 100 and infos[-1]["sent"] == 4
    assert decode(sent[0][0][2:]).payload.shape == (2, 4, 6)


def test_a_tap_ends_with_its_lease_unless_asked_again_and_at_once_when_asked_to():
    sent, clock = [], Clock()
    taps = PortTaps(None, "p", clock=clock, send=lambda sock, parts, flags=0: sent.append(parts))
    taps.sock, taps.endpoint = object(), "ipc://x"
    ask = {"port": "out", "rate_hz": 10.0, "rows": 1, "for_s": 2.0, "endpoint": "ipc://x"}
    taps.apply(ask)
    header, f = frame(0)
    clock.t += 1.5
    taps.apply(ask)                                                        # renewed: 2 s from now
    clock.t += 1.9
    taps.offer("out", header, f)
    assert len(sent) == 1 and "out" in taps.ports
    clock.t += 0.2
    taps.offer("out", header, f)
    assert len(sent) == 1 and "out" not in taps.ports                      # the lease ran out
    taps.apply(ask)
    taps.apply({**ask, "for_s": 0})
    assert taps.ports == {}
    for bad in ({**ask, "rate_hz": MAX_RATE_HZ * 2}, {**ask, "rows": 0}, {**ask, "endpoint": "ipc://elsewhere"},
                {**ask, "port": 3}):
        taps.apply(bad)
        assert taps.ports == {}, bad


def test_a_tap_nobody_reads_or_whose_reader_never_reads_never_holds_the_producer_back(tapdir):
    """Each copy is due (the clock moves a second a frame) and 1 MB large; the producer's offers all return, with
    a subscriber that never reads and with none at all."""
    ctx, clock = zmq.Context(), Clock()
    big = Frame({}, {"data": np.zeros((1, 512, 1024), np.int16)})
    for reader in (False, True):
        ep = transport.ipc_endpoint(tapdir, f"tap-{reader}")
        taps = PortTaps(ctx, "p", clock=clock)
        taps.apply({"port": "out", "rate_hz": MAX_RATE_HZ, "rows": 1, "for_s": 60.0, "endpoint": ep})
        sub = subscriber(ctx, ep) if reader else None
        done = threading.Event()

        def produce(taps=taps):
            for k in range(300):
                clock.t += 1.0
                taps.ports["out"].until = clock.t + 60.0
                taps.offer("out", {"stream": "p.out", "seq": k, "cycle": k}, big)
            done.set()
        threading.Thread(target=produce, daemon=True).start()
        who = "a reader that never reads" if reader else "no reader"
        assert done.wait(60.0), f"the producer stalled on a tap with {who}"
        assert taps.ports["out"].frames == 300
        taps.close()
        if sub is not None:
            sub.close()
    ctx.term()


def test_a_tap_asked_over_the_control_plane_copies_what_the_port_sends_and_the_edge_gets_every_frame(harness,
                                                                                                      tapdir):
    ep = transport.ipc_endpoint(tapdir, "tap-p")
    harness.control(Control.TAP, port="out", rate_hz=MAX_RATE_HZ, rows=1, for_s=30.0, endpoint=ep)
    ports = harness.node.ports
    assert "out" in ports.taps.ports
    sub = subscriber(ports.ctx, ep, b"p.out")
    driver, k = harness.node.driver, 0
    while not sub.poll(0):
        assert k < 500, "no tap message while the port sent 500 frames"
        ports.taps.ports["out"].next_at = 0.0                               # due at every frame
        driver.send("out", Frame({}, {"data": np.full((2, 3), float(k))}), Frame({"seq": k}))
        k += 1
    _, info, got = receive(sub)
    assert got.header["stream"] == "p.out" and got.payload.shape == (1, 3)
    assert ports.outputs.c_sent[EDGE] == k and len(harness.outputs(k)) == k   # the edge got every frame
    assert harness.node.counters()["taps"]["out"]["frames"] == k
    sub.close()


@pytest.fixture(scope="module")
def chain():
    """The radar chain's graph (with an attacker) and a stand-in for each of its nodes' state."""
    graph = load_graph(graph_file("table1_smart"))
    return graph, {n: NodeState(n, SimpleNamespace(type=node.type)) for n, node in graph.nodes.items()}


def test_the_supervisor_lists_every_output_port_and_refuses_a_tap_of_a_private_one_or_a_bad_request(chain, tapdir):
    graph, nodes = chain
    ports = {f"{p['node']}.{p['port']}": p for p in output_ports(graph, nodes)}
    assert {k for k, p in ports.items() if p["private"]} == {"source.tx", "source.rho", "channel.air",
                                                            "detector.verdict"}
    assert ports["adc.frames"]["kind"] == "adc_frame" and ports["adc.frames"]["edges"] >= 1
    for req, culprit in (({"node": "source", "port": "rho"}, "source.rho is private"),
                         ({"node": "detector", "port": "verdict"}, "detector.verdict is private"),
                         ({"node": "nowhere", "port": "x"}, "node 'nowhere' does not run on this host"),
                         ({"node": "adc", "port": "rx"}, "node 'adc' has no output port 'rx'"),
                         ({"node": "adc", "port": "frames", "rate_hz": 100.0}, "rate_hz must be"),
                         ({"node": "adc", "port": "frames", "for_s": -1}, "for_s must be")):
        reply, control = tap_request(graph, nodes, tapdir, req)
        assert not reply["ok"] and culprit in reply["error"] and control is None, (req, reply)
    reply, control = tap_request(graph, nodes, tapdir, {"node": "adc", "port": "frames", "rate_hz": 2.0})
    assert reply["ok"] and reply["topic"] == "adc.frames" and control["endpoint"] == f"ipc://{tapdir}/tap-adc"
    assert control == {"port": "frames", "rate_hz": 2.0, "rows": 1, "for_s": 10.0, "endpoint": control["endpoint"]}


def test_the_admin_socket_answers_ports_and_tap_and_tells_the_node(chain, tapdir):
    graph, nodes = chain
    told, answers = [], []
    server = AdminServer(graph, nodes, SimpleNamespace(), send=lambda node, kind, **f: told.append((node, kind, f)),
                         request_stop=lambda why: None, log=lambda text: None, run_dir=tapdir)
    server.sock = SimpleNamespace(send=lambda raw: answers.append(unpack(raw)))
    server.on_admin({"type": Admin.PORTS})
    assert answers[-1]["ok"] and any(p["node"] == "gate" and p["port"] == "clean" for p in answers[-1]["ports"])
    server.on_admin({"type": Admin.TAP, "node": "gate", "port": "clean", "rate_hz": 4.0, "for_s": 6.0})
    assert answers[-1]["ok"] and answers[-1]["topic"] == "gate.clean"
    assert told == [("gate", Control.TAP, {"port": "clean", "rate_hz": 4.0, "rows": 1, "for_s": 6.0,
                                           "endpoint": answers[-1]["endpoint"]})]
    server.on_admin({"type": Admin.TAP, "node": "source", "port": "tx"})
    assert not answers[-1]["ok"] and "private" in answers[-1]["error"] and len(told) == 1
