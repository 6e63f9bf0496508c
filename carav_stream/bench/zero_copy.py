"""`carav bench zerocopy`: one same-host hop for the large frames, by three data planes (issue 18's evaluation).

A producer process writes every frame (np.copyto of a prepared array: the cost of writing its output, the same
in every mode) and hands it to a consumer process, which reads it whole (a sum over its values) and lets it go:

    zmq   pyzmq PUSH/PULL over ipc://, the frame sent without a copy in Python (copy=False); the kernel copies it
          into the socket buffer and out again (today's data plane)
    shm   multiprocessing.shared_memory: a ring of --slots slots, the producer writes into a free slot, a ZeroMQ
          message names the slot, the consumer reads it in place and sends the slot back when done (back-pressure:
          the producer waits for a free slot)
    iox   iceoryx2 publish-subscribe of a byte slice: the producer loans a sample in iceoryx2's shared memory,
          writes into it and sends it; an iceoryx2 event wakes the consumer, which reads the sample in place and
          releases it (the subscriber buffer holds --slots samples; a full buffer makes the publisher retry, no
          overwrite; a send that still reaches no subscriber, seen in about one run in twenty, is sent again and
          counted in `resent`)

Frames: 563 200 bytes (one Table I cycle, 64 x 1100 complex64) and 262 144 bytes (AWR1642, 128 x 256 complex64).
Figures, medians over --repeats rounds with the modes interleaved: frames/s (consumer side, first to last frame),
CPU per frame of both processes together (process time), and each shared-memory mode over zmq in the same round.
iox is skipped, and the record says so, when the iceoryx2 package is not installed (the `zerocopy` extra).
"""
from __future__ import annotations

import argparse
import ctypes
import multiprocessing as mp
import os
import statistics
import tempfile
import time

import numpy as np

from carav_stream.bench import records as bench_records
from carav_stream.cli.options import count, output_file

FRAMES = {"table1": 563_200, "awr1642": 262_144}
MODES = ("zmq", "shm", "iox")
TIMEOUT_S = 120.0


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")
    parser.add_argument("--frames", type=count(10), default=3000, help="frames per run")
    parser.add_argument("--repeats", type=count(1), default=5, help="rounds of the modes (median reported)")
    parser.add_argument("--slots", type=count(2), default=4, help="slots (shm) or subscriber buffer (iox)")


def iceoryx2_missing() -> str | None:
    try:
        import iceoryx2  # noqa: F401
    except ImportError:
        return "the iceoryx2 package is not installed (pip install 'carav-stream[zerocopy]')"
    return None


