"""`carav experiment tracks`: what each attacker does to the car's picture of the road, without a defence, with
CARAV, with the tracker's NIS alarm and with both (carav_stream/experiments/tracks.py).

    carav experiment tracks [--cycles N] [--models LIST] [--rarms LIST] [--seed S] [--json FILE] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.errors import CommandError
from carav_stream.console.options import count, float_list, output_file
from carav_stream.experiments.tracks import DEFENCES, MODELS, SCENE, START, TRACKER, tracks_experiment

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--cycles", type=count(START + 1), default=2000,
                        help=f"cycles per run, the attack on from cycle {START} (default 2000)")
    parser.add_argument("--models", default=",".join(MODELS),
                        help=f"comma-separated attacker models (default {','.join(MODELS)})")
    parser.add_argument("--rarms", type=float_list(0.0), default=[1.0, 3.0], help="attack levels (default 1,3)")
    parser.add_argument("--seed", type=count(0), default=13, help="seed of the simulation")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")
    quiet_option(parser)


def _number(x: float | None, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def _print_cell(c: dict) -> None:
    print(f"\n{c['model']} at RARMS {c['rarms']:g}: {c['attacked_cycles']} attacked cycles, {c['refused_cycles']} "
          f"refused by CARAV ({c['false_refusals']} before the attack)")
    print(f"{'defence':<8}{'false tracks/min':>18}{'car lost':>10}{'lead range RMSE':>17}{'lead rdot RMSE':>16}"
          f"{'first alarm':>13}")
    for name in DEFENCES:
        d = c["defences"][name]
        first = d["first_alarm_cycles"]
        lead_r = _number(d["lead_range_rmse_m"], ".3g") + " m"
        lead_v = _number(d["lead_velocity_rmse_mps"], ".3g") + " m/s"
        print(f"{name:<8}{d['false_tracks_per_min']:>18.4g}{d['car_lost']:>10.1%}{lead_r:>17}{lead_v:>16}"
              f"{'-' if first is None else f'{first} cycles':>13}", flush=True)


def run(args: argparse.Namespace) -> int:
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    unknown = [m for m in models if m not in MODELS]
    if unknown or not models:
        raise CommandError(f"--models: {', '.join(unknown) or 'none given'}: expected some of {', '.join(MODELS)}")
    print(f"{SCENE}: the car at 43 m at the radar's speed; attack on from cycle {START}, {args.cycles} cycles per "
          f"run, seed {args.seed}")
    print(f"tracker as graphs/table1_tracks.toml: R = ({TRACKER['sigma_range_m']:g} m, "
          f"{TRACKER['sigma_velocity_mps']:g} m/s), coast {TRACKER['coast_cycles']} cycles, NIS over "
          f"{TRACKER['nis_window']} updates at {TRACKER['nis_pfa']:g}")
    print("figures from the attack's start on; lead: the nearest confirmed track")
    rows = tracks_experiment(models, args.rarms, args.cycles, args.seed, partial=_print_cell,
                             progress=progress_bar(args, "tracks", unit="runs"))
    write_json(args.json, rows)
    return 0
