"""Fuzzing the frame decoder and a live node's input sockets, bounded in count and time.

Every malformed input must be refused with a FrameError (a reason), never another exception; a node counts
each refusal, keeps running, and never hands a refused or forged message to its block.
"""
import msgpack
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from carav_stream.runtime.frames import Frame, FrameError, decode, encode

VALID = encode(Frame({"k": 1}, {"data": np.arange(6, dtype=np.float32).reshape(2, 3)}), stream="a.out", seq=5)
HEAD = bytes(VALID[0])
BODY = bytes(memoryview(VALID[1]))


def decoded_or_refused(parts) -> Frame | None:
    """The decoder's verdict: a Frame whose arrays match their buffers, or None for a FrameError."""
    try:
        frame = decode(parts)
    except FrameError as exc:
        assert str(exc), "a refusal must give its reason"
        return None
    for a in frame.arrays.values():                 # what it accepted is consistent
        assert isinstance(a, np.ndarray) and not a.flags.writeable
    return frame


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.binary(max_size=64), min_size=0, max_size=4))
def test_random_bytes_are_refused_with_a_reason(parts):
    assert decoded_or_refused(parts) is None or parts[:1] == [HEAD]


@settings(max_examples=400, deadline=None)
@given(positions=st.lists(st.integers(0, len(HEAD) - 1), min_size=1, max_size=6), values=st.data(),
       cut=st.integers(0, len(BODY)), extra=st.booleans())
def test_mutated_valid_frames_are_refused_or_decoded_consistently(positions, values, cut, extra):
    head = bytearray(HEAD)
    for p in positions:
        head[p] = values.draw(st.integers(0, 255))
    parts = [bytes(head), BODY[:cut]] + ([b"x" * 8] if extra else [])
    frame = decoded_or_refused(parts)
    if frame is not None and frame.arrays:
        assert sum(a.nbytes for a in frame.arrays.values()) == cut


@pytest.mark.parametrize("header", [
    {"v": 1, "stream": "a.b", "seq": 1, "cycle": 1, "eos": False, "arrays": [["d", "float32", [2 ** 40, 2 ** 40]]]},
    {"v": 1, "stream": "a.b", "seq": 1, "cycle": 1, "eos": False, "arrays": [["d", "float32", [0, 2 ** 62]]]},
    {"v": 1, "stream": "a.b", "seq": 1, "cycle": 1, "eos": False, "arrays": [["d", "float32", [1]]] * 10_000},
    {"v": 1, "stream": "a.b", "seq": -1, "cycle": 1, "eos": False, "arrays": []},
    {"v": 1, "stream": "x" * (2 << 20), "seq": 1, "cycle": 1, "eos": False, "arrays": []},
])
def test_bomb_headers_are_refused_without_allocating(header):
    assert decoded_or_refused([msgpack.packb(header), b""]) is None


def test_a_live_node_refuses_fuzzed_and_forged_input_counts_it_and_keeps_running(harness):
    h = harness
    rng = np.random.default_rng(7)
    garbage = [[rng.bytes(int(rng.integers(0, 80)))] for _ in range(40)]
    garbage += [[HEAD[:n]] for n in range(0, len(HEAD), 7)]            # truncated headers
    for parts in garbage:
        h.send_raw("a", parts)
    h.feed("a", 0, 1)
    h.feed("b", 0, 1)
    h.feed("a", 1)                                                      # forged: seq 1 again on a
    h.feed("b", 0)                                                      # forged: seq 0 again on b
    h.run_until(2, lambda: sum(h.node.ports.c_rejected.values()) == len(garbage) + 2, "every refusal to be counted")
    assert h.outputs(2) == [(0, "paired", None), (1, "paired", None)]
    assert h.node.ports.c_rejected == {"a": len(garbage) + 1, "b": 1}
    assert h.node.ports.c_in == {"a": 2, "b": 2} and h.node.driver.processed == 2   # nothing refused reached the block