def _source(nbytes: int) -> np.ndarray:
    return np.random.default_rng(0).standard_normal(nbytes // 4).astype(np.float32)


# -- zmq ------------------------------------------------------------------------------------------------------
def _zmq_producer(ep: str, nbytes: int, n: int, slots: int, out) -> None:
    import zmq
    ctx = zmq.Context()
    sock = ctx.socket(zmq.PUSH)
    sock.sndhwm = slots
    sock.connect(ep)
    src = _source(nbytes)
    c0 = time.process_time()
    for i in range(n):
        buf = np.empty_like(src)           # a zero-copy send keeps the buffer: a new output per frame
        np.copyto(buf, src)
        sock.send_multipart([i.to_bytes(8, "little"), buf], copy=False)
    out.put(("producer", time.process_time() - c0))
    sock.close(linger=-1)
    ctx.term()


def _zmq_consumer(ep: str, nbytes: int, n: int, slots: int, out) -> None:
    import zmq
    ctx = zmq.Context()
    sock = ctx.socket(zmq.PULL)
    sock.rcvhwm = slots
    sock.bind(ep)
    out.put(("ready", None))
    c0, t0, total = time.process_time(), None, 0.0
    for _ in range(n):
        parts = sock.recv_multipart(copy=False)
        t0 = t0 or time.perf_counter()
        total += float(np.frombuffer(parts[1].buffer, np.float32).sum())
    out.put(("consumer", (time.perf_counter() - t0, time.process_time() - c0)))
    sock.close(linger=0)
    ctx.term()


# -- multiprocessing.shared_memory ring + ZeroMQ notifications --------------------------------------------------
def _attach(name: str, nbytes: int, slots: int):
    """The segment `name` and a float32 view of each of its slots."""
    from multiprocessing import shared_memory
    shm = shared_memory.SharedMemory(name=name)
    return shm, [np.ndarray(nbytes // 4, np.float32, shm.buf, offset=k * nbytes) for k in range(slots)]


def _shm_producer(name: str, ep_note: str, ep_free: str, nbytes: int, n: int, slots: int, out) -> None:
    import zmq
    shm, views = _attach(name, nbytes, slots)
    ctx = zmq.Context()
    note, free = ctx.socket(zmq.PUSH), ctx.socket(zmq.PULL)
    note.connect(ep_note)
    free.bind(ep_free)
    src, avail = _source(nbytes), list(range(slots))
    c0 = time.process_time()
    for i in range(n):
        while not avail:                          # back-pressure: wait for the consumer to give a slot back
            avail.append(int.from_bytes(free.recv(), "little"))
        k = avail.pop(0)
        np.copyto(views[k], src)                  # the output written into the slot itself
        note.send(i.to_bytes(8, "little") + k.to_bytes(4, "little"))
    out.put(("producer", time.process_time() - c0))
    del views
    note.close(linger=-1)
    free.close(linger=0)
    ctx.term()
    shm.close()


def _shm_consumer(name: str, ep_note: str, ep_free: str, nbytes: int, n: int, slots: int, out) -> None:
    import zmq
    shm, views = _attach(name, nbytes, slots)
    ctx = zmq.Context()
    note, free = ctx.socket(zmq.PULL), ctx.socket(zmq.PUSH)
    note.bind(ep_note)
    free.connect(ep_free)
    out.put(("ready", None))
    c0, t0, total = time.process_time(), None, 0.0
    for _ in range(n):
        msg = note.recv()
        t0 = t0 or time.perf_counter()
        k = int.from_bytes(msg[8:], "little")
        total += float(views[k].sum())            # read in place
        free.send(k.to_bytes(4, "little"))
    out.put(("consumer", (time.perf_counter() - t0, time.process_time() - c0)))
    del views
    note.close(linger=0)
    free.close(linger=-1)
    ctx.term()
    shm.close()


# -- iceoryx2 -------------------------------------------------------------------------------------------------
def _iox():
    import iceoryx2 as iox
    iox.set_log_level(iox.LogLevel.Error)          # not its notice that it runs on its default configuration
    return iox


def _iox_service(node, iox, name: str, slots: int):
    return (node.service_builder(iox.ServiceName.new(name)).publish_subscribe(iox.Slice[ctypes.c_uint8])
            .enable_safe_overflow(False).subscriber_max_buffer_size(slots).open_or_create())


def _iox_producer(name: str, nbytes: int, n: int, slots: int, out, start) -> None:
    iox = _iox()
    node = iox.NodeBuilder.new().create(iox.ServiceType.Ipc)
    pub = (_iox_service(node, iox, name, slots).publisher_builder().initial_max_slice_len(nbytes)
           .backpressure_strategy(iox.BackpressureStrategy.RetryUntilDelivered).create())
    notifier = node.service_builder(iox.ServiceName.new(name + "/ev")).event().open_or_create() \
        .notifier_builder().create()
    src = _source(nbytes)
    start.get(timeout=TIMEOUT_S)                  # the subscriber exists ...
    pub.update_connections()                      # ... and the publisher has connected to it: nothing goes nowhere
    c0, resent = time.process_time(), 0
    for _ in range(n):
        while True:
            sample = pub.loan_slice_uninit(nbytes)
            np.copyto(np.frombuffer(sample.payload().as_memory_view(), np.float32), src)
            if sample.assume_init().send() == 1:
                break
            resent += 1                           # seen: a full subscriber buffer despite RetryUntilDelivered
            notifier.notify()
            time.sleep(1e-4)
        notifier.notify()
    out.put(("producer", time.process_time() - c0))
    out.put(("resent", resent))
    start.get(timeout=TIMEOUT_S)                  # stay until the consumer has read everything


def _iox_consumer(name: str, nbytes: int, n: int, slots: int, out, start) -> None:
    iox = _iox()
    node = iox.NodeBuilder.new().create(iox.ServiceType.Ipc)
    sub = _iox_service(node, iox, name, slots).subscriber_builder().buffer_size(slots).create()
    listener = node.service_builder(iox.ServiceName.new(name + "/ev")).event().open_or_create() \
        .listener_builder().create()
    out.put(("ready", None))
    start.put("go")
    c0, t0, total, got = time.process_time(), None, 0.0, 0
    while got < n:
        listener.timed_wait(iox.Duration.from_millis(100))
        while (sample := sub.receive()) is not None:
            t0 = t0 or time.perf_counter()
            total += float(np.frombuffer(sample.payload().as_memory_view(), np.float32).sum())   # in place
            del sample                                                                             # released
            got += 1
    out.put(("consumer", (time.perf_counter() - t0, time.process_time() - c0)))
    start.put("done")


def run_once(mode: str, nbytes: int, n: int, slots: int) -> tuple[float, float, int]:
    """(frames/s, CPU us per frame of both processes, frames iox had to send again) of one run."""
    ctx = mp.get_context("spawn")
    out = ctx.Queue()
    folder = tempfile.mkdtemp(prefix="carav-zc-")
    shm = None
    if mode == "zmq":
        ep = f"ipc://{folder}/data"
        consumer = ctx.Process(target=_zmq_consumer, args=(ep, nbytes, n, slots, out))
        producer = ctx.Process(target=_zmq_producer, args=(ep, nbytes, n, slots, out))
    elif mode == "shm":
        from multiprocessing import shared_memory
        shm = shared_memory.SharedMemory(create=True, size=slots * nbytes)
        eps = (f"ipc://{folder}/note", f"ipc://{folder}/free")
        consumer = ctx.Process(target=_shm_consumer, args=(shm.name, *eps, nbytes, n, slots, out))
        producer = ctx.Process(target=_shm_producer, args=(shm.name, *eps, nbytes, n, slots, out))
    else:
        start = ctx.Queue()
        name = f"carav/zc/{os.getpid()}/{time.monotonic_ns()}"
        consumer = ctx.Process(target=_iox_consumer, args=(name, nbytes, n, slots, out, start))
        producer = ctx.Process(target=_iox_producer, args=(name, nbytes, n, slots, out, start))
    try:
        consumer.start()
        got = dict([out.get(timeout=TIMEOUT_S)])
        producer.start()
        for _ in range(3 if mode == "iox" else 2):
            key, value = out.get(timeout=TIMEOUT_S)
            got[key] = value
        wall, consumer_cpu = got["consumer"]
        return n / wall, (got["producer"] + consumer_cpu) / n * 1e6, got.get("resent", 0)
    finally:
        for p in (producer, consumer):
            p.join(10)
            if p.is_alive():
                p.kill()
        if shm is not None:
            shm.close()
            shm.unlink()
        for f in os.listdir(folder):
            os.unlink(os.path.join(folder, f))
        os.rmdir(folder)


def run(args: argparse.Namespace) -> int:
    missing = iceoryx2_missing()
    modes = [m for m in MODES if m != "iox" or missing is None]
    records = []
    for frame, nbytes in FRAMES.items():
        runs: dict[str, list[tuple[float, float, int]]] = {m: [] for m in modes}
        for _ in range(args.repeats):
            for mode in modes:
                runs[mode].append(run_once(mode, nbytes, args.frames, args.slots))
        rec = {"frame": frame, "bytes": nbytes, "frames": args.frames, "repeats": args.repeats, "slots": args.slots,
               "iox": "skipped: " + missing if missing else "measured"}
        for mode in modes:
            fps = [r[0] for r in runs[mode]]
            cpu = [r[1] for r in runs[mode]]
            rec[mode] = {"frames_per_s": statistics.median(fps), "runs_frames_per_s": fps,
                         "cpu_us_per_frame": statistics.median(cpu), "runs_cpu_us_per_frame": cpu,
                         "resent": [r[2] for r in runs[mode]]}
            if mode != "zmq":
                rec[mode]["ratio_to_zmq"] = statistics.median(
                    [a[0] / b[0] for a, b in zip(runs[mode], runs["zmq"])])
                rec[mode]["cpu_ratio_to_zmq"] = statistics.median(
                    [a[1] / b[1] for a, b in zip(runs[mode], runs["zmq"])])
            ratio = f"  x{rec[mode]['ratio_to_zmq']:.2f} zmq" if mode != "zmq" else ""
            print(f"{frame:<8} {nbytes:>7} B  {mode:<4} {rec[mode]['frames_per_s']:8.0f} frames/s  "
                  f"{rec[mode]['cpu_us_per_frame']:6.1f} us CPU/frame{ratio}", flush=True)
        records.append(rec)
    if missing:
        print(f"iox: skipped: {missing}")
    if args.json:
        bench_records.write(args.json, args, records)
    return 0


if __name__ == "__main__":
    from carav_stream.cli import run_as_command
    raise SystemExit(run_as_command("carav_stream.bench.zero_copy"))
