"""The DCA1000's live raw-data stream over UDP: cycles reassembled from packets, damaged ones named; and a
packet replayer of our own, over loopback only, to test and measure the receiver.

TI's DCA1000 user guide, raw mode: the card sends the LVDS data as UDP datagrams to the host's data port (4098
by default), each

    sequence number   4 bytes, little endian, 1 for the first packet, +1 per packet
    byte count        6 bytes, little endian: bytes of the stream sent before this packet's data
    data              up to 1456 bytes of the capture's words (the .bin file's bytes, in order)

The byte counts place every packet in the stream, and a cycle is bytes [c B, (c + 1) B) of it (B the layout's
bytes per cycle; cycle 0 starts the capture: a receiver that joins late starts at the next whole cycle). The
Reassembler fails closed: every cycle touched by a packet that is

    lost        a jump in the sequence number; the bytes between the last packet and the next are missing
    truncated   a gap in the byte count after a packet that was cut short (no sequence jump, or it carried
                fewer bytes than the stream's packets): all its bytes are doubted; or a datagram shorter than
                its 10-byte header (found as a lost packet)
    duplicated  a sequence number already received
    reordered   a sequence number below the highest received, never received before
    overlapping a byte count that reaches back into bytes already written
    incomplete  the last cycle, when the sender stops within it

is damaged: its samples are not trusted (missing bytes are zeros; a late packet is never written in), it is
released with its reasons, and everything is counted. Pure logic, no socket: testable datagram by datagram.

UdpReceiver binds the socket and feeds a Reassembler from a thread of its own (the kernel's receive buffer then
only has to cover the thread's pauses, not the consumer's); Replayer sends a capture's packets to 127.0.0.1 at a
given rate, with faults, and refuses any other address (it is a test instrument, not a radar).

Cost: a packet is a slice copy into the cycle buffer and a few integer checks, about 2 to 5 us of Python; the
receiver's rate is measured by `python3 dev.py bench dca1000-udp` (docs/CAPTURE.md).
"""
from __future__ import annotations

import ipaddress
import socket
import threading
import time
from collections import Counter
from dataclasses import dataclass, field

DATA_PORT = 4098
HEADER_BYTES = 10
MAX_PAYLOAD = 1456
REASONS = ("lost", "truncated", "duplicated", "reordered", "overlapping", "incomplete")


def header(seq: int, byte_count: int) -> bytes:
    return seq.to_bytes(4, "little") + byte_count.to_bytes(6, "little")


def packetize(stream: bytes, payload: int = MAX_PAYLOAD, first_seq: int = 1) -> list[bytes]:
    """A capture's bytes as the DCA1000 sends them: datagrams of up to `payload` data bytes after the header."""
    return [header(first_seq + i, off) + stream[off:off + payload]
            for i, off in enumerate(range(0, len(stream), payload))]


@dataclass
class Released:
    """Consecutive cycles out of the reassembler: their bytes and, per cycle, the reasons it is damaged."""

    first_cycle: int
    data: bytes
    damage: list[tuple[str, ...]]


