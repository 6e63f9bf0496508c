"""carav bench pipeline: cycles/s of the multi-process radar graph against the same chain in one process.

For each case (table1 at beat and at waveform fidelity, awr1642 at beat) and mode:
  pipeline       the 8-node graph of graphs/radar_chain.toml (smart attacker from half the run on), one process per
                 node, run by the supervisor, frames of --batch cycles; cycles/s from go to the last sink
  fused          carav_stream.algorithm1.run_algorithm1 in one fresh process started like a node (the same allocator
                 and BLAS settings, supervisor.NODE_ENV), in batches of the same --batch cycles (the same
                 work per cycle, the same vectorisation; scene templates built before the clock starts, as
                 the channel node builds them before the run starts)
Each figure is the median of --repeats runs; the real-time factor is cycles/s over the radar's own cycle
rate (table1: 1 / (64 x 7.33 us) = 2131 cycles/s); the bottleneck is the node with the most busy time.
Noise and attacks are fresh and i.i.d. in every cycle and every cycle is processed in full.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

from carav_graphs import graph_file
from carav_stream.algorithm1 import run_algorithm1
from carav_stream.bench import records as bench_records
from carav_stream.cli.options import count, number, output_file
from carav_stream.radar.physics import echo_templates
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.supervisor import NODE_ENV, Supervisor

CASES = (("table1", "beat", 2000), ("table1", "waveform", 1000), ("awr1642", "beat", 1000))


def pipeline_overrides(preset: str, fidelity: str, n: int, method: str, batch: int) -> list[str]:
    """`--set` values that make graphs/radar_chain.toml the graph of one benchmark case (the smart attacker from
    half the run on, as in the fused chain)."""
    return [f"scene={preset}", f"fidelity={fidelity}", f"batch={batch}", "seed=5", "attacker.model=smart",
            "attacker.rarms=3.0", f"attacker.start_cycle={n // 2}", f"ranging.method={method}"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")
    parser.add_argument("--repeats", type=count(1), default=3, help="runs per case and mode (median reported)")
    parser.add_argument("--scale", type=number(0.0, strict=True), default=1.0, help="multiply the cycles of every case")
    parser.add_argument("--batch", default="16,32", help="cycles per frame (pipeline) and per call (fused); a comma "
                        "list runs each (default: the blocks' default 16 and the table1 graphs' 32)")
    parser.add_argument("--method", default="ml", help="range estimator of the graph and the fused chain")
    parser.add_argument("--cases", default="all", help="comma list of preset:fidelity, or all")


def _pipeline(preset: str, fidelity: str, n: int, method: str, batch: int) -> tuple[float, dict]:
    graph = load_graph(graph_file("radar_chain"), pipeline_overrides(preset, fidelity, n, method, batch))
    summary = Supervisor(graph, cycles=n, progress=False, log=lambda text: None).run()
    if summary["failures"] or summary["lost"] or summary["cycles_judged"] != n:
        raise RuntimeError(f"pipeline run of {preset}/{fidelity} failed: {summary['failures']} lost {summary['lost']}")
    busy = {node: p["busy_s"] / n * 1e6 for node, p in summary["per_node"].items()}
    return summary["throughput_cycles_per_s"], busy


_WORKER = ("import json, sys; from carav_stream.bench.pipeline import _fused_worker; "
           "print(json.dumps(_fused_worker(*json.loads(sys.argv[1]))))")


def _fused(preset: str, fidelity: str, n: int, method: str, batch: int) -> tuple[float, float]:
    """cycles/s and CPU us per cycle of run_algorithm1 in a fresh process started as the supervisor starts a node."""
    args = json.dumps([preset, fidelity, n, method, batch])
    out = subprocess.run([sys.executable, "-c", _WORKER, args], env={**NODE_ENV, **os.environ},
                         capture_output=True, text=True, timeout=1800)
    if out.returncode:
        raise RuntimeError(f"fused run of {preset}/{fidelity} failed:\n{out.stderr[-2000:]}")
    rate, cpu_us = json.loads(out.stdout.splitlines()[-1])
    return rate, cpu_us


def _fused_worker(preset: str, fidelity: str, n: int, method: str, batch: int) -> tuple[float, float]:
    scene = scene_of(preset)
    echo_templates(scene, fidelity)   # built once per scene, like the channel node does before the run starts
    t0, c0 = time.perf_counter(), time.process_time()
    run_algorithm1(scene, n, seed=5, attack="smart", attack_params={"rarms": 3.0, "start_cycle": n // 2},
                   method=method, fidelity=fidelity, batch=batch)
    return n / (time.perf_counter() - t0), (time.process_time() - c0) / n * 1e6


def run(args: argparse.Namespace) -> int:
    wanted = None if args.cases == "all" else {tuple(c.split(":")) for c in args.cases.split(",")}
    batches = [int(b) for b in str(args.batch).split(",")]
    records = []
    for preset, fidelity, n in CASES:
        if wanted and (preset, fidelity) not in wanted:
            continue
        n = max(20, int(n * args.scale))
        rate_radar = scene_of(preset).cycles_per_s
        for batch in batches:
            runs = {"pipeline": [], "fused": []}
            busy_runs, fused_cpu = [], []
            for _ in range(args.repeats):   # modes interleaved: the ratios compare like with like
                rate, busy = _pipeline(preset, fidelity, n, args.method, batch)
                runs["pipeline"].append(rate)
                busy_runs.append(busy)
                rate, cpu_us = _fused(preset, fidelity, n, args.method, batch)
                runs["fused"].append(rate)
                fused_cpu.append(cpu_us)
            busy = {node: statistics.median(b[node] for b in busy_runs) for node in busy_runs[0]}
            bottleneck = max(busy, key=busy.get)
            fused = statistics.median(runs["fused"])
            for mode, rates in runs.items():
                rate = statistics.median(rates)
                rec = {"preset": preset, "fidelity": fidelity, "mode": mode, "batch": batch, "cycles": n,
                       "repeats": args.repeats, "method": args.method, "cycles_per_s": rate,
                       "runs_cycles_per_s": rates, "real_time_factor": rate / rate_radar,
                       "radar_cycles_per_s": rate_radar, "speedup_over_fused": rate / fused}
                if mode == "pipeline":
                    rec["bottleneck_node"] = bottleneck
                    rec["busy_us_per_cycle"] = busy
                else:
                    rec["cpu_us_per_cycle"] = statistics.median(fused_cpu)
                records.append(rec)
                print(f"{preset:<8} {fidelity:<8} batch {batch:<3} {mode:<8} {rate:9.1f} cycles/s  real-time "
                      f"x{rate / rate_radar:6.3f}  vs fused x{rate / fused:5.2f}"
                      + (f"  bottleneck {bottleneck} ({busy[bottleneck]:.0f} us/cycle)" if mode == "pipeline" else ""),
                      flush=True)
    if args.json:
        bench_records.write(args.json, args, records)
    return 0


if __name__ == "__main__":
    from carav_stream.cli import run_as_command
    raise SystemExit(run_as_command("carav_stream.bench.pipeline"))
