"""`carav scenes [NAME | FILE ...]`: what a scene implies, side by side, as a markdown table.

Chirps and samples, sweep, slope, the sampling window (and, for a scene that does not give t_adc_start_s, that its
start is the default one: once the IF filter has settled after the ramp's reset), sampling rate, cycle rate, the
targets, the SNR of the first target per sample once its echo has arrived (radar equation) and the echoes' SNR
averaged over a slot (what `carav design` and the detector's closed form use), range resolution, maximum range, the
ranges where the beat and waveform fidelities differ by design (the IF filter's transition band), unambiguous
velocity, the beat with Doppler (and where it folds to when the ADC cannot represent it), the ADC, and the scene's
warnings, among them any echo that leaks enough into the silent slots to raise C(eta)'s false-alarm rate at the eta
designed for 1e-6 (carav_stream/firmware/leak.py).
With no argument: every preset.

`carav scenes --from-ti-cfg FILE.cfg [--device NAME] [--out SCENE.toml] [--noise-codes X]`: the scene of a TI mmWave
CLI profile (carav_stream/capture/ti_cfg.py), checked by the scene loader, written to --out (or printed), then the
device (given or assumed), for a TDM MIMO profile the unambiguous velocity per transmitter repetition, and its table.
"""
from __future__ import annotations

import argparse
import math
import tomllib
from functools import lru_cache
from pathlib import Path

from carav_stream.capture.ti_cfg import TiCfgError, profile_from_cfg, scene_toml
from carav_stream.capture.ti_devices import DEFAULT_DEVICE, DEFAULT_DEVICE_3TX, DEVICES
from carav_stream.console.errors import CommandError, Exit
from carav_stream.firmware.design import PF_WARN, scene_law
from carav_stream.firmware.leak import leak_warnings
from carav_stream.radar.physics import fidelity_dependent_ranges_m
from carav_stream.radar.scene import IF_SETTLE_SAMPLES, SceneError, fold_beat_hz
from carav_stream.radar.scene_loader import load_scene, preset_names, scene_from_dict

