"""gr_zmq_source: a stream sent as GNU Radio's ZMQ PUSH Sink sends it (a plain ZeroMQ socket and messages built by
the wire format) comes out as the scene's ADC frames with their activation sequences: the codes the samples stand
for, bit for bit; a dropped message, a missing sequence and a sender that stops mid-cycle give cycles the detector
must refuse (nonfinite = their samples), never clean ones; a stream that cannot be this scene's, or messages that
do not fit the settings, end the node in one line naming the address and the message; a REQ asks for a cycle at
a time and frames replies of any length; and gr_zmq_sink's stream, activation included, comes back as it left,
pushed or served to requests."""
from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest

from carav_blocks.gr_zmq_sink import GrZmqSink
from carav_blocks.gr_zmq_source import GrZmqSource
from carav_stream.capture.gr_stream import TAG_NAMES, cycle_tags, layout_of
from carav_stream.capture.gr_zmq import Sender, Tag, encode
from carav_stream.radar.adc import from_codes
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime import BlockError
from carav_stream.testing.harness import BlockHarness, check_declared, wire
from carav_stream.view.server import free_port

GOLDEN = Path(__file__).resolve().parents[1] / "golden"
SCENE = str(GOLDEN / "adc_small_iq.toml")          # 4 chirps x 256 I/Q samples, a 12-bit ADC
LAY = layout_of(load_scene(SCENE))
N = LAY.items_per_cycle


