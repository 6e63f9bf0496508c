"""A toy data plane, for the tests only: each output port appends its frames' buffers to a file of its own in the
run folder, the header carries [offset, length] of the frame in it, and every consumer reads its copy back with
pread. Nothing is ever reused, so nothing is given back and a restart needs nothing: the file grows with the run
and goes with the run folder.

It is found as a plane module of a folder named in CARAV_PLANE_PATH (runtime/planes/) and chosen with
`[run] transport = "toy"`; no other file of the project names it.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Collection
from typing import Any

from carav_stream.runtime.planes import Plane, PortResources, Reader, Writer


class ToyPlane(Plane):
    def open_port(self, port: str, edges: list[str]) -> PortResources | None:
        path = self.run_dir / f"toy-{port}"
        path.touch(mode=0o600)              # there before any node opens it
        return PortResources(str(path), [str(path)] * len(edges))

    @classmethod
    def writer(cls, resources: Any, taps: Collection[str]) -> Writer:
        return ToyWriter(resources)

    @classmethod
    def reader(cls, resources: Any) -> Reader:
        return ToyReader(resources)


class ToyWriter(Writer):
    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_WRONLY | os.O_APPEND)
        self.frames = self.bytes = 0

    def place(self, buffers: list[Any], cut: Collection[str], idle: Callable[[], None]) -> list[Any] | None:
        data = memoryview(b"".join(buffers))
        offset = os.fstat(self.fd).st_size       # the port's one writer appends: where this frame begins
        done = 0
        while done < len(data):
            done += os.write(self.fd, data[done:])
        self.frames += 1
        self.bytes += len(data)
        return [offset, len(data)]

    def counters(self) -> dict[str, Any]:
        return {"frames": self.frames, "bytes": self.bytes}

    def close(self) -> None:
        os.close(self.fd)


class ToyReader(Reader):
    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDONLY)

    def resolve(self, ref: Any, sizes: list[int]) -> list[Any]:
        if not (type(ref) is list and len(ref) == 2 and all(type(v) is int and v >= 0 for v in ref)):
            raise ValueError(f"toy plane: a reference must be [offset, length], got {ref!r}")
        offset, length = ref
        if length != sum(sizes):
            raise ValueError(f"toy plane: the header's arrays need {sum(sizes)} bytes, the reference names {length}")
        data = os.pread(self.fd, length, offset)
        if len(data) != length:
            raise ValueError(f"toy plane: {length} bytes at {offset} go beyond the port's file")
        starts = [sum(sizes[:i]) for i in range(len(sizes))]
        return [memoryview(data[start:start + n]) for start, n in zip(starts, sizes)]   # each its own copy

    def close(self) -> None:
        os.close(self.fd)
