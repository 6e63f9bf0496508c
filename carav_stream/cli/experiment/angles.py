"""`carav experiment angles`: the radar chain's azimuth of one target against its Cramer-Rao bound, at 0, 20 and 45
degrees, beat and waveform fidelity, I-only and I/Q (carav_stream/experiments/angles.py).

    carav experiment angles [--cycles N] [--seed S] [--azimuths LIST] [--json FILE] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.options import count, float_list, output_file
from carav_stream.experiments.angles import AZIMUTHS, angles

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--cycles", type=count(10), default=300, help="attack-free cycles per row (default 300)")
    parser.add_argument("--seed", type=count(0), default=5, help="seed of the simulation (default 5)")
    parser.add_argument("--azimuths", type=float_list(low=-80.0), default=list(AZIMUTHS),
                        help="the target's azimuths [degrees] (default 0,20,45; from -80 on)")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")
    quiet_option(parser)


def run(args: argparse.Namespace) -> int:
    out = angles(args.cycles, args.seed, args.azimuths, progress=progress_bar(args, "angles"))
    s = out["scene"]
    print(f"{s['preset']}: one target at {s['range_m']:g} m, {s['snr_db']:.1f} dB per sample, {s['n_rx']} receivers "
          f"and {s['n_virtual']} virtual channels, {s['n_samples']} samples x {s['n_loops'] // 2} active loops; "
          f"azimuth as the range_estimator reads it on the array, {out['cycles']} attack-free cycles per row, seed "
          f"{out['seed']}; bound: the scene's (its SNR, not measured), reported: the RMS of the per-cycle bounds")
    print(f"{'fidelity':>9}{'samples':>8}{'azimuth':>9}{'RMSE [mdeg]':>13}{'mean [mdeg]':>13}{'bound [mdeg]':>14}"
          f"{'RMSE/bound':>12}{'reported [mdeg]':>17}")
    for r in out["rows"]:
        print(f"{r['fidelity']:>9}{'I/Q' if r['iq'] else 'I-only':>8}{r['azimuth_deg']:>9g}{r['rmse_deg'] * 1e3:>13.3f}"
              f"{r['mean_deg'] * 1e3:>13.3f}{r['bound_deg'] * 1e3:>14.3f}{r['ratio']:>12.2f}"
              f"{r['reported_bound_rms_deg'] * 1e3:>17.3f}")
    write_json(args.json, out)
    return 0
