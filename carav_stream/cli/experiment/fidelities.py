"""`carav experiment fidelities`: where the beat and the waveform fidelity agree, at the range edge and for loud
echoes, in the detector's units or the estimator's (carav_stream/experiments/fidelities.py).

    carav experiment fidelities [--units detector|estimator] [--trials N] [--seed S] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option
from carav_stream.console.options import count
from carav_stream.experiments.fidelities import rows

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--units", choices=("detector", "estimator"), default="detector",
                        help="the detector's statistics or the estimator's range")
    parser.add_argument("--trials", type=count(10), default=200, help="cycles per fidelity and case (estimator)")
    parser.add_argument("--seed", type=count(0), default=5, help="seed of the activation and the noise")
    quiet_option(parser)


def _print_row(r: dict) -> None:
    line = (f"{r['preset']:<8} {r['echo']:<5} {r['fraction']:8.2f} {r['range_m']:8.1f} {r['snr_db']:+7.1f} "
            f"{r['range_rate_mps']:7.1f}")
    if "d0" in r:
        line += f" {r['d0']:11.2f} {r['d1']:11.2f}"
    else:
        line += f" {r['beat']:8.2f} {r['waveform']:9.2f} {r['difference']:11.2f}"
    print(line, flush=True)


def run(args: argparse.Namespace) -> int:
    if args.units == "detector":
        print("noise-free echoes, one balanced activation pattern: the largest |beat - waveform| of each slot's "
              "expected statistic, over its standard deviation under the noise")
        print(f"{'preset':<8} {'echo':<5} {'R / Rmax':>8} {'range m':>8} {'SNR dB':>7} {'m/s':>7} {'D0 silent':>11} "
              f"{'D1 active':>11}")
    else:
        print(f"{args.trials} cycles per fidelity, the same activation and noise at both, seed {args.seed}: ml's range "
              "RMSE at each fidelity and the RMS of their difference, over the bound")
        print(f"{'preset':<8} {'echo':<5} {'R / Rmax':>8} {'range m':>8} {'SNR dB':>7} {'m/s':>7} {'beat':>8} "
              f"{'waveform':>9} {'difference':>11}")
    rows(args.units, args.trials, args.seed, _print_row, progress_bar(args, "fidelities", unit="cases"))
    return 0
