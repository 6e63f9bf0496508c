"""`carav experiment matlab-table1`: MATLAB's published FMCWExample result beside our replica of its chain, `ml` and
`root_music`, as a markdown table (carav_stream/experiments/matlab_table1.py; docs/ESTIMATION.md quotes it).

    carav experiment matlab-table1 [--cycles N] [--seed S] [--json FILE] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option, write_json
from carav_stream.console.options import count, output_file
from carav_stream.experiments.matlab_table1 import SNR_DB, figures, simulate

__all__ = ["configure", "run", "report"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--cycles", type=count(10), default=400, help="Monte Carlo cycles")
    parser.add_argument("--seed", type=count(0), default=2026)
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write every figure as JSON")
    quiet_option(parser)


ROWS = [  # (chain, quantity, key, decimals)
    ("our replica of the MATLAB chain", "beat-only range [m]", "replica_range_m", 5),
    ("our replica of the MATLAB chain", "closing speed [m/s]", "replica_closing_speed_mps", 4),
    ("`ml` (this package)", "beat-only range [m]", "ml_beat_range_m", 5),
    ("`ml`", "range, coupling removed [m]", "ml_range_m", 5),
    ("`ml`", "velocity [m/s]", "ml_velocity_mps", 5),
    ("`root_music` (L = 32, FB)", "beat-only range [m]", "root_music_beat_range_m", 5),
]


def report(fig: dict, cycles: int, seed: int) -> list[str]:
    """The markdown of figures(): a table per chain and quantity, then MATLAB's values as z-scores."""
    st = fig["stats"]
    lines = [f"{cycles} cycles, seed {seed}, +{SNR_DB} dB per sample, all 64 chirps, range migration included", "",
             "| chain | quantity | mean | std | 0.5 % .. 99.5 % |", "|---|---|---|---|---|"]
    for chain, quantity, key, d in ROWS:
        s = st[key]
        lines.append(f"| {chain} | {quantity} | {s['mean']:.{d}f} | {s['std']:.4g} | "
                     f"{s['q005']:.{d - 1}f} .. {s['q995']:.{d - 1}f} |")
    lines.append("")
    for name, unit in (("range", "m"), ("closing_speed", "m/s")):
        t = fig["matlab"][name]
        lo, hi = t["accepted"]
        lines.append(f"- MATLAB's {name.replace('_', ' ')} {t['published']:g} {unit}: z = {t['z']:+.2f} within the "
                     f"replica's spread; |z| < 3 accepts any published value in [{lo:.4g}, {hi:.4g}] {unit} "
                     f"(width {hi - lo:.3g} {unit}; truth {t['truth']:.4g} {unit}).")
    return lines


def run(args: argparse.Namespace) -> int:
    fig = figures(simulate(args.cycles, args.seed, progress=progress_bar(args, "matlab-table1")))
    print("\n".join(report(fig, args.cycles, args.seed)))
    write_json(args.json, fig)
    return 0
