"""`python3 dev.py bench dca1000-udp`: the live DCA1000 receiver against the AWR1642's data rate, and the replayer's
own limit.

The stream: the awr1642 preset's cycle as a DCA1000 capture of --n-rx receivers (real, 16 bits: 128 chirps x 256
samples x 2 bytes per receiver), its data rate the cycle's bytes over the preset's 40 ms cycle. Two measurements:

  replayer   the replayer sends --cycles cycles of packets as fast as it can to a loopback socket nobody reads
             (the kernel drops what does not fit): packets/s and MB/s, the most any receiver can be offered here
  receiver   a receiver process (UdpReceiver + Reassembler, as dca1000_udp_source runs them in its own process)
             takes --cycles cycles sent by the replayer at each --rates multiple of the AWR1642's data rate (0:
             unpaced, as fast as the replayer goes): packets and cycles received, lost, damaged, and the rate
             offered; a multiple at which nothing is lost and no cycle is damaged is one the receiver keeps up with

Each figure is of this machine, busy or not (its load average is in the record); the receiver is not measured
above what the replayer can offer.
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import socket

from bench import records as bench_records
from carav_stream.capture.dca1000_udp import Reassembler, Replayer, UdpReceiver, packetize
from carav_stream.console.options import count, output_file
from carav_stream.radar.scene_loader import load_scene

TIMEOUT_S = 120.0


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")
    parser.add_argument("--cycles", type=count(2), default=50, help="cycles per run (default 50)")
    parser.add_argument("--n-rx", type=int, default=4, choices=(1, 2, 3, 4), help="receivers in the stream")
    parser.add_argument("--rates", type=float, nargs="+", default=[1, 2, 4, 8, 0],
                        help="multiples of the AWR1642 data rate to offer (0: unpaced)")


def _receiver(bytes_per_cycle: int, cycles: int, ready, out) -> None:
    rx = UdpReceiver("127.0.0.1", 0, Reassembler(bytes_per_cycle), rcvbuf_bytes=8 << 20)
    ready.put(rx.address[1])
    while rx.take(cycles, cycles, idle_timeout_s=1.0) is not None:
        pass
    rx.close()
    out.put({**rx.reassembler.counts, "rcvbuf_granted_bytes": rx.rcvbuf_granted_bytes})


def receiver_run(stream: bytes, bytes_per_cycle: int, cycles: int, bytes_per_s: float | None) -> dict:
    ctx = mp.get_context("spawn")
    ready, out = ctx.Queue(), ctx.Queue()
    proc = ctx.Process(target=_receiver, args=(bytes_per_cycle, cycles, ready, out))
    proc.start()
    try:
        port = ready.get(timeout=TIMEOUT_S)
        packets = packetize(stream)
        tx = Replayer("127.0.0.1", port)
        seconds = tx.send(packets, bytes_per_s)
        tx.close()
        counts = out.get(timeout=TIMEOUT_S)
    finally:
        proc.join(TIMEOUT_S)
        if proc.is_alive():
            proc.kill()
    return {"packets_sent": len(packets), "packets_received": counts.get("packets", 0),
            "packets_lost": counts.get("lost", 0), "cycles_sent": cycles, "cycles_received": counts.get("cycles", 0),
            "damaged_cycles": counts.get("damaged_cycles", 0), "offered_mb_per_s": len(stream) / seconds / 1e6,
            "send_seconds": seconds, "packets_dropped_by_host": counts.get("dropped_by_host"),
            "rcvbuf_granted_bytes": counts["rcvbuf_granted_bytes"]}


def replayer_limit(stream: bytes) -> dict:
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    try:
        packets = packetize(stream)
        tx = Replayer("127.0.0.1", sink.getsockname()[1])
        seconds = tx.send(packets)
        tx.close()
    finally:
        sink.close()
    return {"packets": len(packets), "packets_per_s": len(packets) / seconds, "mb_per_s": len(stream) / seconds / 1e6}


def run(args: argparse.Namespace) -> int:
    scene = load_scene("awr1642")
    bytes_per_cycle = scene.n_chirps * args.n_rx * scene.n_samples * 2 * (2 if scene.iq else 1)
    rate = bytes_per_cycle / scene.t_cycle_s
    stream = bytes(range(256)) * (bytes_per_cycle * args.cycles // 256)
    limit = replayer_limit(stream)
    print(f"AWR1642 stream: {bytes_per_cycle} bytes per cycle, {rate / 1e6:.3g} MB/s ({args.n_rx} receivers, real, "
          f"16 bits, {scene.t_cycle_s * 1e3:g} ms cycles)")
    print(f"replayer alone: {limit['packets_per_s']:.0f} packets/s, {limit['mb_per_s']:.1f} MB/s")
    records = [{"case": "replayer", **limit}]
    for multiple in args.rates:
        r = receiver_run(stream, bytes_per_cycle, args.cycles, multiple * rate if multiple > 0 else None)
        r = {"case": "receiver", "rate_multiple": multiple, **r}
        records.append(r)
        print(f"receiver at {'unpaced' if multiple <= 0 else f'{multiple:g} x AWR1642'}: offered "
              f"{r['offered_mb_per_s']:.1f} MB/s, {r['packets_received']} of {r['packets_sent']} packets, "
              f"{r['cycles_received']} cycles, {r['damaged_cycles']} damaged, "
              f"{r['packets_dropped_by_host']} dropped by this host (receive buffer {r['rcvbuf_granted_bytes']} bytes)")
    if args.json:
        bench_records.write(args.json, args, records, awr1642_mb_per_s=rate / 1e6, bytes_per_cycle=bytes_per_cycle)
    return 0
