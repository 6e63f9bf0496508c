"""`python3 dev.py bench pipeline`: cycles/s of the multi-process radar graph against the same chain in one process.

For each case (table1 at beat and at waveform fidelity, awr1642 at beat, awr1642_mimo, its 2 TX x 4 RX array, at
waveform) and mode:
  pipeline       the 8-node graph of graphs/radar_chain.toml (smart attacker from half the run on), one process per
                 node, run by the supervisor, frames of --batch cycles; cycles/s from go to the last sink
  fused          carav_stream.firmware.algorithm1.run_algorithm1 in one fresh process started like a node (the
                 same allocator and BLAS settings, supervisor.NODE_ENV), in batches of the same --batch cycles (the same
                 work per cycle, the same vectorisation; scene templates built before the clock starts, as
                 the channel node builds them before the run starts)
  tracker        the pipeline graph with the tracker of graphs/table1_tracks.toml added after the target list
                 (ranging.estimates and gate.alarms in, as in that graph), run right after a pipeline of the same
                 repeat on the same scene; its cycles/s over that pipeline's, repeat by repeat, and the loss 1 - that
                 ratio (target: at most TRACKER_LOSS_TARGET). The scene is TRACKER_SCENES's for the case's preset:
                 for table1, table1_following (Table I's radar behind the car at its own speed, the scene of
                 graphs/table1_tracks.toml). The simulator starts every cycle from the scene's ranges, so a target
                 with a range rate (table1's car closes at 4 km/h) never moves while its Doppler says it does: no
                 constant-velocity track follows it, and a tracker there spends its time deleting tracks and starting
                 new ones (validation warns). On the other presets the case's own scene is kept, and the record's
                 tracks born and deleted say how much of the tracker's cost is that churn.
Each figure is the median of --repeats runs; the real-time factor is cycles/s over the radar's own cycle
rate (table1: 1 / (64 x 7.33 us) = 2131 cycles/s); the bottleneck is the node with the most busy time. Each
node's busy time is also given per sample (us per cycle over the cycle's real values, table1 64 x 1080, every
receiver's for an array), to set
beside the kernels' costs and bounds of `bench synth` and `bench detector`.
Noise and attacks are fresh and i.i.d. in every cycle and every cycle is processed in full.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from bench import records as bench_records
from carav_graphs import graph_file
from carav_stream.capture.sigmf_io import open_recording
from carav_stream.cli.record import record_graph
from carav_stream.cli.replay import overrides_for
from carav_stream.console.options import count, number, output_file
from carav_stream.estimate import METHODS
from carav_stream.firmware.algorithm1 import run_algorithm1
from carav_stream.radar.arrays import receiver_echoes
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.graph import TRANSPORTS
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.supervisor import NODE_ENV, Supervisor

CASES = (("table1", "beat", 2000), ("table1", "waveform", 1000), ("awr1642", "beat", 1000),
         ("awr1642_mimo", "waveform", 1000))
MODES = ("pipeline", "tracker", "fused", "record", "replay")
EXTRA_MODES = ("record", "replay", "tracker")
TRACKER_LOSS_TARGET = 0.05     # the tracker may cost the graph at most this share of its cycles/s
TRACKER_JUDGED = "table1"      # ... judged on this scene's graph, every paired run of its cases pooled (tracker_pooled)
TRACKER_SCENES = {"table1": "table1_following"}   # the tracker's paired runs: a scene its motion model holds on


def tracker_scene(preset: str) -> str:
    """The scene of the tracker's paired runs for a case of `preset` (TRACKER_SCENES, else the preset's own)."""
    return TRACKER_SCENES.get(preset, preset)


def _modes(text: str) -> list[str]:
    wanted = [] if text == "none" else text.split(",")
    if set(wanted) - set(EXTRA_MODES) or "replay" in wanted and "record" not in wanted:
        raise argparse.ArgumentTypeError(f"expected a comma list of {', '.join(EXTRA_MODES)} (replay needs record), "
                                         f"or none, got {text!r}")
    return wanted


def pipeline_overrides(preset: str, fidelity: str, n: int, method: str, batch: int,
                       transport: str = "zmq") -> list[str]:
    """`--set` values that make graphs/radar_chain.toml the graph of one benchmark case (the smart attacker from
    half the run on, as in the fused chain), its arrays over `transport`."""
    return [f"scene={preset}", f"fidelity={fidelity}", f"batch={batch}", "seed=5", "attacker.model=smart",
            "attacker.rarms=3.0", f"attacker.start_cycle={n // 2}", f"ranging.method={method}",
            f"run.transport={transport}"]


def _transports(text: str) -> list[str]:
    wanted = text.split(",")
    if not wanted or set(wanted) - set(TRANSPORTS):
        raise argparse.ArgumentTypeError(f"expected a comma list of {', '.join(TRANSPORTS)}, got {text!r}")
    return wanted


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")
    parser.add_argument("--repeats", type=count(1), default=3, help="runs per case and mode (median reported)")
    parser.add_argument("--scale", type=number(0.0, strict=True), default=1.0, help="multiply the cycles of every case")
    parser.add_argument("--batch", default="16,32", help="cycles per frame (pipeline) and per call (fused); a comma "
                        "list runs each (default: the blocks' default 16 and the table1 graphs' 32)")
    parser.add_argument("--method", default="ml", choices=METHODS,
                        help="range estimator of the graph and the fused chain")
    parser.add_argument("--cases", default="all", help="comma list of preset:fidelity, or all")
    parser.add_argument("--transport", default=",".join(TRANSPORTS), type=_transports,
                        help="data planes of the pipeline runs: zmq (arrays in ZeroMQ messages), shm (in shared "
                        "memory, runtime/shm.py), or both as a comma list (record and replay use the first)")
    parser.add_argument("--with", dest="with_modes", default=list(EXTRA_MODES), type=_modes, metavar="MODES",
                        help="extra modes beside pipeline and fused, a comma list: record, replay (needs record), "
                        "tracker (the graph with the tracker after the target list); or none (default: all three)")


def _run(graph, n: int, what: str) -> dict:
    summary = Supervisor(graph, cycles=n, progress=False, log=lambda text: None).run()
    if summary["failures"] or summary["lost"] or summary["cycles_judged"] != n:
        raise RuntimeError(f"{what} failed: {summary['failures']} lost {summary['lost']}")
    return summary


def outside_blocks(summary: dict, n: int) -> dict[str, float]:
    """us per cycle each node spends outside its block from its first frame on (the ZeroMQ I/O thread, decoding,
    pairing, sending, shared-memory slots, control): what only the pipeline spends, beside the kernels."""
    return {node: max(p["cpu_working_s"] - p["busy_s"], 0.0) / n * 1e6 for node, p in summary["per_node"].items()}


def ceiling(busy: dict[str, float], outside: dict[str, float], cores: int) -> tuple[float, str]:
    """The most cycles/s a graph whose nodes spend these CPU times per cycle (us, inside and outside their blocks)
    can make on `cores` cores. A node's block runs on its main thread, one frame after another, so the node allows
    1 / (its busy time per cycle); what it spends outside the block may run beside it (ZeroMQ's I/O thread), so
    that counts only toward the cores, which allow cores / (the sum of everything). Returns (cycles/s, what binds:
    the node's name, or "N cores")."""
    node = max(busy, key=busy.get)
    one_node = 1e6 / busy[node]
    shared = cores * 1e6 / (sum(busy.values()) + sum(outside.get(n, 0.0) for n in busy))
    return (one_node, node) if one_node <= shared else (shared, f"{cores} core{'s' if cores != 1 else ''}")


def tracker_graph(folder: Path) -> Path:
    """Write FOLDER/tracker_chain.toml: graphs/radar_chain.toml with the tracker of graphs/table1_tracks.toml (its
    own parameters, the graph-wide ones left to the including graph) on the estimator's target list and the gate's
    refusals, wired as in that graph; returns its path. The tracks go nowhere: what is measured is the tracker."""
    tracks = load_graph(graph_file("table1_tracks"))
    own = {k: v for k, v in tracks.nodes["tracker"].params.items() if k not in tracks.params}
    fields = ", ".join(f"{k} = {json.dumps(v)}" for k, v in {"type": "tracker", **own}.items())
    wires = [f"{e.src}.{e.src_port} -> {e.dst}.{e.dst_port}" for e in tracks.edges if e.dst == "tracker"]
    path = folder / "tracker_chain.toml"
    path.write_text(f"include = {json.dumps(str(graph_file('radar_chain')))}\n"
                    f"connections = {json.dumps(wires)}\n\n[blocks]\ntracker = {{ {fields} }}\n")
    return path


def _pipeline(preset: str, fidelity: str, n: int, method: str, batch: int, transport: str,
              record_to: Path | None = None, tracker: bool = False) -> tuple[float, dict, dict]:
    """cycles/s, busy us per cycle by node, and the run summary; with record_to, the graph with its recorder
    (carav record) writing into that folder; with tracker, the graph with the tracker (tracker_graph)."""
    overrides = pipeline_overrides(preset, fidelity, n, method, batch, transport)
    with tempfile.TemporaryDirectory(prefix="carav-bench-") as folder:
        graph = load_graph(tracker_graph(Path(folder)) if tracker else graph_file("radar_chain"), overrides)
        if record_to is not None:
            graph = load_graph(record_graph(graph, record_to, overrides), overrides)
        what = "record" if record_to else "tracker" if tracker else "pipeline"
        summary = _run(graph, n, f"{what} run of {preset}/{fidelity}")
    busy = {node: p["busy_s"] / n * 1e6 for node, p in summary["per_node"].items()}
    return summary["throughput_cycles_per_s"], busy, summary


def _replay(folder: Path, n: int, method: str, transport: str) -> tuple[float, dict]:
    """cycles/s and busy us per cycle of graphs/replay.toml on the recording in `folder` (carav replay)."""
    rec = open_recording(folder, verify_hash=False)
    overrides = [*overrides_for(rec, "source", {}, recorded_settings=False), f"ranging.method={method}",
                 f"run.transport={transport}"]
    summary = _run(load_graph(graph_file("replay"), overrides), n, f"replay of {folder}")
    return summary["throughput_cycles_per_s"], {node: p["busy_s"] / n * 1e6 for node, p in summary["per_node"].items()}


_WORKER = ("import json, sys; from bench.pipeline import _fused_worker; "
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
    receiver_echoes(scene, fidelity)   # built once per scene, like the channel node does before the run starts
    t0, c0 = time.perf_counter(), time.process_time()
    run_algorithm1(scene, n, seed=5, attack="smart", attack_params={"rarms": 3.0, "start_cycle": n // 2},
                   method=method, fidelity=fidelity, batch=batch)
    return n / (time.perf_counter() - t0), (time.process_time() - c0) / n * 1e6


@dataclass
class _Runs:
    """What the repeats of one case and batch measured, run by run: rates and busy times by (mode, transport), each
    pipeline run's CPU outside the blocks by transport, the fused chain's CPU, the recording's bytes per cycle."""

    rates: dict[tuple[str, str], list[float]]
    busy: dict[tuple[str, str], list[dict]] = field(default_factory=dict)
    outside: dict[str, list[dict]] = field(default_factory=dict)
    tracker_base: list[float] = field(default_factory=list)      # the pipeline each tracker run is paired with
    tracker_tracks: list[dict] = field(default_factory=list)     # each tracker run's tracks born and deleted
    fused_cpu: list[float] = field(default_factory=list)
    bytes_per_cycle: int | None = None

    def add(self, key: tuple[str, str], rate: float, busy: dict | None = None) -> None:
        self.rates[key].append(rate)
        if busy is not None:
            self.busy.setdefault(key, []).append(busy)


def _repeat(runs: _Runs, case: tuple[str, str, int], args: argparse.Namespace, batch: int) -> None:
    """One run of every mode, interleaved so that the ratios compare like with like: each pipeline, the tracker
    right after the pipeline on the first plane, the fused chain, then record and replay."""
    preset, fidelity, n = case
    first = args.transport[0]
    for transport in args.transport:
        rate, busy, summary = _pipeline(preset, fidelity, n, args.method, batch, transport)
        runs.add(("pipeline", transport), rate, busy)
        runs.outside.setdefault(transport, []).append(outside_blocks(summary, n))
        if transport == first and ("tracker", first) in runs.rates:
            scene = tracker_scene(preset)
            runs.tracker_base.append(rate if scene == preset else
                                     _pipeline(scene, fidelity, n, args.method, batch, first)[0])
            rate, busy, summary = _pipeline(scene, fidelity, n, args.method, batch, first, tracker=True)
            runs.add(("tracker", first), rate, busy)
            runs.tracker_tracks.append({k: summary["tracks"][k] for k in ("born", "deleted")})
    rate, cpu_us = _fused(preset, fidelity, n, args.method, batch)
    runs.add(("fused", "none"), rate)
    runs.fused_cpu.append(cpu_us)
    if ("record", first) in runs.rates:
        with tempfile.TemporaryDirectory(prefix="carav-bench-") as folder:
            rate, busy, summary = _pipeline(preset, fidelity, n, args.method, batch, first, Path(folder))
            runs.add(("record", first), rate, busy)
            runs.bytes_per_cycle = summary["recording"]["bytes_per_cycle"]
            if ("replay", first) in runs.rates:
                runs.add(("replay", first), *_replay(Path(folder), n, args.method, first))


def _record(runs: _Runs, mode: str, transport: str, base: dict, samples: int) -> tuple[dict, str]:
    """The record of one mode and plane from its runs, and the note its printed line ends with."""
    rates = runs.rates[(mode, transport)]
    rate = statistics.median(rates)
    # against the fused chain run in the same repeat: a paired ratio per repeat, and their median, so that the
    # machine's load drifting from repeat to repeat cancels out
    paired = [r / f for r, f in zip(rates, runs.rates[("fused", "none")])]
    rec = {**base, "mode": mode, "transport": transport, "cycles_per_s": rate, "runs_cycles_per_s": rates,
           "real_time_factor": rate / base["radar_cycles_per_s"], "speedup_over_fused": statistics.median(paired),
           "runs_speedup_over_fused": paired}
    if mode == "fused":
        rec["cpu_us_per_cycle"] = statistics.median(runs.fused_cpu)
        return rec, ""
    b_runs = runs.busy[(mode, transport)]
    busy = {node: statistics.median(b[node] for b in b_runs) for node in b_runs[0]}
    rec["bottleneck_node"] = bottleneck = max(busy, key=busy.get)
    rec["busy_us_per_cycle"] = busy
    rec["samples_per_cycle"] = samples
    rec["busy_ns_per_sample"] = {node: us * 1e3 / samples for node, us in busy.items()}
    note = f"  bottleneck {bottleneck} ({busy[bottleneck]:.0f} us/cycle)"
    if mode == "pipeline":
        o_runs = runs.outside[transport]
        rec["outside_us_per_cycle"] = outside = {node: statistics.median(o[node] for o in o_runs) for node in o_runs[0]}
        # every node's CPU, in and outside its block, run by run: the graph's cost of a cycle
        rec["cpu_us_per_cycle"] = cpu = statistics.median(
            sum(b.values()) + sum(o.values()) for b, o in zip(b_runs, o_runs))
        note += f"  outside the blocks {sum(outside.values()):.0f} us/cycle, CPU {cpu:.0f} us/cycle"
    if mode in ("record", "replay"):
        rec["bytes_per_cycle"] = runs.bytes_per_cycle
        rec["ratio_to_pipeline"] = rate / statistics.median(runs.rates[("pipeline", transport)])
        note += f"  {runs.bytes_per_cycle} B/cycle on disk, x{rec['ratio_to_pipeline']:.2f} live graph"
    if mode == "tracker":
        # against a pipeline of the same repeat, plane and scene, run just before it: paired, like the fused ratio
        rec["tracker_scene"] = tracker_scene(base["preset"])
        rec["runs_paired_pipeline_cycles_per_s"] = runs.tracker_base
        rec["runs_tracks"] = runs.tracker_tracks
        rec["runs_ratio_to_pipeline"] = ratios = [t / p for t, p in zip(rates, runs.tracker_base)]
        rec["ratio_to_pipeline"] = statistics.median(ratios)
        rec["cycles_per_s_loss"] = loss = 1.0 - rec["ratio_to_pipeline"]
        rec["loss_target"] = TRACKER_LOSS_TARGET
        born = statistics.median(t["born"] for t in runs.tracker_tracks)
        note += (f"  x{rec['ratio_to_pipeline']:.3f} the graph without it (loss {loss:.1%}; scene "
                 f"{rec['tracker_scene']}, tracks born {born:g} a run)")
    return rec, note


def tracker_pooled(records: list[dict]) -> list[dict]:
    """Per scene, the tracker's loss over every paired run of its cases (fidelities, batches) pooled: the runs'
    losses 1 - (tracker cycles/s over the pipeline's of the same repeat), their count, mean, standard deviation,
    the mean's standard error and its one-sided 95 % upper bound (Student's t); `judged` for TRACKER_JUDGED,
    whose bound the target holds. A case's median of a few runs moves by about the run-to-run spread over the
    square root of their number, so one case alone can land on either side of the target; the pooled mean and its
    bound say what the runs show together."""
    from scipy import stats

    out = []
    for preset in dict.fromkeys(r["preset"] for r in records if r["mode"] == "tracker"):
        losses = [1.0 - x for r in records if r["mode"] == "tracker" and r["preset"] == preset
                  for x in r["runs_ratio_to_pipeline"]]
        n = len(losses)
        mean = statistics.fmean(losses)
        sd = statistics.stdev(losses) if n > 1 else math.nan
        se = sd / math.sqrt(n)
        upper = mean + float(stats.t.ppf(0.95, n - 1)) * se if n > 1 else math.nan
        scene = next(r["tracker_scene"] for r in records if r["mode"] == "tracker" and r["preset"] == preset)
        out.append({"preset": preset, "scene": scene, "runs": n, "mean_loss": mean, "sd": sd, "se": se,
                    "upper_95": upper, "target": TRACKER_LOSS_TARGET, "judged": preset == TRACKER_JUDGED})
    return out


def run(args: argparse.Namespace) -> int:
    wanted = None if args.cases == "all" else {tuple(c.split(":")) for c in args.cases.split(",")}
    batches = [int(b) for b in str(args.batch).split(",")]
    modes = {"pipeline", "fused", *args.with_modes}
    records = []
    print(bench_records.header(), flush=True)
    for preset, fidelity, n in CASES:
        if wanted and (preset, fidelity) not in wanted:
            continue
        n = max(20, int(n * args.scale))
        scene = scene_of(preset)
        rate_radar = scene.cycles_per_s
        samples = scene.n_rx * scene.n_chirps * scene.n_samples * (2 if scene.iq else 1)    # real values a cycle
        for batch in batches:
            # (mode, transport) -> rates; the fused chain has no data plane, the extra modes run on the first plane
            runs = _Runs({(m, t): [] for m in MODES if m in modes
                          for t in (args.transport if m == "pipeline" else ["none"] if m == "fused"
                                    else [args.transport[0]])})
            for _ in range(args.repeats):
                _repeat(runs, (preset, fidelity, n), args, batch)
            base = {"preset": preset, "fidelity": fidelity, "batch": batch, "cycles": n, "repeats": args.repeats,
                    "method": args.method, "radar_cycles_per_s": rate_radar}
            for mode, transport in runs.rates:
                rec, note = _record(runs, mode, transport, base, samples)
                records.append(rec)
                print(f"{preset:<8} {fidelity:<8} batch {batch:<3} {mode:<8} {transport:<4} "
                      f"{rec['cycles_per_s']:9.1f} cycles/s  real-time x{rec['real_time_factor']:6.3f}  "
                      f"vs fused x{rec['speedup_over_fused']:5.2f}{note}", flush=True)
                if "busy_ns_per_sample" in rec:
                    per_node = ", ".join(f"{node} {rec['busy_us_per_cycle'][node]:.0f} ({ns:.2f})"
                                         for node, ns in rec["busy_ns_per_sample"].items())
                    shape = " x ".join(str(d) for d in scene.frame_shape(1)[1:])
                    print(f"    busy us/cycle (ns/sample, {shape} a cycle): {per_node}", flush=True)
    if args.json:
        bench_records.write(args.json, args, records)
    return 0
