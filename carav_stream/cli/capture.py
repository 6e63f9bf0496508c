"""`carav capture inspect FILE --scene S`: what a TI DCA1000 capture holds, before it goes through a graph.

    carav capture inspect adc_data.bin --scene profile.toml [--n-rx 4] [--lanes 2] [--encoding twos_complement]
                          [--activation LOG | --pattern 0101...] [--cycles 64] [--top 5] [--json OUT]

Prints the whole cycles and the bytes left over, the noise RMS per receiver (from the silent chirps when an
activation log or pattern is given, and the robust floor of the range-Doppler map always), the spread of chirp
RMS within a cycle (what the detector's D1 sees on this radar), the strongest range-Doppler cells with their range
and velocity, and every doubt about the layout with its likely fix (carav_stream/capture/inspect.py). With a TDM
MIMO scene (several slots in its tdm_schedule) the Doppler FFT runs over each transmitter's own chirps (velocity
within +-max_velocity_mps), the noise floor and the chirps' RMS are also given per slot, and the cells get an
azimuth when the scene places the capture's receivers.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from carav_stream.capture.activation_log import ActivationLogError, read_log
from carav_stream.capture.dca1000 import ENCODINGS, Layout, check_loops, complete_cycles, read_cycles
from carav_stream.capture.inspect import inspect_codes, layout_warnings
from carav_stream.console import jsonout
from carav_stream.console.errors import CommandError, Exit
from carav_stream.radar.adc import adc_step
from carav_stream.radar.scene import SceneError
from carav_stream.radar.scene_loader import load_scene

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="capture", required=True, metavar="ACTION")
    p = sub.add_parser("inspect", help="cycles, noise RMS per receiver, chirp RMS spread, strongest cells",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", type=Path, help="DCA1000 .bin capture")
    p.add_argument("--scene", required=True, help="scene of the capture's chirps (preset or TOML file)")
    p.add_argument("--n-rx", type=int, default=4, choices=(1, 2, 3, 4), help="receivers enabled (default 4)")
    p.add_argument("--lanes", type=int, default=2, choices=(2, 4), help="LVDS lanes: 2 (xWR16xx) or 4 (xWR14xx)")
    p.add_argument("--encoding", default="twos_complement", choices=ENCODINGS)
    rho = p.add_mutually_exclusive_group()
    rho.add_argument("--activation", type=Path, help="activation log of the capture (cycles 0, 1, ...)")
    rho.add_argument("--pattern", help="fixed activation pattern of every cycle (n_chirps digits 0 | 1)")
    p.add_argument("--cycles", type=int, default=64, help="cycles to read from the start (default 64)")
    p.add_argument("--top", type=int, default=5, help="strongest range-Doppler cells to list (default 5)")
    p.add_argument("--json", type=Path, help="write the report as JSON")


def _rho(args: argparse.Namespace, n_chirps: int, n_slots: int, cycles: int) -> np.ndarray | None:
    if args.pattern is not None:
        if len(args.pattern) != n_chirps or set(args.pattern) - {"0", "1"}:
            raise CommandError(f"--pattern: expected {n_chirps} digits 0 or 1 (the scene's n_chirps), got "
                               f"{len(args.pattern)} characters")
        fixed = np.frombuffer(args.pattern.encode(), np.uint8) == ord("1")
        _whole_loops(fixed[None], n_slots, "--pattern", Exit.USAGE)
        return np.tile(fixed, (cycles, 1))
    if args.activation is None:
        return None
    try:
        log_cycles, rho = read_log(args.activation, n_chirps)
    except ActivationLogError as exc:
        raise CommandError(f"--activation: {exc}", Exit.INVALID) from None
    if len(log_cycles) < cycles or np.any(log_cycles[:cycles] != np.arange(cycles)):
        raise CommandError(f"--activation: {args.activation}: expected cycles 0 .. {cycles - 1} in order, as the "
                           f"capture's log lists them", Exit.INVALID)
    _whole_loops(rho[:cycles], n_slots, f"--activation: {args.activation}", Exit.INVALID)
    return rho[:cycles]


def _whole_loops(rho: np.ndarray, n_slots: int, where: str, code: Exit) -> None:
    try:
        check_loops(rho, n_slots, where)
    except ValueError as exc:
        raise CommandError(str(exc), code) from None


def report(args: argparse.Namespace) -> tuple[dict, list[str]]:
    """The inspection as plain data, and its text lines."""
    try:
        scene = load_scene(args.scene)
    except SceneError as exc:
        raise CommandError(f"--scene: {exc}", Exit.INVALID) from None
    if not args.file.is_file():
        raise CommandError(f"{args.file}: capture file not found")
    try:
        layout = Layout(args.n_rx, scene.n_samples, scene.n_chirps, scene.iq,
                        scene.adc_bits if scene.adc_bits in (12, 14) else 16, args.lanes, args.encoding)
    except ValueError as exc:
        raise CommandError(str(exc), Exit.INVALID) from None
    whole, left = complete_cycles(args.file, layout)
    n = min(whole, max(args.cycles, 1))
    rho = _rho(args, scene.n_chirps, scene.n_slots, n)
    words = np.fromfile(args.file, dtype="<i2", count=n * layout.bytes_per_cycle // 2)
    codes = read_cycles(args.file, layout, 0, n, None)
    doubts = layout_warnings(str(args.file), args.file.stat().st_size, words, layout, codes, rho, scene.n_slots)
    out = {"file": str(args.file), "layout": layout.describe(), "bytes_per_cycle": layout.bytes_per_cycle,
           "whole_cycles": whole, "bytes_left_over": left, "warnings": doubts}
    if n:
        out |= inspect_codes(codes, scene, rho, args.top)
        lsb = adc_step(scene)
        out["lsb"] = lsb
        out["scene_sigma_n_codes"] = scene.sigma_n / lsb if lsb else None
    return out, _lines(out)


def _lines(r: dict) -> list[str]:
    lines = [f"{r['file']}: {r['layout']}",
             f"  whole cycles {r['whole_cycles']} ({r['bytes_per_cycle']} bytes each), bytes left over "
             f"{r['bytes_left_over']}"]
    if "noise_rms" in r:
        rx = range(r["n_rx"])
        lines.append(f"  inspected the first {r['cycles']} cycles")
        for key, name in (("silent_chirps_codes", "noise RMS, silent chirps"), ("floor_codes", "noise RMS, floor")):
            if key in r["noise_rms"]:
                lines.append(f"  {name} (codes): " + ", ".join(f"rx{i} {v:.4g}" for i, v in
                                                               zip(rx, r["noise_rms"][key])))
        if r.get("scene_sigma_n_codes"):
            lines.append(f"  the scene's sigma_n: {r['scene_sigma_n_codes']:.4g} codes")
        lines.append("  chirp RMS spread within a cycle (median): " + ", ".join(
            f"rx{i} {s:.3g} dB, D1 max {d:.3g}" for i, s, d in zip(rx, r["chirp_rms_spread_db"], r["chirp_d1_max"])))
        lines += _slot_lines(r)
        lines.append("  strongest range-Doppler cells:" if "n_slots" not in r else
                     f"  strongest range-Doppler cells (Doppler over each transmitter's {r['n_doppler']} loops of "
                     f"{r['n_slots']} slots: +-{r['max_velocity_mps']:.4g} m/s; |RD|^2 summed over "
                     f"{r['n_slots'] * r['n_rx']} virtual channels):")
        lines += [f"    range bin {c['range_bin']}, Doppler bin {c['doppler_bin']}: {c['range_m']:.4g} m, "
                  f"{c['velocity_mps']:+.4g} m/s, " + (f"azimuth {c['azimuth_deg']:+.1f} deg, " if "azimuth_deg" in c
                                                      else "") +
                  f"{c['above_floor_db']:.1f} dB above the noise" for c in r["cells"]]
    lines += [f"  warning: {w}" for w in r["warnings"]]
    return lines


def _slot_lines(r: dict) -> list[str]:
    """Per TDM slot (several slots only): its noise floor, its active chirps' RMS and their spread within a cycle."""
    if "n_slots" not in r:
        return []
    lines = []
    for j, tx in enumerate(r["tdm_schedule"]):
        rx = range(r["n_rx"])
        lines.append(f"  slot {j} (transmitter {tx}): noise RMS, floor (codes) " + ", ".join(
            f"rx{i} {v:.4g}" for i, v in zip(rx, r["slot_noise_floor_codes"][j])) + "; chirp RMS (codes) " + ", ".join(
            f"rx{i} {v:.4g}" for i, v in zip(rx, r["slot_rms_codes"][j])) + "; spread within the slot (median) " +
            ", ".join(f"rx{i} {s:.3g} dB" for i, s in zip(rx, r["slot_chirp_rms_spread_db"][j])))
    return lines


def run(args: argparse.Namespace) -> int:
    out, lines = report(args)
    print("\n".join(lines))
    if args.json:
        try:
            jsonout.write(args.json, out, indent=2)
        except OSError as exc:
            raise CommandError(f"--json: {args.json}: {exc.strerror}") from None
    return 0
