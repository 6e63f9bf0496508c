"""The shared-memory data plane: a producer's output port writes each frame's arrays once into a slot of a
segment, and ZeroMQ carries only the header, which names the slot; every consumer on the host reads the arrays in
place, as read-only numpy views, and gives the slot back when the last view of it is gone.

Segments are anonymous memory files (memfd_create): the supervisor creates one per output port whose edges all
stay on its host, and hands it to the producer and to every consumer as an inherited file descriptor. They have
no name anywhere (nothing in /dev/shm to guess, open or leave behind) and the kernel frees them when the last
process holding them exits, SIGKILL of the supervisor included (its nodes die with it).

Layout (little-endian int64 unless said)::

    0        magic, version, n_slots, n_edges, stride (0 until the producer's first frame), last generation
    4096     issued[n_slots]             generation of the frame in each slot (producer writes)
             sent[n_slots]               bitmask of the edges the frame went to (producer writes)
             released[n_slots, n_edges]  the generation each edge's consumer gave back (that consumer writes)
    DATA     n_slots slots of `stride` bytes; a frame's arrays in order, each at a 64-byte boundary

Every field has one writer, so no atomic operation is needed: the producer writes a frame's bytes, then its
generation, then sends the header; a consumer checks the generation on arrival (a header that names a slot outside
the segment, more bytes than a slot holds or a generation the slot no longer has is refused) and writes the slot's
`released` cell once the last numpy view of the frame is gone (weakref.finalize on the one array all views
derive from). The producer reuses a slot only when every edge it went to gave it back (edges whose consumer died
for good excepted), choosing the lowest free slot so that only as many slots are touched as frames are in flight.
With every slot taken the producer waits for one, as it waits for room in a full queue (the slots bound how far
it runs ahead: header-only messages would otherwise queue by the hundred in the kernel's socket buffers); after a
short wait (consumers holding frames), or for a frame larger than a slot, the frame goes inline over ZeroMQ as on
any edge: nothing deadlocks on memory, nothing is lost, and the segment's memory stays at most n_slots x stride.

Restarts: generations never repeat (the counter lives in the segment, so a restarted producer continues it). A
restarted consumer cannot give back what its dead incarnation held: the producer's resume marker carries the
last generation issued before it, and on it the consumer gives back every older slot sent to its edge that it does
not hold itself, and refuses any older frame still arriving from the old connection (stale generation). A producer
killed between writing a slot and sending its header leaves that one slot taken; it is counted in `held`.
"""
from __future__ import annotations

import mmap
import os
import threading
import time
import weakref
from collections.abc import Callable, Collection, Sequence
from typing import Any

import numpy as np

MAGIC = 0x4D48535641524143           # "CARAVSHM" little-endian
VERSION = 1
CONTROL_OFFSET = 4096
MAX_SLOTS = 256
MAX_EDGES = 64                       # edges of one output port: bits of `sent`
ALIGN = 64                           # every array starts on a cache line
STRIDE_QUANTUM = 1 << 16             # slot size: the first frame's bytes rounded up to this
MIN_FRAME_BYTES = 1 << 15            # smaller frames go inline: a slot costs more than a socket copy of this


class SlotError(ValueError):
    """A header whose slot reference cannot be honoured; the text says why."""


