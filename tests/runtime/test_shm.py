"""The shared-memory data plane in one process: slots, generations, give-back, refusals, restarts."""
import gc
import os

import msgpack
import numpy as np
import pytest

from carav_stream.runtime import shm
from carav_stream.runtime.frames import Frame, FrameError, decode, encode_with_header
from carav_stream.runtime.planes.shm import ShmReader

BIG = (64, 1100)            # a Table I cycle of float64: far above shm.MIN_FRAME_BYTES


@pytest.fixture
def segment():
    fds = []

    def make(n_slots=4, n_edges=1):
        fd = shm.create_segment(n_slots, n_edges, "carav-test")
        fds.append(fd)
        return fd
    yield make
    gc.collect()
    for fd in fds:
        os.close(fd)


def frame_parts(array, writer, **place):
    """The message a node sends for Frame.of(array) over `writer`'s segment."""
    header = {"stream": "a.out", "seq": 0, "cycle": 0}
    return encode_with_header(header, Frame.of(array), None, lambda b: writer.place(b, **place))


def test_a_frame_in_a_slot_reads_back_equal_as_read_only_views_and_the_message_is_the_header_alone(segment):
    fd = segment()
    w, r = shm.SlotWriter(fd, ["a.out -> b.inp"]), shm.SlotReader(fd, 0)
    x = np.random.default_rng(1).standard_normal(BIG)
    extra = np.arange(10, dtype=np.int16)          # a second, odd-sized array: its own 64-byte aligned place
    header = {"stream": "a.out", "seq": 0, "cycle": 0}
    parts = encode_with_header(header, Frame.of(x).derive(keep_data=True, arrays={"k": extra}), None, w.place)
    assert len(parts) == 1 and msgpack.unpackb(parts[0])["shm"] == [0, 1]
    f = decode(parts, reader=ShmReader(r))
    np.testing.assert_array_equal(f.payload, x)
    np.testing.assert_array_equal(f.arrays["k"], extra)
    assert not f.payload.flags.writeable and not f.arrays["k"].flags.writeable
    with pytest.raises(ValueError):
        f.payload[0, 0] = 1.0
    assert f.payload.ctypes.data % shm.ALIGN == 0 and f.arrays["k"].ctypes.data % shm.ALIGN == 0


def test_a_slot_is_reused_only_after_every_view_of_it_is_gone_and_the_lowest_free_slot_first(segment):
    fd = segment(n_slots=3)
    w, r = shm.SlotWriter(fd, ["e"]), shm.SlotReader(fd, 0)
    f0, f1, f2 = (decode(frame_parts(np.full(BIG, float(i)), w), reader=ShmReader(r)) for i in range(3))
    assert [f.header["shm"] for f in (f0, f1, f2)] == [[0, 1], [1, 2], [2, 3]]
    kept = f0.payload[5:9, ::2]                      # a view of a view of slot 0 outlives its frame
    assert f1.payload[0, 0] == 1.0                   # slot 1: its array built, then everything dropped
    del f0, f1
    gc.collect()
    assert w.free_slot(0) == 1                       # slot 0 still held through `kept`
    f3 = decode(frame_parts(np.full(BIG, 3.0), w), reader=ShmReader(r))
    assert f3.header["shm"] == [1, 4]
    assert np.all(kept == 0.0)                       # never overwritten while viewed
    assert frame_parts(np.full(BIG, 4.0), w) != [] and w.c_full == 1   # every slot taken: inline ...
    assert len(frame_parts(np.full(BIG, 4.0), w)) == 2                 # ... header and buffer
    del kept
    gc.collect()
    assert w.free_slot(0) == 0


def test_with_every_slot_taken_the_producer_waits_then_goes_inline_and_counts_it(segment):
    fd = segment(n_slots=1)
    w, r = shm.SlotWriter(fd, ["e"]), shm.SlotReader(fd, 0)
    held = decode(frame_parts(np.ones(BIG), w), reader=ShmReader(r)).payload
    calls = []
    assert w.place([np.ones(BIG)], wait_s=0.05, idle=lambda: calls.append(1)) is None
    assert calls and w.counters()["no_free_slot"] == 1 and w.counters()["held"] == 1
    del held
    gc.collect()
    assert w.place([np.ones(BIG)], wait_s=0.05) == [0, 2]


def test_small_frames_and_frames_larger_than_a_slot_go_inline(segment):
    fd = segment()
    w = shm.SlotWriter(fd, ["e"])
    assert w.place([np.zeros(16)]) is None                        # below MIN_FRAME_BYTES: a socket copy is cheaper
    assert w.place([np.zeros(BIG)]) == [0, 1]                     # lays out the slots for this size
    assert w.place([np.zeros((4 * BIG[0], BIG[1]))]) is None      # larger than a slot
    c = w.counters()
    assert c["frames_in_slots"] == 1 and c["frames_inline"] == 2 and c["stride"] >= np.zeros(BIG).nbytes
    assert c["segment_bytes"] == c["stride"]                      # one slot touched


