"""GNU Radio's ZeroMQ stream messages (gr-zeromq's stream blocks: PUB/SUB, PUSH/PULL, REQ/REP), written and read.

One message per scheduler call of the GNU Radio sink, in one part (two with a PUB key):

    [key]        PUB/SUB only, when the sink has a key: a part of its own, which the SUB source subscribes to and
                 drops
    [header]     with pass_tags only, in the same part as the items, in the sender's byte order:
                     uint16 magic 0x5FF0, uint8 version 1, uint64 offset of the first item in the sender's
                     stream, uint64 tag count                                   (19 bytes)
                 then per tag: uint64 absolute offset of its item, and the PMT bytes (carav_stream/capture/
                 pmt.py, big endian) of its key, its value and its source id
    items        raw items in the sender's byte order: complex64 (gr_complex), float32, int32, int16 or bytes;
                 nothing says which, nor the rate, nor any shape: both ends must agree on them

REQ/REP: the REQ source asks for items with a request of its own, a uint32 in its host's byte order (4 bytes): the
number of items it has room for; the REP sink replies with one message as above holding at most that many (a
request shorter than 4 bytes sets no limit), and waits for the next request.

Without pass_tags nothing but the items travels: a receiver cannot tell where the stream began (a SUB that joins
late), nor whether messages were dropped (a PUB over its high-water mark). With it, the offsets show both.

Receiver and Sender are the sockets (a PULL, SUB or REQ connected to a GNU Radio sink; a PUSH, PUB or REP bound for
a GNU Radio source); encode, decode, request and requested are pure. decode refuses every malformed message with a
GrZmqError naming what is wrong: a bad magic (a hint when it is 0x5FF0 byte-swapped, or when an untagged stream's
items start with a header), an unknown version, a header or tag cut short, a PMT that cannot be read, a tag outside
its message's items, a payload that is not a whole number of items, a part count or key that does not fit the
sender's settings."""
from __future__ import annotations

import ipaddress
import struct
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import zmq

from carav_stream.capture.pmt import PmtError, deserialize, serialize

MAGIC = 0x5FF0
VERSION = 1
HEADER_BYTES = 19
HOST = sys.byteorder
ITEM_TYPES = {"complex64": np.dtype(np.complex64), "float32": np.dtype(np.float32), "int32": np.dtype(np.int32),
              "int16": np.dtype(np.int16), "uint8": np.dtype(np.uint8)}   # GNU Radio: complex float int short byte


class GrZmqError(ValueError):
    """A message that is not what the sender's settings say it is; the text names the problem."""


class OtherKey(GrZmqError):
    """A PUB/SUB message whose key part is not the one subscribed to (another publisher's stream)."""


@dataclass(frozen=True)
class Tag:
    """A stream tag: its item's absolute offset in the sender's stream, key, value and source id (PMT values)."""

    offset: int
    key: Any
    value: Any
    srcid: Any = False      # GNU Radio's tag_t default (PMT_F); a block's alias (a symbol) when it tagged


@dataclass(frozen=True)
class Message:
    """A decoded message: the items (1-D, native byte order); with pass_tags, the offset of items[0] and the tags
    (absolute offsets, within [offset, offset + len(items))); untagged, offset None and no tags."""

    items: np.ndarray
    offset: int | None = None
    tags: tuple[Tag, ...] = ()


def _order(byteorder: str) -> str:
    if byteorder not in ("little", "big"):
        raise ValueError(f"byteorder: {byteorder!r}, expected 'little' or 'big'")
    return "<" if byteorder == "little" else ">"


def header_bytes(offset: int, tags: Sequence[Tag] = (), byteorder: str = HOST) -> bytes:
    """The pass_tags header of a message whose first item has `offset`."""
    o = _order(byteorder)
    out = [struct.pack(f"{o}HBQQ", MAGIC, VERSION, offset, len(tags))]
    for tag in tags:
        try:
            out += [struct.pack(f"{o}Q", tag.offset), serialize(tag.key), serialize(tag.value), serialize(tag.srcid)]
        except (PmtError, struct.error) as exc:
            raise GrZmqError(f"tag {tag.key!r} at item {tag.offset}: {exc}") from None
    return b"".join(out)


