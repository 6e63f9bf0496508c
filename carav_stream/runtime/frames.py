"""Frames: one msgpack header plus zero or more raw numpy buffers, and their validating codec.

Wire format (one ZeroMQ multipart message)::

    part 0      msgpack map: the header (flat, snake_case keys)
    part 1..n   raw little-endian C-ordered bytes of each array named in header["arrays"]

Reserved header keys (the runtime stamps them; blocks set their own fields beside them):

    v              int    schema version (SCHEMA_VERSION)
    stream         str    "node.port" that sent the frame
    seq            int    sequence number on the stream (>= 0); outputs inherit the seq of their inputs
    cycle          int    cycle index (the source's count; carried unchanged through the graph)
    cycles         int    how many consecutive cycles the frame carries, from `cycle` on (absent = 1); the
                          runtime counts cycles with it, blocks set it (a source batching cycles, say); a
                          frame stating it carries that many rows (a consumer refuses it otherwise, pairing.py)
    t_created_s    float  wall-clock time the source created the cycle (Unix seconds)
    t_sent_s       float  wall-clock time of this hop's send
    arrays         list   [[name, dtype, shape], ...] describing parts 1..n
    node, block, block_version   provenance of the node and block version that produced the frame
    trail          list   ["node:block@version", ...] every hop the cycle went through
    eos            bool   end of stream: an explicit frame, never an empty payload
    resume         bool   first message of a producer's fresh connection to a restarted consumer (header only):
                          frames before `seq` on this stream went with the old connection, the next has
                          seq >= `seq`
    shm            list   the arrays are not in the message: the edge's data plane holds them, and this names
                          where (runtime/planes/; the shared-memory plane's is [slot, generation])

Decoding validates everything before any use and never builds objects from the wire: msgpack ext types are
refused, dtypes come from a whitelist of plain numeric types, and shape, size and header types are checked.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import msgpack
import numpy as np

SCHEMA_VERSION = 1
MAX_HEADER_BYTES = 1 << 20          # 1 MiB of msgpack header
MAX_ARRAY_BYTES = 1 << 30           # 1 GiB per message, all arrays together
MAX_ARRAYS = 16
MAX_NDIM = 8

# Plain numeric dtypes only, little-endian on the wire. Object, void, string and datetime dtypes are refused.
ALLOWED_DTYPES = frozenset({"bool", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64",
                            "float16", "float32", "float64", "complex64", "complex128"})

# dtype -> wire name and wire name -> little-endian dtype, looked up instead of computed on every message
_NAME_OF = {np.dtype(n).newbyteorder(o): n for n in ALLOWED_DTYPES for o in "<>="}
_WIRE_DTYPE = {n: np.dtype(n).newbyteorder("<") for n in ALLOWED_DTYPES}

RESERVED_KEYS = frozenset({"v", "stream", "seq", "cycle", "cycles", "t_created_s", "t_sent_s", "arrays",
                           "node", "block", "block_version", "trail", "eos", "resume", "shm"})
# Reserved keys a block may not set (it may set the cycle fields of a frame it creates)
_RUNTIME_ONLY_KEYS = RESERVED_KEYS - {"cycle", "cycles", "t_created_s"}
# Keys a derived frame does not inherit: the runtime stamps them anew at every hop.
_PER_HOP_KEYS = frozenset({"v", "stream", "arrays", "t_sent_s", "node", "block", "block_version", "shm"})

# Exact types: msgpack builds only plain int, float, str, bytes, bool, None, list and dict objects, so
# `type(value) in types` checks a received header exactly (and refuses a bool where an int is expected).
_HEADER_TYPES: dict[str, tuple[type, ...]] = {
    "v": (int,), "stream": (str,), "seq": (int,), "cycle": (int,), "cycles": (int,), "t_created_s": (float, int),
    "t_sent_s": (float, int), "arrays": (list,), "node": (str,), "block": (str,), "block_version": (str,),
    "trail": (list,), "eos": (bool,), "resume": (bool,), "shm": (list,),
}
_REQUIRED_KEYS = frozenset({"v", "stream", "seq", "cycle", "arrays", "eos"})
_STR = frozenset({str})
_NUMBER = frozenset({float, int})
_NO_TRAIL: list = []
_INT = frozenset({int})
PLANE_REF = "shm"          # the header key of a data plane's reference to the arrays it holds


class FrameError(ValueError):
    """A message that is not a valid frame; the text says what is wrong and where."""


class Frame:
    """A header dict plus named arrays (the first, usually "data", is the payload).

    Frames are immutable by convention: arrays received from the wire are read-only views of the message
    buffers, and a block must never modify an array after returning it (sends do not copy). Derive a new
    frame (`derive`, `with_header`) instead of changing one.

    A received frame builds its arrays (numpy views of the message buffers, no copy) when `arrays` is first
    read; a frame derived with `keep_data=True` from one whose arrays were never read sends the received
    buffers on as they came, without building them at all (a block forwarding a frame it routes by header).
    """

    __slots__ = ("header", "_arrays", "wire")

    def __init__(self, header: dict[str, Any] | None = None, arrays: dict[str, np.ndarray] | None = None,
                 wire: dict[str, list] | None = None) -> None:
        self.header = {} if header is None else header
        self._arrays = {} if arrays is None else arrays      # None: not built yet from `wire`
        # name -> [array built from it or None, message part, spec [name, dtype, shape], dtype, buffer]
        # for arrays received from the wire: an array forwarded unchanged is sent as the part it arrived in
        self.wire = {} if wire is None else wire

    @property
    def arrays(self) -> dict[str, np.ndarray]:
        arrays = self._arrays
        if arrays is None:
            arrays = self._arrays = {name: _view(received) for name, received in self.wire.items()}
        return arrays

    def __repr__(self) -> str:
        return f"Frame(header={self.header!r}, arrays={self.arrays!r})"

    @classmethod
    def of(cls, data: np.ndarray | None = None, **fields: Any) -> Frame:
        """A new frame with `data` as its payload and the block's own header fields."""
        _check_user_fields(fields)
        return cls(dict(fields), {} if data is None else {"data": np.asarray(data)})

    @property
    def payload(self) -> np.ndarray | None:
        return self.arrays.get("data")

    @property
    def seq(self) -> int:
        return self.header["seq"]

    @property
    def cycle(self) -> int:
        return self.header.get("cycle", self.header.get("seq", 0))

    @property
    def eos(self) -> bool:
        return bool(self.header.get("eos", False))

    def derive(self, data: np.ndarray | None = None, *, keep_data: bool = False,
               arrays: Mapping[str, np.ndarray] | None = None, **fields: Any) -> Frame:
        """A frame for the same cycle: inherits this header (seq, cycle, trail, block fields), sets `fields`.

        The payload is `data`, or this frame's arrays with `keep_data=True`, plus any named `arrays`.
        """
        header = dict(self.header)
        for key in _PER_HOP_KEYS:
            header.pop(key, None)
        if fields:
            _check_user_fields(fields)
            header.update(fields)
        if keep_data and self._arrays is None and data is None and not arrays:
            return _received(header, self.wire)        # the received arrays, still unbuilt, go on as they came
        new_arrays: dict[str, np.ndarray] = dict(self.arrays) if keep_data else {}
        if data is not None:
            new_arrays["data"] = np.asarray(data)
        if arrays:
            new_arrays.update({k: np.asarray(a) for k, a in arrays.items()})
        wire = {k: w for k, w in self.wire.items() if new_arrays.get(k) is w[0]} if self.wire else {}
        return Frame(header, new_arrays, wire)

    def with_header(self, **fields: Any) -> Frame:
        """The same arrays with extra header fields."""
        return self.derive(keep_data=True, **fields)


