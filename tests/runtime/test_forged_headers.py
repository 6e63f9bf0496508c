"""A node's input checks without sockets: every header field the pairing acts on is judged against what the node
already knows, and a refused message moves nothing.

Each test builds the message a forger on the host could send (well formed, so decode accepts it), shows it is
refused with its reason, and that the stream then goes on exactly as if it had never come.
"""
import numpy as np
import pytest

from carav_stream.runtime.control import ControlState
from carav_stream.runtime.frames import Frame, decode, encode
from carav_stream.runtime.pairing import Pairing, frame_cycles_problem
from carav_stream.runtime.protocol import Control

PRODUCER, OTHER, RESTARTED = 4242, 999, 5000
STARTED = {PRODUCER: 71, RESTARTED: 93, OTHER: 12}     # each process's start time (senders.start_ticks)


def message(seq: int, arrays=None, **header) -> Frame:
    """A decoded message as a node receives it: a data frame by default, or header-only with `arrays={}`."""
    arrays = {"data": np.full(2, float(seq))} if arrays is None else arrays
    return decode(encode(Frame(header, arrays), stream="up.a", seq=seq))


def pairing(bound: int | None = 200) -> Pairing:
    return Pairing(["a"], 8, bounds={} if bound is None else {"a": bound},
                   producers={"a": {PRODUCER: STARTED[PRODUCER]}}, start_of=STARTED.get)


def feed(p: Pairing, *seqs: int, sender: int = PRODUCER) -> list[int]:
    """Admit and hand on data frames; the seqs handed to the block."""
    for s in seqs:
        ok, reason = p.admit("a", message(s), sender)
        assert reason is None, reason
        if ok:
            p.push("a", message(s))
    out = []
    while (nxt := p.next_set(merge=False)) is not None:
        out.append(nxt[1][0].seq)
    return out


def state(p: Pairing) -> tuple:
    return dict(p.last_seq), dict(p.eos), dict(p.received), p.handled, {k: len(b) for k, b in p.buffers.items()}


def test_a_seq_beyond_the_producers_lease_bound_is_refused_and_the_stream_goes_on():
    p = pairing(bound=200)
    assert feed(p, 0, 1, 2) == [0, 1, 2]
    before = state(p)
    ok, reason = p.admit("a", message(311), PRODUCER)
    assert not ok and "seq 311 is beyond every seq this input's producer can have been granted (at most 200)" in reason
    assert state(p) == before
    assert feed(p, 3, 4) == [3, 4]        # the real frames that follow are taken, not refused as out of order


def test_a_seq_within_the_bound_is_taken():
    p = pairing(bound=200)
    assert feed(p, 0, 200) == [0, 200]


def test_a_port_without_a_bound_is_not_checked_on_seq():
    assert feed(pairing(bound=None), 0, 10**9) == [0, 10**9]


@pytest.mark.parametrize("count", ["many", -1, 2.0, None, True])
def test_an_end_of_stream_whose_count_is_not_a_non_negative_int_is_refused_and_the_input_stays_open(count):
    p = pairing()
    feed(p, 0)
    header = {"eos": True} if count is None else {"eos": True, "count": count}
    ok, reason = p.admit("a", message(1, {}, **header), PRODUCER)
    assert not ok and "end of stream: count must be an int >= 0" in reason
    assert "a" not in p.eos and p.wanted() == ["a"]
    assert feed(p, 1) == [1]


def test_an_end_of_stream_announcing_fewer_frames_than_came_from_its_sender_is_refused():
    p = pairing()
    feed(p, 0, 1, 2)
    ok, reason = p.admit("a", message(3, {}, eos=True, count=2), PRODUCER)
    assert not ok and "end of stream announces 2 frames, but 3 came from its sender" in reason
    assert "a" not in p.eos
    ok, reason = p.admit("a", message(3, {}, eos=True, count=3), PRODUCER)
    assert (ok, reason) == (False, None) and p.eos == {"a": 3} and p.finished()


def test_a_restarted_producer_counts_its_end_of_stream_from_its_own_first_frame():
    # frames of the dead incarnation (pid 4242) still queued are taken; the new one (pid 5000) sent 1 frame
    p = Pairing(["a"], 8, producers={"a": {PRODUCER: STARTED[PRODUCER], RESTARTED: STARTED[RESTARTED]}},
                start_of=STARTED.get)
    feed(p, 0, 1, sender=PRODUCER)
    feed(p, 5, sender=RESTARTED)
    ok, reason = p.admit("a", message(6, {}, eos=True, count=1), RESTARTED)
    assert (ok, reason) == (False, None) and p.eos == {"a": 1}


def test_an_end_of_stream_from_another_process_is_refused():
    p = pairing()
    ok, reason = p.admit("a", message(0, {}, eos=True, count=0), OTHER)
    assert not ok and f"sent by process {OTHER}, not by this input's producer (process {PRODUCER})" in reason
    assert not p.eos


def test_a_frame_from_another_process_is_refused_even_with_the_next_seq():
    p = pairing()
    feed(p, 0)
    before = state(p)
    ok, reason = p.admit("a", message(1), OTHER)
    assert not ok and "not by this input's producer" in reason and state(p) == before
    assert feed(p, 1) == [1]