def encode(items: np.ndarray, *, offset: int | None = None, tags: Sequence[Tag] = (), key: bytes = b"",
           byteorder: str = HOST) -> list[bytes]:
    """The message parts a GNU Radio sink sends for `items` (1-D): offset None = without pass_tags (no tags then);
    key = the PUB key's part first. A tag outside the items is refused, as GNU Radio never sends one."""
    items = np.asarray(items)
    if offset is None and tags:
        raise GrZmqError("tags travel only with pass_tags (an offset)")
    for tag in tags:
        if offset is None or not offset <= tag.offset < offset + len(items):
            raise GrZmqError(f"tag {tag.key!r} at item {tag.offset} is outside the message's items "
                             f"{offset} .. {(offset or 0) + len(items) - 1}")
    raw = items.astype(items.dtype.newbyteorder(_order(byteorder)), copy=False).tobytes()
    body = raw if offset is None else header_bytes(offset, tags, byteorder) + raw
    return [key, body] if key else [body]


def parse_header(buf: bytes | memoryview, byteorder: str = HOST) -> tuple[int, tuple[Tag, ...], int]:
    """(offset, tags, header length) of a pass_tags message; GrZmqError for a header that is not one."""
    o, view = _order(byteorder), memoryview(buf).cast("B")
    if len(view) < HEADER_BYTES:
        raise GrZmqError(f"truncated header: {len(view)} bytes, a tag header has at least {HEADER_BYTES}")
    magic, version, offset, n_tags = struct.unpack_from(f"{o}HBQQ", view)
    if magic != MAGIC:
        swapped = struct.unpack_from(f"{'>' if o == '<' else '<'}H", view)[0] == MAGIC
        raise GrZmqError(f"bad magic 0x{magic:04x}, expected 0x{MAGIC:04x}" + (
            f": the sender's byte order is not {byteorder}" if swapped else
            ": is the sender's pass_tags off? (its items then start the message)"))
    if version != VERSION:
        raise GrZmqError(f"header version {version}, only version {VERSION} is known")
    if n_tags * 11 > len(view) - HEADER_BYTES:   # a tag takes at least an offset and three one-byte PMTs
        raise GrZmqError(f"header announces {n_tags} tags; the {len(view) - HEADER_BYTES} bytes after it cannot "
                         "hold them")
    pos, tags = HEADER_BYTES, []
    for i in range(n_tags):
        if len(view) - pos < 8:
            raise GrZmqError(f"truncated header: tag {i} of {n_tags} has no offset (byte {pos})")
        tag_offset, = struct.unpack_from(f"{o}Q", view, pos)
        try:
            k, pos = deserialize(view, pos + 8)
            v, pos = deserialize(view, pos)
            src, pos = deserialize(view, pos)
        except PmtError as exc:
            raise GrZmqError(f"tag {i} of {n_tags} (item {tag_offset}): {exc}") from None
        tags.append(Tag(tag_offset, k, v, src))
    return offset, tuple(tags), pos


def decode(parts: Sequence[bytes], item: np.dtype | str, *, tagged: bool, key: bytes = b"",
           byteorder: str = HOST) -> Message:
    """A received message: `parts` as the socket gave them, `item` the stream's item type, `tagged` the sender's
    pass_tags, `key` its PUB key (b"" = none). OtherKey for another key, GrZmqError for anything malformed."""
    item = np.dtype(item)
    if len(parts) != (2 if key else 1):
        raise GrZmqError(f"{len(parts)} message parts, expected {2 if key else 1}" + (
            f" (the key {key!r}, then the items)" if key else
            ": the sender publishes with a key; set the same key here" if len(parts) == 2 else ""))
    if key and bytes(parts[0]) != key:
        raise OtherKey(f"key {bytes(parts[0])[:40]!r}, subscribed to {key!r}")
    body = memoryview(parts[-1]).cast("B")
    offset, tags, start = parse_header(body, byteorder) if tagged else (None, (), 0)
    size = len(body) - start
    if size % item.itemsize:
        hint = ""
        if not tagged and len(body) >= 3 and struct.unpack_from(f"{_order(byteorder)}HB", body) == (MAGIC, VERSION):
            hint = "; it starts with a tag header: is the sender's pass_tags on?"
        raise GrZmqError(f"wrong item size: {size} bytes of items are not a whole number of {item} items "
                         f"({item.itemsize} bytes each){hint}")
    items = np.frombuffer(body[start:], item.newbyteorder(_order(byteorder))).astype(item)
    for tag in tags:
        if not offset <= tag.offset < offset + len(items):
            raise GrZmqError(f"tag {tag.key!r} at item {tag.offset} is outside the message's items "
                             f"{offset} .. {offset + len(items) - 1}")
    return Message(items, offset, tags)


def request(n_items: int, byteorder: str = HOST) -> bytes:
    """A REQ source's request for up to n_items items."""
    if not 0 <= n_items < 2 ** 32:
        raise GrZmqError(f"a request is a uint32: {n_items} items cannot be asked for")
    return struct.pack(f"{_order(byteorder)}I", n_items)


