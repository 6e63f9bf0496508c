"""The DCA1000 UDP stream: cycles reassembled from packets written as TI describes them (a 4-byte sequence number
from 1, a 6-byte count of the bytes sent before, up to 1456 data bytes), and every cycle touched by a lost,
truncated, duplicated or reordered packet, or left unfinished by a sender that stops, released as damaged: never
clean. Without sockets first, then over loopback through the replayer (datagrams this host's kernel drops counted
apart from those the link loses, and the receive buffer granted), then through the block, the detector and the
gate."""
from __future__ import annotations

import socket
import struct
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.capture.dca1000_udp import Faults, Reassembler, Replayer, UdpReceiver, apply_faults

B = 4096                                     # bytes per cycle: 16 chirps x 2 receivers x 64 real 16-bit samples
PAYLOAD = 1456


def ti_packets(stream: bytes) -> list[bytes]:
    """The DCA1000's raw-mode datagrams of a stream, from TI's description (independent of packetize)."""
    out = []
    for i in range(0, -(-len(stream) // PAYLOAD)):
        data = stream[i * PAYLOAD:(i + 1) * PAYLOAD]
        out.append(struct.pack("<I", i + 1) + (i * PAYLOAD).to_bytes(6, "little") + data)
    return out


def touched(i: int, total: int) -> set[int]:
    """Cycles holding bytes of packet i."""
    a, b = i * PAYLOAD, min((i + 1) * PAYLOAD, total)
    return set(range(a // B, (b - 1) // B + 1))


def stream_of(cycles: int, seed: int = 0) -> bytes:
    return np.random.default_rng(seed).integers(-3000, 3000, cycles * B // 2).astype("<i2").tobytes()


def reassemble(packets, stop=True):
    r = Reassembler(B)
    for p in packets:
        r.feed(p)
    out = []
    while (got := r.take(3)) is not None:
        out.append(got)
    if stop and (tail := r.flush()) is not None:
        out.append(tail)
    cycles = {}
    for got in out:
        for j, damage in enumerate(got.damage):
            cycles[got.first_cycle + j] = (got.data[j * B:(j + 1) * B], damage)
    return cycles, r.counts


def test_a_whole_stream_comes_back_cycle_by_cycle_and_clean():
    stream = stream_of(10)
    cycles, counts = reassemble(ti_packets(stream))
    assert sorted(cycles) == list(range(10))
    assert all(cycles[c] == (stream[c * B:(c + 1) * B], ()) for c in range(10))
    assert counts["damaged_cycles"] == 0 and counts["lost"] == 0 and counts["bytes"] == len(stream)


@pytest.mark.parametrize("fault, reason", [
    (Faults(lose=frozenset({7})), "lost"),
    (Faults(duplicate=frozenset({7})), "duplicated"),
    (Faults(swap=frozenset({7})), "reordered"),
    (Faults(truncate={7: 10 + 500}), "truncated"),
    (Faults(truncate={7: 6}), "lost"),               # shorter than its header: its bytes are found missing
])
def test_every_cycle_a_damaged_packet_touches_is_released_damaged_and_the_others_intact(fault, reason):
    stream = stream_of(10, 1)
    cycles, counts = reassemble(apply_faults(ti_packets(stream), fault))
    hit = touched(7, len(stream))
    assert sorted(cycles) == list(range(10))
    for c, (data, damage) in cycles.items():
        if c in hit:
            assert reason in damage, (c, damage)
        elif not damage:
            assert data == stream[c * B:(c + 1) * B]
    assert sum(1 for c in cycles if cycles[c][1]) >= len(hit)
    assert counts["damaged_cycles"] == sum(1 for c in cycles if cycles[c][1])


def test_a_sender_that_stops_within_a_cycle_leaves_it_damaged_as_incomplete():
    stream = stream_of(6, 2)
    packets = ti_packets(stream)
    cycles, counts = reassemble(packets[:12])                 # 12 x 1456 bytes = 4.27 cycles
    assert sorted(cycles) == [0, 1, 2, 3, 4]
    assert cycles[4][1] == ("incomplete",) and all(cycles[c][1] == () for c in range(4))
    assert counts["incomplete"] == 1


def test_a_receiver_that_joins_late_starts_at_the_next_whole_cycle_and_says_so():
    stream = stream_of(6, 3)
    cycles, counts = reassemble(ti_packets(stream)[5:])      # packet 5 starts at byte 7280, within cycle 1
    assert min(cycles) == 2 and all(cycles[c] == (stream[c * B:(c + 1) * B], ()) for c in range(2, 6))
    assert counts["skipped_bytes"] == 2 * B


@settings(max_examples=80, deadline=None)
@given(cycles=st.integers(1, 8), seed=st.integers(0, 1000), data=st.data())
def test_no_cycle_touched_by_a_fault_is_ever_released_clean_and_clean_ones_are_exact(cycles, seed, data):
    stream = stream_of(cycles, seed)
    packets = ti_packets(stream)
    n = len(packets)
    idx = st.integers(0, n - 1)
    faults = Faults(lose=frozenset(data.draw(st.sets(idx, max_size=3))),
                    duplicate=frozenset(data.draw(st.sets(idx, max_size=2))),
                    swap=frozenset(data.draw(st.sets(st.integers(0, max(n - 2, 0)), max_size=2))),
                    truncate=data.draw(st.dictionaries(idx, st.integers(0, PAYLOAD), max_size=2)))
    sent = apply_faults(packets, faults)
    got, _ = reassemble(sent)
    # what happened to each packet, read off the datagrams sent (their sequence numbers), not off the faults
    ids = [struct.unpack("<I", d[:4])[0] - 1 if len(d) >= 10 else None for d in sent]
    seen = [i for i in ids if i is not None]
    lost = set(range(n)) - set(seen)
    doubled = {i for i in seen if seen.count(i) > 1}
    cut = {i for i, d in zip(ids, sent) if i is not None and d != packets[i]}
    late = {k for j, k in enumerate(seen) if any(e > k for e in seen[:j])}
    faulty = lost | doubled | cut | late
    hit = set().union(*(touched(i, len(stream)) for i in faulty)) if faulty else set()
    for c, (block, damage) in got.items():
        if c in hit:
            assert damage, (c, faults)
        if not damage:
            assert block == stream[c * B:(c + 1) * B]


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_over_loopback_the_replayer_s_faults_reach_the_receiver_and_a_stop_ends_the_stream():
    stream = stream_of(12, 4)
    rx = UdpReceiver("127.0.0.1", 0, Reassembler(B))
    tx = Replayer("127.0.0.1", rx.address[1])
    try:
        tx.send(apply_faults(ti_packets(stream), Faults(lose=frozenset({9}), stop_after=30)))
        got = {}
        while (r := rx.take(4, 4, idle_timeout_s=0.5)) is not None:
            for j, d in enumerate(r.damage):
                got[r.first_cycle + j] = (r.data[j * B:(j + 1) * B], d)
    finally:
        tx.close()
        rx.close()
    # 34 packets, packet 9 lost, the sender stops after 30 more: packet 30 ends at byte 45136, within cycle 11
    assert sorted(got) == list(range(12)) and rx.stopped
    assert got[11][1] == ("incomplete",)
    assert all("lost" in got[c][1] for c in touched(9, len(stream)))
    clean = [c for c in got if not got[c][1]]
    assert len(clean) == 12 - 1 - len(touched(9, len(stream)))
    assert all(got[c][0] == stream[c * B:(c + 1) * B] for c in clean)


def kernel_udp(port: int) -> tuple[int, int]:
    """(rx_queue bytes, drops) of the socket bound to 127.0.0.1:port, from /proc/net/udp (by port, not by inode as
    the receiver looks itself up)."""
    with open("/proc/net/udp") as fh:
        for f in map(str.split, fh.readlines()[1:]):
            if f[1] == f"0100007F:{port:04X}":
                return int(f[4].split(":")[1], 16), int(f[12])
    raise AssertionError(f"no UDP socket bound to 127.0.0.1:{port}")


def rmem_max() -> int:
    with open("/proc/sys/net/core/rmem_max") as fh:
        return int(fh.read())


def test_datagrams_the_host_drops_are_counted_as_the_host_s_and_every_cycle_they_touch_is_damaged():
    stream = stream_of(12, 5)
    packets = ti_packets(stream)                                      # 34 packets
    rx = UdpReceiver("127.0.0.1", 0, Reassembler(B), rcvbuf_bytes=4096)   # granted 8192: three datagrams
    port = rx.address[1]
    tx = Replayer("127.0.0.1", port)
    got = {}
    try:
        with rx.cond:      # the receiving thread cannot feed the reassembler: the socket fills and the kernel drops
            tx.send(packets[:20])
            dropped = kernel_udp(port)[1]
        tx.send(packets[20:], room=lambda: not rx.queued())          # the rest, no faster than the receiver drains
        while (r := rx.take(4, 4, idle_timeout_s=0.5)) is not None:
            for j, d in enumerate(r.damage):
                got[r.first_cycle + j] = (r.data[j * B:(j + 1) * B], d)
        assert kernel_udp(port)[1] == dropped                         # none after the burst
    finally:
        tx.close()
        rx.close()
    counts = rx.reassembler.counts
    assert dropped >= 10, dropped                                     # 20 sent, at most 4 held (3 queued, 1 read)
    assert counts["dropped_by_host"] == dropped and counts["lost"] == dropped
    assert counts["packets"] == len(packets) - dropped
    assert sorted(got) == list(range(12))
    damaged = {c for c, (_, d) in got.items() if d}
    assert damaged and all(got[c][1] == ("lost",) for c in damaged)
    assert all(got[c][0] == stream[c * B:(c + 1) * B] for c in set(got) - damaged)   # no missing byte in them
    assert counts["damaged_cycles"] == len(damaged)


def test_the_receiver_gets_the_buffer_it_asks_for_beyond_rmem_max_when_privileged_and_says_what_it_got():
    limit = rmem_max()
    asked = limit + (1 << 20)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.setsockopt(socket.SOL_SOCKET, 33, asked)            # SO_RCVBUFFORCE: needs CAP_NET_ADMIN
            privileged = True
        except PermissionError:
            privileged = False
    rx = UdpReceiver("127.0.0.1", 0, Reassembler(B), rcvbuf_bytes=asked)
    try:
        # Linux doubles the request for its bookkeeping; unprivileged, the request is capped at rmem_max first
        assert rx.rcvbuf_granted_bytes == 2 * (asked if privileged else limit)
        assert rx.rcvbuf_granted_bytes == rx.sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
    finally:
        rx.close()


def test_the_replayer_waits_while_the_receiver_has_no_room_and_then_keeps_its_pace_without_a_burst():
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    tx = Replayer("127.0.0.1", sink.getsockname()[1])
    calls = []

    def room() -> bool:
        calls.append(kernel_udp(sink.getsockname()[1])[0])
        if len(calls) == 6:           # before packet 5: no room for 0.3 s
            time.sleep(0.3)
            return False
        return True

    packets = ti_packets(stream_of(4, 6))[:10]
    try:
        seconds = tx.send(packets, bytes_per_s=20 * (10 + PAYLOAD), room=room)   # 20 packets/s
        received = [sink.recv(2048) for _ in packets]
    finally:
        tx.close()
        sink.close()
    assert received == packets and len(calls) == 11                 # asked before every packet, and once more
    # packets 0-4 take 0.2 s, the wait 0.3 s, then packets 5-9 0.2 s more: a sender that caught up on its schedule
    # after the wait would send packets 5-9 at once and finish in 0.5 s
    assert seconds >= 0.2 + 0.3 + 0.2 - 0.01, seconds


def test_the_replayer_refuses_an_address_off_this_host():
    with pytest.raises(ValueError, match="loopback address only"):
        Replayer("192.0.2.1", 4098)


SCENE = """name = "udp"
fc_hz = 77e9
bandwidth_hz = 1.0e9
t_sweep_s = 50e-6
t_chirp_s = 60e-6
fs_hz = 2e6
n_chirps = 16
n_samples = 64
iq = false
adc_bits = 16
adc_full_scale = 1.0
sigma_n = 9.1552734375e-4
"""   # sigma_n = 30 codes x 2^-15


def test_the_block_sends_damaged_cycles_that_the_detector_judges_invalid_and_the_gate_refuses(tmp_path):
    from blocks.dca1000_udp_source import Dca1000UdpSource
    from blocks.gate import Gate
    from blocks.rms_detector import RmsDetector
    from carav_stream.runtime import Frame

    scene = tmp_path / "udp.toml"
    scene.write_text(SCENE)
    codes = np.rint(np.random.default_rng(9).standard_normal(8 * B // 2) * 30).astype("<i2")   # noise, 30 codes
    stream = codes.tobytes()
    port = free_port()
    block = Dca1000UdpSource(port=port, n_rx=2, rx=1, pattern="10" * 8, scene=str(scene), batch=8,
                             idle_timeout_s=0.5)
    block.start()
    tx = Replayer("127.0.0.1", port)
    try:
        tx.send(apply_faults(ti_packets(stream), Faults(duplicate=frozenset({12}))))
        out = block.generate(0)
        assert block.generate(1) is None                             # the sender stopped on a cycle boundary
    finally:
        tx.close()
        block.finish()
    frames, rho = out["frames"], out["rho"]
    hit = touched(12, len(stream))
    assert frames.payload.shape == (8, 16, 64) and rho.payload.shape == (8, 16)
    per = frames.header["per_cycle"]
    assert [c for c in range(8) if per["nonfinite"][c]] == sorted(hit)
    assert all(per["damage"][c] == "duplicated" for c in hit)
    expected = codes.reshape(8, 16, 2, 64)[:, :, 1]                 # receiver 1, from TI's 2-lane real order
    np.testing.assert_array_equal(frames.payload, expected)
    frames, rho = (Frame(dict(f.header, seq=0), dict(f.arrays)) for f in (frames, rho))
    verdict = RmsDetector(scene=str(scene), eta=1.5).process(frames, rho)
    judged = Gate().process(frames, verdict)
    refused = judged["alarms"].header["per_cycle"]
    assert refused["reason"] == ["invalid"] * len(hit)
    assert judged["clean"].header["cycles"] == 8 - len(hit)
    summary = block.summary()["run"]["live_capture"]
    assert summary["duplicated"] == 1 and summary["damaged_cycles"] == len(hit) and summary["cycles"] == 8
    assert summary["dropped_by_host"] == 0 and summary["rcvbuf_granted_bytes"] >= 2 * min(8 << 20, rmem_max()), summary


def test_a_four_receiver_stream_comes_out_with_a_receiver_axis_and_its_damaged_cycles_flagged(tmp_path):
    """A TDM scene's 4 receivers over the UDP stream (complex, 2 lanes, written from TI's layout): every receiver of
    every clean cycle where the radar put it; a cycle a lost packet touches flagged with all its receivers' samples."""
    from blocks.dca1000_udp_source import Dca1000UdpSource
    from tests.capture.ti_dca1000 import capture_bytes

    scene = tmp_path / "mimo.toml"
    scene.write_text(SCENE.replace("n_samples = 64", "n_samples = 32").replace("iq = false", "iq = true")
                     + "tx_positions_wl = [0.0, 2.0]\ntdm_schedule = [0, 1]\nrx_positions_wl = [0.0, 0.5, 1.0, 1.5]\n")
    cycles, per_cycle = 6, 16 * 4 * 32 * 2 * 2             # 16 chirps x 4 receivers x 32 complex int16 samples
    x = np.random.default_rng(11).integers(-3000, 3000, size=(cycles, 16, 4, 32, 2)).astype(np.int16)
    stream = capture_bytes(x.reshape(cycles * 16, 4, 32, 2), complex_data=True)
    assert len(stream) == cycles * per_cycle
    port = free_port()
    block = Dca1000UdpSource(port=port, n_rx=4, pattern="1100" * 4, scene=str(scene), batch=cycles,
                             idle_timeout_s=0.5)
    block.start()
    tx = Replayer("127.0.0.1", port)
    try:
        tx.send(apply_faults(ti_packets(stream), Faults(lose=frozenset({9}))))
        out = block.generate(0)
        assert block.generate(1) is None
    finally:
        tx.close()
        block.finish()
    frames = out["frames"]
    assert frames.payload.shape == (cycles, 4, 16, 32, 2) and out["rho"].payload.shape == (cycles, 16)
    hit = set(range(9 * PAYLOAD // per_cycle, ((9 + 1) * PAYLOAD - 1) // per_cycle + 1))
    per = frames.header["per_cycle"]
    assert [c for c in range(cycles) if per["nonfinite"][c]] == sorted(hit)
    assert all(per["nonfinite"][c] == 4 * 16 * 32 for c in hit) and all(per["damage"][c] == "lost" for c in hit)
    for c in set(range(cycles)) - hit:
        np.testing.assert_array_equal(frames.payload[c], np.moveaxis(x[c], 1, 0))   # (receiver, chirp, sample, I|Q)
