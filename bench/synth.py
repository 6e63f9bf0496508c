"""`python3 dev.py bench synth`: time per simulated cycle of the signal chain (carav_stream.radar.synth).

Cases: presets table1 and awr1642, fidelities beat and waveform, attacker none / random (RARMS 3) /
ghost / secondary_antenna (waveform only), I-only (the presets) and I/Q for table1. Each case runs
``--repeats`` batches of ``--cycles`` cycles after a warm-up batch (which fills the per-scene caches);
the median time per cycle is reported, with the radar's own cycle rate (Table I: 64 x 7.33 us =
469 us, 2131 cycles/s) and the real-time factor (simulated cycles per second / radar cycles per
second, > 1 is faster than the radar). ``cold_s`` is the first batch's extra cost (echo templates).
Stages of one beat cycle (noise, echo, ADC, the whole cycle) are timed alone and given per sample beside
a bound measured in the same run on the same shapes (``stage_bounds``).
One process, numpy single-threaded: one core.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from bench import records as bench_records
from carav_stream.console.options import count, output_file
from carav_stream.core.allocator import keep_freed_memory
from carav_stream.radar import physics
from carav_stream.radar.activation import ActivationSource
from carav_stream.radar.adc import CHUNK_ELEMENTS, adc
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


def _per_call(fn, repeats: int) -> float:
    """Median over ``repeats`` of the mean time of 20 calls, after one call that warms caches and scratch."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(20):
            fn()
        times.append((time.perf_counter() - t0) / 20)
    return float(np.median(times))


def stage_bounds(scene, repeats: int) -> dict[str, tuple[float, str]]:
    """A bound for each stage of one cycle of `scene`: what the named numpy passes alone cost on its shapes, timed
    like the stages (s per cycle):

    noise  the Box-Muller's vector math alone: np.log and np.sqrt over n/2 float32, np.cos and np.sin over n/2
           float32 (n the cycle's real values), in noise.py's chunk (CHUNK_WORDS words, at least one row: one
           cycle is one row, so one chunk); each writes a buffer of its own and reads an input it leaves valid
           (np.sqrt reads u1, not the logarithm); no generator, no scaling: the floor of that formulation
    echo   one np.add of a float32 (n_chirps, n_samples) array into another (I/Q: their float32 view)
    adc    one float32 multiply pass (by 1, values kept) and one float32 -> int16 cast pass over the cycle's
           real values, in adc.py's chunks (CHUNK_ELEMENTS)
    """
    n = scene.n_chirps * scene.n_samples * (2 if scene.iq else 1)
    rng = np.random.default_rng(0)
    h = (n + 1) // 2
    u = (1.0 - rng.random(h, dtype=np.float32)).astype(np.float32)           # u1 in (0, 1]
    theta = rng.uniform(-np.pi, np.pi, h).astype(np.float32)                 # in [-pi, pi)
    r, c, sn = (np.empty(h, np.float32) for _ in range(3))

    def box_muller() -> None:
        np.log(u, out=r)
        np.sqrt(u, out=r)
        np.cos(theta, out=c)
        np.sin(theta, out=sn)

    rx, echo, x = (rng.standard_normal(n, dtype=np.float32).reshape(scene.n_chirps, -1) for _ in range(3))
    x = x.reshape(-1) * np.float32(100.0)                                     # codes within +-700: no rails
    step = min(n, CHUNK_ELEMENTS)
    scaled, codes, one = np.empty(step, np.float32), np.empty(n, np.int16), np.float32(1.0)

    def quantise() -> None:
        for a in range(0, n, step):
            m = min(step, n - a)
            np.multiply(x[a: a + m], one, out=scaled[:m])
            np.copyto(codes[a: a + m], scaled[:m], casting="unsafe")

    return {"noise": (_per_call(box_muller, repeats), "np.log + np.sqrt on n/2, np.cos + np.sin on n/2 float32"),
            "echo": (_per_call(lambda: np.add(rx, echo, out=rx), repeats), "one np.add of float32 arrays"),
            "adc": (_per_call(quantise, repeats), "one float32 multiply pass + one float32 -> int16 cast pass")}


def time_stages(preset: str, iq: bool, repeats: int) -> list[dict]:
    """Where one beat-fidelity cycle goes: noise, echo, ADC and the whole cycle (median of ``repeats`` x 20 single
    cycles), each beside its bound (`stage_bounds`; the whole cycle's is the three bounds' sum), per real value."""
    scene = load_scene(preset, {"iq": iq})
    rho = ActivationSource("seeded", seed=1).next(1, scene.n_chirps)
    rng = seed_streams(0).noise
    rx = draw_noise(scene, rng, 1)
    stages = {"noise": lambda: draw_noise(scene, rng, 1), "echo": lambda: _add_echo(scene, rx, rho, "beat"),
              "adc": lambda: adc(scene, rx), "total": lambda: simulate_cycles(scene, rho, rng, fidelity="beat")}
    bounds = stage_bounds(scene, repeats)
    bounds["total"] = (sum(t for t, _ in bounds.values()), "the sum of the noise, echo and adc bounds")
    values = scene.n_chirps * scene.n_samples * (2 if iq else 1)
    out = []
    for name, fn in stages.items():
        t = _per_call(fn, repeats)
        bound_s, bound_what = bounds[name]
        out.append({"bench": "synth_stage", "preset": preset, "fidelity": "beat", "attacker": "none", "iq": iq,
                    "stage": name, "n_chirps": scene.n_chirps, "n_samples": scene.n_samples,
                    "time_per_cycle_s": t, "real_values_per_cycle": values,
                    "per": "real value (I or Q)" if iq else "sample", "ns_per_sample": t / values * 1e9,
                    "bound_time_per_cycle_s": bound_s, "bound_ns_per_sample": bound_s / values * 1e9,
                    "bound": bound_what, "x_bound": t / bound_s})
    return out


def print_stages(stages: list[dict]) -> None:
    r0 = stages[0]
    print(f"  {r0['preset']} {'I/Q' if r0['iq'] else 'I'}, {r0['n_chirps']} x {r0['n_samples']}"
          f"{' complex samples, ns per real value' if r0['iq'] else ' samples'}:")
    print(f"    {'stage':<6} {'us/cycle':>9} {'ns/sample':>10} {'bound ns/sample':>16} {'x bound':>8}  bound")
    for r in stages:
        print(f"    {r['stage']:<6} {r['time_per_cycle_s'] * 1e6:9.0f} {r['ns_per_sample']:10.3f} "
              f"{r['bound_ns_per_sample']:16.3f} {r['x_bound']:8.2f}  {r['bound']}", flush=True)


def run(args: argparse.Namespace) -> int:
    presets = [p.strip() for p in args.presets.split(",") if p.strip()]
    records = []
    print(bench_records.header())
    if not keep_freed_memory():   # a node's allocator settings (`dev.py bench` applies them too; this says if not)
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
        print("\nbeat fidelity, one cycle at a time, by stage, beside each stage's bound measured the same way:")
        for preset in presets:
            for iq in (False, True):
                stages = time_stages(preset, iq, args.repeats)
                records.extend(stages)
                print_stages(stages)
    if args.json:
        bench_records.write(args.json, args, records)
    return 0