def data_offset(n_slots: int, n_edges: int) -> int:
    control = CONTROL_OFFSET + 8 * n_slots * (2 + n_edges)
    return -(-control // mmap.PAGESIZE) * mmap.PAGESIZE


def create_segment(n_slots: int, n_edges: int, name: str = "carav") -> int:
    """A new segment for an output port with `n_edges` consumers on this host: its file descriptor (close-on-exec;
    pass it to a child with Popen(pass_fds=...))."""
    if not 1 <= n_slots <= MAX_SLOTS or not 1 <= n_edges <= MAX_EDGES:
        raise ValueError(f"segment: 1..{MAX_SLOTS} slots and 1..{MAX_EDGES} edges, got {n_slots} and {n_edges}")
    fd = os.memfd_create(name, os.MFD_CLOEXEC)
    os.ftruncate(fd, data_offset(n_slots, n_edges))
    with mmap.mmap(fd, CONTROL_OFFSET) as m:
        np.frombuffer(m, np.int64, 6)[:] = (MAGIC, VERSION, n_slots, n_edges, 0, 0)
    return fd


def offsets(nbytes: Sequence[int]) -> tuple[list[int], int]:
    """Where each array of a frame starts in its slot, and the bytes the frame needs."""
    out, end = [], 0
    for n in nbytes:
        out.append(end)
        end += -(-n // ALIGN) * ALIGN
    return out, end


class _Segment:
    """The control fields of one segment, mapped read-write, and its data, mapped on the first frame."""

    def __init__(self, fd: int, writable_data: bool) -> None:
        self.fd = fd
        self.writable_data = writable_data
        head = mmap.mmap(fd, CONTROL_OFFSET)
        magic, version, n_slots, n_edges = (int(v) for v in np.frombuffer(head, np.int64, 4))
        head.close()
        if magic != MAGIC or version != VERSION:
            raise ValueError(f"file descriptor {fd} is not a carav segment (version {VERSION})")
        self.n_slots, self.n_edges = n_slots, n_edges
        self.data0 = data_offset(n_slots, n_edges)
        self.control = mmap.mmap(fd, self.data0)
        fields = np.frombuffer(self.control, np.int64)
        self.head = fields[:6]
        base = CONTROL_OFFSET // 8
        self.issued = fields[base:base + n_slots]
        self.sent = fields[base + n_slots:base + 2 * n_slots].view(np.uint64)
        self.released = fields[base + 2 * n_slots:base + n_slots * (2 + n_edges)].reshape(n_slots, n_edges)
        self.data: mmap.mmap | None = None
        self.stride = 0

    def map_data(self) -> bool:
        """Map the slots once the producer has laid them out; False while it has not."""
        if self.data is None:
            stride = int(self.head[4])
            if not stride:
                return False
            prot = mmap.PROT_READ | (mmap.PROT_WRITE if self.writable_data else 0)
            self.data = mmap.mmap(self.fd, self.n_slots * stride, prot=prot, offset=self.data0)
            self.stride = stride
        return True

    def close(self) -> None:
        self.issued = self.sent = self.released = self.head = None
        for m in (self.data, self.control):
            if m is not None:
                try:
                    m.close()
                except BufferError:     # views still alive somewhere: the mapping goes with the process
                    pass


class SlotWriter:
    """The producer's end of one output port's segment. `edges`: the port's edge names, in the segment's edge
    order."""

    def __init__(self, fd: int, edges: Sequence[str], taps: Collection[str] = ()) -> None:
        self.seg = _Segment(fd, writable_data=True)
        if len(edges) != self.seg.n_edges:
            raise ValueError(f"segment has {self.seg.n_edges} edges, the port {len(edges)}")
        self.bit = {e: 1 << i for i, e in enumerate(edges)}
        self.all_edges = (1 << len(edges)) - 1
        self.bits = np.left_shift(np.uint64(1), np.arange(len(edges), dtype=np.uint64))
        self.taps = self.mask(taps)      # edges to observers that must never slow the port (block.In.tap)
        self.reserved: set[int] = set()   # slots handed to the block (reserve) and not yet issued or dropped
        self.touched = 0          # slots ever written by this process (the lowest first): memory in use
        self.c_slots = 0          # frames placed in a slot
        self.c_inline = 0         # frames sent inline: too small, too large or no slot free
        self.c_full = 0           # ... of which for want of a free slot
        self.c_in_place = 0       # frames whose payload the block computed in its slot (reserve)
        self.base = 0             # address of slot 0 in this process
        self.waiting = False      # waiting for a free slot (diagnostics)

    def place(self, buffers: list[Any], ignore: int = 0, wait_s: float = 0.0,
              idle: Callable[[], None] | None = None) -> list[int] | None:
        """Copy a frame's buffers into a free slot and issue it (a payload the block computed in a slot from
        reserve() stays where it is): the reference [slot, generation] for the header, or None to send the
        frame inline. `ignore`: bitmask of edges whose consumer is gone for good;
        with every slot taken, wait up to `wait_s` for one (calling `idle` meanwhile) before going inline."""
        views = [memoryview(b).cast("B") for b in buffers]
        starts, total = offsets([v.nbytes for v in views])
        written = self.reserved_slot_of(views[0]) if self.reserved and views else None
        self.reserved.clear()                # what the block did not return is free again
        if total >= MIN_FRAME_BYTES:
            self.lay_out(total)
        if total < MIN_FRAME_BYTES or total > self.seg.stride:
            self.c_inline += 1
            self.detach(buffers, views)
            return None
        seg = self.seg
        slot = written if written is not None else self.slot(ignore, wait_s, idle)
        if slot is None:
            self.c_inline += 1
            self.c_full += 1
            self.detach(buffers, views)
            return None
        dst = np.frombuffer(seg.data, np.uint8, total, slot * seg.stride)
        for i, (start, v) in enumerate(zip(starts, views)):
            if i or written is None:         # the payload computed in its slot is there already
                dst[start:start + v.nbytes] = np.frombuffer(v, np.uint8)
        gen = int(seg.head[5]) + 1
        seg.head[5] = gen
        seg.sent[slot] = self.all_edges
        seg.issued[slot] = gen       # last: a consumer that sees this generation sees the bytes
        self.touched = max(self.touched, slot + 1)
        self.c_slots += 1
        self.c_in_place += written is not None
        return [slot, gen]

    def lay_out(self, nbytes: int) -> None:
        """Size the slots for frames of `nbytes` on the first frame (one quantum spare for the arrays beside a
        payload computed in place), and map them."""
        seg = self.seg
        if not seg.stride:
            if not seg.head[4]:        # else laid out by an earlier incarnation of this node
                stride = (-(-nbytes // STRIDE_QUANTUM) + 1) * STRIDE_QUANTUM
                os.ftruncate(seg.fd, seg.data0 + seg.n_slots * stride)
                seg.head[4] = stride
            seg.map_data()
            self.base = np.frombuffer(seg.data, np.uint8).ctypes.data

    def reserve(self, shape: tuple[int, ...], dtype: np.dtype, ignore: int = 0, wait_s: float = 0.0,
                idle: Callable[[], None] | None = None) -> np.ndarray | None:
        """A writable array at the start of a free slot for the block to compute its payload into (then place()
        sends it without a copy), or None (too small, larger than a slot, no slot free)."""
        nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        if nbytes < MIN_FRAME_BYTES:
            return None
        self.lay_out(nbytes)
        if nbytes > self.seg.stride:
            return None
        slot = self.slot(ignore, wait_s, idle)
        if slot is None:
            return None
        self.reserved.add(slot)
        return np.frombuffer(self.seg.data, np.uint8, nbytes, slot * self.seg.stride).view(dtype).reshape(shape)

    def reserved_slot_of(self, view: memoryview) -> int | None:
        """The reserved slot whose start `view` (a frame's payload) is, if any."""
        offset = np.frombuffer(view, np.uint8).ctypes.data - self.base if view.nbytes else -1
        slot, rest = divmod(offset, self.seg.stride)
        return slot if rest == 0 and slot in self.reserved else None

    def detach(self, buffers: list[Any], views: list[memoryview]) -> None:
        """A frame going inline must not reference this segment's slots: ZeroMQ sends its buffers later, when the
        slot may be written again. Copy any such buffer (a payload computed in place that did not fit)."""
        if not self.seg.stride:
            return
        lo, hi = self.base, self.base + self.seg.n_slots * self.seg.stride
        for i, v in enumerate(views):
            if v.nbytes and lo <= np.frombuffer(v, np.uint8).ctypes.data < hi:
                buffers[i] = bytes(v)

    def slot(self, ignore: int, wait_s: float, idle: Callable[[], None] | None) -> int | None:
        """The lowest free slot, waiting up to `wait_s` for one (calling `idle` meanwhile); none at once when
        only taps hold the slots (a tap never slows its producer: the frame goes inline instead)."""
        slot = self.free_slot(ignore)
        if slot is None and self.taps and self.free_slot(ignore | self.taps) is not None:
            return None
        if slot is None and wait_s > 0:      # back-pressure: consumers give slots back as they finish frames
            deadline = time.monotonic() + wait_s
            pause = 5e-5
            self.waiting = True
            try:
                while slot is None and time.monotonic() < deadline:
                    if idle is not None:
                        idle()
                    time.sleep(pause)
                    pause = min(2 * pause, 1e-3)
                    slot = self.free_slot(ignore)
            finally:
                self.waiting = False
        return slot

    def held(self, ignore: int = 0) -> np.ndarray:
        """bool (slots,): a frame in the slot not given back yet by an edge it went to (edges in `ignore` aside)."""
        seg = self.seg
        waiting = seg.released < seg.issued[:, None]                  # (slots, edges): not given back yet
        sent = (seg.sent[:, None] & self.bits) != 0
        return np.any(waiting & sent & ((self.bits & np.uint64(ignore)) == 0), axis=1)

    def free_slot(self, ignore: int) -> int | None:
        """The lowest slot neither held nor reserved, or None."""
        busy = self.held(ignore)
        if self.reserved:
            busy[list(self.reserved)] = True
        free = np.flatnonzero(~busy)
        return int(free[0]) if free.size else None

    def unsend(self, ref: list[int], edges: Sequence[str]) -> None:
        """The frame in slot ref[0] did not go to `edges` (a tap with no room, a cut edge): they owe nothing."""
        self.seg.sent[ref[0]] = np.uint64(int(self.seg.sent[ref[0]]) & ~self.mask(edges))

    def mask(self, edges: Collection[str]) -> int:
        """The bitmask of these edges of the port (others ignored)."""
        m = 0
        for e in edges:
            m |= self.bit.get(e, 0)
        return m

    @property
    def generation(self) -> int:
        return int(self.seg.head[5])

    def counters(self) -> dict[str, int]:
        seg = self.seg
        return {"segment_bytes": self.touched * seg.stride, "slots": seg.n_slots, "stride": seg.stride,
                "frames_in_slots": self.c_slots, "computed_in_place": self.c_in_place,
                "frames_inline": self.c_inline, "no_free_slot": self.c_full, "held": int(self.held().sum())}

    def close(self) -> None:
        self.seg.close()


class SlotReader:
    """A consumer's end of its producer's segment: edge `edge` of it."""

    def __init__(self, fd: int, edge: int) -> None:
        self.seg = _Segment(fd, writable_data=False)
        if not 0 <= edge < self.seg.n_edges:
            raise ValueError(f"edge {edge} outside the segment's {self.seg.n_edges}")
        self.edge = edge
        self.floor = 0                    # generations up to this came before a resume marker: stale
        self.live: dict[int, int] = {}    # slot -> generation of the frame this process holds views of
        self.lock = threading.Lock()      # releases may come from ZeroMQ's thread (frames forwarded inline)

    def resolve(self, ref: Any, total: int) -> memoryview:
        """The read-only bytes of the frame `ref` = [slot, generation] names, `total` long; they stay valid (the
        slot is not reused) until every array built from them is gone."""
        if not (type(ref) is list and len(ref) == 2 and type(ref[0]) is int and type(ref[1]) is int):
            raise SlotError(f"shared-memory reference must be [slot, generation], got {ref!r}")
        slot, gen = ref
        seg = self.seg
        if not 0 <= slot < seg.n_slots:
            raise SlotError(f"slot {slot} is outside the segment's {seg.n_slots} slots")
        if not seg.map_data():
            raise SlotError(f"slot {slot}: the producer has not laid out its segment")
        if total > seg.stride:
            raise SlotError(f"slot {slot}: the header's arrays need {total} bytes, a slot holds {seg.stride}")
        if gen <= self.floor or int(seg.issued[slot]) != gen:
            raise SlotError(f"slot {slot}: stale generation {gen} (the slot holds {int(seg.issued[slot])}"
                            + (f", and generations up to {self.floor} came before a resume marker)"
                               if gen <= self.floor else ")"))
        anchor = np.frombuffer(seg.data, np.uint8, total, slot * seg.stride)
        with self.lock:
            self.live[slot] = gen
        weakref.finalize(anchor, self._release, slot, gen)
        return memoryview(anchor)

    def _release(self, slot: int, gen: int) -> None:
        with self.lock:
            if self.live.get(slot) == gen:
                del self.live[slot]
            cells = self.seg.released
            if cells is not None and cells[slot, self.edge] < gen:
                cells[slot, self.edge] = gen

    def resume(self, generation: int) -> None:
        """The producer connected afresh (this process, or its consumer, was restarted) and issued nothing after
        `generation` before: give back every slot up to it that this process does not hold, refuse older frames."""
        seg = self.seg
        bit = np.uint64(1 << self.edge)
        with self.lock:
            self.floor = max(self.floor, generation)
            for slot in range(seg.n_slots):
                gen = int(seg.issued[slot])
                if (0 < gen <= generation and seg.released[slot, self.edge] < gen and seg.sent[slot] & bit
                        and slot not in self.live):
                    seg.released[slot, self.edge] = gen

    def close(self) -> None:
        self.seg.close()
