"""The shared-memory plane (`[run] transport = "shm"`): the arrays of same-host edges are written once into a slot
of the producer's segment and read in place by every consumer; ZeroMQ carries the header alone, whose "shm" names
the slot as [slot, generation]. The segments, their slots and their rules are runtime/shm.py's; this module is
what the runtime sees of them.

Resources of an output port: the producer gets {fd, edges} (its segment and the port's edges in the segment's
order), each consumer [fd, edge index]; both inherit the segment's file descriptor, and the supervisor closes its
own when the run ends. A port with more edges than a segment can track goes inline.

Restarts: the resume marker a producer sends a restarted consumer carries `shm_gen`, the last generation issued
before it (a frame still being delivered excepted: it follows the marker on the fresh connection); on it the
consumer gives back what its dead incarnation held and refuses older slots (runtime/shm.py).
"""
from __future__ import annotations

import os
from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from carav_stream.runtime import shm, transport
from carav_stream.runtime.planes import Plane, PortResources, Reader, Writer

SLOTS_PER_QUEUED_FRAME = 6       # slots of a segment: ZeroMQ's queues, pairing and the frames in hand
SPARE_SLOTS = 4


class ShmPlane(Plane):
    header_only = True

    def __init__(self, run: Mapping[str, Any], run_dir: Path) -> None:
        super().__init__(run, run_dir)
        self.n_slots = min(shm.MAX_SLOTS, SLOTS_PER_QUEUED_FRAME * int(run["queue_frames"]) + SPARE_SLOTS)
        self.fds: list[int] = []

    def open_port(self, port: str, edges: list[str]) -> PortResources | None:
        if len(edges) > shm.MAX_EDGES:
            return None
        fd = shm.create_segment(self.n_slots, len(edges), f"carav-{port}")
        self.fds.append(fd)
        return PortResources({"fd": fd, "edges": list(edges)}, [[fd, i] for i in range(len(edges))], (fd,))

    def close(self) -> None:
        for fd in self.fds:             # the kernel frees a segment when its last holder closes it
            os.close(fd)
        self.fds.clear()

    @classmethod
    def writer(cls, resources: Any, taps: Collection[str]) -> ShmWriter:
        return ShmWriter(shm.SlotWriter(resources["fd"], resources["edges"], taps))

    @classmethod
    def reader(cls, resources: Any) -> ShmReader:
        fd, edge = resources
        return ShmReader(shm.SlotReader(fd, edge))


class ShmWriter(Writer):
    """A producer's port over its segment: a frame waits up to a tick for a free slot (serving control), then
    goes inline."""

    waits_for = "a free shared-memory slot"

    def __init__(self, slots: shm.SlotWriter) -> None:
        self.slots = slots
        self.delivering = False         # a frame placed in a slot is being delivered

    @property
    def waiting(self) -> bool:
        return self.slots.waiting

    def place(self, buffers: list[Any], cut: Collection[str], idle: Callable[[], None]) -> list[Any] | None:
        ref = self.slots.place(buffers, self.slots.mask(cut) if cut else 0, transport.TICK_S, idle)
        self.delivering = ref is not None
        return ref

    def delivered(self, ref: list[Any] | None, missed: Sequence[str]) -> None:
        self.delivering = False
        if ref is not None and missed:
            self.slots.unsend(ref, missed)

    def reserve(self, shape: tuple[int, ...], dtype: Any, cut: Collection[str],
                idle: Callable[[], None]) -> np.ndarray | None:
        return self.slots.reserve(shape, dtype, self.slots.mask(cut) if cut else 0, transport.TICK_S, idle)

    def resume_fields(self) -> dict[str, Any]:
        # what the consumer may give back: every generation issued before, except a frame this node is still
        # delivering (it goes on the fresh connection after the marker)
        return {"shm_gen": self.slots.generation - self.delivering}

    def counters(self) -> dict[str, Any]:
        return self.slots.counters()

    def close(self) -> None:
        self.slots.close()


class ShmReader(Reader):
    """A consumer's input over its producer's segment: a frame's arrays are read-only views of its slot, each at a
    64-byte boundary, in the header's order."""

    def __init__(self, slots: shm.SlotReader) -> None:
        self.slots = slots

    def resolve(self, ref: Any, sizes: list[int]) -> list[memoryview]:
        starts, total = shm.offsets(sizes)
        try:
            block = self.slots.resolve(ref, total)
        except ValueError as exc:
            raise ValueError(f"shared memory: {exc}") from None
        return [block[start:start + n] for start, n in zip(starts, sizes)]

    def resume(self, header: Mapping[str, Any]) -> None:
        gen = header.get("shm_gen")
        if type(gen) is int:
            self.slots.resume(gen)

    def close(self) -> None:
        self.slots.close()
