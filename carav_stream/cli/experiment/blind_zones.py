"""`carav experiment blind-zones`: what each detector misses of the weak attacks, per scene
(carav_stream/experiments/blind_zones.py).

    carav experiment blind-zones [--trials N] [--seed S] [--json FILE] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.options import count, output_file
from carav_stream.experiments.blind_zones import blind_zones
from carav_stream.firmware.blind_zone import DETECTORS

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trials", type=count(10), default=200, help="attacked cycles per RARMS")
    parser.add_argument("--seed", type=count(0), default=7, help="seed of the simulation")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")
    quiet_option(parser)


def _print_scene(scene, entries: list[dict], n: int) -> None:
    """One scene's table: the share of cycles each detector misses per attack and RARMS, then the weakest caught."""
    eta = entries[0]["rows"][0]["eta"]
    print(f"\n{entries[0]['scene']}: {scene.n_chirps} x {scene.n_samples} samples "
          f"({'I/Q' if scene.iq else 'I only'}), C at eta = {eta:.4f}")
    print(f"{'attack':<8}{'RARMS':>6}" + "".join(f"{d:>12}" for d in DETECTORS))
    for e in entries:
        for r in e["rows"]:
            print(f"{e['attack']:<8}{r['rarms']:>6g}" + "".join(f"{r['missed'][d] / n:>12.3f}" for d in DETECTORS))
    print("weakest RARMS caught in 9 cycles of 10 or more, from it on (- : none in the grid)")
    for e in entries:
        w = e["weakest_caught"]
        print(f"  {e['attack']:<8}" + "".join(f"{d} {'-' if w[d] is None else f'{w[d]:g}'}   " for d in DETECTORS))


def run(args: argparse.Namespace) -> int:
    n = args.trials
    print(f"share of attacked cycles missed, {n} per cell, seed {args.seed}; each detector at its design for PF 1e-6 "
          "per cycle; beat fidelity")
    out = blind_zones(n, args.seed, partial=lambda scene, entries: _print_scene(scene, entries, n),
                      progress=progress_bar(args, "blind-zones"))
    write_json(args.json, out)
    return 0
