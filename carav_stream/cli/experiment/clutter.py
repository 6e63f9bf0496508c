"""`carav experiment clutter`: several targets and clutter, no attacker: false alarms of every detector and the
radar's target list (carav_stream/experiments/clutter.py).

    carav experiment clutter [--trials N] [--seed S] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option
from carav_stream.console.options import count
from carav_stream.experiments.clutter import clutter

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trials", type=count(1), default=200, help="cycles per scene")
    parser.add_argument("--seed", type=count(0), default=17, help="seed of the simulation and of the clutter draw")
    quiet_option(parser)


def _print_row(m: dict) -> None:
    pd = "n/a" if m["car_pd"] is None else f"{m['car_pd']:.2f}"
    rmse = "n/a" if m["car_range_rmse_m"] is None else f"{m['car_range_rmse_m'] * 1e3:.1f} mm"
    print(f"{m['preset'] + ' / ' + m['fidelity']:<19}{m['scene']:<19}{m['c_1_5']:>7.3f}{m['c_design']:>8.3f}"
          f"{m['spectral']:>9.3f}{m['integrated']:>8.3f}{m['coherent']:>7.3f}{pd:>7}{rmse:>15}"
          f"{m['false_targets_per_cycle']:>12.2f}", flush=True)


def run(args: argparse.Namespace) -> int:
    print(f"attack-free cycles, {args.trials} per scene, seed {args.seed}: share of cycles with an alarm (every alarm "
          "is false), and the OS-CFAR target list (pfa 1e-6 per cell)")
    print(f"{'preset / fidelity':<19}{'scene':<19}{'C(1.5)':>7}{'C(1e-6)':>8}{'spectral':>9}{'integr.':>8}"
          f"{'coher.':>7}{'car Pd':>7}{'car range RMSE':>15}{'false/cycle':>12}")
    clutter(args.trials, args.seed, partial=_print_row, progress=progress_bar(args, "clutter"))
    return 0
