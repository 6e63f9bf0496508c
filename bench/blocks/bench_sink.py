"""Transport benchmark sink: per-frame latency (receive time minus t_created_s) and the steady receive rate.

    latency_s[k] = time.time() at process() - header t_created_s        (one machine, one clock)
    rate         = (n - 1 - k0) / (t_recv[n-1] - t_recv[k0]),  k0 = warmup_frames (pipeline fill excluded)

Ports   in  inp   samples   frames to time
Params  warmup_frames (int, 0): frames left out of the rate and latency figures
Graph   sink = { type = "bench_sink", warmup_frames = 50 }
Summary latency_median_s, latency_p99_s, latency_max_s, frames, frames_per_s, bytes_per_frame, in_order,
        cpu_ms_per_frame (this process, all threads; the source and pass blocks report it too)
"""
import time

from bench.blocks._common import cpu_figures, cpu_s, figures, profile_start, profile_stop
from carav_stream.runtime.block import Block, In, Param
from carav_stream.runtime.frames import Frame


class BenchSink(Block):
    inputs = (In("inp", kind="samples"),)
    params = (Param("warmup_frames", int, 0, "frames left out of the figures", low=0),)

    def start(self) -> None:
        self.t_recv: list[float] = []
        self.latency_s: list[float] = []
        self.nbytes = 0
        self.next_seq = 0
        self.in_order = True
        self.profiler = profile_start("sink")
        self.cpu0 = cpu_s()
        self.cpu: dict = {}

    def process(self, inp: Frame) -> None:
        now = time.time()
        self.t_recv.append(time.perf_counter())
        self.latency_s.append(now - inp.header["t_created_s"])
        self.in_order &= inp.seq == self.next_seq
        self.next_seq = inp.seq + 1
        self.nbytes = sum(a.nbytes for a in inp.arrays.values())
        return None

    def finish(self) -> None:
        self.cpu = cpu_figures(self.cpu0, len(self.t_recv))
        profile_stop(self.profiler)

    def summary(self) -> dict:
        return {**figures(self.t_recv, self.latency_s, self.warmup_frames, self.nbytes, self.in_order), **self.cpu}

