"""`carav experiment latency`: the spill test's false alarms over the echo power, and what it and the other detectors
miss of a reactive repeater over its latency (carav_stream/experiments/latency.py).

    carav experiment latency [--trials N] [--seed S] [--json FILE] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.options import count, output_file
from carav_stream.experiments.latency import false_alarms, misses, windows
from carav_stream.experiments.reporting import rate

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trials", type=count(10), default=400, help="cycles per cell")
    parser.add_argument("--seed", type=count(0), default=23, help="seed of the simulation")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")
    quiet_option(parser)


def _band(inside: bool) -> str:
    return "in band" if inside else "filtered"


def _false_alarm_row(r: dict, n: int) -> None:
    print(f"{r['preset'] + ' / ' + r['fidelity']:<19}{r['scene']:<14}{r['echo_db']:>+4d}dB  "
          f"{rate(r['spill_pf_0_05'], n):<27}{r['spill_pf_1e_6'] / n:>7.3f}  {rate(r['head_tail'], n):<36}", flush=True)


def _miss_row(r: dict, n: int) -> None:
    print(f"{r['preset'] + ' / ' + r['fidelity']:<19}{r['latency_us']:>7.2f}us{r['delay_us']:>7.2f}us  "
          f"{_band(r['own_in_band']):<9}{_band(r['spill_in_band']):<9}{r['spill_missed'] / n:>11.3f}"
          f"{r['c15_missed'] / n:>8.3f}{r['integrated_missed'] / n:>9.3f}", flush=True)


def run(args: argparse.Namespace) -> int:
    n = args.trials
    for w in windows():
        print(f"{w['preset']}: longest visible round trip {w['longest_round_trip_s'] * 1e6:.3f} us; spill window "
              f"samples {w['first_sample']}..{w['n_samples'] - 1} of silent slots after active ones "
              f"({w['n_samples']} samples, chirp {w['t_chirp_s'] * 1e6:g} us)")
    print(f"false alarms: attack-free cycles, {n} per cell, seed {args.seed}; echo power relative to the scene's own")
    print(f"{'preset / fidelity':<19}{'scene':<14}{'echo':>6}  {'spill @ PF 0.05 [95% CI]':<27}{'@ 1e-6':>7}"
          f"  {'head/tail (calibrated at 0 dB, 0.05)':<36}")
    data = {"false_alarms": false_alarms(n, args.seed, lambda r: _false_alarm_row(r, n),
                                        progress_bar(args, "latency: false alarms"))}
    print(f"misses: reactive repeater at 30 m, RARMS 1, {n} attacked cycles per row; share of cycles missed")
    print(f"{'preset / fidelity':<19}{'latency':>9}{'delay':>9}  {'own beat':<9}{'spill':<9}{'spill test':>11}"
          f"{'C(1.5)':>8}{'integr.':>9}")
    data["misses"] = misses(n, args.seed, lambda r: _miss_row(r, n), progress_bar(args, "latency: misses"))
    write_json(args.json, data)
    return 0
