"""`carav experiment cfar`: the radar's CFAR target detection measured against its design
(carav_stream/experiments/cfar_experiment.py).

    carav experiment cfar [--preset NAME] [--trials N] [--pfa P] [--seed S] [--quiet]
"""
from __future__ import annotations

import argparse

from carav_stream.cli.experiment import progress_bar, quiet_option
from carav_stream.console.options import count, number
from carav_stream.experiments.cfar_experiment import cfar_experiment

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--preset", default="table1", help="the scene whose map shape is used (default table1)")
    parser.add_argument("--trials", type=count(1), default=400, help="cycles per measurement")
    parser.add_argument("--pfa", type=number(0.0, strict=True), default=1e-4, help="design false-alarm rate per cell")
    parser.add_argument("--seed", type=count(0), default=5, help="seed")
    quiet_option(parser)


def _false_alarms(p: dict) -> None:
    print(f"{p['scene']} map: {p['n_chirps']} Doppler x {p['n_range_cells']} range cells, half the chirps silent, "
          f"{p['cycles']} noise-only cycles, seed {p['seed']}; design {p['pfa']:g} per cell, training 8 cells each "
          "side every third bin")
    print(f"{'CFAR':<6}{'cells above threshold':>24}{'design':>10}{'targets listed/cycle':>22}{'design':>10}")
    for r in p["rows"]:
        print(f"{r['kind']:<6}{r['above']:>24.3g}{p['pfa']:>10.3g}{r['listed_per_cycle']:>22.3g}"
              f"{p['pfa'] * p['cells']:>10.3g}")


def _detection(p: dict) -> None:
    print(f"Swerling 1 target on range bin {p['range_bin']}, Doppler bin {p['doppler_bin']}; CA-CFAR, {p['cycles']} "
          "cycles per SNR")
    print(f"{'SNR after integration':>22}{'Pd measured':>13}{'Pd textbook':>13}")
    for r in p["rows"]:
        print(f"{r['snr_db']:>19.0f} dB{r['pd']:>13.3f}{r['pd_textbook']:>13.3f}")


def _refined(p: dict) -> None:
    print(f"The list refined (ml), pfa 1e-6 per cell, {p['cycles']} cycles per point: RMSE over the CRLB")
    print(f"{'preset':<9}{'SNR after integration':>22}{'range':>8}{'velocity':>10}{'listed/cycle':>14}")
    for r in p["rows"]:
        print(f"{r['preset']:<9}{r['snr_db']:>19.0f} dB{r['range_rmse_over_crlb']:>8.2f}"
              f"{r['velocity_rmse_over_crlb']:>10.2f}{r['listed_per_cycle']:>14.3f}")


def _two_targets(p: dict) -> None:
    print("table1, a target 20 dB louder 12 range bins from one at 20 dB: cycles listing the weak one")
    for r in p["rows"]:
        print(f"  {r['detection']}: {r['weak_listed']:.3f}")


def _resolution(p: dict) -> None:
    print(f"table1, two equal targets at 20 dB, same velocity, OS-CFAR + ml, {p['cycles']} cycles per spacing")
    print(f"{'spacing (bins)':>15}{'both listed':>13}{'as one':>13}")
    for r in p["rows"]:
        print(f"{r['spacing_bins']:>15g}{r['both_listed']:>13.2f}{r['as_one']:>13.2f}")


def _migration(p: dict) -> None:
    print(f"awr1642 car at {p['range_m']:g} m closing at {p['closing_mps']:.1f} m/s, OS-CFAR pfa 1e-6 per cell, "
          f"{p['cycles']} cycles per row: without and with range-walk compensation (max_speed_mps 100); SNR: the "
          "listed cell's, after integration (median)")
    print(f"{'RCS':>9}{'SNR':>7}{'max speed':>11}{'Pd':>7}{'false/cycle':>13}{'range RMSE':>12}{'velocity RMSE':>15}"
          f"{'true alias':>12}")
    for r in p["rows"]:
        print(f"{r['rcs_m2']:>6.2g} m2{r['snr_db']:>4.0f} dB{r['max_speed_mps']:>7g} m/s{r['pd']:>7.2f}"
              f"{r['false_per_cycle']:>13.2f}{r['range_rmse_m']:>10.3f} m{r['velocity_rmse_mps']:>11.3f} m/s"
              f"{r['true_alias']:>12.2f}")


PRINTERS = {"false_alarms": _false_alarms, "detection": _detection, "refined": _refined,
            "two_targets": _two_targets, "resolution": _resolution, "migration": _migration}


def run(args: argparse.Namespace) -> int:
    cfar_experiment(args.preset, args.trials, args.pfa, args.seed, partial=lambda name, part: PRINTERS[name](part),
                    progress=progress_bar(args, "cfar"))
    return 0