def requested(buf: bytes | memoryview, byteorder: str = HOST) -> int | None:
    """The number of items a request asks for; None (no limit) for one shorter than 4 bytes, as GNU Radio's REP
    sink reads it."""
    view = memoryview(buf).cast("B")
    return struct.unpack_from(f"{_order(byteorder)}I", view)[0] if len(view) >= 4 else None


# ------------------------------------------------------------------ sockets (the GNU Radio sink binds, the source
# connects; carav's sink binds the same way, so GNU Radio's source connects to it)

SOCKETS = {"pull": zmq.PULL, "sub": zmq.SUB, "req": zmq.REQ, "push": zmq.PUSH, "pub": zmq.PUB, "rep": zmq.REP}


def check_address(address: str) -> str:
    """A ZeroMQ endpoint GNU Radio can use (tcp://HOST:PORT or ipc://PATH); ValueError naming it otherwise."""
    scheme, sep, rest = address.partition("://")
    if not sep or scheme not in ("tcp", "ipc") or not rest:
        raise ValueError(f"address: {address!r} is not tcp://HOST:PORT or ipc://PATH")
    if scheme == "tcp":
        host, colon, port = rest.rpartition(":")
        if not colon or not host or not (port == "*" or port.isdigit() and 0 <= int(port) <= 65535):
            raise ValueError(f"address: {address!r} has no port (tcp://HOST:PORT)")
    return address


def is_local(address: str) -> bool:
    """Whether the endpoint stays on this host (ipc://, or tcp:// on a loopback address or localhost)."""
    scheme, _, rest = address.partition("://")
    if scheme == "ipc":
        return True
    host = rest.rpartition(":")[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Receiver:
    """A PULL, SUB or REQ socket connected to a GNU Radio sink's address; `key` is the SUB subscription,
    `request_items` what a REQ asks for each time."""

    def __init__(self, address: str, kind: str, key: bytes = b"", request_items: int = 0) -> None:
        self.context = zmq.Context()
        self.socket = self.context.socket(SOCKETS[kind])
        self.socket.setsockopt(zmq.LINGER, 0)
        if kind == "sub":
            self.socket.setsockopt(zmq.SUBSCRIBE, key)
        self.socket.connect(address)
        self.request = request(request_items) if kind == "req" else None
        self.asked = False                        # a REQ's request is out and its reply not yet in

    def receive(self, timeout_s: float) -> list[bytes] | None:
        """The next message's parts, or None when none comes within timeout_s (a REQ asks first, once per
        reply: the request waits in the socket's queue until the REP sink is there)."""
        if self.request is not None and not self.asked:
            self.socket.send(self.request)
            self.asked = True
        if not self.socket.poll(max(int(timeout_s * 1000), 0), zmq.POLLIN):
            return None
        self.asked = False
        return self.socket.recv_multipart()

    def close(self) -> None:
        self.socket.close(0)
        self.context.term()


class Sender:
    """A PUSH, PUB or REP socket bound where GNU Radio's source connects. `address` is where it is bound (the port
    the system chose for tcp://HOST:0). A REP sends only in reply: `wait_request` first, then one `send`."""

    def __init__(self, address: str, kind: str) -> None:
        self.context = zmq.Context()
        self.socket = self.context.socket(SOCKETS[kind])
        self.socket.setsockopt(zmq.LINGER, 0)     # a process that ends without close() is not held by its queue
        self.socket.bind(address)
        self.address = self.socket.getsockopt_string(zmq.LAST_ENDPOINT)

    def wait_request(self, timeout_s: float) -> int | None:
        """A REP's next request: the items it asks for (2^32 - 1 for a request without a number); None when none
        comes within timeout_s."""
        if not self.socket.poll(max(int(timeout_s * 1000), 0), zmq.POLLIN):
            return None
        n = requested(self.socket.recv())
        return 2 ** 32 - 1 if n is None else n

    def send(self, parts: list[bytes], timeout_s: float) -> bool:
        """Send the message once the socket takes it (a PUSH waits for a receiver); False after timeout_s."""
        if not self.socket.poll(max(int(timeout_s * 1000), 0), zmq.POLLOUT):
            return False
        self.socket.send_multipart(parts, copy=False)
        return True

    def close(self, linger_s: float) -> None:
        """Close, leaving up to linger_s for the messages still queued to reach their receiver."""
        self.socket.close(int(linger_s * 1000))
        self.context.term()