def test_a_resume_marker_far_ahead_is_refused_and_moves_nothing():
    p = pairing(bound=200)
    feed(p, 0)
    before = state(p)
    ok, reason = p.admit("a", message(10**6, {}, resume=True), PRODUCER)
    assert not ok and "beyond every seq" in reason and state(p) == before
    assert feed(p, 1) == [1]


def test_a_resume_marker_with_resume_false_is_refused():
    p = pairing()
    ok, reason = p.admit("a", message(3, {}, resume=False), PRODUCER)
    assert not ok and "resume = true" in reason and p.last_seq == {}


@pytest.mark.parametrize("header, arrays, problem", [
    ({"cycles": 100_000_000}, {}, "cycles = 100000000 with no payload"),
    ({"cycles": 5}, {"data": np.zeros((4, 3))}, "cycles = 5 with a payload of shape (4, 3)"),
    ({"cycles": 3, "per_cycle": {"q": [1, 2]}}, {}, "cycles = 3 with no payload"),
])
def test_a_frame_whose_cycles_it_cannot_justify_is_refused(header, arrays, problem):
    p = pairing()
    ok, reason = p.admit("a", message(0, arrays, **header), PRODUCER)
    assert not ok and problem in reason and p.last_seq == {}


@pytest.mark.parametrize("header, arrays", [
    ({"cycles": 4}, {"data": np.zeros((4, 3))}),                      # rows of payload
    ({"cycles": 3, "per_cycle": {"cycle_index": [7, 9, 12]}}, {}),    # header only: a column per cycle
    ({"cycles": 3, "per_cycle": {"a": [0, 1, 1]}}, {"data": np.zeros((1, 8))}),   # broadcast reply + column
    ({}, {"data": np.zeros((64, 2))}),                                # no cycles stated: one cycle
])
def test_a_frame_carrying_the_cycles_it_states_is_taken(header, arrays):
    h = message(0, arrays, **header).header
    assert frame_cycles_problem(h) is None
    assert pairing().admit("a", message(0, arrays, **header), PRODUCER) == (True, None)


def test_control_messages_raise_bounds_and_add_producers_the_pairing_sees():
    ctl = ControlState(go=True, input_bounds={"a": 100}, producers={"a": [[PRODUCER, STARTED[PRODUCER]]]})
    p = Pairing(["a"], 8, bounds=ctl.input_bounds, producers=ctl.producers, start_of=STARTED.get)
    assert p.admit("a", message(150), RESTARTED)[0] is False
    ctl.apply({"type": str(Control.LEASE), "inputs": {"a": 300}})
    ctl.apply({"type": str(Control.LEASE), "inputs": {"a": 50}})          # a bound never shrinks
    ctl.apply({"type": str(Control.PEERS), "inputs": {"a": [RESTARTED, STARTED[RESTARTED]]}})
    for bad in ({"a": "x"}, {"a": [1]}, {"a": [1, "2"]}, {"a": 5001}, {3: [1, 2]}):   # malformed: ignored
        ctl.apply({"type": str(Control.PEERS), "inputs": bad})
    assert ctl.input_bounds == {"a": 300}
    assert ctl.producers == {"a": {PRODUCER: STARTED[PRODUCER], RESTARTED: STARTED[RESTARTED]}}
    assert list(ctl.producers["a"]) == [PRODUCER, RESTARTED]          # the current producer last
    assert p.admit("a", message(150), RESTARTED) == (True, None)
    assert p.admit("a", message(151), PRODUCER) == (True, None)         # the dead incarnation's queued frames


def test_a_producers_pid_held_by_a_process_that_started_at_another_time_is_refused():
    """The supervisor names each producer's pid with its start time; a process holding that pid that started at
    another time (the pid given to someone else) is refused whatever it sends, and the stream goes on."""
    started = dict(STARTED)
    p = Pairing(["a"], 8, producers={"a": {PRODUCER: STARTED[PRODUCER]}}, start_of=started.get)
    started[PRODUCER] = 5555                        # the pid now belongs to a process started later
    before = state(p)
    ok, reason = p.admit("a", message(0), PRODUCER)
    assert not ok and (f"sent by process {PRODUCER}, which started at tick 5555, not by the incarnation of this "
                       f"input's producer that had that pid (started at tick {STARTED[PRODUCER]})") in reason
    assert state(p) == before
    started[PRODUCER] = STARTED[PRODUCER]
    assert feed(p, 0, 1) == [0, 1]


def test_a_senders_start_time_is_read_once_per_pid():
    reads = []
    p = Pairing(["a"], 8, producers={"a": {PRODUCER: STARTED[PRODUCER]}},
                start_of=lambda pid: reads.append(pid) or STARTED[pid])
    assert feed(p, *range(5)) == list(range(5))
    assert reads == [PRODUCER]
    assert p.admit("a", message(5), OTHER)[0] is False and reads == [PRODUCER]   # not a producer: no read


def test_a_local_message_before_its_inputs_producer_is_named_is_refused():
    p = Pairing(["a"], 8, start_of=STARTED.get)        # the supervisor has named no producer for "a" yet
    ok, reason = p.admit("a", message(0), OTHER)
    assert not ok and reason == f"sent by process {OTHER} before this input's producer was named"
    assert p.admit("a", message(0)) == (True, None)     # no sender (tcp): judged on its fields alone
