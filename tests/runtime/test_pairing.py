"""Input pairing without sockets: frames pair by seq, a frame whose partner can never come goes alone, once.

When a consumer is restarted, each producer connects afresh and first sends a `resume` marker: the frames its old
connection held are gone, so the new consumer must not wait for them to pair its other inputs (waiting deadlocks a
graph whose producers are blocked behind that consumer). A partner that comes after its seq was handled without it
is refused, never handed to the block: a second, out-of-order output would follow.
"""
import numpy as np

from carav_stream.runtime.frames import Frame, decode, encode
from carav_stream.runtime.pairing import Pairing


def message(port: str, seq: int, **header) -> Frame:
    """A decoded message as a node receives it on `port`: a data frame, or a header-only marker."""
    arrays = {} if header else {"data": np.full(2, float(seq))}
    return decode(encode(Frame(header, arrays), stream=f"up.{port}", seq=seq))


class Node:
    """The block side of a node, as the runner drives it: admit, push, and hand on every set that is ready."""

    def __init__(self, limit: int = 8, **kw) -> None:
        self.pairing = Pairing(["a", "b"], limit, **kw)
        self.rejected: list[tuple[str, str]] = []
        self.handed: list[tuple[int, str, str | None]] = []

    def feed(self, port: str, *seqs: int, **marker) -> None:
        frames = [message(port, s) for s in seqs] + ([message(port, marker.pop("seq"), **marker)] if marker else [])
        for f in frames:
            ok, reason = self.pairing.admit(port, f)
            if reason:
                self.rejected.append((port, reason))
            if ok:
                self.pairing.push(port, f)
        while (nxt := self.pairing.next_set(merge=False)) is not None:
            what, frames_, port_ = nxt
            self.handed.append((frames_[0].seq, "paired" if what == "process" else "alone", port_))


def test_frames_pair_by_seq_and_a_skipped_seq_goes_alone_once_the_other_input_is_past_it():
    node = Node()
    node.feed("a", 0, 1, 2, 3)
    node.feed("b", 0, 2, 3)
    assert node.handed == [(0, "paired", None), (1, "alone", "a"), (2, "paired", None), (3, "paired", None)]


def test_an_unmatched_frame_waits_for_its_partner_while_one_may_still_come():
    node = Node()
    node.feed("a", 0, 1)
    assert node.handed == []
    node.feed("b", 0, 1)
    assert node.handed == [(0, "paired", None), (1, "paired", None)]


def test_a_resume_marker_releases_the_frames_whose_partners_went_with_the_old_connection():
    # a restarted consumer: input b's producer resumed at seq 3, so frames 0-2 on a can never pair
    node = Node()
    node.feed("a", 0, 1, 2, 3, 4)
    node.feed("b", seq=3, resume=True)
    assert node.handed == [(0, "alone", "a"), (1, "alone", "a"), (2, "alone", "a")]
    node.feed("b", 3, 4)
    assert node.handed[3:] == [(3, "paired", None), (4, "paired", None)] and node.rejected == []


def test_a_malformed_resume_marker_is_rejected_and_releases_nothing():
    node = Node()
    node.feed("a", 0, 1)
    node.feed("b", seq=5, resume=False)
    assert node.handed == [] and node.rejected == [("b", "a resume marker must say resume = true and carry no arrays")]


def test_a_partner_arriving_after_its_seq_was_given_up_is_refused_not_processed():
    clock = [0.0]
    node = Node(limit=4, recovering=True, stall_s=2.0, clock=lambda: clock[0])   # fed by a restarted node
    node.feed("a", 0, 1, 2, 3)                    # a full buffer with no partner in sight
    assert node.handed == []                      # ... waits stall_s first
    clock[0] = 2.0
    node.feed("a")
    assert node.handed[0] == (0, "alone", "a")
    gone = node.handed[-1][0]
    node.feed("b", *range(gone + 1))              # the partners, too late
    node.feed("b", gone + 1)                      # and the first one in time
    assert [p for p, _ in node.rejected] == ["b"] * (gone + 1)   # refused, counted, never handed to the block
    assert node.handed[-1] == (gone + 1, "paired", None)


def test_a_full_buffer_outside_recovery_waits_for_its_partner_however_long():
    clock = [0.0]
    node = Node(limit=2, recovering=False, clock=lambda: clock[0])
    node.feed("a", 0, 1)
    clock[0] = 1e6
    node.feed("a")
    assert node.handed == [] and node.pairing.wanted() == ["b"]


def test_duplicates_and_reordered_frames_are_refused_and_the_end_of_stream_releases_the_rest():
    node = Node()
    node.feed("a", 0, 1, 1, 0)
    assert [r for _, r in node.rejected] == ["seq 1 after 1: duplicate or out of order",
                                              "seq 0 after 1: duplicate or out of order"]
    node.feed("b", seq=0, eos=True, count=0)
    assert node.handed == [(0, "alone", "a"), (1, "alone", "a")]
    assert not node.pairing.finished()
    node.feed("a", seq=2, eos=True, count=2)
    assert node.pairing.finished() and node.pairing.eos == {"a": 2, "b": 0}


def test_merging_inputs_hands_on_every_frame_alone_in_arrival_order_per_port():
    pairing = Pairing(["a", "b"], 8)
    for port, seq in (("a", 0), ("b", 5), ("a", 1)):
        f = message(port, seq)
        assert pairing.admit(port, f) == (True, None)
        pairing.push(port, f)
    got = []
    while (nxt := pairing.next_set(merge=True)) is not None:
        got.append((nxt[2], nxt[1][0].seq))
    assert sorted(got) == [("a", 0), ("a", 1), ("b", 5)] and [s for p, s in got if p == "a"] == [0, 1]


def test_describe_names_each_input_s_buffered_frames_last_seq_and_end_of_stream():
    """The line the supervisor prints for a node that did not drain in time (supervisor: drain deadline)."""
    node = Node(limit=8, recovering=True)
    node.feed("a", 0, 1, 2)
    node.feed("b", 0)
    node.feed("b", seq=5, eos=True, count=1)
    assert node.pairing.describe() == ("a: 0 buffered, last seq 2; b: 0 buffered, last seq 0 ended after 1 frames; "
                                       "handed on up to seq 2; recovering")
    fresh = Node()
    fresh.feed("b", 3, 4)
    assert fresh.pairing.describe() == "a: 0 buffered, last seq None; b: 2 buffered from seq 3, last seq 4"


def test_the_most_frames_an_input_buffered_at_once_is_kept_as_its_high_water_mark():
    node = Node()
    node.feed("a", 0, 1, 2)                  # three wait for their partners
    assert node.pairing.most_buffered == {"a": 3}
    node.feed("b", 0, 1, 2, 3)               # all four land before the pairs are handed on; 3 then waits alone
    assert node.pairing.most_buffered == {"a": 3, "b": 4} and len(node.pairing.buffers["b"]) == 1
    node.feed("a", 3)
    assert node.pairing.most_buffered == {"a": 3, "b": 4} and not any(node.pairing.buffers.values())
