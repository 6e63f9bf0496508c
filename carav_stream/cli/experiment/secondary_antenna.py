"""`carav experiment secondary-antenna`: the paper's Figures 6 to 8 and its "harmless misses" claim
(carav_stream/experiments/secondary_antenna.py).

    carav experiment secondary-antenna [--power low|medium|high|all] [--trials N] [--attacker KIND|both] [--eta ETA]
                                       [--method NAME] [--antenna-range M] [--ghost-range M] [--snr-db DB]
                                       [--seed S] [--json FILE] [--plot FILE.png] [--quiet]
"""
from __future__ import annotations

import argparse

import numpy as np

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.errors import CommandError
from carav_stream.console.options import count, number, output_file
from carav_stream.detect.detector import PAPER_ETA
from carav_stream.estimate import METHODS
from carav_stream.experiments.errors import ExperimentError
from carav_stream.experiments.secondary_antenna import TRUE_RANGE_M, experiment, json_ready, plot

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--power", choices=("low", "medium", "high", "all"), default="all")
    parser.add_argument("--trials", type=count(1), default=200,
                        help="attacked cycles per power level (and clean cycles)")
    parser.add_argument("--attacker", choices=("secondary_antenna", "ghost", "both"), default="both")
    parser.add_argument("--eta", type=number(0.0, strict=True), default=PAPER_ETA, help="detector threshold")
    parser.add_argument("--method", default="music", choices=METHODS, help="range estimator")
    parser.add_argument("--antenna-range", type=number(0.0, strict=True), default=30.0,
                        help="secondary antenna distance [m]")
    parser.add_argument("--ghost-range", type=number(0.0, strict=True), default=45.0,
                        help="range the ghost pretends [m]")
    parser.add_argument("--snr-db", type=number(), default=None,
                        help="per-sample SNR of the car [dB] (default: the preset's radar equation, about +2.2 dB)")
    parser.add_argument("--seed", type=count(0), default=7, help="seed of the simulation (simulation only)")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the results as JSON")
    parser.add_argument("--plot", type=output_file, default=None, metavar="FILE.png",
                        help="PF/PM curves and Q against range error")
    quiet_option(parser)


def _print_clean(c: dict, args: argparse.Namespace) -> None:
    print(f"table1 car at {TRUE_RANGE_M:g} m, {c['snr_db']:+.1f} dB per sample; eta = {args.eta:g}; "
          f"estimator {args.method}")
    print(f"clean cycles: PF(eta={args.eta:g}) = {c['pf']:.3f}, range error median "
          f"{c['range_error_median_m']:.4f} m, max {c['range_error_max_m']:.4f} m; false-target threshold "
          f"{10 * np.log10(c['false_target_threshold']):.1f} dB below the strongest peak")
    print(f"{'attacker':18s} {'power':6s} {'RARMS':>5s} {'tx power':>9s} {'PM':>6s} {'missed':>6s} "
          f"{'max err missed m':>16s} {'false tgt|missed':>16s}  harmless(range / strict)")


def _print_level(s: dict) -> None:
    mm = "-" if s["max_missed_range_error_m"] is None else f"{s['max_missed_range_error_m']:.3f}"
    ftr = "-" if s["missed_false_target_rate"] is None else f"{s['missed_false_target_rate']:.3f}"
    p_w = s["tx_power_w"]
    tx = "-" if p_w is None else f"{p_w * 1e3:.3g} mW" if p_w >= 1e-3 else f"{p_w * 1e6:.3g} uW"
    print(f"{s['attacker']:18s} {s['power']:6s} {s['rarms']:5.2f} {tx:>9s} {s['pm']:6.3f} {s['n_missed']:6d} "
          f"{mm:>16s} {ftr:>16s}  "
          f"{'yes' if s['harmless_range'] else 'NO'} / {'yes' if s['harmless_strict'] else 'NO'}", flush=True)


def run(args: argparse.Namespace) -> int:
    printers = {"clean": lambda c: _print_clean(c, args), "level": _print_level}
    try:
        res = experiment(power=args.power, trials=args.trials, attacker=args.attacker, eta=args.eta,
                         method=args.method, antenna_range_m=args.antenna_range, ghost_range_m=args.ghost_range,
                         snr_db=args.snr_db, seed=args.seed, partial=lambda what, data: printers[what](data),
                         progress=progress_bar(args, "secondary-antenna"))
    except ExperimentError as exc:
        raise CommandError(str(exc)) from None
    for kind in dict.fromkeys(s["attacker"] for s in res["levels"]):
        rows = [s for s in res["levels"] if s["attacker"] == kind]
        verdict = all(s["harmless_range"] for s in rows)
        strict = all(s["harmless_strict"] for s in rows)
        print(f"{kind}: every missed attack harmless (range error < {rows[0]['range_resolution_m']:.2f} m): "
              f"{'HOLDS' if verdict else 'FAILS'}; with no false target either: {'HOLDS' if strict else 'FAILS'}")
    write_json(args.json, json_ready(res))
    if args.plot:
        plot(res["levels"], res["clean"]["q"], args.eta, args.plot)
    return 0