def _received(header: dict[str, Any], wire: dict[str, list]) -> Frame:
    """A frame of received arrays that are built from `wire` when first read."""
    frame = _new_frame(Frame)
    frame.header, frame._arrays, frame.wire = header, None, wire
    return frame


_new_frame = Frame.__new__


def _view(received: list) -> np.ndarray:
    """The read-only array (no copy) of a received buffer, built once and shared by the frames that carry it."""
    array = received[0]
    if array is None:
        spec, dtype, buffer = received[2], received[3], received[4]
        array = received[0] = np.ndarray(spec[2], dtype, buffer.toreadonly())
    return array


def end_of_stream(seq: int, **fields: Any) -> Frame:
    return Frame({"seq": seq, "cycle": seq, "eos": True, **fields}, {})


def _check_user_fields(fields: Mapping[str, Any]) -> None:
    if not _RUNTIME_ONLY_KEYS.isdisjoint(fields):
        raise FrameError(f"header fields {sorted(_RUNTIME_ONLY_KEYS.intersection(fields))} are reserved for the "
                         "runtime; choose other names")


def _pack_default(obj: Any) -> Any:
    # numpy scalars in headers are common (q = np.max(...)): store them as plain numbers.
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray) and obj.size <= 64:
        return obj.tolist()
    raise TypeError(f"header value {obj!r} of type {type(obj).__name__} cannot go in a frame header; "
                    "use plain numbers, strings, lists or dicts, and put arrays in the payload")


