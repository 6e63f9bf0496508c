"""`python3 dev.py bench synth`: time per simulated cycle of the signal chain (carav_stream.radar.synth).

Cases: presets table1 and awr1642, fidelities beat and waveform, attacker none / random (RARMS 3) /
ghost / secondary_antenna (waveform only), I-only (the presets) and I/Q for table1. Each case runs
``--repeats`` batches of ``--cycles`` cycles after a warm-up batch (which fills the per-scene caches);
the median time per cycle is reported, with the radar's own cycle rate (Table I: 64 x 7.33 us =
469 us, 2131 cycles/s) and the real-time factor (simulated cycles per second / radar cycles per
second, > 1 is faster than the radar). ``cold_s`` is the first batch's extra cost (echo templates).
One process, numpy single-threaded: one core.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from bench import records as bench_records
from carav_stream.console.options import count, output_file
from carav_stream.radar import physics
from carav_stream.radar.activation import ActivationSource
from carav_stream.radar.adc import adc
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.streams import seed_streams
from carav_stream.radar.synth import _add_echo, draw_noise, simulate_cycles

ATTACKERS = {"none": None, "random": {"rarms": 3.0}, "ghost": {"range_m": 30.0, "rarms": 3.0},
             "secondary_antenna": {"range_m": 40.0, "tx_power_w": 1e-6}}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write one JSON record per case to FILE")
    parser.add_argument("--cycles", type=count(1), default=32, help="cycles per timed batch (default 32)")
    parser.add_argument("--repeats", type=count(1), default=7, help="timed batches per case (default 7)")
    parser.add_argument("--presets", default="table1,awr1642", help="comma-separated presets")
    parser.add_argument("--quick", action="store_true", help="beat fidelity and no attacker only")


def cases(presets: list[str], quick: bool):
    for preset in presets:
        for fidelity in ("beat",) if quick else ("beat", "waveform"):
            for attacker in ("none",) if quick else tuple(ATTACKERS):
                if attacker == "secondary_antenna" and fidelity != "waveform":
                    continue
                for iq in ((False, True) if preset == "table1" and attacker in ("none", "random") else (False,)):
                    yield preset, fidelity, attacker, iq


def time_case(preset: str, fidelity: str, attacker: str, iq: bool, n_cycles: int, repeats: int) -> dict:
    scene = load_scene(preset, {"iq": iq})
    physics.echo_templates.cache_clear()
    physics.waveform_grid.cache_clear()
    src = ActivationSource("seeded", seed=1)
    params = ATTACKERS[attacker]
    att = make_attacker(attacker, scene, **params) if params is not None else None
    streams = seed_streams(1)                     # the generators a run's channel and attacker draw from
    rng_n, rng_a = streams.noise, streams.attack
    cycle = 0

    def batch() -> tuple[float, float]:
        nonlocal cycle
        rho = src.next(n_cycles, scene.n_chirps)
        t0, c0 = time.perf_counter(), time.process_time()
        simulate_cycles(scene, rho, rng_n, attacker=att, rng_attack=rng_a, fidelity=fidelity, cycle0=cycle)
        cycle += n_cycles
        return time.perf_counter() - t0, time.process_time() - c0

    first = batch()[0]
    wall, cpu = zip(*[batch() for _ in range(repeats)])
    times = list(wall)
    per_cycle = float(np.median(times)) / n_cycles
    radar_rate = 1.0 / scene.t_cycle_s
    return {"bench": "synth", "preset": preset, "fidelity": fidelity, "attacker": attacker, "iq": iq,
            "n_chirps": scene.n_chirps, "n_samples": scene.n_samples, "cycles_per_batch": n_cycles,
            "repeats": repeats, "time_per_cycle_s": per_cycle, "cycles_per_s": 1.0 / per_cycle,
            "time_per_cycle_min_s": min(times) / n_cycles,
            "cpu_time_per_cycle_s": float(np.median(cpu)) / n_cycles, "radar_cycles_per_s": radar_rate,
            "realtime_factor": 1.0 / per_cycle / radar_rate, "cold_s": max(first - per_cycle * n_cycles, 0.0)}


def time_stages(preset: str, iq: bool, repeats: int) -> list[dict]:
    """Where one beat-fidelity cycle goes: noise, echo, ADC (median of ``repeats`` x 20 single cycles)."""
    scene = load_scene(preset, {"iq": iq})
    rho = ActivationSource("seeded", seed=1).next(1, scene.n_chirps)
    rng = seed_streams(0).noise
    rx = draw_noise(scene, rng, 1)
    stages = {"noise": lambda: draw_noise(scene, rng, 1), "echo": lambda: _add_echo(scene, rx, rho, "beat"),
              "adc": lambda: adc(scene, rx), "total": lambda: simulate_cycles(scene, rho, rng, fidelity="beat")}
    out = []
    for name, fn in stages.items():
        fn()
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            for _ in range(20):
                fn()
            times.append((time.perf_counter() - t0) / 20)
        out.append({"bench": "synth_stage", "preset": preset, "fidelity": "beat", "attacker": "none", "iq": iq,
                    "stage": name, "time_per_cycle_s": float(np.median(times))})
    return out


def run(args: argparse.Namespace) -> int:
    presets = [p.strip() for p in args.presets.split(",") if p.strip()]
    records = []
    if not bench_records.use_node_allocator():
        print("note: glibc's mallopt is not available: timed with this allocator's defaults, not a node's")
    print(f"{'preset':<10} {'fidelity':<9} {'attacker':<18} {'iq':<3} {'us/cycle':>9} {'cycles/s':>9} "
          f"{'radar/s':>8} {'x realtime':>10} {'cpu us':>7} {'cold ms':>8}")
    for preset, fidelity, attacker, iq in cases(presets, args.quick):
        r = time_case(preset, fidelity, attacker, iq, args.cycles, args.repeats)
        records.append(r)
        print(f"{preset:<10} {fidelity:<9} {attacker:<18} {'y' if iq else 'n':<3} {r['time_per_cycle_s'] * 1e6:9.0f} "
              f"{r['cycles_per_s']:9.0f} {r['radar_cycles_per_s']:8.0f} {r['realtime_factor']:10.2f} "
              f"{r['cpu_time_per_cycle_s'] * 1e6:7.0f} "
              f"{r['cold_s'] * 1e3:8.1f}", flush=True)
    if not args.quick:
        print("\nbeat fidelity, one cycle at a time, by stage (us):")
        for preset in presets:
            for iq in (False, True):
                stages = time_stages(preset, iq, args.repeats)
                records.extend(stages)
                print(f"  {preset:<10} {'I/Q' if iq else 'I  '}  " + "  ".join(
                    f"{r['stage']} {r['time_per_cycle_s'] * 1e6:.0f}" for r in stages), flush=True)
    if args.json:
        bench_records.write(args.json, args, records)
    return 0
