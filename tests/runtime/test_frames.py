import msgpack
import numpy as np
import pytest
import zmq
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from carav_stream.runtime.frames import (
    _HEADER_TYPES,
    _REQUIRED_KEYS,
    ALLOWED_DTYPES,
    MAX_HEADER_BYTES,
    RESERVED_KEYS,
    SCHEMA_VERSION,
    Frame,
    FrameError,
    decode,
    encode,
    end_of_stream,
    header_packer,
)

header_values = st.recursive(
    st.none() | st.booleans() | st.integers(-2**63, 2**63 - 1) | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
    max_leaves=10)
user_headers = st.dictionaries(st.from_regex(r"[a-z][a-z_]{0,10}", fullmatch=True).filter(
    lambda k: k not in {"v", "stream", "seq", "arrays", "node", "block", "block_version", "trail", "eos",
                        "t_sent_s", "cycle", "t_created_s"}), header_values, max_size=5)
dtypes = st.sampled_from(sorted(ALLOWED_DTYPES))


@pytest.mark.slow
@settings(max_examples=60)
@given(dtype=dtypes, shape=hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=6), header=user_headers,
       seq=st.integers(0, 2**40), data=st.data())
def test_round_trip_preserves_array_and_header_for_any_dtype_and_shape(dtype, shape, header, seq, data):
    array = data.draw(hnp.arrays(np.dtype(dtype), shape))
    frame = Frame.of(array, **header)
    out = decode(encode(frame, seq=seq, stream="n.p"))
    assert out.payload.dtype == array.dtype and out.payload.shape == array.shape
    np.testing.assert_array_equal(out.payload, array)
    assert out.seq == seq and out.header["v"] == SCHEMA_VERSION
    for k, v in header.items():
        assert out.header[k] == v


@settings(max_examples=30)
@given(arr=hnp.arrays(np.complex64, (6, 8)), step=st.integers(1, 3), transpose=st.booleans())
def test_round_trip_of_non_contiguous_views(arr, step, transpose):
    view = arr[::step, ::2]
    if transpose:
        view = view.T
    out = decode(encode(Frame.of(view), seq=0, stream="n.p"))
    np.testing.assert_array_equal(out.payload, view)


def test_big_endian_arrays_arrive_with_their_values():
    arr = np.arange(5, dtype=">f8")
    out = decode(encode(Frame.of(arr), seq=0, stream="s.p"))
    np.testing.assert_array_equal(out.payload, arr)
    assert out.payload.dtype == np.dtype("<f8")


def test_decoded_arrays_are_read_only_views_of_the_message():
    parts = encode(Frame.of(np.ones(1000)), seq=3, stream="s.p")
    out = decode([bytes(p) for p in parts])
    assert not out.payload.flags.writeable
    with pytest.raises(ValueError):
        out.payload[0] = 2


def test_encode_does_not_copy_contiguous_payloads():
    arr = np.arange(10000, dtype=np.float32)
    parts = encode(Frame.of(arr), seq=0, stream="s.p")
    assert np.shares_memory(np.frombuffer(parts[1], dtype=np.float32), arr)


def good_parts(**override):
    header = {"v": SCHEMA_VERSION, "stream": "a.b", "seq": 1, "cycle": 1, "eos": False,
              "arrays": [["data", "float32", [2, 3]]]}
    header.update(override)
    return [msgpack.packb(header), np.zeros((2, 3), np.float32).tobytes()]