def header_packer() -> msgpack.Packer:
    """A reusable msgpack packer for `encode` (faster than a packer per call); one per thread, never shared."""
    return msgpack.Packer(use_bin_type=True, default=_pack_default)


def encode(frame: Frame, packer: msgpack.Packer | None = None, /, **stamp: Any) -> list[Any]:
    """The multipart message for `frame`: [header bytes, buffer, ...]; buffers are not copied when contiguous.

    `stamp` adds runtime fields (stream, node, block, ...) to the header; "v" and "arrays" are set here.
    `packer` (from header_packer(), owned by the calling thread) saves building one per message.
    """
    return encode_with_header({**frame.header, **stamp}, frame, packer)


def encode_with_header(header: dict[str, Any], frame: Frame, packer: msgpack.Packer | None = None,
                       place: Callable[[list[Any]], list[int] | None] | None = None) -> list[Any]:
    """`encode` for a caller that built the message's header itself (the runtime, once per frame): `header` is
    a new dict it hands over (completed with "v", "arrays" and the defaults of "eos" and "cycle", then packed);
    the buffers are `frame`'s arrays. `place(buffers)` may keep the buffers on a data plane (runtime/planes/) and
    return its reference, which goes in the header as "shm"; then the message is the header alone."""
    header["v"] = SCHEMA_VERSION
    if "eos" not in header:
        header["eos"] = False
    if "cycle" not in header:
        header["cycle"] = header.get("seq", 0)
    specs, buffers = [], []
    wire = frame.wire
    arrays = frame._arrays
    if arrays is None:                 # received arrays never read: resend the received parts as they are
        for received in wire.values():
            specs.append(received[2])
            buffers.append(received[1])
        arrays = {}
    for name, array in arrays.items():
        received = wire.get(name) if wire else None
        if received is not None and received[0] is array:   # forwarded unchanged: resend the received part
            specs.append(received[2])
            buffers.append(received[1])
            continue
        array = np.asarray(array)
        dtype_name = _NAME_OF.get(array.dtype)
        if dtype_name is None:
            raise FrameError(f"array {name!r}: dtype {array.dtype} is not allowed on the wire; "
                             f"expected one of {sorted(ALLOWED_DTYPES)}")
        if array.dtype.byteorder == ">":
            array = array.astype(_WIRE_DTYPE[dtype_name])
        if not array.flags.c_contiguous:
            array = np.ascontiguousarray(array)  # the one copy a non-contiguous view needs
        specs.append([name, dtype_name, list(array.shape)])
        buffers.append(memoryview(array).cast("B") if array.size else b"")
    header["arrays"] = specs
    if place is not None and buffers:
        ref = place(buffers)
        if ref is not None:
            header[PLANE_REF] = ref
            buffers = []
    try:
        head = (packer or header_packer()).pack(header)
    except (TypeError, ValueError, OverflowError) as exc:
        raise FrameError(f"header cannot be encoded: {exc}") from exc
    return [head, *buffers]


