"""Transport benchmark source: sends one pre-built complex64 array of shape (n_chirps, n_samples) every cycle.

The array is built once in start() and reused for every frame (this block measures transport, not synthesis);
the runtime stamps t_created_s when the frame is sent. With rate_hz > 0 the source is paced (latency runs
without queueing); with rate_hz = 0 it sends as fast as its consumers take frames (throughput runs).

Ports   out out   complex64 (n_chirps, n_samples)   the same array every cycle
Params  n_chirps (int, 64), n_samples (int, 1100), rate_hz (float, 0.0; 0 = unpaced)
Graph   src = { type = "bench_source", n_chirps = 128, n_samples = 256 }
Summary frames, cpu_ms_per_frame (this node process, all threads), page_faults_per_frame, ...
"""
import time

import numpy as np

from bench.blocks._common import cpu_figures, cpu_s, profile_start, profile_stop
from carav_stream.runtime.block import Block, Out, Param
from carav_stream.runtime.frames import Frame


class BenchSource(Block):
    outputs = (Out("out", kind="samples", dtypes=("complex64",)),)
    params = (Param("n_chirps", int, 64, "rows of the payload", low=1),
              Param("n_samples", int, 1100, "columns of the payload", low=1),
              Param("rate_hz", float, 0.0, "frames per second; 0 = as fast as the consumers take them", low=0.0,
                    unit="Hz"))

    def start(self) -> None:
        rng = np.random.default_rng(0)
        shape = (self.n_chirps, self.n_samples)
        data = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(np.complex64)
        data.flags.writeable = False
        self.data = data
        self.t_next = None
        self.profiler = profile_start("source")
        self.n = 0
        self.cpu0 = cpu_s()
        self.cpu: dict = {}

    def generate(self, seq: int) -> Frame:
        if self.rate_hz:
            now = time.monotonic()
            if self.t_next is None:
                self.t_next = now
            if self.t_next > now:
                time.sleep(self.t_next - now)
            self.t_next += 1.0 / self.rate_hz
        self.n += 1
        return Frame.of(self.data)

    def finish(self) -> None:
        self.cpu = cpu_figures(self.cpu0, self.n)
        profile_stop(self.profiler)

    def summary(self) -> dict:
        return {"frames": self.n, **self.cpu}
