"""`carav experiment interference`: benign mutual interference from another car's FMCW radar, and what the
detectors make of it.

Scene: table1 (the car at 43 m, +2.2 dB per sample), no attacker. The interferer is an oncoming car's radar at
--range (driving at 100 km/h towards the victim), transmitting its own chirps, not synchronised with the victim: slope
--slopes x the victim's (same sweep duration, so its bandwidth scales with the slope), a chirp period of
--period-ratio x its sweep (idle time between chirps), a start offset drawn once per run. It is received one way
(`secondary_antenna` attacker model with its own waveform, `waveform` fidelity). Its power is given as the
equivalent RARMS of its signal while in the victim's IF band (SecondaryAntennaAttacker.equivalent_rarms): with a
different slope it crosses the band briefly in each chirp, so its RMS over a chirp is far lower.

Per cell (slope, power): the share of cycles with an alarm from C(1.5), from C(eta) at the scene's PF = 1e-6
threshold (carav_stream/firmware/design.py), from the single-chirp and the integrated spectral silent-chirp
tests (PF = 1e-6 each). None of these cycles holds an attack: every alarm is a false alarm from the driver's
point of view. Beside it, the `random` attacker at the same RARMS, which the detectors are meant to catch.
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from carav_stream.console.options import count, float_list, number, output_file
from carav_stream.core.units import KMH
from carav_stream.detect import opt_in
from carav_stream.detect.detector import detect
from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

__all__ = ["configure", "run", "simulate"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trials", type=count(1), default=200, help="cycles per cell")
    parser.add_argument("--rarms", type=float_list(0.0), default=[0.3, 1.0, 3.0],
                        help="interferer power as its in-band equivalent RARMS (default 0.3,1,3)")
    parser.add_argument("--slopes", type=float_list(0.0), default=[0.5, 0.9, 1.0, 1.1, 2.0],
                        help="interferer slope / the victim's (default 0.5,0.9,1,1.1,2; 1 = a matched radar)")
    parser.add_argument("--range", type=number(0.0, strict=True), default=60.0, help="interferer distance [m]")
    parser.add_argument("--period-ratio", type=number(1.0), default=1.37,
                        help="interferer chirp period / its sweep duration (default 1.37: idle time, unsynchronised)")
    parser.add_argument("--seed", type=count(0), default=11, help="seed of the simulation")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")


def _interferer(scene, slope_ratio: float, rarms: float, range_m: float, period_ratio: float, offset_s: float):
    geometry = dict(range_m=range_m, velocity_mps=-100.0 * KMH,       # oncoming at 100 km/h
                    slope_hz_per_s=slope_ratio * scene.slope_hz_per_s, t_sweep_s=scene.t_sweep_s,
                    t_chirp_s=period_ratio * scene.t_sweep_s, t_offset_s=offset_s)
    probe = make_attacker("secondary_antenna", scene, tx_power_w=1e-3, **geometry)
    p_w = 1e-3 * (rarms / probe.equivalent_rarms()) ** 2
    return make_attacker("secondary_antenna", scene, tx_power_w=p_w, **geometry)


def _alarms(frames, rho, scene, eta_design) -> dict:
    q = detect(frames, rho, scene.sigma_n).q
    return {"c_1_5": int(np.sum(q >= 1.5)), "c_design": int(np.sum(q >= eta_design)),
            "spectral": int(opt_in.spectral_silent_test(frames, rho, scene.sigma_n, pf=1e-6).alarm.sum()),
            "integrated": int(opt_in.integrated_silent_test(frames, rho, scene.sigma_n, pf=1e-6).alarm.sum()),
            "median_q": float(np.median(q))}


def simulate(args: argparse.Namespace) -> dict:
    scene = load_scene("table1")
    eta_design = rms_threshold(scene_law(scene), 1e-6)
    root = np.random.SeedSequence(args.seed)
    n = args.trials
    out = {"scene": scene.name, "trials": n, "seed": args.seed, "eta_design": eta_design, "range_m": args.range,
           "period_ratio": args.period_ratio, "cells": [], "random": []}
    rng = np.random.default_rng(root.spawn(1)[0])
    offset = float(rng.uniform(0, args.period_ratio * scene.t_sweep_s))
    out["t_offset_s"] = offset
    for r in args.rarms:
        rng = np.random.default_rng([args.seed, int(r * 1000), 0])
        rho = balanced_rows(rng, n, scene.n_chirps)
        att = make_attacker("random", scene, rarms=r)
        cyc = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng)
        out["random"].append({"rarms": r, **_alarms(cyc.frames, rho, scene, eta_design)})
        for k in args.slopes:
            rng = np.random.default_rng([args.seed, int(r * 1000), int(k * 1000)])
            rho = balanced_rows(rng, n, scene.n_chirps)
            att = _interferer(scene, k, r, args.range, args.period_ratio, offset)
            cyc = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng, fidelity="waveform")
            out["cells"].append({"slope_ratio": k, "rarms": r, **_alarms(cyc.frames, rho, scene, eta_design)})
    return out


def _rate(k: int, n: int) -> str:
    return f"{k / n:.3f}"


def run(args: argparse.Namespace) -> int:
    res = simulate(args)
    n = res["trials"]
    print(f"table1 car at 43 m, +2.2 dB per sample; interferer at {res['range_m']:g} m, oncoming at 100 km/h, "
          f"period {res['period_ratio']:g} x its sweep, offset {res['t_offset_s'] * 1e6:.3f} us; {n} cycles per "
          f"cell, seed {res['seed']}; eta at PF 1e-6: {res['eta_design']:.4f}")
    print("share of cycles with an alarm (no attack: every alarm is false)")
    print(f"{'source':<26}{'RARMS':>6}{'C(1.5)':>8}{'C(1e-6)':>9}{'spectral':>10}{'integrated':>12}{'median Q':>10}")
    for r in dict.fromkeys(c["rarms"] for c in res["cells"]):
        for c in [c for c in res["cells"] if c["rarms"] == r]:
            name = f"interferer, slope x{c['slope_ratio']:g}"
            print(f"{name:<26}{r:>6g}{_rate(c['c_1_5'], n):>8}{_rate(c['c_design'], n):>9}"
                  f"{_rate(c['spectral'], n):>10}{_rate(c['integrated'], n):>12}{c['median_q']:>10.3f}")
        a = next(a for a in res["random"] if a["rarms"] == r)
        print(f"{'random attacker':<26}{r:>6g}{_rate(a['c_1_5'], n):>8}{_rate(a['c_design'], n):>9}"
              f"{_rate(a['spectral'], n):>10}{_rate(a['integrated'], n):>12}{a['median_q']:>10.3f}")
    if args.json:
        args.json.write_text(json.dumps(res, indent=1))
    return 0
