"""`python3 dev.py bench transport`: frames/s, GB/s and latency through a chain of 6 processes, runtime against raw
pyzmq.

Both chains are source -> 4 pass-through hops -> sink, one OS process each, ipc:// endpoints, the same
high-water mark (the graph's run.queue_frames on the send and the receive side), and the same frames:

    table1   64 x 1100 complex64  (563 200 bytes, one Table I cycle)
    awr1642  128 x 256 complex64  (262 144 bytes, one AWR1642 cycle)

runtime      a real graph run by carav_stream.runtime.supervisor.Supervisor (blocks bench_source, bench_pass,
             bench_sink from bench/blocks): header encode/validate/decode, pairing, counters,
             heartbeats, stamps; arrays in the ZeroMQ messages (run.transport = "zmq")
runtime_shm  the same graph with its arrays in shared memory (run.transport = "shm", runtime/shm.py): each
             pass-through node copies the frame it forwards into its own output slot once (one memcpy a hop)
raw          bare pyzmq PUSH/PULL, multipart [8-byte t_created_s, payload], copy=False on both sides.

Figures come from the sink of each chain, after `warmup` frames (pipeline fill):
    frames/s      = (n - 1 - warmup) / (t_recv[n-1] - t_recv[warmup])   (steady state; equal at every hop)
    GB/s          = frames/s * payload bytes / 1e9                      (per hop)
    latency       = sink receive time - source t_created_s (same clock), median and p99, end to end over 5 hops
Throughput runs are unpaced (queues full), so their latency is mostly queueing (about hops * 2 * HWM frames);
a paced run (--latency-rate-hz, default 100 frames/s) gives the latency of an empty pipeline.
Each figure is the median over --repeats runs; ratio = frames/s / raw frames/s (target for runtime >= 0.8) and CPU
ratio = raw CPU per frame / CPU per frame, both over the whole chain.
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import queue
import statistics
import struct
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench import records as bench_records
from bench.blocks._common import cpu_figures, cpu_s, figures
from carav_stream.console.options import count, number, output_file
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.supervisor import Supervisor

SHAPES = {"table1": (64, 1100), "awr1642": (128, 256)}
TRANSPORTS = ("runtime", "runtime_shm", "raw")      # the runtime over each data plane, and bare pyzmq
PLANE = {"runtime": "zmq", "runtime_shm": "shm"}
N_PASS = 4                  # pass-through nodes: 6 processes, 5 hops
HOPS = N_PASS + 1


# -- runtime chain -----------------------------------------------------------------------------------------
CHAIN_GRAPH = Path(__file__).resolve().parent / "chain.toml"


def chain_overrides(shape: tuple[int, int], *, queue_frames: int, warmup: int, rate_hz: float = 0.0,
                    plane: str = "zmq") -> list[str]:
    """`--set` values that make chain.toml (src -> p1 .. p4 -> sink) the chain of one benchmark case."""
    return [f"src.n_chirps={shape[0]}", f"src.n_samples={shape[1]}", f"src.rate_hz={float(rate_hz)}",
            f"sink.warmup_frames={warmup}", f"run.queue_frames={queue_frames}", f"run.transport={plane}"]


def run_runtime(shape: tuple[int, int], n_frames: int, *, queue_frames: int, warmup: int,
                rate_hz: float = 0.0, plane: str = "zmq") -> dict[str, Any]:
    """One run of the chain through the real runtime over data plane `plane` (run.transport); the sink's
    figures plus the supervisor's throughput."""
    graph = load_graph(CHAIN_GRAPH, chain_overrides(shape, queue_frames=queue_frames, warmup=warmup, rate_hz=rate_hz,
                                                    plane=plane))
    summary = Supervisor(graph, cycles=n_frames, progress=False, log=lambda text: None).run()
    if summary["failures"] or summary["lost"]:
        raise RuntimeError(f"runtime chain failed: failures {summary['failures']}, lost {summary['lost_by_edge']}")
    history = summary["per_node"]["sink"]["history"]
    if not history:
        raise RuntimeError("runtime chain: the sink reported no summary")
    figures = dict(history[-1]["summary"])
    if figures["frames"] != n_frames or not figures["in_order"]:
        raise RuntimeError(f"runtime chain: sink got {figures['frames']} of {n_frames} frames, "
                           f"in order: {figures['in_order']}")
    figures["supervisor_cycles_per_s"] = summary["throughput_cycles_per_s"]
    return _add_cpu(figures, {n: p["history"][-1]["summary"] for n, p in summary["per_node"].items()})


