"""`carav experiment blind-zones`: what each detector misses of the weak attacks, per scene.

Three scenes: table1 (64 x 1080 samples at 150 MHz), awr1642 (128 x 256 at 10 MHz) and table1 cut to short chirps
(48 x 300). Three weak attacks: the ghost (a replica of the victim's chirp planting a false target at 25 m, in every
chirp period), the paper's `random` (i.i.d. Gaussian) and `smart` (the same sequence on every chirp). For each
RARMS of the grid, --trials attacked cycles (seeded, the radar chain at beat fidelity) judged by every detector at
its design for PF 1e-6 per cycle: C(eta) at the scene's designed eta, the spectral, integrated and coherent
silent-chirp tests at theirs (carav_stream/firmware/blind_zone.py). Printed: the share of cycles each detector
misses, and the weakest RARMS of the grid from which on it misses at most one cycle in ten.
"""
from __future__ import annotations

import argparse
import json

from carav_stream.console.options import count, output_file
from carav_stream.firmware.blind_zone import DETECTORS, miss_rates, weakest_caught
from carav_stream.radar.scene_loader import load_scene

__all__ = ["configure", "run", "SCENES", "ATTACKS", "RARMS"]

SCENES = {"table1": ("table1", None), "awr1642": ("awr1642", None),
          "short chirps": ("table1", {"n_chirps": 48, "n_samples": 300})}
ATTACKS = {"ghost": {"range_m": 25.0}, "random": {}, "smart": {}}
RARMS = (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 3.0)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trials", type=count(10), default=200, help="attacked cycles per RARMS")
    parser.add_argument("--seed", type=count(0), default=7, help="seed of the simulation")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")


def run(args: argparse.Namespace) -> int:
    n, out = args.trials, []
    print(f"share of attacked cycles missed, {n} per cell, seed {args.seed}; each detector at its design for PF 1e-6 "
          "per cycle; beat fidelity")
    for label, (preset, over) in SCENES.items():
        scene = load_scene(preset, over)
        rows_by_attack = {a: miss_rates(scene, a, RARMS, n, args.seed, fidelity="beat", params=p)
                          for a, p in ATTACKS.items()}
        eta = next(iter(rows_by_attack.values()))[0]["eta"]
        print(f"\n{label}: {scene.n_chirps} x {scene.n_samples} samples ({'I/Q' if scene.iq else 'I only'}), "
              f"C at eta = {eta:.4f}")
        print(f"{'attack':<8}{'RARMS':>6}" + "".join(f"{d:>12}" for d in DETECTORS))
        for attack, rows in rows_by_attack.items():
            for r in rows:
                print(f"{attack:<8}{r['rarms']:>6g}" + "".join(f"{r['missed'][d] / n:>12.3f}" for d in DETECTORS))
        print("weakest RARMS caught in 9 cycles of 10 or more, from it on (- : none in the grid)")
        for attack, rows in rows_by_attack.items():
            w = weakest_caught(rows)
            print(f"  {attack:<8}" + "".join(f"{d} {'-' if w[d] is None else f'{w[d]:g}'}   " for d in DETECTORS))
            out.append({"scene": label, "attack": attack, "rows": rows, "weakest_caught": w})
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0
