"""`carav experiment near-echoes`: the table1 car near the radar, attack-free, against every detector
(carav_stream/experiments/near_echoes.py).

    carav experiment near-echoes [--trials N] [--seed S] [--json FILE] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.options import count, output_file
from carav_stream.experiments.near_echoes import ALARMS, PF, STARTS, near_echoes
from carav_stream.experiments.reporting import rate

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trials", type=count(10), default=300, help="attack-free cycles per cell")
    parser.add_argument("--seed", type=count(0), default=11, help="seed of the simulation")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")
    quiet_option(parser)


def _print_cell(c: dict, n: int) -> None:
    warned = "yes" if c["warned"] else "no"
    print(f"{c['start']:<15}{c['range_m']:>4g} m {c['fidelity']:<9}{c['eta']:>7.4f}{c['leak_pf']:>9.2g} {warned:<7}"
          + "".join(f"{rate(c['alarms'][k], n):<26}" for k in ALARMS)
          + ("-" if c["cusum_first_alarm"] is None else f"cycle {c['cusum_first_alarm']}"), flush=True)


def run(args: argparse.Namespace) -> int:
    n = args.trials
    print(f"attack-free cycles of the table1 car (100 m^2), {n} per row, seed {args.seed}: cycles with an alarm "
          f"[95 % interval]; C(eta) at the eta designed for PF {PF:g}, the opt-in tests at their {PF:g} designs")
    head = f"{'sampled':<15}{'range':>6} {'fidelity':<9}{'eta':>7}{'leak PF':>9} {'warned':<7}"
    print(head + "".join(f"{c:<26}" for c in ALARMS) + "CUSUM")
    rows = near_echoes(n, args.seed, partial=lambda c: _print_cell(c, n), progress=progress_bar(args, "near-echoes"))
    for start in STARTS:
        c = next(x for x in rows if x["start"] == start)
        print(f"{start}: {c['n_samples']} samples from {c['t_adc_start_s'] * 1e9:.4g} ns into the sweep")
    write_json(args.json, rows)
    return 0
