"""`carav experiment interference`: another car's FMCW radar in the scene, and the false alarms of every detector
(carav_stream/experiments/interference.py).

    carav experiment interference [--trials N] [--rarms LIST] [--slopes LIST] [--range M] [--period-ratio R]
                                  [--seed S] [--json FILE]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.options import count, float_list, number, output_file
from carav_stream.experiments.interference import simulate

__all__ = ["configure", "run"]


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
    quiet_option(parser)


def _rate(k: int, n: int) -> str:
    return f"{k / n:.3f}"


def _row(name: str, rarms: float, cell: dict, n: int) -> str:
    return (f"{name:<26}{rarms:>6g}{_rate(cell['c_1_5'], n):>8}{_rate(cell['c_design'], n):>9}"
            f"{_rate(cell['spectral'], n):>10}{_rate(cell['integrated'], n):>12}{cell['median_q']:>10.3f}")


def run(args: argparse.Namespace) -> int:
    res = simulate(args.trials, args.rarms, args.slopes, args.range, args.period_ratio, args.seed,
                   progress=progress_bar(args, "interference"))
    n = res["trials"]
    print(f"table1 car at 43 m, +2.2 dB per sample; interferer at {res['range_m']:g} m, oncoming at 100 km/h, "
          f"period {res['period_ratio']:g} x its sweep, offset {res['t_offset_s'] * 1e6:.3f} us; {n} cycles per "
          f"cell, seed {res['seed']}; eta at PF 1e-6: {res['eta_design']:.4f}")
    print("share of cycles with an alarm (no attack: every alarm is false)")
    print(f"{'source':<26}{'RARMS':>6}{'C(1.5)':>8}{'C(1e-6)':>9}{'spectral':>10}{'integrated':>12}{'median Q':>10}")
    for r in dict.fromkeys(c["rarms"] for c in res["cells"]):
        for c in [c for c in res["cells"] if c["rarms"] == r]:
            print(_row(f"interferer, slope x{c['slope_ratio']:g}", r, c, n))
        print(_row("random attacker", r, next(a for a in res["random"] if a["rarms"] == r), n))
    write_json(args.json, res)
    return 0