def codes(cycles: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(-2048, 2048, (cycles, 4, 256, 2)).astype(np.int16)


def samples(c: np.ndarray) -> np.ndarray:
    return from_codes(load_scene(SCENE), c).reshape(-1)


def run_source(source: GrZmqSource, deadline_s: float = 30.0) -> list[dict]:
    """The source's frames, asked for as its node asks (ready_in, then generate), until its stream ends."""
    out, seq, t_end = [], 0, time.monotonic() + deadline_s
    while time.monotonic() < t_end:
        wait = source.ready_in(seq)
        if wait > 0:
            time.sleep(wait)
            continue
        got = source.generate(seq)
        if got is None:
            source.finish()
            return out
        check_declared(source, got, source.batch)
        out.append({port: wire(frame, seq) for port, frame in got.items()})
        seq += 1
    raise AssertionError("the source did not end its stream")


def source_and_sender(**params) -> tuple[GrZmqSource, Sender]:
    sender = Sender(f"tcp://127.0.0.1:{free_port('127.0.0.1')}", "push")
    source = GrZmqSource(**{"scene": SCENE, "address": sender.address, "idle_timeout_s": 0.5, "batch": 3, **params})
    source.start()
    return source, sender


def joined(frames: list[dict], port: str, name: str | None = None):
    if name is None:
        return np.concatenate([f[port].payload for f in frames])
    return [v for f in frames for v in f[port].header["per_cycle"][name]]


def test_a_tagged_stream_comes_out_as_the_codes_it_stands_for_with_the_pattern():
    source, sender = source_and_sender(pass_tags=True, pattern="1010")
    x = codes(7)
    stream = samples(x)
    cuts = [0, 700, 1024, 3000, 5000, 7 * N]
    tags = [t for c in range(7) for t in cycle_tags(LAY, c * N, c, frozenset(TAG_NAMES[:-1]), rate=c == 0)]
    for a, b in zip(cuts, cuts[1:]):
        assert sender.send(encode(stream[a:b], offset=a, tags=[t for t in tags if a <= t.offset < b]), 5.0)
    frames = run_source(source)
    sender.close(0)
    assert np.array_equal(joined(frames, "frames"), x)
    assert np.array_equal(joined(frames, "rho"), np.tile([True, False, True, False], (7, 1)))
    assert [f["frames"].header["cycle"] for f in frames] == [0, 3, 6]
    assert joined(frames, "frames", "nonfinite") == [0] * 7 and joined(frames, "frames", "damage") == [""] * 7
    assert joined(frames, "frames", "rx_time_s") == pytest.approx([c * LAY.t_cycle_s for c in range(7)])
    s = source.summary()["run"]["gr_stream"]
    assert s["cycles"] == 7 and s["damaged_cycles"] == 0 and s["messages"] == 5 and s["sender_stopped"] is True


@pytest.mark.slow
def test_a_stream_whose_first_message_never_comes_ends_after_first_timeout_s_and_not_before():
    source = GrZmqSource(scene=SCENE, address=f"tcp://127.0.0.1:{free_port('127.0.0.1')}", pattern="1111",
                         first_timeout_s=1.0, idle_timeout_s=0.05)
    source.start()
    t0 = time.monotonic()
    assert run_source(source) == [] and time.monotonic() - t0 >= 1.0
    assert source.summary()["run"]["gr_stream"]["sender_stopped"] is True


def test_an_untagged_stream_starts_cycle_0_at_its_first_item_and_an_ideal_adc_keeps_the_samples():
    scene = str(GOLDEN / "ranging_small.toml")
    sender = Sender(f"tcp://127.0.0.1:{free_port('127.0.0.1')}", "push")
    source = GrZmqSource(scene=scene, address=sender.address, idle_timeout_s=0.5, pattern="1" * 16)
    source.start()
    x = np.random.default_rng(3).standard_normal((2, 16, 256)).astype(np.float32) * 1e-3
    for part in np.array_split(x.ravel(), 5):
        assert sender.send(encode(part), 5.0)
    frames = run_source(source)
    sender.close(0)
    lsb = load_scene(scene).adc_full_scale / 2 ** 11
    assert np.array_equal(joined(frames, "frames"), np.clip(np.rint(x / np.float32(lsb)), -2048, 2047))


def test_a_dropped_message_and_a_sender_that_stops_mid_cycle_give_refused_cycles_never_clean_ones():
    source, sender = source_and_sender(pass_tags=True, pattern="1111")
    stream = samples(codes(5))
    cuts = [0, 1100, 1500, 3 * N, 4 * N, 4 * N + 100]
    for a, b in zip(cuts, cuts[1:]):
        if a != 1100:                                           # items 1100 .. 1499 (of cycle 1) lost
            assert sender.send(encode(stream[a:b], offset=a), 5.0)
    frames = run_source(source)
    sender.close(0)
    assert joined(frames, "frames", "damage") == ["", "lost", "", "", "incomplete"]
    assert joined(frames, "frames", "nonfinite") == [0, N, 0, 0, N]
    s = source.summary()["run"]["gr_stream"]
    assert (s["lost"], s["incomplete"], s["lost_items"], s["damaged_cycles"]) == (1, 1, 400, 2)


def test_the_activation_from_the_tags_and_a_cycle_without_its_sequence_refused():
    source, sender = source_and_sender(pass_tags=True, rho_from_tags=True)
    rho = np.random.default_rng(4).random((4, 4)) < 0.5
    stream = samples(codes(4))
    for c in range(4):
        tags = cycle_tags(LAY, c * N, c, frozenset({"carav_rho"}) if c != 2 else frozenset(), rho=rho[c])
        assert sender.send(encode(stream[c * N:(c + 1) * N], offset=c * N, tags=tags), 5.0)
    frames = run_source(source)
    sender.close(0)
    got = joined(frames, "rho")
    assert np.array_equal(got[[0, 1, 3]], rho[[0, 1, 3]]) and not got[2].any()
    assert joined(frames, "frames", "damage") == ["", "", "no_activation", ""]
    assert joined(frames, "frames", "nonfinite") == [0, 0, N, 0]
    assert source.summary()["run"]["gr_stream"]["no_activation"] == 1


@pytest.mark.parametrize(("params", "message", "said"), [
    ({"pass_tags": True}, [Tag(0, "packet_len", 128)],
     r"message 1: not scene .*'s stream: packet_len 128 at item 0: the scene's chirps are 256 samples long"),
    ({"pass_tags": True}, [Tag(0, "rx_rate", 100e6)],
     "message 1: .*: rx_rate 100000000.0 Hz at item 0: the scene samples at 1.5e"),
    ({"pass_tags": True}, None, r"message 1: bad magic .*: is the sender's pass_tags off\?"),
    ({}, [], "message 1: wrong item size: .*starts with a tag header: is the sender's pass_tags on"),
])
def test_a_stream_that_cannot_be_this_scene_s_ends_the_node_in_one_line(params, message, said):
    source, sender = source_and_sender(pattern="1111", **params)
    x = samples(codes(1))
    parts = encode(x[:255], offset=0) if message == [] else encode(x) if message is None else \
        encode(x, offset=0, tags=message)
    assert sender.send(parts, 5.0)
    with pytest.raises(BlockError, match=f"{source.address}: {said}") as refused:
        run_source(source)
    assert refused.value.retry is False and "\n" not in str(refused.value)
    source.finish()
    sender.close(0)


@pytest.mark.slow
def test_a_subscriber_takes_its_key_s_stream_from_where_it_joined_and_counts_the_other_key_s():
    pub = Sender(f"tcp://127.0.0.1:{free_port('127.0.0.1')}", "pub")
    source = GrZmqSource(scene=SCENE, address=pub.address, socket="sub", key="radar", pass_tags=True,
                         pattern="1111", idle_timeout_s=1.0, batch=2)
    source.start()
    x = codes(40, seed=7)
    stream = samples(x)

    def publish():                     # cycle after cycle, each also under another key; the first ones may be
        for c in range(40):            # published before the subscription arrives (ZeroMQ's slow joiner)
            item = stream[c * N:(c + 1) * N]
            pub.send(encode(item, offset=c * N, key=b"radar"), 1.0)
            pub.send(encode(item * 0, offset=c * N, key=b"radarX"), 1.0)     # SUB matches prefixes
            time.sleep(0.01)
    sender = threading.Thread(target=publish)
    sender.start()
    frames = run_source(source)
    sender.join()
    pub.close(0)
    index = [c for f in frames for c in range(f["frames"].header["cycle"],
                                              f["frames"].header["cycle"] + f["frames"].header["cycles"])]
    assert len(index) > 10 and index == list(range(index[0], 40))
    assert np.array_equal(joined(frames, "frames"), x[index[0]:])
    s = source.summary()["run"]["gr_stream"]
    assert s["other_key"] >= len(index) and s["damaged_cycles"] == 0


def test_a_req_asks_for_a_cycle_s_items_at_a_time_and_frames_the_replies_however_short():
    rep = Sender(f"tcp://127.0.0.1:{free_port('127.0.0.1')}", "rep")     # what GNU Radio's ZMQ REP Sink is
    source = GrZmqSource(scene=SCENE, address=rep.address, socket="req", pass_tags=True, pattern="1010",
                         idle_timeout_s=0.5, batch=3)
    source.start()
    x = codes(5, seed=3)
    stream, asked = samples(x), []
    tags = [t for c in range(5) for t in cycle_tags(LAY, c * N, c, frozenset(TAG_NAMES[:-1]), rate=c == 0)]

    def serve() -> None:                    # a flowgraph replies with what it has ready: here at most 700 items
        pos = 0
        while pos < len(stream) and (n := rep.wait_request(10.0)) is not None:
            asked.append(n)
            k = min(n, 700)
            rep.send(encode(stream[pos:pos + k], offset=pos, tags=[t for t in tags if pos <= t.offset < pos + k]),
                     5.0)
            pos += k
    server = threading.Thread(target=serve)
    server.start()
    frames = run_source(source)
    server.join(30)
    rep.close(0)
    assert asked == [N] * -(-5 * N // 700)
    assert np.array_equal(joined(frames, "frames"), x) and joined(frames, "frames", "damage") == [""] * 5
    assert source.summary()["run"]["gr_stream"]["messages"] == len(asked)


@pytest.mark.parametrize("sink, source_socket", [("push", "pull"), ("rep", "req")])
def test_gr_zmq_sink_s_stream_with_its_activation_comes_back_as_it_left(sink, source_socket):
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    source = GrZmqSource(scene=SCENE, address=address, socket=source_socket, pass_tags=True, rho_from_tags=True,
                         idle_timeout_s=0.5)
    source.start()
    x, rho = codes(6, seed=5), np.random.default_rng(6).random((6, 4)) < 0.5
    harness = BlockHarness(GrZmqSink, scene=SCENE, address=address, socket=sink, pass_tags=True, tags=[*TAG_NAMES])
    server = threading.Thread(target=harness.run, args=({"frames": x, "rho": rho},),
                              kwargs={"bounds": [(0, 4), (4, 6)], "cycle0": 10})
    server.start()
    frames = run_source(source)
    server.join(30)
    assert not server.is_alive()
    assert np.array_equal(joined(frames, "frames"), x) and np.array_equal(joined(frames, "rho"), rho)
    assert frames[0]["frames"].header["cycle"] == 10 and frames[0]["rho"].header["cycle"] == 10
    assert joined(frames, "frames", "damage") == [""] * 6


@pytest.mark.parametrize(("params", "message"), [
    ({"pattern": "1111", "key": "radar"}, "key: 'radar': only a PUB sink has a key"),
    ({"rho_from_tags": True}, "rho_from_tags: the sequences come from the tags alone: pass_tags = true"),
    ({"rho_from_tags": True, "pass_tags": True, "pattern": "1111"}, "neither activation nor pattern"),
    ({}, "activation, pattern: give exactly one"),
    ({"pattern": "11"}, "pattern: expected 4 digits"),
    ({"pattern": "1111", "address": "tcp://host"}, "address: 'tcp://host' has no port"),
])
def test_settings_that_do_not_fit_are_refused_naming_them(params, message):
    with pytest.raises(BlockError, match=message):
        GrZmqSource(scene=SCENE, **params)