def _reject_ext(code: int, data: bytes) -> Any:
    raise FrameError(f"header contains msgpack extension type {code}; extension types are refused")


def decode(parts: list[Any], *, max_array_bytes: int = MAX_ARRAY_BYTES, reader: Any = None) -> Frame:
    """Validate and decode a multipart message (bytes or zmq.Frame parts); arrays are read-only views.

    A header with "shm" names arrays a data plane holds instead of carrying buffer parts: `reader` (the input's
    planes.Reader) resolves it, or the message is refused."""
    if not parts:
        raise FrameError("empty message: expected a header part")
    head = getattr(parts[0], "buffer", None)      # a zmq.Frame received with copy=False: its memoryview
    if type(head) is not memoryview:
        head = _as_buffer(parts[0])
    if len(head) > MAX_HEADER_BYTES:
        raise FrameError(f"header of {len(head)} bytes exceeds the limit of {MAX_HEADER_BYTES}")
    try:
        header = msgpack.unpackb(head, raw=False, strict_map_key=True, ext_hook=_reject_ext,
                                 use_list=True)
    except FrameError:
        raise
    except Exception as exc:  # msgpack raises several unrelated types for truncated or garbled input
        raise FrameError(f"header is not valid msgpack ({type(exc).__name__}: {exc})") from exc
    if not isinstance(header, dict):
        raise FrameError(f"header must be a msgpack map, got {type(header).__name__}")
    _check_header(header)
    specs = header["arrays"]
    if PLANE_REF in header:
        parts = _held_parts(header, parts, specs, max_array_bytes, reader)
    elif len(parts) - 1 != len(specs):
        raise FrameError(f"header announces {len(specs)} array(s) but the message has {len(parts) - 1} "
                         "buffer part(s)")
    wire: dict[str, list] = {}
    total = 0
    for i, spec in enumerate(specs):
        name, dtype, shape = _check_spec(i, spec)
        nbytes = dtype.itemsize * math.prod(shape)
        total += nbytes
        if total > max_array_bytes:
            raise FrameError(f"arrays total more than the limit of {max_array_bytes} bytes")
        if not nbytes and math.prod(d for d in shape if d) > max_array_bytes:
            raise FrameError(f"array {name!r}: shape {tuple(shape)} is too large (an empty array with more than "
                             f"{max_array_bytes} elements across its other dimensions)")
        part = parts[i + 1]
        buf = getattr(part, "buffer", None)
        if type(buf) is not memoryview:
            buf = _as_buffer(part)
        if len(buf) != nbytes:
            raise FrameError(f"array {name!r}: shape {tuple(shape)} of {dtype.name} needs {nbytes} bytes, "
                             f"buffer has {len(buf)}")
        if name in wire:
            raise FrameError(f"array name {name!r} appears twice")
        wire[name] = [None, part, spec, dtype, buf]   # the array view is built when first read
    return _received(header, wire)


def _held_parts(header: dict, parts: list[Any], specs: list, max_array_bytes: int, reader: Any) -> list[Any]:
    """The message of a frame whose arrays a data plane holds (header "shm") as if they had come in it: the header
    part, then the read-only buffers `reader` resolves (checked by decode like received parts)."""
    if reader is None:
        raise FrameError("header names arrays held by a data plane ('shm'), but this input has no data plane")
    if len(parts) != 1:
        raise FrameError(f"a frame whose arrays a data plane holds is the header alone; the message has "
                         f"{len(parts) - 1} buffer part(s) besides")
    sizes = [dtype.itemsize * math.prod(shape) for _, dtype, shape in map(_check_spec, range(len(specs)), specs)]
    if sum(sizes) > max_array_bytes:
        raise FrameError(f"arrays total more than the limit of {max_array_bytes} bytes")
    try:
        buffers = reader.resolve(header[PLANE_REF], sizes)
    except ValueError as exc:
        raise FrameError(str(exc)) from None
    if len(buffers) != len(sizes):
        raise FrameError(f"the data plane gave {len(buffers)} buffer(s) for {len(sizes)} array(s)")
    return [parts[0], *buffers]


