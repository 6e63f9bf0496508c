"""gr-zeromq's stream messages: the bytes GNU Radio 3.10 itself sent (tests/golden/gr_zmq.json, captured by
tests/golden/make_gr_zmq.py) read back as the items and tags its flowgraphs were given and written again byte for
byte; messages built here with struct from the format's description (not with the encoder) read back; every
malformed message refused naming what is wrong; a REQ source's request; and the sockets, over loopback."""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.capture.gr_zmq import (
    GrZmqError,
    OtherKey,
    Receiver,
    Sender,
    Tag,
    check_address,
    decode,
    encode,
    is_local,
    request,
    requested,
)
from carav_stream.capture.pmt import Pair, UInt64

GOLDEN = json.loads((Path(__file__).resolve().parents[1] / "golden" / "gr_zmq.json").read_text())


def parts_of(capture: str) -> list[list[bytes]]:
    return [[bytes.fromhex(p) for p in m] for m in GOLDEN["captures"][capture]["messages"]]


def sym(s: str) -> bytes:
    return struct.pack(">BH", 2, len(s)) + s.encode()


def header(offset: int, tags: list[tuple[int, bytes]], order: str = "<") -> bytes:
    """gr-zeromq's header from its description: uint16 0x5FF0, uint8 1, uint64 offset, uint64 count (host byte
    order), then per tag a uint64 offset and the PMT bytes of key, value and source id."""
    return struct.pack(f"{order}HBQQ", 0x5FF0, 1, offset, len(tags)) + b"".join(
        struct.pack(f"{order}Q", o) + pmts for o, pmts in tags)


PACKET_LEN_16 = sym("packet_len") + struct.pack(">Bi", 3, 16) + b"\x01"      # key, value 16, source PMT_F


# ------------------------------------------------------------------ what GNU Radio sent

def test_gnu_radio_s_tagged_push_message_reads_as_the_flowgraph_s_items_and_tags():
    assert GOLDEN["byteorder"] == "little" and GOLDEN["gnuradio"].startswith("3.10")
    [parts] = parts_of("tagged_push")
    msg = decode(parts, "complex64", tagged=True)
    n = np.arange(64)
    assert msg.offset == 0 and msg.items.dtype == np.complex64 and np.array_equal(msg.items, n + 0.5 - 1j * n)
    tags = {(t.offset, t.key): t for t in msg.tags}
    assert [o for o, k in tags if k == "packet_len"] == [0, 16, 32, 48]
    assert all(tags[(o, "packet_len")].value == 16 and tags[(o, "packet_len")].srcid == "golden" for o in (0, 16))
    rx_time = tags[(0, "rx_time")].value
    assert rx_time == (12, 0.25) and type(rx_time[0]) is UInt64 and type(rx_time[1]) is float
    assert tags[(0, "rx_rate")].value == 2.5e6
    assert tags[(5, "label")].value == "chirp" and tags[(5, "label")].srcid is False
    assert tags[(6, "big")].value == -(2 ** 40)
    assert tags[(7, "count")].value == UInt64(2 ** 63 + 5) and type(tags[(7, "count")].value) is UInt64
    assert tags[(8, "phase")].value == 1.5 - 2j
    assert tags[(9, "flag")].value is True and tags[(10, "none")].value is None
    assert tags[(11, "pair")].value == Pair(1, 2.0)
    assert tags[(12, "list")].value == Pair("a", Pair(-7, None))
    assert tags[(13, "meta")].value == {"gain_db": -3.5, "chan": 2}
    assert np.array_equal(tags[(14, "rho")].value, [1, 0, 1, 1]) and tags[(14, "rho")].value.dtype == np.uint8
    assert np.array_equal(tags[(15, "taps")].value, np.array([0.5, -1.25], np.float32))
    assert tags[(17, "vec")].value == [3, 3]


@pytest.mark.parametrize("capture", ["tagged_push", "untagged_push", "tagged_pub"])
def test_gnu_radio_s_messages_are_written_again_byte_for_byte(capture):
    c = GOLDEN["captures"][capture]
    for parts in parts_of(capture):
        msg = decode(parts, c["item"], tagged=c["pass_tags"], key=c["key"].encode())
        assert encode(msg.items, offset=msg.offset, tags=msg.tags, key=c["key"].encode()) == parts


def test_gnu_radio_s_untagged_message_is_the_items_alone():
    [parts] = parts_of("untagged_push")
    assert len(parts[0]) == 64 * 8
    msg = decode(parts, "complex64", tagged=False)
    assert msg.offset is None and msg.tags == () and msg.items[3] == 3.5 - 3j


