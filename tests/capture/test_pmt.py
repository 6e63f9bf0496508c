"""GNU Radio's PMT bytes: every type the gr-zeromq tags use, written as the format describes it (the expected bytes
are built here with struct from that description, not with the serialiser), read back, round-tripped for any value,
and every malformed byte string refused with a PmtError naming the problem, never another exception."""
from __future__ import annotations

import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.capture.pmt import MAX_DEPTH, Pair, PmtError, UInt64, as_dict, deserialize, serialize


def sym(s: str) -> bytes:
    raw = s.encode()
    return struct.pack(">BH", 0x02, len(raw)) + raw


# (value, its bytes from the format's description: type byte, then the body, big endian)
STORED = [
    (True, b"\x00"), (False, b"\x01"), (None, b"\x06"),
    ("packet_len", sym("packet_len")),
    ("", sym("")),
    ("grüße", b"\x02\x00\x07" + "grüße".encode()),
    (256, struct.pack(">Bi", 0x03, 256)),
    (-1, b"\x03\xff\xff\xff\xff"),
    (2 ** 31 - 1, struct.pack(">Bi", 0x03, 2 ** 31 - 1)),
    (2 ** 31, struct.pack(">Bq", 0x0d, 2 ** 31)),                 # beyond int32: int64, as GNU Radio writes it
    (-(2 ** 40), struct.pack(">Bq", 0x0d, -(2 ** 40))),
    (UInt64(2 ** 64 - 1), b"\x0b" + b"\xff" * 8),
    (UInt64(5), struct.pack(">BQ", 0x0b, 5)),
    (150e6, struct.pack(">Bd", 0x04, 150e6)),
    (-0.0, struct.pack(">Bd", 0x04, -0.0)),
    (1.5 - 2j, struct.pack(">Bdd", 0x05, 1.5, -2.0)),
    ((UInt64(12), 0.25), struct.pack(">BI", 0x0c, 2) + struct.pack(">BQ", 0x0b, 12) + struct.pack(">Bd", 0x04, 0.25)),
    ((), struct.pack(">BI", 0x0c, 0)),
    (Pair(1, 2.0), b"\x07" + struct.pack(">Bi", 0x03, 1) + struct.pack(">Bd", 0x04, 2.0)),
    (Pair("a", Pair(-7, None)), b"\x07" + sym("a") + b"\x07" + struct.pack(">Bi", 0x03, -7) + b"\x06"),   # (a -7)
    ({"chan": 2, "gain_db": -3.5}, b"\x09\x07" + sym("chan") + struct.pack(">Bi", 0x03, 2)
     + b"\x09\x07" + sym("gain_db") + struct.pack(">Bd", 0x04, -3.5) + b"\x06"),
    ([3, "x"], struct.pack(">BI", 0x08, 2) + struct.pack(">Bi", 0x03, 3) + sym("x")),
    (np.array([1, 0, 1], np.uint8), struct.pack(">BBIBB", 0x0a, 0x00, 3, 1, 0) + bytes([1, 0, 1])),
    (np.array([-2, 3], np.int16), struct.pack(">BBIBB", 0x0a, 0x03, 2, 1, 0) + struct.pack(">hh", -2, 3)),
    (np.array([0.5, -1.25], np.float32), struct.pack(">BBIBB", 0x0a, 0x08, 2, 1, 0) + struct.pack(">ff", 0.5, -1.25)),
    (np.array([1 - 1j], np.complex64), struct.pack(">BBIBB", 0x0a, 0x0a, 1, 1, 0) + struct.pack(">ff", 1, -1)),
    (np.array([2 ** 63], np.uint64), struct.pack(">BBIBB", 0x0a, 0x06, 1, 1, 0) + struct.pack(">Q", 2 ** 63)),
]
# what pmt.serialize_str gave in GNU Radio 3.10.5.1 (dict_add of a = 1, then b = 2.0; a tuple; a u8 vector)
GNURADIO = [("090702000162044000000000000000090702000161030000000106", {"b": 2.0, "a": 1}),
            ("0c000000020b0000000000000003043fe0000000000000", (UInt64(3), 0.5)),
            ("0a00000000030100010001", np.array([1, 0, 1], np.uint8))]


