"""GNU Radio's polymorphic types (PMT) as bytes: how a stream tag's key, value and source travel in a gr-zeromq
message (pmt::serialize and pmt::deserialize of GNU Radio's runtime, pmt_serialize.cc).

A value is one type byte and its body, every number big endian:

    0x00 PMT_T   0x01 PMT_F   0x06 PMT_NIL       no body
    0x02 symbol                uint16 length, then its bytes (read here as UTF-8)
    0x03 int32 | 0x0d int64    two's complement (GNU Radio writes int32 when the value fits, int64 otherwise)
    0x0b uint64                8 bytes
    0x04 double                IEEE 754, 8 bytes
    0x05 complex               two doubles: real, imaginary
    0x07 pair                  car, then cdr; a list is pairs ending in PMT_NIL, written flat: 07 a 07 b 06
    0x09 dict                  its (key . value) pairs as a list whose cells are typed 0x09: 09 07 k v 09 07 k v 06
    0x08 vector | 0x0c tuple   uint32 count, then the elements
    0x0a uniform vector        uint8 element type (U8 S8 U16 S16 U32 S32 U64 S64 F32 F64 C32 C64 = 0 .. 11),
                               uint32 count, uint8 npad and npad bytes, then the elements

In Python: True, False, None; str (symbol); int (int32 | int64); UInt64; float; complex; tuple; Pair; dict
(written as GNU Radio writes a dict; an empty one is PMT_NIL, as pmt::make_dict() is, and reads back as None; a list
of pairs GNU Radio made with acons reads back as Pairs, as_dict turns it into a dict); list (vector); a 1-D numpy
array (uniform vector). rx_time is a tuple (UInt64 seconds, float fraction).

Every value that cannot be written, and every byte string that is not a value, raises PmtError naming what is
wrong and at which byte: an unknown type byte, a body cut short, a count larger than the bytes left can hold, a
symbol that is not UTF-8, a dict entry that is not a (key . value) pair; nothing else escapes. Containers nest at
most MAX_DEPTH deep (a list of pairs is read in a loop, as GNU Radio does, so a long list is not deep).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

MAX_DEPTH = 64
MAX_SYMBOL = 1024      # GNU Radio's deserializer refuses a longer symbol ("very long symbol")
T, F, SYMBOL, INT32, DOUBLE, COMPLEX, NIL, PAIR, VECTOR, DICT, UNIFORM, UINT64, TUPLE, INT64 = range(14)
NAMES = {T: "PMT_T", F: "PMT_F", SYMBOL: "symbol", INT32: "int32", DOUBLE: "double", COMPLEX: "complex",
         NIL: "PMT_NIL", PAIR: "pair", VECTOR: "vector", DICT: "dict", UNIFORM: "uniform vector", UINT64: "uint64",
         TUPLE: "tuple", INT64: "int64"}
# uniform vector element types, in the order of their type numbers (big endian on the wire)
UNIFORM_DTYPES = tuple(np.dtype(f">{c}") for c in ("u1", "i1", "u2", "i2", "u4", "i4", "u8", "i8", "f4", "f8",
                                                     "c8", "c16"))
_UNIFORM_CODE = {d.newbyteorder("="): i for i, d in enumerate(UNIFORM_DTYPES)}


class PmtError(ValueError):
    """A value that cannot be written as a PMT, or bytes that are not one; the text says what and where."""


class UInt64(int):
    """An integer that travels as a PMT uint64 (a plain int travels as int32 or int64)."""

    def __new__(cls, value: int) -> UInt64:
        if not 0 <= int(value) < 2 ** 64:
            raise PmtError(f"uint64: {value} is outside 0 .. 2^64 - 1")
        return super().__new__(cls, value)

    def __repr__(self) -> str:
        return f"UInt64({int(self)})"


@dataclass(frozen=True)
class Pair:
    """A PMT pair (car . cdr); a list (a b) is Pair(a, Pair(b, None))."""

    car: Any
    cdr: Any


def as_dict(value: Any) -> dict:
    """A dict from a PMT dict or a list of (key . value) pairs (what pmt::acons builds); PmtError otherwise."""
    if isinstance(value, dict):
        return value
    out, cell = {}, value
    while isinstance(cell, Pair):
        if not isinstance(cell.car, Pair):
            raise PmtError(f"not a dict: its element {cell.car!r} is not a (key . value) pair")
        out[cell.car.car] = cell.car.cdr
        cell = cell.cdr
    if cell is not None:
        raise PmtError(f"not a dict: the list ends in {cell!r}, not PMT_NIL")
    return out


# ------------------------------------------------------------------ writing

def serialize(value: Any) -> bytes:
    """The PMT bytes of a Python value (module docstring); PmtError naming a value that has no PMT form."""
    out = bytearray()
    _write(value, out, 0)
    return bytes(out)


def _write(value: Any, out: bytearray, depth: int) -> None:
    if depth > MAX_DEPTH:
        raise PmtError(f"nested deeper than {MAX_DEPTH} containers (a value that contains itself?)")
    if value is True or value is False or isinstance(value, np.bool_):
        out.append(T if value else F)
    elif value is None:
        out.append(NIL)
    elif isinstance(value, str):
        raw = value.encode()
        if len(raw) > MAX_SYMBOL:
            raise PmtError(f"symbol of {len(raw)} bytes: GNU Radio reads symbols of at most {MAX_SYMBOL} bytes")
        out += struct.pack(">BH", SYMBOL, len(raw)) + raw
    elif isinstance(value, UInt64) or isinstance(value, np.uint64):
        out += struct.pack(">BQ", UINT64, int(value))
    elif isinstance(value, int | np.integer):
        v = int(value)
        if -2 ** 31 <= v < 2 ** 31:
            out += struct.pack(">Bi", INT32, v)
        elif -2 ** 63 <= v < 2 ** 63:
            out += struct.pack(">Bq", INT64, v)
        else:
            raise PmtError(f"integer {v} is beyond int64 (UInt64 holds 0 .. 2^64 - 1)")
    elif isinstance(value, float | np.floating):
        out += struct.pack(">Bd", DOUBLE, float(value))
    elif isinstance(value, complex | np.complexfloating):
        out += struct.pack(">Bdd", COMPLEX, value.real, value.imag)
    elif isinstance(value, Pair):
        cell = value
        while isinstance(cell, Pair):      # a list written flat, as GNU Radio writes it
            out.append(PAIR)
            _write(cell.car, out, depth + 1)
            cell = cell.cdr
        _write(cell, out, depth + 1)
    elif isinstance(value, dict):
        for k, v in value.items():
            out.append(DICT)
            out.append(PAIR)
            _write(k, out, depth + 1)
            _write(v, out, depth + 1)
        out.append(NIL)
    elif isinstance(value, tuple | list):
        out += struct.pack(">BI", TUPLE if isinstance(value, tuple) else VECTOR, len(value))
        for v in value:
            _write(v, out, depth + 1)
    elif isinstance(value, np.ndarray):
        code = _UNIFORM_CODE.get(value.dtype.newbyteorder("="))
        if value.ndim != 1 or code is None:
            raise PmtError(f"array {value.dtype} {value.shape}: a uniform vector is 1-D, of "
                           "u1 i1 u2 i2 u4 i4 u8 i8 f4 f8 c8 c16")
        out += struct.pack(">BBIBB", UNIFORM, code, len(value), 1, 0)   # one pad byte, as GNU Radio writes
        out += value.astype(UNIFORM_DTYPES[code], copy=False).tobytes()
    else:
        raise PmtError(f"{type(value).__name__} {value!r:.60} has no PMT form")


# ------------------------------------------------------------------ reading

class _Reader:
    def __init__(self, buf: bytes | memoryview, pos: int) -> None:
        self.buf, self.pos = memoryview(buf).cast("B"), pos

    def take(self, n: int, what: str) -> memoryview:
        if n > len(self.buf) - self.pos:
            raise PmtError(f"truncated: {what} needs {n} bytes at byte {self.pos}, "
                           f"{max(len(self.buf) - self.pos, 0)} left")
        self.pos += n
        return self.buf[self.pos - n:self.pos]

    def unpack(self, fmt: str, what: str) -> tuple:
        return struct.unpack(fmt, self.take(struct.calcsize(fmt), what))

    def count(self, what: str, least_bytes: int) -> int:
        """A uint32 count, checked against the bytes left (each element takes at least least_bytes)."""
        n, = self.unpack(">I", f"{what} count")
        if n * least_bytes > len(self.buf) - self.pos:
            raise PmtError(f"truncated: {what} of {n} elements (count at byte {self.pos - 4}), "
                           f"only {len(self.buf) - self.pos} bytes left")
        return n


def deserialize(buf: bytes | memoryview, pos: int = 0) -> tuple[Any, int]:
    """(the value whose bytes start at buf[pos], the position after them); PmtError for bytes that are not one."""
    reader = _Reader(buf, pos)
    return _read(reader, 0), reader.pos


def _read(r: _Reader, depth: int) -> Any:
    if depth > MAX_DEPTH:
        raise PmtError(f"nested deeper than {MAX_DEPTH} containers at byte {r.pos}")
    at = r.pos
    kind, = r.unpack(">B", "a type byte")
    if kind in (T, F, NIL):
        return {T: True, F: False, NIL: None}[kind]
    if kind == SYMBOL:
        n, = r.unpack(">H", "a symbol's length")
        raw = bytes(r.take(n, f"a symbol of {n} bytes"))
        try:
            return raw.decode()
        except UnicodeDecodeError:
            raise PmtError(f"symbol at byte {at} is not UTF-8: {raw[:40]!r}") from None
    if kind in (INT32, INT64, UINT64, DOUBLE, COMPLEX):
        fmt = {INT32: ">i", INT64: ">q", UINT64: ">Q", DOUBLE: ">d", COMPLEX: ">dd"}[kind]
        v = r.unpack(fmt, f"the body of {NAMES[kind]}")
        return UInt64(v[0]) if kind == UINT64 else complex(*v) if kind == COMPLEX else v[0]
    if kind in (PAIR, DICT):
        return _read_list(r, kind, depth)
    if kind in (VECTOR, TUPLE):
        n = r.count(NAMES[kind], 1)
        items = [_read(r, depth + 1) for _ in range(n)]
        return tuple(items) if kind == TUPLE else items
    if kind == UNIFORM:
        code, = r.unpack(">B", "a uniform vector's element type")
        if code >= len(UNIFORM_DTYPES):
            raise PmtError(f"unknown uniform vector element type 0x{code:02x} at byte {at + 1} (known: 0x00 .. 0x0b)")
        dtype = UNIFORM_DTYPES[code]
        n = r.count(f"{dtype.newbyteorder('=')} uniform vector", 0)
        pad, = r.unpack(">B", "a uniform vector's pad count")
        r.take(pad, "a uniform vector's padding")
        raw = r.take(n * dtype.itemsize, f"a {dtype.newbyteorder('=')} uniform vector of {n} elements")
        return np.frombuffer(raw, dtype).astype(dtype.newbyteorder("="))
    raise PmtError(f"unknown PMT type 0x{kind:02x} at byte {at} (known: 0x00 .. 0x0d)")


def _read_list(r: _Reader, kind: int, depth: int) -> Any:
    """A chain of pair (or dict) cells, read in a loop as pmt::deserialize does: car, then the cdr's type byte."""
    cars, chain = [], {PAIR} if kind == PAIR else {PAIR, DICT}
    while True:
        cars.append(_read(r, depth + 1))
        nxt, = r.unpack(">B", "a pair's cdr")
        if nxt in chain:
            continue
        r.pos -= 1
        tail = _read(r, depth + 1)
        break
    if kind == DICT:
        if tail is not None:
            raise PmtError(f"dict ends in {tail!r}, not PMT_NIL, at byte {r.pos}")
        try:
            return as_dict(_chain(cars, None))
        except TypeError:
            raise PmtError(f"dict before byte {r.pos} has a key no Python dict can hold (unhashable)") from None
    return _chain(cars, tail)


def _chain(cars: list, tail: Any) -> Any:
    for car in reversed(cars):
        tail = Pair(car, tail)
    return tail
