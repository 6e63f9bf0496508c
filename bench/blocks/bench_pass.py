"""Transport benchmark pass-through: forwards the received read-only payload unchanged, without a copy.

Ports   in  inp   samples              frames to forward
        out out   samples, complex64   the same arrays (Frame.derive(keep_data=True)), new hop stamps
Graph   p1 = { type = "bench_pass" }
Summary frames, cpu_ms_per_frame (this node process, all threads), page_faults_per_frame, ...
"""
from bench.blocks._common import cpu_figures, cpu_s, profile_start, profile_stop
from carav_stream.runtime.block import Block, In, Out
from carav_stream.runtime.frames import Frame


class BenchPass(Block):
    inputs = (In("inp", kind="samples"),)
    outputs = (Out("out", kind="samples", dtypes=("complex64",)),)

    def start(self) -> None:
        self.profiler = profile_start("pass")
        self.n = 0
        self.cpu0 = cpu_s()
        self.cpu: dict = {}

    def process(self, inp: Frame) -> Frame:
        self.n += 1
        return inp.derive(keep_data=True)

    def finish(self) -> None:
        self.cpu = cpu_figures(self.cpu0, self.n)
        profile_stop(self.profiler)

    def summary(self) -> dict:
        return {"frames": self.n, **self.cpu}
