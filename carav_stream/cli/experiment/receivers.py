"""`carav experiment receivers`: what C misses of weak attacks on 1, 2, 4 and 8 receivers, each count at its own
PF 1e-6 design; closed form beside Monte Carlo (carav_stream/experiments/receivers.py).

    carav experiment receivers [--trials N] [--seed S] [--rarms LIST] [--json FILE] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.options import count, float_list, output_file
from carav_stream.experiments.receivers import ATTACKS, RARMS, receivers

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trials", type=count(10), default=500, help="attacked cycles per cell (default 500)")
    parser.add_argument("--seed", type=count(0), default=7, help="seed of the simulation (default 7)")
    parser.add_argument("--rarms", type=float_list(low=0.0), default=list(RARMS),
                        help="attack strengths, sigma_a / sigma_n (default 0.3,0.4,0.5)")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")
    quiet_option(parser)


def _cell(c: dict) -> str:
    return f"{c['rate']:.3f} [{c['ci'][0]:.3f}, {c['ci'][1]:.3f}]"


def run(args: argparse.Namespace) -> int:
    out = receivers(args.trials, args.seed, args.rarms, progress=progress_bar(args, "receivers"))
    s = out["scene"]
    print(f"{s['preset']} in the paper's model: {s['n_chirps']} chirps x {s['n_samples']} "
          f"{'I/Q' if s['iq'] else 'I-only'} samples per receiver, echo {s['echo_snr_db']:+.1f} dB, one attacker at "
          f"broadside; C at its PF {s['pf']:g} design for each count; share of attacked cycles missed, "
          f"{out['trials']} per cell, seed {out['seed']}, 95 % intervals")
    print(f"{'receivers':>9}{'RARMS':>7}{'eta':>8}{'random: closed form':>21}{'(independent)':>15}"
          + "".join(f"{a + ': simulated':>24}" for a in ATTACKS))
    for row in out["rows"]:
        print(f"{row['n_rx']:>9}{row['rarms']:>7g}{row['eta']:>8.4f}{row['closed_form']:>21.4f}"
              f"{row['independent']:>15.4f}" + "".join(f"{_cell(row[a]):>24}" for a in ATTACKS))
    write_json(args.json, out)
    return 0
