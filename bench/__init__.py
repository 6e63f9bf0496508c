"""Benchmarks, outside the installed package: `python3 dev.py bench NAME` (or `python -m bench NAME` from the
repository's root). Each writes JSON records with --json docs/bench/records/NAME.json; `report` renders
BENCHMARKS.md and docs/bench/*.md from them.

transport    frames/s and CPU per hop through a chain of processes, against raw pyzmq
synth        signal-chain time per cycle by preset, fidelity and attacker
detector     detector: numerical stability, ns/sample, Monte Carlo speed
compiled     the hot kernels in numpy against numba-compiled loops (AVX-512 and AVX2 code), numba's start cost
compiled_loops  numba's loops of compiled, and what a process running them pays at start (a node, a zygote)
estimators   run time against error, beside the Cramer-Rao bound
pipeline     the multi-process radar graph against the same chain in one process
study        carav study on 1 and 2 local Dask workers; the scheduler's cost per task
view         what the live view costs the radar chain, with and without a browser
dca1000_udp  the live DCA1000 UDP receiver fed by the project's replayer, against the AWR1642's data rate
gr_bridge    the GNU Radio bridge each way (gr_zmq_sink, gr_zmq_source) with GNU Radio and pyzmq peers, beside raw pyzmq
gr_peer      the GNU Radio flowgraphs the gr_bridge benchmark runs under the system's Python (never imported)
soak         the demo graph for minutes with live swaps: memory and descriptor growth, lost cycles
startup      a graph's start with its nodes forked from the zygote and as fresh interpreters: wall, restart, memory
compare      one benchmark on an older revision and on this tree, alternated round by round: medians and ratios
report       BENCHMARKS.md and docs/bench/*.md rendered from the records
pages        the head of each docs/bench page (command, module, record file) from the list below
records      what every benchmark writes with --json: command, machine, records
browser      the headless Chromium (Selenium) that the view benchmark and the live view's browser test drive
blocks/      the transport benchmark's own blocks (source, pass-through, sink)
"""
from __future__ import annotations

from carav_stream.cli import main as _carav_main

BENCHES = {
    "transport": ("bench.transport", "frames/s, GB/s and latency through a chain of processes"),
    "synth": ("bench.synth", "signal-chain time per cycle by preset, fidelity and attacker"),
    "detector": ("bench.detector", "detector stability, ns/sample and Monte Carlo speed"),
    "compiled": ("bench.compiled", "the hot kernels in numpy against numba loops; numba's start cost"),
    "estimators": ("bench.estimators", "run time against error of the range/velocity estimators"),
    "pipeline": ("bench.pipeline", "cycles/s of the multi-process graph against one process"),
    "study": ("bench.study", "carav study on 1 and 2 local Dask workers; scheduler cost per task"),
    "view": ("bench.view", "what the live view costs the radar chain, with and without a browser"),
    "dca1000-udp": ("bench.dca1000_udp", "the live DCA1000 receiver against the AWR1642's data rate"),
    "gr-bridge": ("bench.gr_bridge", "the GNU Radio bridge's items/s each way, beside raw pyzmq"),
    "chaos": ("bench.chaos", "SIGKILL a random node every 2 s on both planes: nothing judged twice, counts right"),
    "soak": ("bench.soak", "the demo graph for N minutes with live swaps: memory, descriptors, losses"),
    "startup": ("bench.startup", "a graph's start, nodes forked from the zygote or fresh: wall, restart, memory"),
    "compare": ("bench.compare", "one benchmark on an older revision and on this tree, alternated: medians, ratios"),
    "report": ("bench.report", "render BENCHMARKS.md and docs/bench/*.md from the benchmark records"),
}



def main(argv: list[str] | None = None) -> int:
    """One benchmark command line (default sys.argv), on the parser and error handling of `carav`."""
    return _carav_main(argv, prog="dev.py bench", description=__doc__, commands=BENCHES, groups={})