def test_gnu_radio_s_pub_messages_carry_the_key_first_and_consecutive_offsets():
    messages = parts_of("tagged_pub")
    assert all(parts[0] == b"carav" for parts in messages)
    decoded = [decode(parts, "float32", tagged=True, key=b"carav") for parts in messages]
    for a, b in zip(decoded, decoded[1:]):
        assert b.offset == a.offset + len(a.items)          # the subscriber missed nothing
    for m in decoded:                                        # item i = (i mod 64) / 4, packet_len every 16 items
        assert np.array_equal(m.items, (np.arange(m.offset, m.offset + len(m.items)) % 64) / 4)
        assert [t.offset for t in m.tags] == [o for o in range(m.offset, m.offset + len(m.items)) if o % 16 == 0]
    with pytest.raises(OtherKey):
        decode(messages[0], "float32", tagged=True, key=b"other")


# ------------------------------------------------------------------ the format, from its description

def test_a_message_built_from_the_description_reads_back():
    items = np.array([1 + 2j, -3 - 4j], np.complex64)
    body = header(1000, [(1000, PACKET_LEN_16), (1001, sym("rx_rate") + struct.pack(">Bd", 4, 5e6) + sym("src"))])
    msg = decode([body + items.astype("<c8").tobytes()], "complex64", tagged=True, byteorder="little")
    assert msg.offset == 1000 and np.array_equal(msg.items, items)
    assert msg.tags == (Tag(1000, "packet_len", 16, False), Tag(1001, "rx_rate", 5e6, "src"))
    assert encode(items, offset=1000, tags=msg.tags, byteorder="little") == [body + items.astype("<c8").tobytes()]


def test_an_empty_tag_header_is_19_bytes_and_a_big_endian_sender_is_read_in_its_byte_order():
    items = np.arange(3, dtype=np.float32)
    raw = header(7, [], ">") + items.astype(">f4").tobytes()
    assert len(header(7, [])) == 19
    msg = decode([raw], "float32", tagged=True, byteorder="big")
    assert msg.offset == 7 and np.array_equal(msg.items, items) and msg.items.dtype == np.float32
    assert encode(items, offset=7, byteorder="big") == [raw]
    with pytest.raises(GrZmqError, match="sender's byte order is not little"):
        decode([raw], "float32", tagged=True, byteorder="little")


def test_an_untagged_message_is_raw_items_and_a_pub_key_a_part_of_its_own():
    items = np.array([1, -2], np.int16)
    assert encode(items) == [items.tobytes()]
    assert encode(items, key=b"radar") == [b"radar", items.tobytes()]
    assert np.array_equal(decode([b"radar", items.tobytes()], "int16", tagged=False, key=b"radar").items, items)


MALFORMED = [
    ([b"\x00\x01\x02"], True, "", "truncated header: 3 bytes"),
    ([header(0, [])[:18]], True, "", "truncated header: 18 bytes"),
    ([struct.pack("<HBQQ", 0x1234, 1, 0, 0)], True, "", r"bad magic 0x1234.*pass_tags off"),
    ([struct.pack("<HBQQ", 0x5FF0, 2, 0, 0)], True, "", "header version 2"),
    ([struct.pack("<HBQQ", 0x5FF0, 1, 0, 10 ** 12)], True, "", "announces 1000000000000 tags"),
    ([struct.pack("<HBQQ", 0x5FF0, 1, 0, 2) + struct.pack("<Q", 0) + PACKET_LEN_16 + b"\x00" * 4], True, "",
     "tag 1 of 2 has no offset"),
    ([header(0, [(0, b"\x0e\x06\x06")])], True, "", r"tag 0 of 1 \(item 0\): unknown PMT type 0x0e"),
    ([header(0, [(0, sym("k") + b"\x03\x00")])], True, "", "tag 0 of 1 .*truncated: the body of int32"),
    ([header(5, [(9, PACKET_LEN_16)]) + b"\x00" * 8], True, "", r"outside the message's items 5 \.\. 5"),
    ([header(0, []) + b"\x00" * 12], True, "", "wrong item size: 12 bytes .* complex64 items"),
    ([header(0, [])], False, "", "wrong item size: 19 bytes.*starts with a tag header: is the sender's pass_tags on"),
    ([b"\x00" * 7], False, "", "wrong item size: 7 bytes"),
    ([b"k", b"\x00" * 8], False, "", "2 message parts, expected 1: the sender publishes with a key"),
    ([b"\x00" * 8], False, "k", r"1 message parts, expected 2 \(the key b'k', then the items\)"),
]