__all__ = ["configure", "run", "scene_table"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenes", nargs="*", metavar="NAME|FILE", help="presets or scene files (default: every preset)")
    parser.add_argument("--from-ti-cfg", type=Path, metavar="FILE.cfg", help="the scene of a TI mmWave CLI profile")
    parser.add_argument("--device", choices=sorted(DEVICES), help=f"with --from-ti-cfg: the radar, for its antenna "
                        f"layout and LVDS lanes (default {DEFAULT_DEVICE}, or {DEFAULT_DEVICE_3TX} when the profile "
                        "enables TX3)")
    parser.add_argument("--out", type=Path, metavar="SCENE.toml", help="with --from-ti-cfg: write the scene here")
    parser.add_argument("--noise-codes", type=float, help="with --from-ti-cfg: the capture's noise RMS in codes "
                                                          "(carav capture inspect) for the scene's sigma_n")


def _mhz(hz: float) -> str:
    return f"{hz / 1e6:.4g} MHz"


def _us(s: float) -> str:
    return f"{s * 1e6:.4g} us"


def _kmh(mps: float) -> str:
    return f"{mps * 3.6:+.4g} km/h"


def _column(scene) -> dict[str, str]:
    t0 = scene.targets[0] if scene.targets else None
    beat = "-"
    if t0 is not None:
        b = scene.beat_hz(t0)
        folded = fold_beat_hz(scene, b)
        beat = _mhz(b) + ("" if math.isclose(folded, b) else f", folds to {_mhz(folded)}")
    targets = "; ".join(f"{t.range_m:g} m, {_kmh(t.velocity_mps)}, {t.rcs_m2:g} m^2"
                        + (f", Swerling {t.swerling}" if t.swerling else "")
                        + (f", {t.azimuth_deg:+g} deg" if scene.has_array else "") for t in scene.targets) or "none"
    v_max = scene.max_velocity_mps
    rate = scene.range_rate_mps(t0) if t0 is not None else None
    return {
        "description": scene.description or "-",
        "chirps x samples": f"{scene.n_chirps} x {scene.n_samples} ({'I/Q' if scene.iq else 'I only'})",
        "antennas": _antennas(scene),
        "sweep / chirp period": f"{_mhz(scene.bandwidth_hz)} in {_us(scene.t_sweep_s)} / {_us(scene.t_chirp_s)}",
        "sampling window": f"{_us(scene.n_samples / scene.fs_hz)} from {_us(scene.t_adc_start_s)}" + (
            f" (the default: {IF_SETTLE_SAMPLES} samples in, once the IF filter has settled after the ramp's reset; "
            "t_adc_start_s = 0 samples from the reset)" if scene.adc_start_default else ""),
        "slope": f"{scene.slope_hz_per_s / 1e12:.4g} MHz/us",
        "fs": _mhz(scene.fs_hz),
        "cycle": f"{scene.t_cycle_s * 1e3:.4g} ms ({scene.cycles_per_s:.5g} cycles/s)",
        "carrier": f"{scene.fc_hz / 1e9:.4g} GHz",
        "radar speed": _kmh(scene.radar_speed_mps),
        "targets": targets,
        "range rate of target 1": "-" if rate is None else f"{rate:+.4g} m/s",
        "beat of target 1 (with Doppler)": beat,
        "SNR of target 1, per sample once its echo has arrived": "-" if t0 is None else f"{scene.snr_db(0):+.2f} dB",
        "echoes' SNR averaged over a slot, ADC noise included (what the detector's law sees)":
            "-" if t0 is None else f"{10 * math.log10(scene_law(scene).snr):+.2f} dB",
        "range resolution": f"{scene.range_resolution_m:.4g} m",
        "max range": f"{scene.max_range_m:.4g} m",
        "ranges where the fidelities differ (the IF filter's transition band)":
            ", ".join(f"{a:.4g}-{b:.4g} m" for a, b in fidelity_dependent_ranges_m(scene)) or "none",
        "unambiguous velocity": f"+-{v_max:.4g} m/s" + (
            f" (one transmitter repeats every {_us(scene.t_loop_s)})" if scene.n_slots > 1 else ""),
        "ADC": f"{scene.adc_bits} bits" if scene.adc_bits else "ideal",
        "warnings": str(len(_warnings(scene))) if _warnings(scene) else "none",
    }


def _antennas(scene) -> str:
    """'1 TX x 1 RX', or the array: transmitters in TDM, receivers, the virtual array's positions."""
    if not scene.has_array:
        return "1 TX x 1 RX"
    virtual = scene.virtual_positions_wl
    return (f"{scene.n_tx} TX (TDM, {scene.n_slots} slots a loop) x {scene.n_rx} RX: {virtual.size} virtual "
            f"elements at {', '.join(f'{x:g}' for x in virtual)} wavelengths")


@lru_cache(maxsize=64)
def _warnings(scene) -> tuple[str, ...]:
    """The scene's own warnings, then its echoes' leak into the silent slots at the eta designed for PF 1e-6."""
    return (*scene.warnings, *leak_warnings(scene, pf_design=PF_WARN))


def scene_table(scenes) -> list[str]:
    """A markdown table, one column per scene, then the warnings spelled out."""
    cols = [_column(s) for s in scenes]
    lines = ["| | " + " | ".join(f"`{s.name}`" for s in scenes) + " |", "|---" * (len(scenes) + 1) + "|"]
    lines += [f"| {key} | " + " | ".join(c[key] for c in cols) + " |" for key in cols[0]]
    notes = [f"- `{s.name}`: {w}" for s in scenes for w in _warnings(s)]
    return lines + (["", "Warnings:", "", *notes] if notes else [])


def from_ti_cfg(args: argparse.Namespace) -> int:
    if args.scenes:
        raise CommandError("--from-ti-cfg: give the profile alone, not scene names as well")
    if args.noise_codes is not None and not args.noise_codes > 0:
        raise CommandError(f"--noise-codes: must be > 0, got {args.noise_codes}")
    try:
        text = args.from_ti_cfg.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise CommandError(f"--from-ti-cfg: {args.from_ti_cfg}: cannot be read: {exc}") from None
    try:
        profile = profile_from_cfg(text, str(args.from_ti_cfg), args.device)
        bits = profile.scene["adc_bits"]
        toml = scene_toml(profile, None if args.noise_codes is None else args.noise_codes / 2 ** (bits - 1))
        scene = scene_from_dict(tomllib.loads(toml), args.from_ti_cfg.name)
    except (TiCfgError, SceneError) as exc:
        raise CommandError(str(exc), Exit.INVALID) from None
    if args.out is None:
        print(toml, end="")
        return 0
    try:
        args.out.write_text(toml)
    except OSError as exc:
        raise CommandError(f"--out: {args.out}: {exc.strerror}") from None
    print(f"wrote {args.out}: {profile.n_rx} receivers, activation pattern {profile.pattern}")
    print(profile.device_line())
    if profile.mimo:
        print(profile.velocity_line())
    print("\n".join(scene_table([scene])))
    return 0


def run(args: argparse.Namespace) -> int:
    if args.from_ti_cfg is not None:
        return from_ti_cfg(args)
    if args.out is not None or args.noise_codes is not None or args.device is not None:
        raise CommandError("--out, --noise-codes and --device go with --from-ti-cfg")
    names = args.scenes or preset_names()
    try:
        scenes = [load_scene(n) for n in names]
    except (SceneError, OSError) as exc:
        raise CommandError(str(exc), Exit.INVALID) from None
    print("\n".join(scene_table(scenes)))
    return 0
