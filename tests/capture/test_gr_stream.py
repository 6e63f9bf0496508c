"""carav's cycles as a GNU Radio stream and back: the sink's tags where the stream's description puts them; a stream
cut into messages anywhere comes back cycle by cycle, tagged or not; dropped or repeated messages, a late start and
a sender that stops mid-cycle damage exactly the cycles they touch (never released clean), a cycle nothing came
for is counted, not released; and a tag that says the stream is another scene's is refused in one line."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.capture.gr_stream import (
    DEFAULT_TAGS,
    TAG_NAMES,
    StreamFramer,
    StreamLayout,
    StreamRefused,
    cycle_tags,
    layout_of,
)
from carav_stream.capture.gr_zmq import Message, Tag, decode, encode
from carav_stream.capture.pmt import UInt64
from carav_stream.radar.scene_loader import load_scene

LAY = StreamLayout(n_chirps=4, n_samples=8, fs_hz=2e6, t_cycle_s=1.25, t_adc_start_s=0.5e-6, iq=True)
N = 32                                       # items per cycle


def stream(cycles: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return (rng.standard_normal(cycles * N) + 1j * rng.standard_normal(cycles * N)).astype(np.complex64)


def messages(x: np.ndarray, cuts: list[int], tagged: bool = True, first: int = 0, tags=()) -> list[Message]:
    """x cut at `cuts` into messages, as a GNU Radio sink sends them (through the wire format)."""
    edges = [0, *sorted(set(cuts)), len(x)]
    out = []
    for a, b in zip(edges, edges[1:]):
        if b > a:
            mine = [t for t in tags if first + a <= t.offset < first + b]
            parts = encode(x[a:b], offset=first + a if tagged else None, tags=mine)
            out.append(decode(parts, "complex64", tagged=tagged))
    return out


def frame_all(msgs: list[Message], layout: StreamLayout = LAY, stop: bool = True):
    framer = StreamFramer(layout)
    got = []
    for m in msgs:
        framer.feed(m)
        while (f := framer.take(3)) is not None:
            got.append(f)
    if stop and (f := framer.flush()) is not None:
        got.append(f)
    cycles = {}
    for f in got:
        for i, g in enumerate(f.grid):
            cycles[g] = (f.samples[i], f.damage[i], f.cycles[i], f.rho[i], f.rx_time_s[i])
    return cycles, framer.counts


# ------------------------------------------------------------------ the sink's tags

def test_the_sink_tags_every_chirp_and_every_cycle_where_the_description_says():
    rho = np.array([1, 0, 0, 1], bool)
    tags = cycle_tags(LAY, 64, 2, frozenset(TAG_NAMES), seq=9, rate=True, rho=rho)
    by_key: dict[str, list[Tag]] = {}
    for t in tags:
        by_key.setdefault(t.key, []).append(t)
        assert t.srcid == "carav"
    assert [(t.offset, t.value) for t in by_key["packet_len"]] == [(64 + 8 * k, 8) for k in range(4)]
    assert [(t.offset, t.value) for t in by_key["carav_chirp"]] == [(64 + 8 * k, k) for k in range(4)]
    assert [(t.offset, t.value) for t in by_key["carav_cycle"]] == [(64, 2)]
    assert type(by_key["carav_cycle"][0].value) is UInt64 and by_key["carav_seq"][0].value == UInt64(9)
    assert by_key["rx_rate"][0].value == 2e6 and by_key["rx_rate"][0].offset == 64
    secs, frac = by_key["rx_time"][0].value                 # 2 x 1.25 s + 0.5 us
    assert type(secs) is UInt64 and secs == 2 and frac == pytest.approx(0.5 + 0.5e-6, abs=1e-12)
    assert np.array_equal(by_key["carav_rho"][0].value, [1, 0, 0, 1])


def test_the_activation_goes_only_when_named_and_then_only_with_its_sequence():
    assert "carav_rho" not in DEFAULT_TAGS
    assert all(t.key != "carav_rho" for t in cycle_tags(LAY, 0, 0, frozenset(DEFAULT_TAGS), rho=np.ones(4, bool)))
    with pytest.raises(ValueError, match="carav_rho: cycle 3 needs its activation sequence of 4 chirps"):
        cycle_tags(LAY, 0, 3, frozenset({"carav_rho"}))


def test_a_scene_gives_its_layout():
    scene = load_scene("table1")
    lay = layout_of(scene)
    assert (lay.n_chirps, lay.n_samples, lay.fs_hz, lay.item) == (64, 1080, 150e6, np.float32)


# ------------------------------------------------------------------ framing

@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(1, 5 * N - 1), max_size=12), st.booleans())
def test_a_stream_cut_anywhere_comes_back_cycle_by_cycle_and_clean(cuts, tagged):
    x = stream(5)
    cycles, counts = frame_all(messages(x, cuts, tagged))
    assert sorted(cycles) == [0, 1, 2, 3, 4]
    for g, (samples, damage, index, _, _) in cycles.items():
        assert np.array_equal(samples.ravel(), x[g * N:(g + 1) * N]) and damage == () and index == g
    assert counts["damaged_cycles"] == 0 and counts["items"] == 5 * N


def test_a_dropped_message_damages_exactly_the_cycles_it_touched():
    x = stream(6)
    msgs = messages(x, [20, 40, 70, 100, 150])                      # messages of items [40, 70) dropped
    cycles, counts = frame_all([m for m in msgs if m.offset != 40])
    assert {g: c[1] for g, c in cycles.items()} == {0: (), 1: ("lost",), 2: ("lost",), 3: (), 4: (), 5: ()}
    assert np.all(cycles[1][0].ravel()[40 - 32:] == 0) and np.all(cycles[2][0].ravel()[:70 - 64] == 0)
    assert counts["lost_items"] == 30 and counts["lost_cycles"] == 0 and counts["damaged_cycles"] == 2


def test_a_cycle_nothing_came_for_is_counted_and_not_released():
    x = stream(6)
    msgs = messages(x, [40, 150])                                    # items [40, 150) dropped
    cycles, counts = frame_all([m for m in msgs if m.offset != 40])
    assert sorted(cycles) == [0, 1, 4, 5]
    assert cycles[1][1] == ("lost",) and cycles[4][1] == ("lost",) and cycles[5][1] == ()
    assert counts["lost_cycles"] == 2 and counts["lost_items"] == 110


def test_items_sent_again_damage_their_open_cycles_and_are_not_written_twice():
    x = stream(4)
    msgs = messages(x, [40, 80])
    again = decode(encode(x[70:80] * 0 + 5, offset=70), "complex64", tagged=True)   # items 70 .. 79 again
    cycles, counts = frame_all([msgs[0], msgs[1], again, msgs[2]])
    assert cycles[2][1] == ("overlapping",) and cycles[0][1] == () and cycles[1][1] == ()
    assert np.array_equal(cycles[2][0].ravel(), x[64:96])              # the first copy of items 70 .. 79 kept
    assert counts["overlapping_items"] == 10


def test_a_receiver_that_joins_late_starts_at_the_next_whole_cycle():
    x = stream(4)
    msgs = messages(x[45:], [10, 30], first=45)
    cycles, counts = frame_all(msgs)
    assert sorted(cycles) == [2, 3] and counts["items_before_first_cycle"] == 64 - 45
    assert all(c[1] == () for c in cycles.values())


def test_a_sender_that_stops_within_a_cycle_leaves_it_incomplete():
    x = stream(3)
    cycles, counts = frame_all(messages(x[:80], [33]))
    assert cycles[2][1] == ("incomplete",) and np.all(cycles[2][0].ravel()[16:] == 0)
    assert counts["incomplete"] == 1 and counts["cycles"] == 3
    cycles, _ = frame_all(messages(x[:80], [33]), stop=False)
    assert sorted(cycles) == [0, 1]                                    # not released while the stream goes on


def test_carav_tags_carry_the_cycle_index_the_activation_and_the_time():
    x = stream(4)
    tags = [t for g in range(4) for t in cycle_tags(LAY, g * N, 100 + g + (g >= 2) * 5, frozenset(TAG_NAMES),
                                                    rho=np.array([g % 2, 1, 0, 1], bool))]
    tags = [t for t in tags if not (t.key == "carav_rho" and t.offset == N)]     # cycle 1's sequence missing
    cycles, counts = frame_all(messages(x, [50], tags=tags))
    assert [cycles[g][2] for g in range(4)] == [100, 101, 107, 108]
    assert cycles[1][3] is None and np.array_equal(cycles[3][3], [True, True, False, True])
    assert cycles[2][4] == pytest.approx(107 * 1.25 + 0.5e-6)
    assert counts["tags"] == len(tags)


# ------------------------------------------------------------------ a stream that is not this scene's

REFUSED = [
    (Tag(0, "packet_len", 16), "packet_len 16 at item 0: the scene's chirps are 8 samples long"),
    (Tag(0, "packet_len", 8.0), "packet_len 8.0 at item 0"),
    (Tag(12, "packet_len", 8), "packet_len at item 12 is not where a chirp starts"),
    (Tag(0, "rx_rate", 2.5e6), "rx_rate 2500000.0 Hz at item 0: the scene samples at 2e\\+06 Hz"),
    (Tag(8, "carav_chirp", 2), "carav_chirp 2 at item 8: item 8 is sample 0 of chirp 1 of 4"),
    (Tag(8, "carav_cycle", UInt64(0)), "carav_cycle at item 8 is not where a cycle starts"),
    (Tag(0, "carav_cycle", -1), "carav_cycle -1 at item 0: a cycle index is an integer"),
    (Tag(0, "carav_rho", np.array([1, 2, 0, 0], np.uint8)), "carav_rho at item 0: .* is not 4 values 0 or 1"),
    (Tag(0, "carav_rho", np.ones(5, np.uint8)), "is not 4 values 0 or 1"),
    (Tag(0, "rx_time", 3.5), r"rx_time 3.5 at item 0: expected \(uint64 seconds, double fraction\)"),
]


@pytest.mark.parametrize(("tag", "message"), REFUSED, ids=[m[:40] for _, m in REFUSED])
def test_a_tag_that_says_the_stream_is_another_scene_s_is_refused_in_one_line(tag, message):
    framer = StreamFramer(LAY)
    with pytest.raises(StreamRefused, match=message) as refused:
        framer.feed(decode(encode(stream(1), offset=0, tags=[tag]), "complex64", tagged=True))
    assert "\n" not in str(refused.value)


def test_other_tags_pass_and_an_rx_time_within_a_cycle_is_left_out():
    tags = [Tag(3, "snr", 1.5), Tag(5, "rx_time", (UInt64(1), 0.5)), Tag(0, "packet_len", UInt64(8))]
    cycles, counts = frame_all(messages(stream(1), [], tags=tags))
    assert cycles[0][1] == () and cycles[0][4] is None and counts["tags_ignored"] == 2