def same(a, b) -> bool:
    """Equal values of equal types (an int is not a UInt64, a list not a tuple), arrays by dtype and content."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b)
    if type(a) is not type(b):
        return False
    if isinstance(a, tuple | list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return list(a) == list(b) and all(same(a[k], b[k]) for k in a)
    if isinstance(a, Pair):
        return same(a.car, b.car) and same(a.cdr, b.cdr)
    if isinstance(a, float) and a == 0:
        return struct.pack(">d", a) == struct.pack(">d", b)
    return a == b


@pytest.mark.parametrize(("value", "raw"), STORED, ids=[repr(v)[:30] for v, _ in STORED])
def test_every_type_is_written_and_read_as_the_format_describes(value, raw):
    assert serialize(value) == raw
    back, end = deserialize(raw + b"\xaa", 0)        # a value ends where its bytes end
    assert end == len(raw) and same(back, value)


@pytest.mark.parametrize(("hexed", "value"), GNURADIO)
def test_bytes_gnu_radio_wrote_read_back_and_are_written_again_byte_for_byte(hexed, value):
    back, end = deserialize(bytes.fromhex(hexed))
    assert end == len(hexed) // 2 and same(back, value)
    assert serialize(back).hex() == hexed


def test_a_list_gnu_radio_made_with_acons_reads_as_pairs_and_turns_into_a_dict():
    alist = b"\x07\x07" + sym("k") + b"\x03\x00\x00\x00\x01" + b"\x07\x07" + sym("j") + b"\x01" + b"\x06"
    value, _ = deserialize(alist)
    assert value == Pair(Pair("k", 1), Pair(Pair("j", False), None))
    assert as_dict(value) == {"k": 1, "j": False}
    with pytest.raises(PmtError, match="not a dict"):
        as_dict(Pair(1, None))


def test_an_empty_dict_is_pmt_nil_as_in_gnu_radio():
    assert serialize({}) == b"\x06" and deserialize(b"\x06") == (None, 1)      # pmt::make_dict() is PMT_NIL


def test_numpy_scalars_travel_as_their_pmt_types():
    assert serialize(np.float32(0.5)) == serialize(0.5)
    assert serialize(np.int64(-3)) == serialize(-3)
    assert serialize(np.uint64(7)) == serialize(UInt64(7))
    assert serialize(np.bool_(True)) == b"\x00"
    assert serialize(np.complex64(1j)) == serialize(1j)


leaves = (st.none() | st.booleans() | st.integers(-2 ** 63, 2 ** 63 - 1)
          | st.integers(0, 2 ** 64 - 1).map(UInt64) | st.floats(allow_nan=False) | st.complex_numbers(allow_nan=False)
          | st.text(max_size=20)
          | st.lists(st.integers(0, 255), max_size=6).map(lambda v: np.array(v, np.uint8))
          | st.lists(st.floats(allow_nan=False, width=32), max_size=4).map(lambda v: np.array(v, np.float32)))
values = st.recursive(leaves, lambda inner: st.tuples(inner, inner) | st.lists(inner, max_size=3)
                      | st.builds(Pair, inner, inner)
                      | st.dictionaries(st.text(max_size=5), inner, min_size=1, max_size=3), max_leaves=12)


@settings(max_examples=300, deadline=None)
@given(values)
def test_any_value_comes_back_as_it_went(value):
    raw = serialize(value)
    back, end = deserialize(raw)
    assert end == len(raw) and same(back, value)


MALFORMED = [
    (b"", "truncated: a type byte"),
    (b"\x0e", "unknown PMT type 0x0e at byte 0"),
    (b"\x3b", "unknown PMT type 0x3b"),                  # a comment: GNU Radio does not read it either
    (b"\x02\x00", "truncated: a symbol's length"),
    (b"\x02\x00\x05abc", "truncated: a symbol of 5 bytes"),
    (b"\x02\x00\x02\xff\xfe", "symbol at byte 0 is not UTF-8"),
    (b"\x03\x00\x01", "truncated: the body of int32"),
    (b"\x0b\x00", "truncated: the body of uint64"),
    (b"\x05" + b"\x00" * 12, "truncated: the body of complex"),
    (b"\x0c\xff\xff\xff\xff\x06", "tuple of 4294967295 elements"),
    (b"\x08\x00\x00\x00\x03\x06", "truncated: vector of 3 elements"),
    (b"\x08\x00\x00\x00\x02\x03\x00", "truncated: the body of int32"),
    (b"\x0a\x0c\x00\x00\x00\x01\x01\x00\x00", "unknown uniform vector element type 0x0c"),
    (b"\x0a\x04\x00\x00\x00\x02\x01\x00\x00\x00\x00\x01", "truncated: a uint32 uniform vector of 2 elements"),
    (b"\x0a\x00\x00\x00\x00\x01\x05\x00", "truncated: a uniform vector's padding"),
    (b"\x07\x06", "truncated: a pair's cdr"),
    (b"\x09\x06\x06", "not a dict: its element None"),
    (b"\x09\x07\x06\x06\x04", "truncated: the body of double"),
    (b"\x09\x07\x0a\x00\x00\x00\x00\x00\x00\x06\x06", "unhashable"),
    (b"\x0c\x00\x00\x00\x01" * (MAX_DEPTH + 2) + b"\x06", f"nested deeper than {MAX_DEPTH}"),
]


@pytest.mark.parametrize(("raw", "message"), MALFORMED, ids=[m for _, m in MALFORMED])
def test_malformed_bytes_are_refused_naming_the_problem(raw, message):
    with pytest.raises(PmtError, match=message.replace("(", r"\(").replace(")", r"\)")):
        deserialize(raw)


@settings(max_examples=500, deadline=None)
@given(st.binary(max_size=64))
def test_any_bytes_give_a_value_or_a_pmt_error_and_nothing_else(raw):
    try:
        deserialize(raw)
    except PmtError:
        pass


def test_a_long_list_is_read_without_recursion():
    raw = b"".join(b"\x07\x03\x00\x00\x00\x01" for _ in range(5000)) + b"\x06"
    value, _ = deserialize(raw)
    n = 0
    while value is not None:
        value, n = value.cdr, n + 1
    assert n == 5000


@pytest.mark.parametrize(("value", "message"), [
    ("x" * 1025, "at most 1024 bytes"),
    (2 ** 63, "beyond int64"),
    (np.zeros((2, 2), np.uint8), "a uniform vector is 1-D"),
    (np.zeros(2, np.float16), "a uniform vector is 1-D, of"),
    (object(), "object .* has no PMT form"),
    (b"raw", "bytes .* has no PMT form"),
])
def test_a_value_without_a_pmt_form_is_refused_naming_it(value, message):
    with pytest.raises(PmtError, match=message):
        serialize(value)


def test_uint64_holds_only_unsigned_64_bit_values_and_a_value_that_contains_itself_is_refused():
    with pytest.raises(PmtError, match="outside 0 .. 2"):
        UInt64(-1)
    with pytest.raises(PmtError, match="outside"):
        UInt64(2 ** 64)
    loop: list = []
    loop.append(loop)
    with pytest.raises(PmtError, match="nested deeper"):
        serialize(loop)