@dataclass
class Reassembler:
    bytes_per_cycle: int
    counts: Counter = field(default_factory=Counter)

    def __post_init__(self) -> None:
        self.buf = bytearray()
        self.base = 0               # stream offset of buf[0]: the start of the oldest cycle not yet released
        self.next_cycle = 0         # index of that cycle
        self.expected = None        # stream offset after the last in-order packet (None: nothing received yet)
        self.max_seq = 0
        self.seen: set[int] = set()
        self.damage: dict[int, set[str]] = {}
        self.last = (0, 0)          # (byte count, data bytes) of the last in-order packet
        self.widest = 0             # the most data bytes a packet has carried: the stream's packet size

    def _mark(self, start: int, stop: int, reason: str) -> None:
        if stop <= start:
            return
        for cycle in range(start // self.bytes_per_cycle, (stop - 1) // self.bytes_per_cycle + 1):
            if cycle >= self.next_cycle:
                self.damage.setdefault(cycle, set()).add(reason)
            else:
                self.counts["late"] += 1          # its cycle was released already; never written in

    def feed(self, datagram: bytes) -> None:
        self.counts["packets"] += 1
        if len(datagram) < HEADER_BYTES:
            self.counts["truncated"] += 1         # not placed: the next packet's byte count shows the gap
            return
        seq = int.from_bytes(datagram[:4], "little")
        off = int.from_bytes(datagram[4:HEADER_BYTES], "little")
        payload = memoryview(datagram)[HEADER_BYTES:]
        end = off + len(payload)
        if self.expected is None:                 # the first packet: start at the first whole cycle
            self.next_cycle = -(-off // self.bytes_per_cycle)
            self.base = self.next_cycle * self.bytes_per_cycle
            self.counts["skipped_bytes"] += self.base   # the stream before the first whole cycle received
            self.expected, self.max_seq = off, seq - 1
        if seq <= self.max_seq:
            reason = "duplicated" if seq in self.seen else "reordered"
            self.counts[reason] += 1
            self._mark(max(off, self.base), end, reason)
            self.seen.add(seq)
            return
        if seq > self.max_seq + 1:
            self.counts["lost"] += seq - self.max_seq - 1
        if off > self.expected:
            jump = seq > self.max_seq + 1
            if not jump or self.last[1] < self.widest:   # the last packet was cut: its own bytes are doubted too
                self.counts["truncated"] += 1
                self._mark(max(self.last[0], self.base), off, "truncated")
            if jump:
                self._mark(max(self.expected, self.base), off, "lost")
        elif off < self.expected:
            self.counts["overlapping"] += 1
            self._mark(max(off, self.base), min(self.expected, end), "overlapping")
        self.max_seq = seq
        self.last, self.widest = (off, len(payload)), max(self.widest, len(payload))
        self.seen.add(seq)
        if len(self.seen) > 8192:                 # a duplicate older than 4096 packets counts as reordered
            self.seen = {s for s in self.seen if s > seq - 4096}
        self.counts["bytes"] += len(payload)
        if end > self.base:
            start = max(off, self.base)
            if end - self.base > len(self.buf):
                self.buf.extend(bytes(end - self.base - len(self.buf)))
            self.buf[start - self.base:end - self.base] = payload[start - off:]
        self.expected = max(self.expected, end)

    def complete(self) -> int:
        """Whole cycles ready to release."""
        return 0 if self.expected is None else max(self.expected - self.base, 0) // self.bytes_per_cycle

    def take(self, max_cycles: int) -> Released | None:
        n = min(self.complete(), max_cycles)
        if n == 0:
            return None
        size = n * self.bytes_per_cycle
        data = bytes(self.buf[:size])
        del self.buf[:size]
        first = self.next_cycle
        self.base += size
        self.next_cycle += n
        damage = [tuple(sorted(self.damage.pop(c, ()))) for c in range(first, first + n)]
        self.counts["cycles"] += n
        self.counts["damaged_cycles"] += sum(1 for d in damage if d)
        return Released(first, data, damage)

    def flush(self) -> Released | None:
        """At the end of the stream: the cycle the sender stopped within, zero-padded and damaged (incomplete)."""
        if self.expected is None or self.expected <= self.base:
            return None
        self.buf.extend(bytes(self.bytes_per_cycle - len(self.buf)))
        self.damage.setdefault(self.next_cycle, set()).add("incomplete")
        self.counts["incomplete"] += 1
        self.expected = self.base + self.bytes_per_cycle
        return self.take(1)


class UdpReceiver:
    """A bound UDP socket feeding a Reassembler from its own thread; take() waits for whole cycles."""

    def __init__(self, address: str, port: int, reassembler: Reassembler, rcvbuf_bytes: int = 8 << 20) -> None:
        self.reassembler = reassembler
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf_bytes)
        self.sock.bind((address, port))
        self.sock.settimeout(0.05)
        self.address = self.sock.getsockname()
        self.cond = threading.Condition()
        self.last_packet = time.monotonic()
        self.running = True
        self.stopped = False
        self.thread = threading.Thread(target=self._receive, name="dca1000-udp", daemon=True)
        self.thread.start()

    def _receive(self) -> None:
        scratch = bytearray(65536)
        view = memoryview(scratch)
        while self.running:
            try:
                n = self.sock.recv_into(scratch)
            except TimeoutError:
                continue
            except OSError:
                break
            with self.cond:
                before = self.reassembler.complete()
                self.reassembler.feed(bytes(view[:n]))
                self.last_packet = time.monotonic()
                if self.reassembler.complete() > before:
                    self.cond.notify()

    def take(self, max_cycles: int, want: int, idle_timeout_s: float) -> Released | None:
        """Up to max_cycles whole cycles once `want` are ready; fewer if the sender falls silent for idle_timeout_s,
        then the cycle it stopped within (damaged); None once nothing is left after it stopped."""
        with self.cond:
            while self.reassembler.complete() < want and not self.stopped:
                if time.monotonic() - self.last_packet >= idle_timeout_s:
                    self.stopped = True
                    break
                self.cond.wait(0.05)
            got = self.reassembler.take(max_cycles)
            if got is None and self.stopped:
                return self.reassembler.flush()
            return got

    def close(self) -> None:
        self.running = False
        self.thread.join(1.0)
        self.sock.close()


def loopback(address: str) -> str:
    """The address, if it is a loopback one; ValueError otherwise (the replayer sends to this host only)."""
    try:
        if ipaddress.ip_address(address).is_loopback:
            return address
    except ValueError:
        pass
    raise ValueError(f"replayer address {address!r}: the replayer sends to a loopback address only (127.0.0.1)")


@dataclass
class Faults:
    """What the replayer does to its packets (indices into the packet list)."""

    lose: frozenset[int] = frozenset()
    duplicate: frozenset[int] = frozenset()
    swap: frozenset[int] = frozenset()            # packet i goes after packet i + 1
    truncate: dict[int, int] = field(default_factory=dict)   # packet i keeps its first n bytes (header included)
    stop_after: int | None = None                 # the sender stops after this many packets


def apply_faults(packets: list[bytes], faults: Faults) -> list[bytes]:
    out = list(packets)
    for i in sorted(faults.swap):
        if i + 1 < len(out):
            out[i], out[i + 1] = out[i + 1], out[i]
    out = [p[:faults.truncate[i]] if i in faults.truncate else p for i, p in enumerate(out)]
    out = [q for i, p in enumerate(out) if i not in faults.lose for q in ([p, p] if i in faults.duplicate else [p])]
    return out if faults.stop_after is None else out[:faults.stop_after]


class Replayer:
    """Sends datagrams to a loopback address and port, as fast as it can or paced to a byte rate."""

    def __init__(self, address: str = "127.0.0.1", port: int = DATA_PORT) -> None:
        self.target = (loopback(address), port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4 << 20)

    def send(self, packets: list[bytes], bytes_per_s: float | None = None) -> float:
        """Send every packet; returns the seconds it took. Paced: packet i leaves no earlier than the time its
        bytes take at bytes_per_s (checked every packet, slept in steps of at least 1 ms)."""
        start = time.perf_counter()
        sent = 0
        for p in packets:
            if bytes_per_s:
                ahead = sent / bytes_per_s - (time.perf_counter() - start)
                if ahead > 1e-3:
                    time.sleep(ahead)
            self.sock.sendto(p, self.target)
            sent += len(p)
        return time.perf_counter() - start

    def close(self) -> None:
        self.sock.close()
