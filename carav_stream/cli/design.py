"""`carav design`: the threshold of every detector for a target false-alarm rate per cycle on one scene.

    carav design --preset NAME | --scene FILE [--pf 1e-6] [--nr N] [--ns N] [--iq] [--snr-db DB] [--ideal-adc]
                 [--receivers N] [--rarms LIST] [--trials N] [--seed S] [--fidelity beat|waveform]
                 [--benign-trials N] [--json FILE] [--quiet]

Thresholds (closed forms; model and limits: carav_stream/firmware/design.py):
- C(eta), the RMS detector (D0 on the silent chirps, D1 on the active ones): eta with PF(eta) = pf per cycle, and PF
  at the paper's eta = 1.5 beside it;
- the spectral silent-chirp test (carav_stream/detect/opt_in.py): its exact threshold over the scene's bins;
- the CUSUM of the silent power across cycles: h for an in-control average run length of 1 / pf cycles.
Misses of C at both etas for the paper's attacks: `random` by the closed form, `smart` by Monte Carlo (--trials
cycles per RARMS, seeded, with 95 % intervals).
The closed forms hold for the noise and the echoes the beat fidelity renders. The scene's own benign cycles are
simulated too (--benign-trials, at --fidelity beat or waveform): their alarms at both etas, with 95 % intervals,
and a warning when even the interval's lower end exceeds the target PF (the scene's echo, not noise, then sets
the false-alarm rate: at waveform fidelity a strong near echo leaks into the silent slots' first samples).
The weakest ghost (a false target at 25 m, carav_stream/firmware/blind_zone.py) each detector catches in 9
cycles of 10 or more, from a grid of RARMS, --ghost-trials cycles each: the scene's blind zone for that attack.
--receivers N (default the scene's own count, `getattr(scene, "n_rx", 1)`): C judges each chirp's RMS over all N
receivers, so its law is the one receiver's with N times the samples (carav_stream/detect/receivers.py); the
`random` misses are one attacker's signal on every receiver (at broadside). The opt-in tests' thresholds stay per
receiver. With N other than the scene's own count the radar chain cannot render the cycles: the smart attack's are
then the array paper model's (the scene's beat echo on N receivers, ideal ADC), and the benign cycles, the ghost and
the leaks are left out (a line says so).
Two SNRs are printed, each named: the echo's power averaged over a slot (what the detector's law sees, counting
the samples before the echo arrives) and per sample once it has arrived (what `carav scenes` and `carav sweep`
print).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Callable

import numpy as np

from carav_stream.console import jsonout
from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.options import count, even_count, float_list, number, output_file
from carav_stream.console.progress import ProgressBar
from carav_stream.detect.detector import PAPER_ETA
from carav_stream.detect.opt_in import cusum_threshold, exact_bins, gamma_threshold
from carav_stream.detect.stats import clopper_pearson
from carav_stream.experiments.reporting import Tally
from carav_stream.firmware.blind_zone import miss_rates, weakest_caught
from carav_stream.firmware.design import QUANTISED_BELOW, pf_per_cycle, pm_random, rms_threshold, scene_law
from carav_stream.firmware.leak import scene_leaks
from carav_stream.montecarlo.array_source import ArraySource
from carav_stream.montecarlo.engine import simulate_q
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.scene import SceneError
from carav_stream.radar.scene_loader import load_scene

__all__ = ["configure", "run", "design"]

GHOST_RANGE_M = 25.0
GHOST_RARMS = (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 3.0)


def configure(parser: argparse.ArgumentParser) -> None:
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--preset", default=None, help="a built-in scene (carav_stream/radar/presets); default table1")
    where.add_argument("--scene", default=None, metavar="FILE", help="a scene file")
    parser.add_argument("--pf", type=number(0.0, strict=True), default=1e-6,
                        help="target false-alarm probability per cycle (default 1e-6)")
    parser.add_argument("--nr", type=even_count(2), default=None, help="override the number of chirps per cycle N_r")
    parser.add_argument("--ns", type=count(1), default=None, help="override the samples per chirp N_s")
    parser.add_argument("--iq", action="store_true", help="complex I/Q samples instead of the scene's I only")
    parser.add_argument("--snr-db", type=float, default=None, help="per-sample echo SNR of the first target, dB")
    parser.add_argument("--ideal-adc", action="store_true", help="no quantisation (adc_bits = 0)")
    parser.add_argument("--receivers", type=count(1), default=None, metavar="N",
                        help="receivers whose samples C combines per chirp (default the scene's own, else 1)")
    parser.add_argument("--rarms", type=float_list(0.0), default=[0.5, 1.0, 1.5, 2.0, 3.0, 5.0],
                        help="attack strengths for the miss rates (default 0.5,1,1.5,2,3,5)")
    parser.add_argument("--trials", type=count(1), default=2000, help="Monte Carlo cycles per smart-attack point")
    parser.add_argument("--seed", type=int, default=1, help="seed of the smart-attack Monte Carlo (default 1)")
    parser.add_argument("--fidelity", choices=("beat", "waveform"), default="beat",
                        help="signal model of the simulated cycles (benign and smart): beat, or waveform (the IF "
                             "filter and each slot's start as the receiver sees them)")
    parser.add_argument("--benign-trials", type=count(0), default=200,
                        help="benign cycles simulated to check the design against the scene's own echo (0: none)")
    parser.add_argument("--ghost-trials", type=count(0), default=100,
                        help="attacked cycles per RARMS for the weakest ghost each detector catches (0: none)")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="also write the numbers as JSON")
    parser.add_argument("--quiet", action="store_true", help="no progress (on stderr: a bar on a terminal, else a "
                        "line every 10 s with the time left)")


def _scene(args: argparse.Namespace):
    over: dict = {}
    if args.nr is not None:
        over["n_chirps"] = args.nr
    if args.ns is not None:
        over["n_samples"] = args.ns
    if args.iq:
        over["iq"] = True
    if args.snr_db is not None:
        over["snr_db"] = args.snr_db
    if args.ideal_adc:
        over["adc_bits"] = 0
    try:
        return load_scene(args.scene or args.preset or "table1", over or None)
    except (SceneError, OSError) as exc:
        raise CommandError(str(exc), Exit.INVALID) from None


def design(scene, pf: float, rarms: list[float], trials: int, seed: int, fidelity: str = "beat",
           benign_trials: int = 0, ghost_trials: int = 0, progress: Callable[[int, int], None] | None = None,
           n_rx: int | None = None) -> dict:
    """Every number `carav design` prints, as a dict (JSON-ready); progress(cycles done, cycles in all) as the
    benign, smart and ghost cycles are simulated; n_rx receivers (default the scene's own)."""

    if not 0 < pf < 1:
        raise CommandError(f"--pf: must be in (0, 1), got {pf:g}", Exit.USAGE)
    own = getattr(scene, "n_rx", 1)
    n_rx = own if n_rx is None else n_rx
    law = scene_law(scene, n_rx)
    eta = rms_threshold(law, pf)
    m = scene.n_chirps // 2
    bins = exact_bins(scene.n_samples, scene.iq)                          # the spectral test's bins per chirp
    spectral = None
    if bins:                      # a bin's power summed over the receivers: Gamma(n_rx, 1) under noise
        spectral = gamma_threshold(pf, m * bins, n_rx)
    chain = n_rx == own                             # the radar chain renders the scene's own receivers only
    if chain:
        source = RadarSource(scene, fidelity=fidelity)
    else:
        source = ArraySource(RadarSource(scene).paper_equivalent(), n_rx)
        benign_trials = ghost_trials = 0
    seeds = np.random.SeedSequence(seed).spawn(len(rarms) + 1)
    tally = Tally(benign_trials + trials * len(rarms) + ghost_trials * len(GHOST_RARMS), progress)
    benign = None
    if benign_trials:
        q = simulate_q(source, "none", 0.0, benign_trials, seeds[-1], workers=1, progress=tally).q
        benign = {"trials": benign_trials}
        for key, e in (("design", eta), ("paper", PAPER_ETA)):
            k = int(np.sum(q >= e))
            lo, hi = clopper_pearson(k, benign_trials)
            benign[key] = {"eta": e, "alarms": k, "rate": k / benign_trials, "ci": [float(lo), float(hi)]}
        benign["above_design"] = benign["design"]["ci"][0] > pf
    misses = []
    for r, child in zip(rarms, seeds):
        q = simulate_q(source, "smart", r, trials, child, workers=1, progress=tally).q
        row = {"rarms": r}
        for key, e in (("design", eta), ("paper", PAPER_ETA)):
            k = int(np.sum(q < e))
            lo, hi = clopper_pearson(k, trials)
            row[key] = {"random": float(pm_random(law, e, r)), "smart": k / trials,
                        "smart_ci": [float(lo), float(hi)]}
        misses.append(row)
    ghost = None
    if ghost_trials:
        rows = miss_rates(scene, "ghost", GHOST_RARMS, ghost_trials, seed, fidelity=fidelity,
                          params={"range_m": GHOST_RANGE_M}, pf=pf, tick=tally)
        ghost = {"range_m": GHOST_RANGE_M, "trials": ghost_trials, "rarms": list(GHOST_RARMS),
                 "weakest_caught": weakest_caught(rows), "rows": rows}
    return {
        "scene": {"name": scene.name, "n_chirps": scene.n_chirps, "n_samples": scene.n_samples, "iq": scene.iq,
                  "dof": law.dof, "echo_snr_db": float(10 * np.log10(law.snr)) if law.snr > 0 else None,
                  "echo_snr_per_sample_db": float(scene.snr_db(0)) if scene.targets else None,
                  "fidelity": fidelity,
                  "adc_bits": scene.adc_bits, "noise_inflation_by_adc": law.sigma_eff / law.sigma_n,
                  "noise_in_adc_steps": law.steps(), "quantised_law": law.steps() < QUANTISED_BELOW,
                  "n_rx": n_rx, "scene_n_rx": own, "array_paper_model": not chain},
        "pf": pf,
        "rms_detector": {"eta": eta, "pf_at_eta": float(pf_per_cycle(law, eta)),
                         "paper_eta": PAPER_ETA, "pf_at_paper_eta": float(pf_per_cycle(law, PAPER_ETA))},
        "spectral_silent_test": {"threshold": spectral, "bins_tested": m * bins,
                                 "threshold_db": None if spectral is None else float(10 * np.log10(spectral))},
        "cusum_silent_power": {"k": 0.5, "h": cusum_threshold(1 / pf, 0.5), "arl0_cycles": 1 / pf},
        "benign": benign, "misses": misses, "smart_trials": trials, "seed": seed,
        "leaks": [dataclasses.asdict(k) for k in scene_leaks(scene, eta, pf_design=pf)] if chain else [],
        "ghost": ghost,
    }


def _print(d: dict, stream=None) -> None:
    stream = stream or sys.stdout
    s, rd = d["scene"], d["rms_detector"]
    snr = ("no echo" if s["echo_snr_db"] is None else
           f"echoes' SNR {s['echo_snr_db']:+.1f} dB averaged over a slot, ADC noise included (target 1: "
           f"{s['echo_snr_per_sample_db']:+.1f} dB per sample once its echo has arrived)")
    adc = (f"noise {s['noise_in_adc_steps']:.3g} steps: most silent samples quantise to 0, D0's law is the "
           "quantised noise's" if s["quantised_law"] else f"noise x{s['noise_inflation_by_adc']:.6f}")
    nu = (f"nu = {s['dof']}" if s["n_rx"] == 1 else
          f"nu = {s['dof']} per receiver, {s['n_rx']} receivers: {s['n_rx'] * s['dof']} per chirp")
    print(f"scene {s['name']}: N_r = {s['n_chirps']}, N_s = {s['n_samples']}, {'I/Q' if s['iq'] else 'I only'} "
          f"({nu}), {snr}, {s['adc_bits']}-bit ADC ({adc}); "
          f"target PF {d['pf']:g} per cycle", file=stream)
    if s["array_paper_model"]:
        print(f"  the scene has {s['scene_n_rx']} receiver{'s' * (s['scene_n_rx'] != 1)}, the radar chain renders "
              f"no other count: no benign cycles, ghost or leaks; the smart attack's cycles are the array paper "
              f"model's (the scene's beat echo on {s['n_rx']} receivers, ideal ADC, the attacker at broadside)",
              file=stream)
    print(f"  C(eta), RMS detector (D0 + D1)   eta = {rd['eta']:.4f}    PF per cycle {rd['pf_at_eta']:.3g} "
          f"(at the paper's eta = {rd['paper_eta']:g}: {rd['pf_at_paper_eta']:.3g})", file=stream)
    sp = d["spectral_silent_test"]
    if sp["threshold"] is None:
        print(f"  spectral silent-chirp test       not defined: N_s = {s['n_samples']} I only has no range bin with "
              "an exact law (the opt-in tests take N_s >= 3, or --iq)", file=stream)
    else:
        print(f"  spectral silent-chirp test       {sp['threshold']:.2f} x noise power per bin "
              f"({sp['threshold_db']:.1f} dB) over {sp['bins_tested']} bins"
              + (f", each bin's power summed over the {s['n_rx']} receivers" if s["n_rx"] > 1 else ""), file=stream)
    cu = d["cusum_silent_power"]
    print(f"  CUSUM of silent power (k = {cu['k']:g})  h = {cu['h']:.2f} for an in-control run of "
          f"{cu['arl0_cycles']:.3g} cycles", file=stream)
    for k in d["leaks"]:
        if not k["judged"] and k["lam"] > 0:
            print(f"  target {k['target'] + 1} ({k['range_m']:g} m, {k['rcs_m2']:g} m^2) leaks up to "
                  f"{k['fraction']:.2g} of a slot of its echo into a silent slot after an active one "
                  f"({k['fidelity']} fidelity), up to {k['peak_steps']:.3g} ADC steps in a sample: its rate is not "
                  "stated where the ADC's step is coarse against the noise", file=stream)
            continue
        if k["lam"] == 0:
            print(f"  target {k['target'] + 1} ({k['range_m']:g} m, {k['rcs_m2']:g} m^2) leaks nothing into the silent "
                  "slots at either fidelity", file=stream)
            continue
        over = ", ".join(f"{a:.3g}-{b:.3g} m" for a, b in k["ranges_over"] or ())
        print(f"  target {k['target'] + 1} ({k['range_m']:g} m, {k['rcs_m2']:g} m^2) leaks up to {k['fraction']:.2g} "
              f"of a slot of its echo into a silent slot after an active one ({k['fidelity']} fidelity): PF "
              f"{k['pf']:.3g} at eta = {k['eta']:.4f}; within {k['limit']:.2g} below {k['rcs_limit_m2']:.3g} m^2 at "
              f"its range" + (f"; at its RCS it exceeds at {over}" if over else ""), file=stream)
        if k["pf"] > k["limit"]:
            print("  WARNING: that leak, not the noise, sets the false-alarm rate (docs/DETECTION.md, near echoes)",
                  file=stream)
    b = d.get("benign")
    if b:
        cells = [f"{b[k]['alarms']} at eta = {b[k]['eta']:.4g} (95 % interval {b[k]['ci'][0]:.3g}-{b[k]['ci'][1]:.3g})"
                 for k in ("design", "paper")]
        print(f"benign cycles of the scene ({s['fidelity']} fidelity, seed {d['seed']}): alarms in {b['trials']}: "
              f"{cells[0]}, {cells[1]}", file=stream)
        if b["above_design"]:
            print(f"  WARNING: the scene's own echo raises false alarms above the target PF {d['pf']:g} at "
                  f"{s['fidelity']} fidelity: the threshold is set by the scene, not by the noise "
                  "(docs/DETECTION.md, near echoes)", file=stream)
    g = d.get("ghost")
    if g:
        w = g["weakest_caught"]
        grid = ", ".join(f"{r:g}" for r in g["rarms"])
        print(f"weakest ghost caught in 9 cycles of 10 or more ({g['range_m']:g} m; RARMS {grid}; {g['trials']} "
              f"cycles each at {s['fidelity']} fidelity; C at eta, the opt-in tests at PF 1e-6): "
              + ", ".join(f"{k} {'none' if v is None else f'{v:g}'}" for k, v in w.items())
              + ("" if len(w) > 1 else " (the opt-in tests are not defined here)"), file=stream)
    where = "in the array paper model" if s["array_paper_model"] else f"at {s['fidelity']} fidelity"
    print(f"misses of C per attacked cycle (random: closed form; smart: {d['smart_trials']} cycles per RARMS "
          f"{where}, seed {d['seed']}, 95 % interval)", file=stream)
    print(f"  {'RARMS':>6}  {'random @ eta':>12}  {'smart @ eta':>22}  {'random @ 1.5':>12}  {'smart @ 1.5':>22}",
          file=stream)
    for row in d["misses"]:
        cells = []
        for key in ("design", "paper"):
            c = row[key]
            cells += [f"{c['random']:12.3g}", f"{c['smart']:7.3g} [{c['smart_ci'][0]:.3g}, {c['smart_ci'][1]:.3g}]"]
        print(f"  {row['rarms']:6g}  {cells[0]}  {cells[1]:>22}  {cells[2]}  {cells[3]:>22}", file=stream)


def run(args: argparse.Namespace) -> int:
    if not args.pf < 1:
        raise CommandError(f"--pf: must be in (0, 1), got {args.pf:g}", Exit.USAGE)
    bar = ProgressBar("design") if ProgressBar.wanted(args.quiet) else None
    result = design(_scene(args), args.pf, args.rarms, args.trials, args.seed, args.fidelity, args.benign_trials,
                    args.ghost_trials, progress=bar, n_rx=args.receivers)
    _print(result)
    if args.json:
        jsonout.write(args.json, result, indent=1)
    return 0
