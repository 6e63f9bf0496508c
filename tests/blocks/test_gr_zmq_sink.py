"""gr_zmq_sink: the ADC's cycles, in frames cut anywhere, reach a plain ZeroMQ receiver (what GNU Radio's ZMQ PULL
Source is) as one gr-zeromq message per cycle: the samples the codes stand for, offsets that follow one another,
the tags on the items the stream's description names, and the activation sequence only when asked for and only
to this host; as a REP, each cycle in replies of at most what each request asks for; a frame that is not the
scene's, a receiver or request that never comes, and settings that do not fit are refused naming them."""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from carav_blocks.gr_zmq_sink import GrZmqSink
from carav_stream.capture.gr_zmq import Receiver, decode
from carav_stream.capture.pmt import UInt64
from carav_stream.radar.adc import adc_step
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime import BlockError
from carav_stream.testing.harness import BlockHarness, random_bounds
from carav_stream.view.server import free_port

GOLDEN = Path(__file__).resolve().parents[1] / "golden"
SCENE = str(GOLDEN / "adc_small_iq.toml")          # 4 chirps x 256 I/Q samples, a 12-bit ADC
N_CYCLES = 7


def codes(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(-2048, 2048, (N_CYCLES, 4, 256, 2)).astype(np.int16)


def receive_all(rx: Receiver) -> list[list[bytes]]:
    out = []
    while (parts := rx.receive(2.0 if not out else 0.5)) is not None:
        out.append(parts)
    return out


def test_every_cycle_arrives_as_its_samples_with_its_tags_whole_or_split():
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    rx = Receiver(address, "pull")                 # connects before the sink binds: ZeroMQ retries
    x = codes()
    rho = np.random.default_rng(1).random((N_CYCLES, 4)) < 0.5
    h = BlockHarness(GrZmqSink, scene=SCENE, address=address, pass_tags=True,
                     tags=["packet_len", "rx_rate", "rx_time", "carav_cycle", "carav_chirp", "carav_seq", "carav_rho"])
    bounds = random_bounds(N_CYCLES, "sink")
    h.run({"frames": x, "rho": rho}, bounds=bounds, cycle0=40)
    got = [decode(p, "complex64", tagged=True) for p in receive_all(rx)]
    rx.close()
    lsb = np.float32(adc_step(load_scene(SCENE)))
    assert len(got) == N_CYCLES
    for c, m in enumerate(got):
        want = (x[c].astype(np.float32) * lsb).view(np.complex64)[..., 0].ravel()    # I + jQ, in sqrt(W)
        assert m.offset == c * 1024 and np.array_equal(m.items, want)
        tags = {}
        for t in m.tags:
            tags.setdefault(t.key, []).append((t.offset - m.offset, t.value))
        assert tags["packet_len"] == [(256 * k, 256) for k in range(4)]
        assert tags["carav_chirp"] == [(256 * k, k) for k in range(4)]
        assert tags["carav_cycle"] == [(0, 40 + c)] and type(tags["carav_cycle"][0][1]) is UInt64
        assert np.array_equal(tags["carav_rho"][0][1], rho[c]) and tags["carav_rho"][0][0] == 0
        assert ("rx_rate" in tags) == (c == 0) and tags.get("rx_rate", [(0, 150e6)]) == [(0, 150e6)]
        secs, frac = tags["rx_time"][0][1]
        assert secs + frac == pytest.approx((40 + c) * load_scene(SCENE).t_cycle_s)
        starts = [a for a, _ in bounds]
        assert ("carav_seq" in tags) == (c in starts)
        if c in starts:
            assert tags["carav_seq"] == [(0, starts.index(c))]
    assert h.block.summary()["run"]["gr_stream_sent"] == {"address": address, "messages": N_CYCLES,
                                                          "items": N_CYCLES * 1024, "cycles": N_CYCLES,
                                                          "tags": sum(len(m.tags) for m in got)}


def test_without_pass_tags_a_message_is_the_items_alone_and_a_pub_key_goes_first():
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    rx = Receiver(address, "pull")
    x = np.random.default_rng(2).standard_normal((3, 16, 256)).astype(np.float32)     # an ideal ADC's samples
    BlockHarness(GrZmqSink, scene=str(GOLDEN / "ranging_small.toml"), address=address).run({"frames": x})
    got = receive_all(rx)
    rx.close()
    assert [p for [p] in got] == [x[c].tobytes() for c in range(3)]
    sink = GrZmqSink(scene=SCENE, address="tcp://127.0.0.1:1", socket="pub", key="radar")
    assert sink.key == "radar"


def test_a_push_that_no_receiver_takes_fails_naming_its_address():
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    h = BlockHarness(GrZmqSink, scene=SCENE, address=address, timeout_s=0.2)
    with pytest.raises(BlockError, match=f"{address}: no receiver took cycle 0 within 0.2 s"):
        h.run({"frames": codes()[:1]})
    h.block.finish()


def test_a_rep_answers_each_request_with_at_most_the_items_asked_for_and_never_two_cycles_in_one():
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    req = Receiver(address, "req", request_items=300)      # what GNU Radio's ZMQ REQ Source is, asking for 300
    x, failed = codes(), []
    h = BlockHarness(GrZmqSink, scene=SCENE, address=address, socket="rep", pass_tags=True)

    def serve() -> None:
        try:
            h.run({"frames": x}, bounds=random_bounds(N_CYCLES, "rep"))
        except BaseException as exc:                           # noqa: BLE001 - reported by the test's thread
            failed.append(exc)
    server = threading.Thread(target=serve)
    server.start()
    got = []
    while sum(len(m.items) for m in got) < N_CYCLES * 1024 and not failed:
        parts = req.receive(10.0)
        assert parts is not None, "no reply"
        got.append(decode(parts, "complex64", tagged=True))
    server.join(30)
    req.close()
    assert not failed and not server.is_alive()
    sizes = [len(m.items) for m in got]
    assert sizes == [300, 300, 300, 124] * N_CYCLES
    assert [m.offset for m in got] == [sum(sizes[:i]) for i in range(len(sizes))]
    lsb = np.float32(adc_step(load_scene(SCENE)))
    want = (x.astype(np.float32) * lsb).view(np.complex64)[..., 0].ravel()
    assert np.array_equal(np.concatenate([m.items for m in got]), want)
    assert [t.offset for m in got for t in m.tags if t.key == "packet_len"] == list(range(0, N_CYCLES * 1024, 256))
    assert [t.offset for m in got for t in m.tags if t.key == "carav_cycle"] == list(range(0, N_CYCLES * 1024, 1024))
    assert h.block.summary()["run"]["gr_stream_sent"]["messages"] == 4 * N_CYCLES


def test_a_rep_that_no_request_comes_to_fails_naming_its_address():
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    h = BlockHarness(GrZmqSink, scene=SCENE, address=address, socket="rep", timeout_s=0.2)
    with pytest.raises(BlockError, match=f"{address}: no request for cycle 0 within 0.2 s .*ZMQ REQ Source"):
        h.run({"frames": codes()[:1]})
    h.block.finish()


def test_a_frame_that_is_not_the_scene_s_cycles_is_refused_naming_its_shape():
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    h = BlockHarness(GrZmqSink, scene=SCENE, address=address)
    with pytest.raises(BlockError, match=r"frame seq 0: int16 \(1, 4, 128, 2\) is not 1 cycles of the scene's 4 "
                                         r"chirps of 256 I/Q samples"):
        h.run({"frames": codes()[:1, :, :128]})
    with pytest.raises(BlockError, match="float32 .* is not"):
        h.run({"frames": np.zeros((1, 4, 256), np.float32)})
    h.block.finish()


def test_codes_for_a_scene_with_an_ideal_adc_are_refused(tmp_path):
    ideal = tmp_path / "ideal.toml"
    ideal.write_text((GOLDEN / "adc_small_iq.toml").read_text().replace("adc_bits = 12", "adc_bits = 0"))
    h = BlockHarness(GrZmqSink, scene=str(ideal), address=f"tcp://127.0.0.1:{free_port('127.0.0.1')}")
    with pytest.raises(BlockError, match="frame seq 0: int16 codes, but scene .* has an ideal ADC"):
        h.run({"frames": codes()[:1]})
    h.block.finish()


def test_the_activation_is_refused_without_its_sequences_and_beyond_this_host():
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    h = BlockHarness(GrZmqSink, scene=SCENE, address=address, pass_tags=True, tags=["carav_rho"])
    with pytest.raises(BlockError, match="tags name carav_rho, but the rho input gives nothing"):
        h.run({"frames": codes()[:1]})
    h.block.finish()
    with pytest.raises(BlockError, match="carav_rho would put the activation sequence.*tcp://10.0.0.2:5556"):
        GrZmqSink(scene=SCENE, address="tcp://10.0.0.2:5556", pass_tags=True, tags=["carav_rho"])
    GrZmqSink(scene=SCENE, address="ipc:///tmp/carav-gr", pass_tags=True, tags=["carav_rho"])


@pytest.mark.parametrize(("params", "message"), [
    ({"tags": ["packet_len", "rho"]}, r"tags: \['rho'\] unknown"),
    ({"key": "radar"}, "key: 'radar': only a PUB socket sends a key"),
    ({"address": "udp://1.2.3.4:5"}, "address: 'udp://1.2.3.4:5' is not tcp://HOST:PORT"),
    ({"socket": "pull"}, "socket"),
])
def test_settings_that_do_not_fit_are_refused_naming_them(params, message):
    with pytest.raises(BlockError, match=message):
        GrZmqSink(**{"scene": SCENE, **params})
