"""`python3 dev.py bench gr-bridge`: the GNU Radio bridge's throughput each way, items/s and MB/s, beside raw pyzmq.

The stream is the scene's (--scene, table1 by default: float32 items, 64 x 1080 a cycle), over tcp:// loopback, the
ZeroMQ queues at their defaults on both sides; each case untagged and with Pass Tags. The carav block runs in this
process, driven as its node drives it (the source waits its tick on a frame not yet whole); its peer in a process
of its own:

  to_gnuradio    gr_zmq_sink (PUSH) gets --batch cycles of ADC codes a frame and sends one message a cycle: the
                 codes turned into samples, the tag header (with Pass Tags: packet_len and carav_chirp on every chirp,
                 rx_time, carav_cycle, rx_rate, carav_seq), the send. Received by GNU Radio's ZMQ PULL Source into a
                 probe block counting items (bench/gr_peer.py, under the system's Python), or by a pyzmq PULL
                 counting messages.
  from_gnuradio  gr_zmq_source (PULL) receives, decodes, frames the stream into cycles, puts them through the
                 scene's ADC and sends frames of --batch cycles with their activation. Fed by GNU Radio's ZMQ PUSH
                 Sink (a Vector Source through Head, with Pass Tags a Stream to Tagged Stream: packet_len on every
                 chirp), in messages as its scheduler makes them, or by a pyzmq PUSH sending the same items and
                 tags in messages of --message-kb, encoded before the clock starts.
  raw            pyzmq PUSH to PULL, two processes, the same message sizes: one cycle's items (what gr_zmq_sink
                 sends) and --message-kb (what the pyzmq feeder sends), the same bytes object each time.

Rates are steady state, taken where the stream is received (the monotonic clock, the same in every process):
items / s = (items - the first tenth) / (time of the last - time the first tenth had come). MB/s counts the items'
bytes (1e6 B), not the tag headers. CPU ns/item is this process's CPU (every thread) per item while the carav
block ran. Each figure is the median of --repeats runs, the cases interleaved; ratio = items/s over raw pyzmq's at
the same message size. GNU Radio's cases need its ZMQ blocks importable by /usr/bin/python3 (`apt-get install
gnuradio`); without them the record says why and holds the pyzmq cases.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import queue
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench import records as bench_records
from bench.blocks._common import cpu_s
from carav_blocks.gr_zmq_sink import GrZmqSink
from carav_blocks.gr_zmq_source import GrZmqSource
from carav_stream.capture.gr_stream import StreamLayout, layout_of
from carav_stream.capture.gr_zmq import Tag, encode
from carav_stream.console.options import count, output_file
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime import Frame
from carav_stream.view.server import free_port

SYSTEM_PYTHON = "/usr/bin/python3"
PEER = Path(__file__).with_name("gr_peer.py")
TIMEOUT_S = 120.0
PEERS = ("gnuradio", "pyzmq")


def gnuradio_version() -> tuple[str | None, str]:
    """(GNU Radio's version, "") when /usr/bin/python3 imports its ZMQ blocks; else (None, why not)."""
    try:
        done = subprocess.run([SYSTEM_PYTHON, str(PEER), "version"], capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return None, str(exc)
    if done.returncode:
        return None, (done.stderr.strip().splitlines() or ["no output"])[-1]
    return done.stdout.strip(), ""


def _rate(n_items: int, warm_items: int, t_warm_s: float, t_end_s: float) -> float:
    if t_end_s <= t_warm_s:
        raise RuntimeError(f"no time between the first tenth and the end ({t_warm_s} .. {t_end_s} s)")
    return (n_items - warm_items) / (t_end_s - t_warm_s)


# -- pyzmq peers (spawned processes) --------------------------------------------------------------------------
def _pull(address: str, n_messages: int, warm: int, out) -> None:
    """Receive n_messages on a PULL connected to address; the clock at message `warm` and at the last."""
    import zmq

    ctx = zmq.Context()
    sock = ctx.socket(zmq.PULL)
    sock.connect(address)
    t_warm = None
    for i in range(n_messages):
        sock.recv(copy=False)
        if i + 1 == warm:
            t_warm = time.monotonic()
    out.put({"t_warm_s": t_warm, "t_end_s": time.monotonic()})
    sock.close(0)
    ctx.term()


def _push(address: str, messages: list[bytes] | tuple[bytes, int], ready, done) -> None:
    """Bind a PUSH on address and send `messages` (or (one message, how many times)); hold until `done`."""
    import zmq

    ctx = zmq.Context()
    sock = ctx.socket(zmq.PUSH)
    sock.bind(address)
    ready.set()
    if isinstance(messages, tuple):
        message, n = messages
        for _ in range(n):
            sock.send(message, copy=False)
    else:
        for message in messages:
            sock.send(message, copy=False)
    done.wait(TIMEOUT_S)
    sock.close(0)
    ctx.term()


def stream_messages(lay: StreamLayout, n_cycles: int, tagged: bool, message_items: int) -> list[bytes]:
    """The stream GNU Radio's feeder sends (a ramp; with tags, packet_len on every chirp) in messages of
    message_items items, encoded as gr-zeromq does."""
    total = n_cycles * lay.items_per_cycle
    stretch = np.arange(lay.items_per_cycle).astype(lay.item)
    out = []
    for start in range(0, total, message_items):
        stop = min(start + message_items, total)
        idx = np.arange(start, stop) % lay.items_per_cycle
        tags = [Tag(o, "packet_len", lay.n_samples) for o in range(-(-start // lay.n_samples) * lay.n_samples, stop,
                                                                    lay.n_samples)] if tagged else []
        out.append(encode(stretch[idx], offset=start if tagged else None, tags=tags)[0])
    return out


class Peer:
    """A peer in a process of its own: GNU Radio's flowgraph (bench/gr_peer.py) or a spawned pyzmq function."""

    def __init__(self, kind: str, *args: Any) -> None:
        self.ctx = mp.get_context("spawn")
        self.out, self.ready, self.done = self.ctx.Queue(), self.ctx.Event(), self.ctx.Event()
        self.gr = kind == "gnuradio"
        if self.gr:
            self.proc = subprocess.Popen([SYSTEM_PYTHON, str(PEER), *map(str, args)], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                         start_new_session=True)
        else:
            target, *rest = args
            extra = (self.out,) if target is _pull else (self.ready, self.done)
            self.proc = self.ctx.Process(target=target, args=(*rest, *extra))
            self.proc.start()

    def result(self) -> dict:
        """The receiver's clock readings (its JSON line, or its queue)."""
        if not self.gr:
            return self.out.get(timeout=TIMEOUT_S)
        for line in self.proc.stdout:
            if line.startswith("{"):
                return json.loads(line)
        self.proc.wait(TIMEOUT_S)
        raise RuntimeError(f"GNU Radio's receiver ended ({self.proc.returncode}): {self.proc.stderr.read()[-400:]}")

    def close(self) -> None:
        if self.gr:
            if self.proc.poll() is None:
                self.proc.stdin.close()
                try:
                    self.proc.wait(10)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait()
            return
        self.done.set()
        self.proc.join(30)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()


# -- the three directions -------------------------------------------------------------------------------------
def to_gnuradio(scene: str, peer: str, tagged: bool, cycles: int, batch: int) -> dict[str, Any]:
    """One run of gr_zmq_sink into `peer`: items/s at the receiver, CPU ns/item here, messages sent."""
    lay = layout_of(load_scene(scene))
    address, n, warm = f"tcp://127.0.0.1:{free_port('127.0.0.1')}", lay.items_per_cycle, max(1, cycles // 10)
    shape = (batch, lay.n_chirps, lay.n_samples, *((2,) if lay.iq else ()))
    codes = np.random.default_rng(0).integers(-2048, 2048, shape).astype(np.int16)
    receiver = (Peer("gnuradio", "receive", address, lay.item.name, int(tagged), cycles * n, warm * n)
                if peer == "gnuradio" else Peer("pyzmq", _pull, address, cycles, warm))
    sink = GrZmqSink(scene=scene, address=address, pass_tags=tagged, timeout_s=TIMEOUT_S)
    try:
        sink.start()
        cpu0 = sum(cpu_s()[:2])
        for seq, first in enumerate(range(0, cycles, batch)):
            frame = Frame.of(codes[:min(batch, cycles - first)], cycle=first, cycles=min(batch, cycles - first))
            frame.header["seq"] = seq
            sink.process(frame)
        cpu = sum(cpu_s()[:2]) - cpu0
        sink.finish()
        got = receiver.result()
    finally:
        receiver.close()
    if got.get("items", cycles * n) != cycles * n:
        raise RuntimeError(f"to_gnuradio ({peer}): {got['items']} of {cycles * n} items received")
    return {"items_per_s": _rate(cycles * n, warm * n, got["t_warm_s"], got["t_end_s"]),
            "cpu_ns_per_item": cpu / (cycles * n) * 1e9, "messages": sink.messages, "items": sink.offset}


def from_gnuradio(scene: str, peer: str, tagged: bool, cycles: int, batch: int, message_items: int) -> dict[str, Any]:
    """One run of gr_zmq_source fed by `peer`: items/s as its frames come out, CPU ns/item here, messages."""
    lay = layout_of(load_scene(scene))
    address, n, warm = f"tcp://127.0.0.1:{free_port('127.0.0.1')}", lay.items_per_cycle, max(1, cycles // 10)
    sender = (Peer("gnuradio", "send", address, lay.item.name, int(tagged), cycles * n, lay.n_samples)
              if peer == "gnuradio" else Peer("pyzmq", _push, address, stream_messages(lay, cycles, tagged,
                                                                                       message_items)))
    source = GrZmqSource(scene=scene, address=address, pass_tags=tagged, pattern="10" * (lay.n_chirps // 2),
                         first_timeout_s=TIMEOUT_S, idle_timeout_s=5.0, batch=batch)
    try:
        source.start()
        out = seq = 0
        t_warm = cpu0 = None
        while out < cycles:
            wait = source.ready_in(seq)
            if wait > 0:
                time.sleep(wait)
                continue
            got = source.generate(seq)
            if got is None:
                raise RuntimeError(f"from_gnuradio: the stream ended after {out} of {cycles} cycles")
            out, seq = out + got["frames"].header["cycles"], seq + 1
            if t_warm is None and out >= warm:
                t_warm, warm_items, cpu0 = time.monotonic(), out * n, sum(cpu_s()[:2])
        t_end, cpu = time.monotonic(), sum(cpu_s()[:2]) - cpu0
        counts = source.framer.counts
        source.finish()
    finally:
        sender.close()
    if counts["items"] != cycles * n or counts["damaged_cycles"]:
        raise RuntimeError(f"from_gnuradio ({peer}): {counts['items']} of {cycles * n} items, "
                           f"{counts['damaged_cycles']} cycles damaged")
    return {"items_per_s": _rate(cycles * n, warm_items, t_warm, t_end),
            "cpu_ns_per_item": cpu / (cycles * n - warm_items) * 1e9, "messages": counts["messages"],
            "items": counts["items"]}


def raw(message_bytes: int, n_messages: int) -> dict[str, Any]:
    """One run of pyzmq PUSH -> PULL: messages/s at the receiver."""
    address, warm = f"tcp://127.0.0.1:{free_port('127.0.0.1')}", max(1, n_messages // 10)
    receiver = Peer("pyzmq", _pull, address, n_messages, warm)
    sender = Peer("pyzmq", _push, address, (bytes(message_bytes), n_messages))
    try:
        got = receiver.result()
    finally:
        sender.close()
        receiver.close()
    return {"messages_per_s": _rate(n_messages, warm, got["t_warm_s"], got["t_end_s"])}


# -- command ----------------------------------------------------------------------------------------------------
def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write one record per case")
    parser.add_argument("--scene", default="table1", help="the stream's scene, a preset or a file (default table1)")
    parser.add_argument("--cycles", type=count(10), default=500, help="cycles per run (default 500)")
    parser.add_argument("--repeats", type=count(1), default=5, help="runs per figure; medians are reported (default 5)")
    parser.add_argument("--batch", type=count(1), default=8, help="cycles per carav frame (default 8)")
    parser.add_argument("--message-kb", type=count(1), default=64,
                        help="the pyzmq feeder's messages, KiB of items (default 64, GNU Radio's larger ones)")
    parser.add_argument("--peers", nargs="+", choices=PEERS, default=list(PEERS),
                        help="the bridge's peers (default both; GNU Radio's only where it is installed)")


def cases(peers: list[str]) -> list[tuple[str, str, bool]]:
    """(direction, peer, tagged) of every bridge case, in the order they run within a repeat."""
    return [(d, p, t) for d in ("to_gnuradio", "from_gnuradio") for t in (False, True) for p in peers]


def measure(args: argparse.Namespace, peers: list[str]) -> list[dict[str, Any]]:
    lay = layout_of(load_scene(args.scene))
    n, size = lay.items_per_cycle, lay.item.itemsize
    k = args.message_kb * 1024 // size
    sizes = {"cycle": n, "message_kb": k}                 # raw pyzmq's message sizes, in items
    runs: dict[Any, list[dict[str, Any]]] = {c: [] for c in [*cases(peers), *sizes]}
    for _ in range(args.repeats):                        # interleaved, so slow drifts of the machine hit all alike
        for direction, peer, tagged in cases(peers):
            run = (to_gnuradio(args.scene, peer, tagged, args.cycles, args.batch) if direction == "to_gnuradio"
                   else from_gnuradio(args.scene, peer, tagged, args.cycles, args.batch, k))
            runs[direction, peer, tagged].append(run)
        for name, items in sizes.items():
            runs[name].append(raw(items * size, args.cycles * n // items))
    raw_rates = {name: statistics.median(r["messages_per_s"] for r in runs[name]) * items
                 for name, items in sizes.items()}
    common = {"scene": args.scene, "item": lay.item.name, "items_per_cycle": n, "cycles": args.cycles,
              "repeats": args.repeats}
    records = [{"direction": "raw", "peer": "pyzmq", "tagged": False, **common, "items_per_message": items,
                "items_per_s": raw_rates[name], "mb_per_s": raw_rates[name] * size / 1e6,
                "runs_items_per_s": [r["messages_per_s"] * items for r in runs[name]]}
               for name, items in sizes.items()]
    for direction, peer, tagged in cases(peers):
        rs = runs[direction, peer, tagged]
        rate = statistics.median(r["items_per_s"] for r in rs)
        per_message = statistics.median(r["items"] / r["messages"] for r in rs)
        reference = raw_rates["cycle" if direction == "to_gnuradio" else "message_kb"]
        records.append({"direction": direction, "peer": peer, "tagged": tagged, **common,
                        "items_per_message": per_message, "items_per_s": rate, "mb_per_s": rate * size / 1e6,
                        "runs_items_per_s": [r["items_per_s"] for r in rs],
                        "cpu_ns_per_item": statistics.median(r["cpu_ns_per_item"] for r in rs),
                        "raw_items_per_s": reference, "raw_mb_per_s": reference * size / 1e6,
                        "ratio_to_raw": rate / reference})
    return records


def _case(r: dict[str, Any]) -> str:
    if r["direction"] == "raw":
        return f"raw pyzmq PUSH -> PULL, {r['items_per_message']:.0f} items a message"
    peer = {"gnuradio": "GNU Radio's ZMQ", "pyzmq": "a pyzmq"}[r["peer"]]
    tags = "with Pass Tags" if r["tagged"] else "untagged"
    gr = r["peer"] == "gnuradio"
    if r["direction"] == "to_gnuradio":
        return f"carav -> GNU Radio: gr_zmq_sink into {peer} PULL{' Source' if gr else ''}, {tags}"
    return f"GNU Radio -> carav: gr_zmq_source fed by {peer} PUSH{' Sink' if gr else ''}, {tags}"


def rows(doc: dict[str, Any]) -> list[tuple[str, str, str, str]]:
    """BENCHMARKS.md's rows: every case's rate beside raw pyzmq's at its message size (reported, no target)."""
    out = []
    for r in doc["records"]:
        got = f"{r['items_per_s'] / 1e6:.3g} M items/s = {r['mb_per_s']:.0f} MB/s"
        if r["direction"] != "raw":
            got += (f", {r['ratio_to_raw']:.2f} x raw pyzmq ({r['raw_mb_per_s']:.0f} MB/s); "
                    f"{r['items_per_message']:.0f} items a message; carav CPU {r['cpu_ns_per_item']:.2f} ns/item")
        out.append((f"{_case(r)} ({r['scene']}, {r['item']})", got, "(reported)", "-"))
    if doc.get("gnuradio_missing"):
        out.append(("GNU Radio's own blocks as the peers", f"not measured: {doc['gnuradio_missing']}", "(reported)",
                    "-"))
    return out


def table(doc: dict[str, Any]) -> list[str]:
    version = doc.get("gnuradio") or f"not measured ({doc.get('gnuradio_missing', '')})"
    lines = [f"GNU Radio: {version}.", "",
             "| direction | peer | tags | items a message | M items/s (runs) | MB/s | x raw pyzmq "
             "| carav CPU ns/item |", "|---|---|---|---:|---|---:|---:|---:|"]
    for r in doc["records"]:
        runs = ", ".join(f"{x / 1e6:.3g}" for x in r["runs_items_per_s"])
        ratio = f"{r['ratio_to_raw']:.2f}" if "ratio_to_raw" in r else "-"
        cpu = f"{r['cpu_ns_per_item']:.2f}" if "cpu_ns_per_item" in r else "-"
        lines.append(f"| {r['direction']} | {r['peer']} | {'yes' if r['tagged'] else 'no'} | "
                     f"{r['items_per_message']:.0f} | {r['items_per_s'] / 1e6:.3g} ({runs}) | {r['mb_per_s']:.0f} | "
                     f"{ratio} | {cpu} |")
    return lines


def run(args: argparse.Namespace) -> int:
    print(bench_records.header())
    peers, extra = list(args.peers), {}
    if "gnuradio" in peers:
        version, why = gnuradio_version()
        if version is None:
            peers.remove("gnuradio")
            extra["gnuradio_missing"] = f"{SYSTEM_PYTHON} does not import GNU Radio's ZMQ blocks: {why}"
            print(f"GNU Radio: {extra['gnuradio_missing']}; measuring the pyzmq peers only")
        else:
            extra["gnuradio"] = version
    try:
        records = measure(args, peers)
    except (RuntimeError, queue.Empty, subprocess.TimeoutExpired) as exc:
        print(f"dev.py bench gr-bridge: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    for r in records:
        print(f"{_case(r)}: {r['items_per_s'] / 1e6:.3g} M items/s, {r['mb_per_s']:.0f} MB/s"
              + (f", {r['ratio_to_raw']:.2f} x raw, CPU {r['cpu_ns_per_item']:.2f} ns/item" if "ratio_to_raw" in r
                 else ""), flush=True)
    if args.json:
        bench_records.write(args.json, args, records, **extra)
    return 0