@pytest.mark.parametrize("ref,total,reason", [
    ([9, 1], 8, "slot 9 is outside the segment's 4 slots"),
    ([-1, 1], 8, "slot -1 is outside"),
    ([0, 1], 1 << 30, "a slot holds"),
    ([0, 7], 8, "stale generation 7 (the slot holds 1)"),
    ([1, 0], 8, "stale generation 0"),
    ("0", 8, "must be [slot, generation]"),
    ([0, 1.0], 8, "must be [slot, generation]"),
    ([True, 1], 8, "must be [slot, generation]"),
])
def test_a_reference_outside_the_segment_too_large_or_stale_is_refused_with_the_reason(segment, ref, total, reason):
    fd = segment()
    w, r = shm.SlotWriter(fd, ["e"]), shm.SlotReader(fd, 0)
    w.place([np.zeros(BIG)])
    with pytest.raises(shm.SlotError, match=reason.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        r.resolve(ref, total)


def test_decode_refuses_slot_headers_without_a_segment_or_with_buffer_parts(segment):
    fd = segment()
    w, r = shm.SlotWriter(fd, ["e"]), shm.SlotReader(fd, 0)
    parts = frame_parts(np.zeros(BIG), w)
    with pytest.raises(FrameError, match="this input has no data plane"):
        decode(parts)
    with pytest.raises(FrameError, match="the header alone"):
        decode([*parts, b"\0" * 8], reader=ShmReader(r))
    bad = msgpack.unpackb(parts[0])
    bad["arrays"] = [["data", "float64", [1 << 20]]]
    with pytest.raises(FrameError, match="shared memory: slot 0: the header's arrays need"):
        decode([msgpack.packb(bad)], reader=ShmReader(r))


def test_a_reference_before_the_producer_laid_out_its_slots_is_refused(segment):
    fd = segment()
    with pytest.raises(shm.SlotError, match="has not laid out"):
        shm.SlotReader(fd, 0).resolve([0, 1], 8)


def test_a_slot_sent_to_two_consumers_is_free_only_when_both_gave_it_back_or_one_is_cut_or_skipped(segment):
    fd = segment(n_slots=2, n_edges=2)
    w = shm.SlotWriter(fd, ["to_a", "to_b"])
    ra, rb = shm.SlotReader(fd, 0), shm.SlotReader(fd, 1)
    parts = frame_parts(np.ones(BIG), w)
    fa, fb = decode(parts, reader=ShmReader(ra)), decode(parts, reader=ShmReader(rb))      # written once, read by both
    np.testing.assert_array_equal(fa.payload, fb.payload)
    del fa
    gc.collect()
    assert w.free_slot(0) == 1                       # b still holds slot 0
    assert w.free_slot(w.mask(["to_b"])) == 0        # unless b is gone for good (a cut edge)
    del fb
    gc.collect()
    assert w.free_slot(0) == 0
    ref = w.place([np.ones(BIG)])                    # a tap that had no room: it owes nothing
    keep = decode(frame_parts(np.ones(BIG), w), reader=ShmReader(ra))   # slot 1, held by a
    w.unsend(ref, ["to_b"])
    decode([msgpack.packb({**msgpack.unpackb(parts[0]), "shm": ref})], reader=ShmReader(ra))   # a got it and dropped it
    gc.collect()
    assert w.free_slot(0) == 0 and keep.header["shm"][0] == 1


def test_a_restarted_producer_continues_the_generations_and_the_layout(segment):
    fd = segment()
    w = shm.SlotWriter(fd, ["e"])
    w.place([np.zeros(BIG)])
    w.place([np.zeros(BIG)])
    w2 = shm.SlotWriter(fd, ["e"])                   # a new incarnation on the same segment
    ref = w2.place([np.zeros(BIG)])
    assert ref == [2, 3] and w2.seg.stride == w.seg.stride   # slots 0 and 1 were never given back


def test_a_restarted_consumer_gives_back_what_its_dead_incarnation_held_and_refuses_older_frames(segment):
    fd = segment(n_slots=4)
    w = shm.SlotWriter(fd, ["e"])
    dead = ShmReader(shm.SlotReader(fd, 0))
    held_by_dead = [decode(frame_parts(np.zeros(BIG), w), reader=dead) for _ in range(2)]   # slots 0, 1
    lost_in_flight = frame_parts(np.zeros(BIG), w)                                      # slot 2, never read
    assert w.free_slot(0) == 3
    new = ShmReader(shm.SlotReader(fd, 0))           # the restarted consumer, on the same edge
    mine = decode(frame_parts(np.ones(BIG), w), reader=new)        # slot 3: held by this process at the marker
    new.resume({"resume": True, "seq": 4, "shm_gen": w.generation})   # the producer's resume marker
    assert w.free_slot(0) == 0                       # 0, 1, 2 given back; 3 is held by this process
    assert [f.header["shm"][0] for f in held_by_dead] == [0, 1] and mine.header["shm"] == [3, 4]
    with pytest.raises(FrameError, match="stale generation 3"):
        decode(lost_in_flight, reader=new)           # arriving late from the old connection
    del mine
    gc.collect()
    assert w.counters()["held"] == 0


def test_segments_are_anonymous_and_gone_when_closed(segment):
    before = set(os.listdir("/dev/shm"))
    fd = shm.create_segment(2, 1, "carav-anon")
    assert os.readlink(f"/proc/self/fd/{fd}").startswith("/memfd:carav-anon")
    assert set(os.listdir("/dev/shm")) == before
    assert not os.get_inheritable(fd)                # reaches a child only through Popen(pass_fds=...)
    os.close(fd)
    with pytest.raises(ValueError, match="slots"):
        shm.create_segment(0, 1)
    other = os.memfd_create("x")
    os.ftruncate(other, 4096)
    with pytest.raises(ValueError, match="not a carav segment"):
        shm.SlotReader(other, 0)
    os.close(other)


def test_a_payload_computed_in_its_slot_is_sent_without_a_copy_and_an_unused_reservation_is_freed(segment):
    fd = segment(n_slots=3)
    w, r = shm.SlotWriter(fd, ["e"]), shm.SlotReader(fd, 0)
    out = w.reserve(BIG, np.dtype(np.float64))
    assert out.flags.writeable and w.free_slot(0) == 1          # slot 0 is the block's until it returns
    out[:] = 7.0
    side = np.arange(5.0)
    header = {"stream": "a.out", "seq": 0, "cycle": 0}
    parts = encode_with_header(header, Frame.of(out).derive(keep_data=True, arrays={"side": side}), None, w.place)
    f = decode(parts, reader=ShmReader(r))
    assert f.header["shm"] == [0, 1] and w.counters()["computed_in_place"] == 1
    np.testing.assert_array_equal(f.payload, out)
    np.testing.assert_array_equal(f.arrays["side"], side)     # the arrays beside it copied after it
    unused = w.reserve(BIG, np.dtype(np.float64))                # the block asks, then returns something else
    assert w.free_slot(0) == 2
    ref = w.place([np.ones(BIG)])
    assert ref == [1, 2] and unused is not None and w.counters()["computed_in_place"] == 1
    del f
    gc.collect()
    assert w.free_slot(0) == 0                                   # the dropped reservation did not stay taken


def test_a_payload_computed_in_a_slot_that_goes_inline_is_copied_out_of_the_segment_first(segment):
    fd = segment(n_slots=2)
    w = shm.SlotWriter(fd, ["e"])
    out = w.reserve(BIG, np.dtype(np.float64))
    out[:] = 3.0
    big = np.zeros((2 * BIG[0], BIG[1]))                         # beside it, more than a slot holds
    buffers = [memoryview(out).cast("B"), memoryview(big).cast("B")]
    assert w.place(buffers) is None and w.c_inline == 1
    assert isinstance(buffers[0], bytes) and np.all(np.frombuffer(buffers[0]) == 3.0)   # a copy: the slot is free
    assert isinstance(buffers[1], memoryview)                    # not in the segment: sent as it is
    assert w.free_slot(0) == 0


def test_output_buffer_is_plain_numpy_outside_a_node_and_a_slot_inside():
    from carav_stream.runtime import Block

    class B(Block):
        pass
    b = B()
    a = b.output_buffer("out", (3, 4), np.int16)
    assert a.shape == (3, 4) and a.dtype == np.int16 and a.flags.writeable
    b.allocate = lambda port, shape, dtype: np.full(shape, 5, dtype) if port == "fast" else None
    assert np.all(b.output_buffer("fast", (2,), np.int16) == 5) and b.output_buffer("slow", (2,), float).shape == (2,)


def test_when_only_a_tap_holds_the_slots_the_frame_goes_inline_at_once_instead_of_waiting(segment):
    fd = segment(n_slots=1, n_edges=2)
    w = shm.SlotWriter(fd, ["chain", "view"], taps=["view"])
    chain, view = shm.SlotReader(fd, 0), shm.SlotReader(fd, 1)
    parts = frame_parts(np.ones(BIG), w)
    decode(parts, reader=ShmReader(chain))                       # the chain gave it back at once
    held_by_view = decode(parts, reader=ShmReader(view)).payload
    waited = []
    assert w.place([np.ones(BIG)], wait_s=5.0, idle=lambda: waited.append(1)) is None and not waited
    del held_by_view
    gc.collect()
    assert w.place([np.ones(BIG)]) == [0, 2]