@pytest.mark.parametrize("parts, reason", [
    ([], "empty message"),
    ([b"\xc1garbage"], "not valid msgpack"),
    ([msgpack.packb([1, 2])], "must be a msgpack map"),
    (good_parts(v=99), "schema version 99"),
    (good_parts(seq="1"), "'seq' must be int"),
    (good_parts(seq=-4), "seq must be >= 0"),
    (good_parts(eos=1), "'eos' must be bool"),
    (good_parts(arrays=[["data", "object", [2, 3]]]), "dtype 'object' is not allowed"),
    (good_parts(arrays=[["data", "float32", [2, -3]]]), "non-negative integers"),
    (good_parts(arrays=[["data", "float32", [2, 4]]]), "needs 32 bytes, buffer has 24"),
    (good_parts(arrays=[["data", "float32", [2, 3]], ["x", "int8", [1]]]), "announces 2 array(s)"),
    (good_parts()[:1], "announces 1 array(s) but the message has 0"),
    ([good_parts()[0], b"\x00" * 23], "buffer has 23"),
    (good_parts(seq=True), "'seq' must be int"),
    (good_parts(t_created_s=True), "'t_created_s' must be float/int"),
    (good_parts(stream=b"a.b"), "'stream' must be str"),
    (good_parts(cycles=0), "cycles must be >= 1"),
    (good_parts(trail=["a:x@1#0", 3]), "list of strings"),
    ([msgpack.packb({"v": 1, "stream": "a.b", "seq": 1, "eos": False, "arrays": []})],
     "lacks required key(s) ['cycle']"),
    (good_parts(arrays=[["data", ["float32"], [2, 3]]]), "must be [name, dtype, shape]"),
    (good_parts(arrays=[["data", "float32", [True, 6]]]), "non-negative integers"),
])
def test_decoder_rejects_bad_messages_with_the_reason(parts, reason):
    with pytest.raises(FrameError, match=None) as info:
        decode(parts)
    assert reason in str(info.value)


@pytest.mark.parametrize("key", sorted(RESERVED_KEYS))
def test_every_reserved_header_key_is_checked_for_its_exact_type(key):
    assert key in _HEADER_TYPES
    for value in (None, {}, "x", 3, 1.5, True, ["a"], b"x"):
        if type(value) in _HEADER_TYPES[key]:
            continue
        with pytest.raises(FrameError, match=f"header key '{key}' must be"):
            decode(good_parts(**{key: value}))


@pytest.mark.parametrize("key", sorted(_REQUIRED_KEYS))
def test_a_missing_required_header_key_is_named(key):
    header = msgpack.unpackb(good_parts()[0])
    del header[key]
    with pytest.raises(FrameError, match=f"lacks required key\\(s\\) \\['{key}'\\]"):
        decode([msgpack.packb(header), np.zeros((2, 3), np.float32).tobytes()])


@pytest.mark.parametrize("shape", [[2**64 - 1, 0], [2**40, 2**40, 0], [0, 1 << 31]])
def test_an_empty_array_of_absurd_shape_is_refused_not_a_crash(shape):
    with pytest.raises(FrameError, match="too large"):
        decode([good_parts(arrays=[["data", "float32", shape]])[0], b""])
    assert decode([good_parts(arrays=[["data", "float32", [0, 1 << 20]]])[0], b""]).payload.shape == (0, 1 << 20)


def test_an_array_name_given_twice_is_refused():
    parts = good_parts(arrays=[["data", "float32", [2, 3]], ["data", "float32", [2, 3]]])
    with pytest.raises(FrameError, match="'data' appears twice"):
        decode([*parts, parts[1]])


def test_arrays_never_read_are_forwarded_as_the_received_parts():
    arr = np.arange(12, dtype=np.complex64).reshape(3, 4)
    head, buffer = encode(Frame.of(arr, note="x"), seq=2, stream="s.p")
    received = [bytes(head), bytes(buffer)]
    frame = decode(received)
    forwarded = frame.derive(keep_data=True, hop=1)
    parts = encode(forwarded, seq=2, stream="p.out")
    assert parts[1] is received[1]                                  # the received part, not an array's buffer
    out = decode(parts)
    assert out.header["hop"] == 1 and out.header["arrays"] == [["data", "complex64", [3, 4]]]
    np.testing.assert_array_equal(out.payload, arr)
    assert forwarded.payload is frame.payload                       # one read-only view, built once, shared
    assert not frame.payload.flags.writeable
    assert encode(forwarded, seq=2, stream="p.out")[1] is received[1]   # still forwarded once read
    replaced = encode(frame.derive(keep_data=True, arrays={"data": np.zeros(2)}), seq=2, stream="p.out")
    assert replaced[1] is not received[1] and decode(replaced).payload.shape == (2,)


def test_decoder_refuses_msgpack_extension_types():
    head = msgpack.packb({"v": 1, "stream": "a.b", "seq": 0, "cycle": 0, "eos": False, "arrays": [],
                          "evil": msgpack.ExtType(42, b"payload")})
    with pytest.raises(FrameError, match="extension type 42"):
        decode([head])