def _add_cpu(figures: dict[str, Any], by_node: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Per-node CPU figures (ms/frame, page faults/frame, switches/frame) and their sums over the chain."""
    for key in ("cpu_ms_per_frame", "page_faults_per_frame", "voluntary_switches_per_frame"):
        figures[f"{key}_by_node"] = {n: f[key] for n, f in by_node.items()}
        figures[f"{key}_total"] = sum(figures[f"{key}_by_node"].values())
    return figures


# -- raw pyzmq chain ---------------------------------------------------------------------------------------
# Every raw process stays alive until the sink has everything (`done`): ZeroMQ drops the frames still in a
# connection when the sending process exits while its consumer's queue is full, even with linger = -1
# (the runtime's nodes wait for the supervisor's "exit" for the same reason).
def _raw_source(endpoint: str, shape: tuple[int, int], n_frames: int, hwm: int, rate_hz: float, go, done,
                results) -> None:
    import zmq

    cpu0 = cpu_s()
    ctx = zmq.Context()
    sock = ctx.socket(zmq.PUSH)
    sock.sndhwm = hwm
    sock.linger = -1
    sock.connect(endpoint)
    rng = np.random.default_rng(0)
    data = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(np.complex64)
    payload = memoryview(data.reshape(-1).view(np.uint8))
    go.wait()
    t_next = time.monotonic()
    for _ in range(n_frames):
        if rate_hz:
            now = time.monotonic()
            if t_next > now:
                time.sleep(t_next - now)
            t_next += 1.0 / rate_hz
        sock.send_multipart([struct.pack("<d", time.time()), payload], copy=False)
    cpu = cpu_figures(cpu0, n_frames)
    results.put(("src", cpu))
    done.wait(120)
    sock.close(linger=0)
    ctx.term()


def _raw_relay(name: str, bind: str, connect: str, n_frames: int, hwm: int, ready, done, results) -> None:
    import zmq

    cpu0 = cpu_s()
    ctx = zmq.Context()
    pull = ctx.socket(zmq.PULL)
    pull.rcvhwm = hwm
    pull.bind(bind)
    push = ctx.socket(zmq.PUSH)
    push.sndhwm = hwm
    push.linger = -1
    push.connect(connect)
    ready.set()
    for _ in range(n_frames):
        push.send_multipart(pull.recv_multipart(copy=False), copy=False)
    results.put((name, cpu_figures(cpu0, n_frames)))
    done.wait(120)
    push.close(linger=0)
    pull.close(linger=0)
    ctx.term()


def _raw_sink(bind: str, n_frames: int, hwm: int, warmup: int, ready, results) -> None:
    import zmq

    cpu0 = cpu_s()
    ctx = zmq.Context()
    pull = ctx.socket(zmq.PULL)
    pull.rcvhwm = hwm
    pull.bind(bind)
    ready.set()
    t_recv, latency = [], []
    nbytes = 0
    for _ in range(n_frames):
        parts = pull.recv_multipart(copy=False)
        now = time.time()
        t_recv.append(time.perf_counter())
        latency.append(now - struct.unpack("<d", parts[0].buffer)[0])
        nbytes = len(parts[1].buffer)
    cpu = cpu_figures(cpu0, n_frames)
    pull.close(linger=0)
    ctx.term()
    results.put(("sink", {**figures(t_recv, latency, warmup, nbytes, True), **cpu}))


def run_raw(shape: tuple[int, int], n_frames: int, *, queue_frames: int, warmup: int,
            rate_hz: float = 0.0, timeout_s: float = 300.0) -> dict[str, Any]:
    """One run of the bare pyzmq chain (6 spawned processes)."""
    mpc = mp.get_context("spawn")
    with tempfile.TemporaryDirectory(prefix="carav-raw-") as tmp:
        eps = [f"ipc://{tmp}/h{i}" for i in range(HOPS)]
        go, done = mpc.Event(), mpc.Event()
        readies = [mpc.Event() for _ in range(N_PASS + 1)]
        results = mpc.Queue()
        procs = [mpc.Process(target=_raw_sink, args=(eps[-1], n_frames, queue_frames, warmup, readies[-1], results))]
        procs += [mpc.Process(target=_raw_relay, args=(f"p{i + 1}", eps[i], eps[i + 1], n_frames, queue_frames,
                                                       readies[i], done, results))
                  for i in range(N_PASS)]
        procs.append(mpc.Process(target=_raw_source,
                                 args=(eps[0], shape, n_frames, queue_frames, rate_hz, go, done, results)))
        try:
            for p in procs:
                p.start()
            deadline = time.monotonic() + 60
            while not all(ev.is_set() for ev in readies):
                dead = [p.exitcode for p in procs if p.exitcode is not None]
                if dead or time.monotonic() > deadline:
                    raise RuntimeError(f"raw chain: processes did not start (exit codes {dead})")
                time.sleep(0.01)
            go.set()
            deadline = time.monotonic() + timeout_s
            by_node: dict[str, dict[str, Any]] = {}
            while len(by_node) < len(procs):
                try:
                    name, figs = results.get(timeout=0.2)
                    by_node[name] = figs
                except queue.Empty:
                    dead = [p.exitcode for p in procs if p.exitcode not in (None, 0)]
                    if dead or time.monotonic() > deadline:
                        raise RuntimeError(f"raw chain: results only from {sorted(by_node)}; exit codes "
                                           f"{[p.exitcode for p in procs]}") from None
            done.set()
            for p in procs:
                p.join(timeout=30)
        finally:
            for p in procs:
                if p.is_alive():
                    p.kill()
                    p.join()
    return _add_cpu(dict(by_node["sink"]), by_node)


# -- command -----------------------------------------------------------------------------------------------
def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE",
                        help="write one record per frame shape and transport")
    parser.add_argument("--frames", type=count(20), default=2000, help="frames per throughput run (default 2000)")
    parser.add_argument("--repeats", type=count(1), default=3, help="runs per figure; medians are reported (default 3)")
    parser.add_argument("--queue-frames", type=count(1), default=8,
                        help="high-water mark of every queue, both chains (default 8, the runtime's default)")
    parser.add_argument("--latency-rate-hz", type=number(0.0), default=100.0,
                        help="paced run for the empty-pipeline latency (frames/s; 0 skips it; default 100)")
    parser.add_argument("--latency-frames", type=count(20), default=200, help="frames per paced run (default 200)")
    parser.add_argument("--shapes", nargs="+", choices=sorted(SHAPES), default=list(SHAPES),
                        help="frame shapes to measure (default both)")


def _median(runs: list[dict[str, Any]], key: str) -> float:
    return float(statistics.median(r[key] for r in runs))


def measure(shape_name: str, args: argparse.Namespace) -> dict[str, Any]:
    shape = SHAPES[shape_name]
    warmup = max(1, min(args.frames // 10, 100))
    runs: dict[str, list[dict[str, Any]]] = {t: [] for t in TRANSPORTS}
    paced: dict[str, list[dict[str, Any]]] = {t: [] for t in TRANSPORTS}
    kw = {"queue_frames": args.queue_frames, "warmup": warmup}
    pkw = {"queue_frames": args.queue_frames, "warmup": min(10, args.latency_frames // 10),
           "rate_hz": args.latency_rate_hz}
    for _ in range(args.repeats):       # interleaved, so slow drifts of the machine hit all alike
        for transport in TRANSPORTS:
            once = run_raw if transport == "raw" else run_runtime
            plane = {} if transport == "raw" else {"plane": PLANE[transport]}
            runs[transport].append(once(shape, args.frames, **kw, **plane))
            if args.latency_rate_hz:
                paced[transport].append(once(shape, args.latency_frames, **pkw, **plane))
    nbytes = runs["raw"][0]["bytes_per_frame"]
    raw_fps, raw_cpu = _median(runs["raw"], "frames_per_s"), _median(runs["raw"], "cpu_ms_per_frame_total")
    records = {}
    for transport in TRANSPORTS:
        fps = _median(runs[transport], "frames_per_s")
        rec = {"frame_shape": [*shape], "frame_name": shape_name, "dtype": "complex64", "bytes_per_frame": nbytes,
               "transport": transport, "hops": HOPS, "processes": HOPS + 1, "frames": args.frames,
               "repeats": args.repeats, "queue_frames": args.queue_frames,
               "frames_per_s": fps, "gb_per_s": fps * nbytes / 1e9,
               "raw_frames_per_s": raw_fps, "ratio": fps / raw_fps,
               "cpu_ratio": raw_cpu / _median(runs[transport], "cpu_ms_per_frame_total"),
               "latency_median_s": _median(runs[transport], "latency_median_s"),
               "latency_p99_s": _median(runs[transport], "latency_p99_s"),
               "frames_per_s_runs": [r["frames_per_s"] for r in runs[transport]],
               "cpu_ms_per_frame_total": _median(runs[transport], "cpu_ms_per_frame_total"),
               "cpu_ms_per_frame_by_node": {n: float(statistics.median(r["cpu_ms_per_frame_by_node"][n]
                                                                       for r in runs[transport]))
                                            for n in runs[transport][0]["cpu_ms_per_frame_by_node"]},
               "page_faults_per_frame_total": _median(runs[transport], "page_faults_per_frame_total"),
               "voluntary_switches_per_frame_total": _median(runs[transport], "voluntary_switches_per_frame_total")}
        if transport != "raw":
            rec["supervisor_cycles_per_s"] = _median(runs[transport], "supervisor_cycles_per_s")
        if paced[transport]:
            rec["paced_rate_hz"] = args.latency_rate_hz
            rec["paced_latency_median_s"] = _median(paced[transport], "latency_median_s")
            rec["paced_latency_p99_s"] = _median(paced[transport], "latency_p99_s")
        records[transport] = rec
    return records


def run(args: argparse.Namespace) -> int:
    out: list[dict[str, Any]] = []
    print(f"transport: {HOPS + 1} processes, {HOPS} hops, ipc, HWM {args.queue_frames}, {args.frames} frames, "
          f"median of {args.repeats} ({os.cpu_count()} CPUs)")
    print(f"{'frame':<18}{'transport':<10}{'frames/s':>10}{'GB/s/hop':>10}{'lat med ms':>12}{'lat p99 ms':>12}"
          f"{'paced med ms':>14}{'paced p99 ms':>14}{'cpu ms/fr':>10}{'ratio':>7}{'cpu ratio':>10}")
    for name in args.shapes:
        try:
            recs = measure(name, args)
        except RuntimeError as exc:
            print(f"dev.py bench transport: {name}: {exc}", file=sys.stderr)
            return 1
        for transport in TRANSPORTS:
            r = recs[transport]
            paced = (f"{r['paced_latency_median_s'] * 1e3:>14.3f}{r['paced_latency_p99_s'] * 1e3:>14.3f}"
                     if "paced_latency_median_s" in r else f"{'-':>14}{'-':>14}")
            label = f"{name} {r['frame_shape'][0]}x{r['frame_shape'][1]}"
            print(f"{label:<18}{transport:<10}{r['frames_per_s']:>10.1f}{r['gb_per_s']:>10.3f}"
                  f"{r['latency_median_s'] * 1e3:>12.2f}{r['latency_p99_s'] * 1e3:>12.2f}{paced}"
                  f"{r['cpu_ms_per_frame_total']:>10.3f}"
                  f"{r['ratio']:>7.2f}{r['cpu_ratio']:>10.2f}", flush=True)
            out.append(r)
    if args.json:
        bench_records.write(args.json, args, out)
    return 0
