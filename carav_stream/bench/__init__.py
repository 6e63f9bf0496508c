"""Benchmarks (`carav bench NAME`): JSON records, summarised in BENCHMARKS.md.

wire           transport: frames/s and CPU per hop through a chain of processes, against raw pyzmq
signal_chain   synth: signal-chain time per cycle by preset, fidelity and attacker
detection      detector: numerical stability, ns/sample, Monte Carlo speed
estimation     estimators: run time against error, beside the Cramer-Rao bound
pipeline       the multi-process radar graph against the same chain in one process
soak           the demo graph for minutes with live swaps: memory and descriptor growth, lost cycles
records        what every benchmark writes with --json: command, machine, records
report         BENCHMARKS.md and docs/bench/*.md rendered from those records
blocks/        the benchmark's own blocks (source, pass-through, sink)
"""