def test_decoder_enforces_size_limits():
    with pytest.raises(FrameError, match="exceeds the limit"):
        decode([b"\x00" * (MAX_HEADER_BYTES + 1)])
    parts = good_parts(arrays=[["data", "float64", [1 << 20]]])
    with pytest.raises(FrameError, match="limit of 1000 bytes"):
        decode(parts, max_array_bytes=1000)


def test_header_with_non_plain_value_is_refused_at_encode():
    with pytest.raises(FrameError, match="cannot be encoded"):
        encode(Frame.of(None, when=object()), seq=0, stream="a.b")


@settings(max_examples=40)
@given(headers=st.lists(user_headers, min_size=1, max_size=4), seq=st.integers(0, 2**40))
def test_a_reused_header_packer_encodes_what_a_fresh_one_does(headers, seq):
    packer = header_packer()           # the node keeps one for all its messages
    for header in headers:
        with pytest.raises(FrameError):                      # a failed header must not leave residue behind
            encode(Frame.of(None, bad=object()), packer, seq=seq, stream="a.b")
        frame = Frame.of(np.arange(4.0), **{**header, "q": np.float32(0.5)})
        assert encode(frame, packer, seq=seq, stream="a.b")[0] == encode(frame, seq=seq, stream="a.b")[0]


def test_numpy_scalars_in_headers_become_plain_numbers():
    out = decode(encode(Frame.of(None, q=np.float32(1.5), n=np.int64(3)), seq=0, stream="a.b"))
    assert out.header["q"] == 1.5 and out.header["n"] == 3


def test_blocks_cannot_set_reserved_header_fields():
    for field in ("seq", "eos", "resume"):
        with pytest.raises(FrameError, match="reserved"):
            Frame.of(np.zeros(2), **{field: True})


def test_a_resume_marker_must_say_true_or_false():
    assert decode(encode(Frame({"seq": 3, "resume": True}), stream="a.b")).header["resume"] is True
    with pytest.raises(FrameError, match="'resume' must be bool"):
        decode(encode(Frame({"seq": 3, "resume": 1}), stream="a.b"))


def test_derive_inherits_cycle_fields_but_not_per_hop_provenance():
    f = decode(encode(Frame.of(np.zeros(3), rms_dbfs=-3.0), seq=7, stream="a.b", node="a", trail=["a:x@1#0"]))
    g = f.derive(np.ones(3), q=1.2)
    assert g.header["seq"] == 7 and g.header["rms_dbfs"] == -3.0 and g.header["q"] == 1.2
    assert "node" not in g.header and g.header["trail"] == ["a:x@1#0"]
    assert f.with_header(alarm=True).payload is f.payload


def test_end_of_stream_is_an_explicit_frame():
    out = decode(encode(end_of_stream(12), stream="a.b"))
    assert out.eos and out.seq == 12 and out.payload is None


def test_arrays_forwarded_unchanged_are_sent_as_the_received_zmq_frames():
    ctx = zmq.Context()
    a, b = ctx.socket(zmq.PAIR), ctx.socket(zmq.PAIR)
    try:
        a.bind("inproc://forward")
        b.connect("inproc://forward")
        arr = np.arange(20000, dtype=np.complex64).reshape(100, 200)
        a.send_multipart(encode(Frame.of(arr), seq=4, stream="s.p", trail=["s:src@1#0"]), copy=False)
        assert b.poll(5000)
        received = b.recv_multipart(copy=False)
        frame = decode(received)
        assert not frame.payload.flags.writeable             # a view of the (writable) received buffer
        with pytest.raises(ValueError):
            frame.payload[0, 0] = 1
        parts = encode(frame.derive(keep_data=True), seq=4, stream="p.out", trail=["s:src@1#0", "p:pass@1#0"])
        assert parts[1] is received[1]                       # no new buffer, no copy
        changed = encode(frame.derive(np.ones(3)), seq=4, stream="p.out")
        assert changed[1] is not received[1]
        out = decode([bytes(p) for p in parts])
        np.testing.assert_array_equal(out.payload, arr)
        assert out.header["trail"] == ["s:src@1#0", "p:pass@1#0"] and not out.payload.flags.writeable
    finally:
        a.close(linger=0)
        b.close(linger=0)
        ctx.term()
