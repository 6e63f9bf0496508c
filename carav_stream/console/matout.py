"""MATLAB files as the commands write them (`--mat`, `carav export`): MATLAB v5, which MATLAB and Octave load.

What a value becomes (`to_matlab`; the small variables are written by scipy.io.savemat):

    dict                     struct, each key made a MATLAB name (`matlab_name`)
    list of numbers          column vector, double; of booleans: logical; of equal-length lists of numbers: matrix
    list of dicts            struct array (n x 1) when they have the same keys, else a cell array
    any other list           cell array (n x 1)
    number                   double (an integer a double cannot hold exactly: int64 or uint64)
    "nan", "inf", "-inf"     NaN, Inf, -Inf (how --json spells a non-finite number: console/jsonout.py)
    None                     [] (an empty double)
    numpy array              as it is (an object array: a cell array of its elements, each converted)

A key becomes a MATLAB name: every character other than an ASCII letter, digit or underscore becomes "_"; a name
that does not start with a letter, or is a MATLAB keyword, gets an "x" in front; it is cut to 63 characters
(MATLAB's namelengthmax); keys of one struct that would end up with the same name get "_2", "_3", ... in order.

A MATLAB v5 variable holds at most 2 GiB: `write` refuses a larger one (VariableTooLarge) before it writes a byte.
A large array (`Slabs`) is written slab by slab of its last axis, each slab a contiguous run of MATLAB's
column-major order, so memory stays near SLAB_BYTES whatever the array's size.
"""
from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from scipy.io import savemat

__all__ = ["MAX_VARIABLE_BYTES", "Slabs", "VariableTooLarge", "matlab_name", "matlab_names", "to_matlab", "write"]

MAX_VARIABLE_BYTES = 2 ** 31          # MATLAB's limit for one variable of a v5 (and v7) MAT-file
SLAB_BYTES = 64 * 2 ** 20
NAME_MAX = 63
KEYWORDS = frozenset("break case catch classdef continue else elseif end for function global if otherwise parfor "
                     "persistent return spmd switch try while".split())
NONFINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}
# numpy dtype of a real part -> (MATLAB class mx*, data type mi*) of the v5 format
CLASSES = {"int8": (8, 1), "uint8": (9, 2), "int16": (10, 3), "uint16": (11, 4), "int32": (12, 5),
           "uint32": (13, 6), "int64": (14, 12), "uint64": (15, 13), "float32": (7, 7), "float64": (6, 9)}
MI_INT8, MI_INT32, MI_UINT32, MI_MATRIX = 1, 5, 6, 14


class VariableTooLarge(ValueError):
    """A variable beyond MAX_VARIABLE_BYTES: `name`, its `nbytes` and the bytes of one row (first axis) of it."""

    def __init__(self, name: str, nbytes: int, row_bytes: int):
        self.name, self.nbytes, self.row_bytes = name, nbytes, row_bytes
        super().__init__(f"{name}: {nbytes / 2 ** 30:.2f} GiB, over the 2 GiB a MATLAB v5 variable holds")


class Slabs(Protocol):
    """An array written without being held whole: its shape and dtype, and `columns(k0, k1)`, the array's
    [..., k0:k1] (a slab of the last axis) as an ndarray of that dtype."""

    shape: tuple[int, ...]
    dtype: np.dtype

    def columns(self, k0: int, k1: int) -> np.ndarray: ...