def _as_buffer(part: Any) -> memoryview:
    """A message part that is not a zmq.Frame (decode reads those itself) as a memoryview."""
    if isinstance(part, (bytes, bytearray, memoryview)):
        return memoryview(part)
    raise FrameError(f"message part of type {type(part).__name__} is not a byte buffer")


def _check_header(header: dict) -> None:
    get = header.get
    try:   # the types of _HEADER_TYPES, spelled out: one expression instead of a loop over the header's keys
        typed = (type(header["v"]) is int and type(header["stream"]) is str and type(header["seq"]) is int
                 and type(header["cycle"]) is int and type(header["arrays"]) is list and type(header["eos"]) is bool
                 and type(get("cycles", 1)) is int and type(get("t_created_s", 0.0)) in _NUMBER
                 and type(get("t_sent_s", 0.0)) in _NUMBER and type(get("node", "")) is str
                 and type(get("block", "")) is str and type(get("block_version", "")) is str
                 and type(get("trail", _NO_TRAIL)) is list and type(get("resume", False)) is bool
                 and type(get("shm", _NO_TRAIL)) is list)
    except KeyError:
        typed = False
    if not typed:
        _refuse_header_types(header)
    if header["v"] != SCHEMA_VERSION:
        raise FrameError(f"schema version {header['v']} is not supported; expected {SCHEMA_VERSION}")
    if header["seq"] < 0:
        raise FrameError(f"seq must be >= 0, got {header['seq']}")
    if get("cycles", 1) < 1:
        raise FrameError(f"cycles must be >= 1, got {header['cycles']}")
    if len(header["arrays"]) > MAX_ARRAYS:
        raise FrameError(f"{len(header['arrays'])} arrays exceed the limit of {MAX_ARRAYS}")
    if "trail" in header and not set(map(type, header["trail"])) <= _STR:
        raise FrameError("header key 'trail' must be a list of strings")


def _refuse_header_types(header: dict) -> None:
    """Raise the reason a header failed the type check of _check_header: a required key missing, or a reserved
    key of a type that _HEADER_TYPES does not allow."""
    if not header.keys() >= _REQUIRED_KEYS:
        raise FrameError(f"header lacks required key(s) {sorted(_REQUIRED_KEYS - header.keys())}")
    for key, value in header.items():
        types = _HEADER_TYPES.get(key)
        if types is not None and type(value) not in types:
            raise FrameError(f"header key {key!r} must be {'/'.join(t.__name__ for t in types)}, "
                             f"got {type(value).__name__}")
    raise FrameError("header has a reserved key of a type it may not have")   # unreachable: a test keeps
    # _check_header and _HEADER_TYPES in step


def _check_spec(i: int, spec: Any) -> tuple[str, np.dtype, list[int]]:
    if not (type(spec) is list and len(spec) == 3 and type(spec[0]) is str and type(spec[1]) is str
            and type(spec[2]) is list):
        raise FrameError(f"arrays[{i}] must be [name, dtype, shape], got {spec!r}")
    name, dtype_name, shape = spec
    dtype = _WIRE_DTYPE.get(dtype_name)
    if dtype is None:
        raise FrameError(f"array {name!r}: dtype {dtype_name!r} is not allowed; expected one of "
                         f"{sorted(ALLOWED_DTYPES)}")
    if len(shape) > MAX_NDIM or not set(map(type, shape)) <= _INT or min(shape, default=0) < 0:
        raise FrameError(f"array {name!r}: shape {shape!r} must be at most {MAX_NDIM} non-negative integers")
    return name, dtype, shape