@pytest.mark.parametrize(("parts", "tagged", "key", "message"), MALFORMED, ids=[m[-1][:40] for m in MALFORMED])
def test_a_malformed_message_is_refused_naming_the_problem(parts, tagged, key, message):
    with pytest.raises(GrZmqError, match=message):
        decode(parts, "complex64", tagged=tagged, key=key.encode())


@settings(max_examples=400, deadline=None)
@given(st.binary(max_size=80), st.booleans())
def test_any_bytes_give_a_message_or_a_gr_zmq_error_and_nothing_else(raw, tagged):
    for body in (raw, header(0, []) + raw, struct.pack("<HBQQ", 0x5FF0, 1, 0, 1) + struct.pack("<Q", 0) + raw):
        try:
            decode([body], "float32", tagged=tagged)
        except GrZmqError:
            pass


def test_the_encoder_refuses_a_tag_outside_its_items_and_tags_without_a_header():
    with pytest.raises(GrZmqError, match="outside the message's items 0 .. 1"):
        encode(np.zeros(2, np.float32), offset=0, tags=[Tag(2, "k", 1)])
    with pytest.raises(GrZmqError, match="only with pass_tags"):
        encode(np.zeros(2, np.float32), tags=[Tag(0, "k", 1)])
    with pytest.raises(GrZmqError, match="tag 'k' at item 0: .*no PMT form"):
        encode(np.zeros(2, np.float32), offset=0, tags=[Tag(0, "k", object())])


# ------------------------------------------------------------------ addresses and sockets

def test_addresses_are_checked_and_local_ones_told_apart():
    assert check_address("tcp://127.0.0.1:5555") and check_address("ipc:///tmp/gr") and check_address("tcp://*:0")
    for bad in ("127.0.0.1:5555", "udp://1.2.3.4:5", "tcp://host", "tcp://host:99999", "ipc://"):
        with pytest.raises(ValueError, match="address"):
            check_address(bad)
    assert is_local("tcp://127.0.0.1:1") and is_local("tcp://localhost:1") and is_local("tcp://[::1]:1")
    assert is_local("ipc:///tmp/x")
    assert not is_local("tcp://192.168.1.2:1") and not is_local("tcp://*:1") and not is_local("tcp://radar:1")


def test_push_to_pull_and_pub_to_sub_with_a_key_over_loopback():
    push = Sender("tcp://127.0.0.1:0", "push")
    assert not push.send([b"x"], 0.05)                      # no receiver yet: a PUSH does not take the message
    pull = Receiver(push.address, "pull")
    message = encode(np.arange(4, dtype=np.float32), offset=0, tags=[Tag(0, "packet_len", 4)])
    assert push.send(message, 5.0)
    assert pull.receive(5.0) == message and pull.receive(0.01) is None
    pull.close()
    push.close(0)
    pub = Sender("tcp://127.0.0.1:0", "pub")
    sub = Receiver(pub.address, "sub", b"radar")
    sent = encode(np.ones(2, np.complex64), key=b"radar")
    for _ in range(500):                                    # a subscriber receives once its subscription arrived
        assert pub.send(sent, 1.0)
        got = sub.receive(0.01)
        if got is not None:
            break
    assert got == sent
    assert np.array_equal(decode(got, "complex64", tagged=False, key=b"radar").items, np.ones(2, np.complex64))
    sub.close()
    pub.close(0)


def test_a_request_is_a_uint32_in_the_host_s_byte_order_and_a_short_one_sets_no_limit():
    assert request(4096, "little") == struct.pack("<I", 4096) and request(4096, "big") == struct.pack(">I", 4096)
    assert requested(struct.pack("<I", 70) + b"rest", "little") == 70 and requested(b"abc") is None
    with pytest.raises(GrZmqError, match="a request is a uint32: 4294967296 items"):
        request(2 ** 32)


def test_a_req_asks_once_per_reply_and_a_rep_replies_to_what_it_was_asked():
    rep = Sender("tcp://127.0.0.1:0", "rep")
    req = Receiver(rep.address, "req", request_items=300)
    assert req.receive(0.05) is None and rep.wait_request(5.0) == 300      # the request went out, once
    assert req.receive(0.05) is None and rep.wait_request(0.05) is None   # no second request before the reply
    reply = encode(np.arange(300, dtype=np.float32), offset=0)
    assert rep.send(reply, 5.0)
    assert req.receive(5.0) == reply
    assert req.receive(0.05) is None and rep.wait_request(5.0) == 300      # the next one
    assert rep.send(encode(np.zeros(0, np.float32)), 5.0) and req.receive(5.0) == [b""]
    req.close()
    rep.close(0)
