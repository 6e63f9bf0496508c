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
only has to cover the thread's pauses, not the consumer's). A packet the card's link loses and one this host's
kernel drops look alike in the stream (a sequence jump, counted `lost`); the receiver tells them apart with the
socket's own drop counter (Linux: the `drops` column of /proc/net/udp), counted `dropped_by_host`:

    dropped_by_host   datagrams that reached this socket and found its receive buffer full (the receiver did not
                      drain in time); lost - dropped_by_host went missing before this socket (the card, the cable,
                      a switch, or the host's own NIC ring and backlog, which the socket's counter does not see)

Either way the cycles they touch are damaged. The buffer: a datagram dropped is lost for good (the card does not
resend), so the receiver asks for its buffer with SO_RCVBUFFORCE, which a privileged process (CAP_NET_ADMIN) gets
beyond net.core.rmem_max, and with SO_RCVBUF, capped at rmem_max, otherwise; `rcvbuf_granted_bytes` is what the
kernel granted (getsockopt SO_RCVBUF: Linux doubles the request, and charges each datagram with its own overhead).

Replayer sends a capture's packets to 127.0.0.1 at a given rate, with faults, optionally no faster than the
receiver drains, and refuses any other address (it is a test instrument, not a radar).

Cost: a packet is a slice copy into the cycle buffer and a few integer checks in Python. Measured:
docs/bench/dca1000_udp.md (the receiver against the AWR1642's data rate).
"""
from __future__ import annotations

import ipaddress
import os
import platform
import select
import socket
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

DATA_PORT = 4098
HEADER_BYTES = 10
MAX_PAYLOAD = 1456
REASONS = ("lost", "truncated", "duplicated", "reordered", "overlapping", "incomplete")
# Python names no SO_RCVBUFFORCE; 33 is its number in asm-generic/socket.h (x86, ARM, ...), not on alpha, parisc or
# sparc, where the receiver asks with SO_RCVBUF only
SO_RCVBUFFORCE = getattr(socket, "SO_RCVBUFFORCE", None) or (
    33 if sys.platform == "linux" and not platform.machine().startswith(("alpha", "parisc", "sparc")) else None)


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


def socket_drops(sock: socket.socket) -> int | None:
    """The kernel's running count of datagrams it dropped for this UDP socket (IPv4): the `drops` column of its line
    in /proc/net/udp, found by the socket's inode; None where that cannot be read (not Linux)."""
    inode = str(os.fstat(sock.fileno()).st_ino)
    try:
        with open("/proc/net/udp") as fh:
            for line in fh:
                fields = line.split()      # sl local rem st tx:rx tr:when retrnsmt uid timeout inode ref ptr drops
                if len(fields) >= 13 and fields[9] == inode:
                    return int(fields[12])
    except (OSError, ValueError):
        pass
    return None


class UdpReceiver:
    """A bound UDP socket feeding a Reassembler from its own thread; take() waits for whole cycles.

    rcvbuf_granted_bytes is the receive buffer the kernel granted; reassembler.counts["dropped_by_host"] the
    datagrams the kernel dropped for the socket, copied from its counter when the stream stops and on close()
    (note_host_drops(); absent where the counter cannot be read)."""

    def __init__(self, address: str, port: int, reassembler: Reassembler, rcvbuf_bytes: int = 8 << 20) -> None:
        self.reassembler = reassembler
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        if not self._force_rcvbuf(rcvbuf_bytes):     # unprivileged: what rmem_max allows
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf_bytes)
        self.rcvbuf_granted_bytes = self.sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        self.sock.bind((address, port))
        self.sock.settimeout(0.05)
        self.address = self.sock.getsockname()
        self.cond = threading.Condition()
        self.last_packet = time.monotonic()
        self.running = True
        self.stopped = False
        self.thread = threading.Thread(target=self._receive, name="dca1000-udp", daemon=True)
        self.thread.start()

    def _force_rcvbuf(self, rcvbuf_bytes: int) -> bool:
        """The buffer asked for, beyond rmem_max, if this process may (CAP_NET_ADMIN)."""
        if SO_RCVBUFFORCE is None:
            return False
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, rcvbuf_bytes)
        except OSError:          # EPERM without the capability
            return False
        return True

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

    def queued(self) -> bool:
        """A datagram waits in the socket's buffer for the receiving thread (False once the thread or the socket
        has ended: nothing will read it)."""
        if self.sock.fileno() < 0 or not self.thread.is_alive():
            return False
        poll = select.poll()
        poll.register(self.sock, select.POLLIN)
        return any(events & select.POLLIN for _, events in poll.poll(0))

    def take(self, max_cycles: int, want: int, idle_timeout_s: float) -> Released | None:
        """Up to max_cycles whole cycles once `want` are ready; fewer if the sender falls silent for idle_timeout_s,
        then the cycle it stopped within (damaged); None once nothing is left after it stopped. Silent means no
        packet for idle_timeout_s and none waiting in the socket: a receiving thread starved of CPU is not a
        sender that stopped."""
        with self.cond:
            while self.reassembler.complete() < want and not self.stopped:
                if time.monotonic() - self.last_packet >= idle_timeout_s and not self.queued():
                    self.stopped = True
                    break
                self.cond.wait(0.05)
            if self.stopped:
                self.note_host_drops()
            got = self.reassembler.take(max_cycles)
            if got is None and self.stopped:
                return self.reassembler.flush()
            return got

    def note_host_drops(self) -> None:
        """Copy the socket's drop counter into reassembler.counts["dropped_by_host"] (while the socket is open)."""
        if self.sock.fileno() < 0 or (drops := socket_drops(self.sock)) is None:
            return
        with self.cond:
            self.reassembler.counts["dropped_by_host"] = drops

    def close(self) -> None:
        self.running = False
        self.thread.join(1.0)
        self.note_host_drops()
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

    def send(self, packets: list[bytes], bytes_per_s: float | None = None,
             room: Callable[[], bool] | None = None) -> float:
        """Send every packet; returns the seconds it took. Paced: packet i leaves no earlier than the time its
        bytes take at bytes_per_s (checked every packet, slept in steps of at least 1 ms). With `room`, asked
        before every packet whether the receiver can take it: while it says no, the sender waits in 1 ms sleeps,
        and the pace starts afresh after a wait (bytes_per_s stays an upper bound: no burst to catch up). `room`
        ends a wait that can never end by raising."""
        first = start = time.perf_counter()
        sent = 0
        for p in packets:
            if room is not None and not room():
                while not room():
                    time.sleep(1e-3)
                start, sent = time.perf_counter(), 0
            if bytes_per_s:
                ahead = sent / bytes_per_s - (time.perf_counter() - start)
                if ahead > 1e-3:
                    time.sleep(ahead)
            self.sock.sendto(p, self.target)
            sent += len(p)
        return time.perf_counter() - first

    def close(self) -> None:
        self.sock.close()