def matlab_name(key: str) -> str:
    """A valid MATLAB identifier for `key` (the rule in the module's docstring, clashes aside)."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", str(key))
    if not name[:1].isalpha() or name in KEYWORDS:
        name = "x" + name
    return name[:NAME_MAX]


def matlab_names(keys) -> dict[Any, str]:
    """key -> its MATLAB name, the names unique among `keys` ("_2", "_3", ... in order)."""
    out: dict[Any, str] = {}
    taken: set[str] = set()
    for key in keys:
        base = name = matlab_name(key)
        n = 2
        while name in taken:
            suffix = f"_{n}"
            name, n = base[:NAME_MAX - len(suffix)] + suffix, n + 1
        taken.add(name)
        out[key] = name
    return out


def _is_number(v: Any) -> bool:
    return (isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))) or \
        (isinstance(v, str) and v in NONFINITE)


def _scalar(v: Any) -> Any:
    if isinstance(v, str):
        return NONFINITE.get(v, v)
    if isinstance(v, bool):
        return v
    if isinstance(v, int) and abs(v) > 2 ** 53:       # a double would round it
        return np.int64(v) if -2 ** 63 <= v < 2 ** 63 else np.uint64(v) if 0 <= v < 2 ** 64 else float(v)
    return float(v)


def _struct_array(structs: list[dict[str, Any]]) -> np.ndarray:
    names = list(structs[0])
    arr = np.empty((len(structs), 1), dtype=[(n, object) for n in names])
    for i, s in enumerate(structs):
        arr[i, 0] = tuple(s[n] for n in names)
    return arr


def _cells(items: list[Any]) -> np.ndarray:
    arr = np.empty((len(items), 1), dtype=object)
    for i, v in enumerate(items):
        arr[i, 0] = to_matlab(v)
    return arr


def _list(items: list[Any]) -> Any:
    if not items:
        return np.zeros((0, 0))
    if all(isinstance(v, (bool, np.bool_)) for v in items):
        return np.array(items, dtype=bool)
    if all(_is_number(v) for v in items):
        return np.array([float(NONFINITE.get(v, v)) if isinstance(v, str) else float(v) for v in items])
    if all(isinstance(v, (list, tuple)) and v and all(_is_number(x) for x in v) for v in items) \
            and len({len(v) for v in items}) == 1:
        return np.array([_list(list(v)) for v in items])
    if all(isinstance(v, dict) and v for v in items):
        structs = [to_matlab(v) for v in items]
        if all(list(s) == list(structs[0]) for s in structs):
            return _struct_array(structs)
    return _cells(items)


def to_matlab(obj: Any) -> Any:
    """obj (JSON-like: dicts, lists, numbers, strings, None; numpy arrays) as scipy.io.savemat writes it for MATLAB
    (the table in the module's docstring)."""
    if isinstance(obj, dict):
        names = matlab_names(obj)
        return {names[k]: to_matlab(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        if obj.dtype != object:
            return obj
        out = np.empty(obj.shape, dtype=object)
        for index in np.ndindex(obj.shape):
            out[index] = to_matlab(obj[index])
        return out
    if isinstance(obj, (list, tuple)):
        return _list(list(obj))
    if obj is None:
        return np.zeros((0, 0))
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, (str, bool, int, float)):
        return _scalar(obj)
    return str(obj)                     # a path, an enum: its text


def _tag(mi: int, nbytes: int) -> bytes:
    return np.array([mi, nbytes], dtype="=u4").tobytes()


def _padded(data: bytes) -> bytes:
    return data + b"\0" * (-len(data) % 8)


def _matrix_header(name: str, shape: tuple[int, ...], mx: int, complex_: bool) -> bytes:
    """Array flags, dimensions and name: the sub-elements of a v5 numeric matrix before its data."""
    flags = _tag(MI_UINT32, 8) + np.array([mx | (complex_ << 11), 0], dtype="=u4").tobytes()
    dims = _tag(MI_INT32, 4 * len(shape)) + _padded(np.array(shape, dtype="=i4").tobytes())
    text = name.encode("ascii")
    label = (np.array([len(text) << 16 | MI_INT8], dtype="=u4").tobytes() + text.ljust(4, b"\0")
             if len(text) <= 4 else _tag(MI_INT8, len(text)) + _padded(text))
    return flags + dims + label


def _part_dtype(dtype: np.dtype) -> np.dtype:
    return np.dtype(np.float32 if dtype == np.complex64 else np.float64) if dtype.kind == "c" else dtype


def data_bytes(src: Slabs) -> int:
    """What the array's data takes in a MAT file (both parts of a complex one)."""
    dtype = np.dtype(src.dtype)
    return math.prod(src.shape) * dtype.itemsize


def _write_slabs(f, name: str, src: Slabs, progress: Callable[[int, int], None] | None) -> None:
    """Append `src` to the open MAT file f as one numeric matrix, its real (and imaginary) part written a slab of
    the last axis at a time at its place in column-major order."""
    dtype = np.dtype(src.dtype)
    complex_, part = dtype.kind == "c", _part_dtype(dtype).newbyteorder("=")
    mx, mi = CLASSES[part.name]
    shape = tuple(int(n) for n in src.shape)
    if len(shape) < 2:
        raise ValueError(f"{name}: a MATLAB array has at least 2 dimensions, got shape {shape}")
    n_part = math.prod(shape) * part.itemsize
    header = _matrix_header(name, shape, mx, complex_)
    span = 8 + n_part + (-n_part % 8)           # one part: its tag, its data, padded to 8 bytes
    f.write(_tag(MI_MATRIX, len(header) + span * (1 + complex_)) + header)
    parts = [f.tell() + 8 + i * span for i in range(1 + complex_)]          # where each part's data starts
    end = parts[-1] - 8 + span
    f.truncate(end)                              # zero-filled: the padding, and a place for every slab
    for at in parts:
        f.seek(at - 8)
        f.write(_tag(mi, n_part))
    row = math.prod(shape[:-1]) * part.itemsize  # bytes of one index of the last axis
    width = max(1, SLAB_BYTES // max(1, row * (1 + complex_)))
    total_mib = max(1, -(-n_part * (1 + complex_) // 2 ** 20))
    for k0 in range(0, shape[-1], width):
        k1 = min(shape[-1], k0 + width)
        block = np.asarray(src.columns(k0, k1))
        pieces = (block.real, block.imag) if complex_ else (block,)
        for at, piece in zip(parts, pieces):
            f.seek(at + k0 * row)
            f.write(np.asarray(piece, dtype=part).tobytes(order="F"))
        if progress:
            progress(total_mib if k1 == shape[-1] else k1 * row * (1 + complex_) // 2 ** 20, total_mib)
    f.seek(end)


def write(path: str | Path, variables: dict[str, Any], slabs: dict[str, Slabs] | None = None, *,
          private: bool = False, progress: Callable[[int, int], None] | None = None) -> None:
    """Write a MAT file: `variables` (name: value, converted by to_matlab, written by scipy), then each of `slabs`
    (name: an array read slab by slab; progress(MiB done, MiB in all) as they go). Names must be MATLAB names.
    VariableTooLarge before anything is written if a slab array exceeds MAX_VARIABLE_BYTES. The file is written
    beside `path` under a temporary name and renamed, so a failed export leaves no partial file; `private`: mode
    0600 (its owner alone), for a file that holds the activation sequence."""
    path, slabs = Path(path), slabs or {}
    for name in (*variables, *slabs):
        if matlab_name(name) != name:
            raise ValueError(f"{name!r} is not a MATLAB variable name")
    for name, src in slabs.items():
        if data_bytes(src) > MAX_VARIABLE_BYTES:
            raise VariableTooLarge(name, data_bytes(src), data_bytes(src) // max(1, src.shape[0]))
    tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
    fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o600 if private else 0o666)
    try:
        with os.fdopen(fd, "w+b") as f:
            savemat(f, {n: to_matlab(v) for n, v in variables.items()}, long_field_names=True, oned_as="column")
            for name, src in slabs.items():
                _write_slabs(f, name, src, progress)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
